#!/usr/bin/env python3
"""Issue 17's fault acceptance, as a rerunnable measurement (make faults).

Over the demo's module scenario (mfns sim nav --scenario module --seed 2, 120
frames), the flight program is run with injected faults, each also with the
beacons of the table displaced from the rendered ones by their survey sigma
(sigma_mm of beacons.csv), and every usable fix (FIX or DEGRADED) is compared
with truth:

- clean;
- desynchronising rows: one hostile row of frames.csv (5 or 7 fields, a NUL,
  a ../ path, a negative exposure, camera w, a duplicate) every 8 frames, the
  camera rotating;
- a camera dying: camera y's frames missing from frame 40 on;
- a CRC-valid odd table: the fixed threshold 2 DN (a flood of blobs);
- 5,000 spurious spots over the run (Gaussian dots of random size and
  brightness at random places).

A fix is misleading when it is more than 20 mm from truth, or more than 5
sigma of its own covariance on any axis of position (mm) or attitude (the
covariance's rotation axes when nav.csv has them, else the Euler sigmas).
With the full 6x6 covariance the NEES is reported too, against the
chi-square(6) quantile of the same tail probability as 5 sigma (5.7e-7:
NEES 39.3). Exits 1 when any fix is misleading.

    python tests/bench/fault_acceptance.py [--work DIR] [--frames N]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
PY = sys.executable
BIN = REPO / "build/host-sim/bin"
AXES_ROS = ("x", "y", "z", "rx", "ry", "rz")
NEES_5SIGMA = 39.3  # chi-square(6) quantile at the two-sided 5-sigma tail, 5.7e-7


def run(*args, timeout: float | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=timeout)


def must(res: subprocess.CompletedProcess, what: str) -> None:
    if res.returncode != 0:
        sys.exit(f"fault_acceptance: {what} failed ({res.returncode}):\n{res.stderr[-2000:]}")


def simulate(out: Path, frames: int) -> None:
    must(
        run(
            PY,
            "-m",
            "mfns",
            "sim",
            "nav",
            out,
            "--quiet",
            "--scenario",
            "module",
            "--seed",
            "2",
            "--frames",
            frames,
        ),
        "mfns sim nav",
    )


def build_table(frames: Path, out: Path, beacons: Path | None = None, settings: Path | None = None) -> Path:
    args = [
        "-m",
        "mfns",
        "table",
        "build",
        frames / "calib.json",
        beacons or frames / "beacons.csv",
        "-o",
        out,
        "-q",
    ]
    if settings is not None:
        args += ["--settings", settings]
    must(run(PY, *args), f"mfns table build {out.name}")
    return out


def displaced_map(frames: Path, out: Path, seed: int) -> Path:
    """beacons.csv with every beacon moved by N(0, sigma_mm) per coordinate."""
    rng = np.random.default_rng(seed)
    with open(frames / "beacons.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            s = float(r["sigma_mm"])
            for a in ("x_mm", "y_mm", "z_mm"):
                r[a] = f"{float(r[a]) + rng.normal(0.0, s):.4f}"
            w.writerow(r)
    return out


def copy_frames(src: Path, dst: Path) -> Path:
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    return dst


HOSTILE = [
    lambda r: [r.rsplit(b",", 1)[0]],
    lambda r: [r + b",7"],
    lambda r: [r.replace(b"cam_", b"cam\0")],
    lambda r: [r.replace(b"cam_", b"../cam_")],
    lambda r: [b",".join(r.split(b",")[:4] + [b"-5"] + r.split(b",")[5:])],
    lambda r: [b",".join(r.split(b",")[:2] + [b"w"] + r.split(b",")[3:])],
    lambda r: [r, r],
]


def desync_rows(folder: Path, n_frames: int) -> None:
    lines = (folder / "frames.csv").read_bytes().split(b"\n")
    out = []
    for ln in lines:
        parts = ln.split(b",")
        if len(parts) > 2 and parts[0].isdigit():
            f = int(parts[0])
            cam = "xyz"[(f // 8) % 3]
            if f % 8 == 3 and parts[2] == cam.encode():
                out += HOSTILE[(f // 8) % len(HOSTILE)](ln)
                continue
        out.append(ln)
    (folder / "frames.csv").write_bytes(b"\n".join(out))


def kill_camera(folder: Path, cam: str, first: int) -> None:
    for p in sorted((folder / f"cam_{cam}").glob("*.pgm")):
        if int(p.stem) >= first:
            p.unlink()


def add_spots(folder: Path, n_total: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    files = sorted(folder.glob("cam_*/*.pgm"))
    per = np.bincount(rng.integers(0, len(files), n_total), minlength=len(files))
    for path, k in zip(files, per, strict=True):
        if k == 0:
            continue
        data = path.read_bytes()
        parts = data.split(b"\n", 3)
        w, h = map(int, parts[1].split())
        maxv = int(parts[2])
        dtype = np.uint8 if maxv < 256 else np.dtype(">u2")
        px = np.frombuffer(parts[3], dtype=dtype).reshape(h, w).astype(float)
        for _ in range(k):
            u, v = rng.uniform(5, w - 5), rng.uniform(5, h - 5)
            s, a = rng.uniform(0.8, 2.0), rng.uniform(40, 200)
            y0, x0 = int(v) - 6, int(u) - 6
            yy, xx = np.mgrid[y0 : y0 + 13, x0 : x0 + 13]
            ok = (yy >= 0) & (yy < h) & (xx >= 0) & (xx < w)
            px[yy[ok], xx[ok]] += a * np.exp(-((xx[ok] - u) ** 2 + (yy[ok] - v) ** 2) / (2 * s * s))
        out = np.clip(px, 0, maxv).astype(dtype)
        path.write_bytes(b"\n".join(parts[:3]) + b"\n" + out.tobytes())


def rot_from_euler213_deg(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """C_w_b = R3(yaw) R1(roll) R2(pitch), frame rotations (docs/conventions.md)."""
    f, t, p = np.radians([roll, pitch, yaw])
    r1 = np.array([[1, 0, 0], [0, math.cos(f), math.sin(f)], [0, -math.sin(f), math.cos(f)]])
    r2 = np.array([[math.cos(t), 0, -math.sin(t)], [0, 1, 0], [math.sin(t), 0, math.cos(t)]])
    r3 = np.array([[math.cos(p), math.sin(p), 0], [-math.sin(p), math.cos(p), 0], [0, 0, 1]])
    return r3 @ r1 @ r2


def quat_to_m3(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def rot_log(r: np.ndarray) -> np.ndarray:
    c = max(-1.0, min(1.0, 0.5 * (np.trace(r) - 1.0)))
    th = math.acos(c)
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return 0.5 * v if th < 1e-6 else th / (2 * math.sin(th)) * v


def fly(frames: Path, table: Path, work: Path, tag: str) -> dict:
    tlm = work / f"{tag}.bin"
    nav = run(BIN / "mfns-nav", "--table", table, "--replay", frames, "--file", tlm, timeout=1800)
    gdir = work / f"ground_{tag}"
    run(BIN / "mfns-ground", "--file", tlm, "--out", gdir, "--no-status")
    with open(gdir / "nav.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    truth = np.atleast_1d(np.genfromtxt(frames / "truth.csv", delimiter=",", names=True))
    by_frame = {int(t["frame"]): t for t in truth} if "frame" in truth.dtype.names else dict(enumerate(truth))
    res = {
        "tag": tag,
        "cycles": len(rows),
        "usable": 0,
        "misleading": 0,
        "worst_mm": 0.0,
        "worst_sigma": 0.0,
        "worst_nees": None,
        "nav_exit": nav.returncode,
    }
    for row in rows:
        if row["status"] not in ("FIX", "DEGRADED"):
            continue
        res["usable"] += 1
        t = by_frame[int(row["cycle"])]
        d_pos = np.array([float(row[a + "_mm"]) - float(t[a + "_mm"]) for a in "xyz"])
        c_true = rot_from_euler213_deg(float(t["roll_deg"]), float(t["pitch_deg"]), float(t["yaw_deg"]))
        if "q_w" in row and f"cov_{AXES_ROS[0]}_{AXES_ROS[0]}" in row:
            c_b_w_est = quat_to_m3(np.array([float(row[k]) for k in ("q_w", "q_x", "q_y", "q_z")]))
            # C_b_w(est) = exp(phi_w) C_b_w(true)
            phi_deg = np.degrees(rot_log(c_b_w_est @ c_true))
            e = np.concatenate([d_pos, phi_deg])
            p = np.zeros((6, 6))
            for i, a in enumerate(AXES_ROS):
                for j in range(i, 6):
                    p[i, j] = p[j, i] = float(row[f"cov_{a}_{AXES_ROS[j]}"])
            sig = np.sqrt(np.maximum(np.diag(p), 1e-18))
            try:
                nees = float(e @ np.linalg.solve(p, e))
            except np.linalg.LinAlgError:
                nees = math.inf
            res["worst_nees"] = max(res["worst_nees"] or 0.0, nees)
        else:
            e_eul = np.array(
                [float(row[a + "_deg"]) - float(t[a + "_deg"]) for a in ("roll", "pitch", "yaw")]
            )
            e_eul = (e_eul + 180.0) % 360.0 - 180.0
            e = np.concatenate([d_pos, e_eul])
            sig = np.array(
                [float(row[f"sigma_{a}_mm"]) for a in "xyz"]
                + [float(row[f"sigma_{a}_deg"]) for a in ("roll", "pitch", "yaw")]
            )
            nees = None
        z = float(np.max(np.abs(e) / np.maximum(sig, 1e-9)))
        far = float(np.max(np.abs(d_pos)))
        res["worst_mm"] = max(res["worst_mm"], far)
        res["worst_sigma"] = max(res["worst_sigma"], z)
        if far > 20.0 or z > 5.0 or (nees is not None and nees > NEES_5SIGMA):
            res["misleading"] += 1
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=REPO / "build/faults")
    ap.add_argument("--frames", type=int, default=120)
    args = ap.parse_args()
    work = args.work
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    base = work / "frames"
    simulate(base, args.frames)
    nominal = build_table(base, work / "nominal.mfnstbl")
    surveyed = build_table(
        base, work / "survey.mfnstbl", beacons=displaced_map(base, work / "beacons_survey.csv", 5)
    )
    (work / "odd.json").write_text(json.dumps({"centroid": {"threshold_dn": 2}}))
    odd = build_table(base, work / "odd.mfnstbl", settings=work / "odd.json")
    odd_s = build_table(
        base, work / "odd_survey.mfnstbl", beacons=work / "beacons_survey.csv", settings=work / "odd.json"
    )
    results = []

    def both(frames: Path, name: str, t_nom: Path = nominal, t_sur: Path = surveyed) -> None:
        results.append(fly(frames, t_nom, work, name))
        results.append(fly(frames, t_sur, work, name + " + survey error"))

    both(base, "clean")
    both(base, "CRC-valid odd table (threshold 2 DN)", odd, odd_s)
    f = copy_frames(base, work / "desync")
    desync_rows(f, args.frames)
    both(f, "hostile rows every 8 frames")
    f = copy_frames(base, work / "dying")
    kill_camera(f, "y", 40)
    both(f, "camera y dies at frame 40")
    shutil.rmtree(work / "desync")
    shutil.rmtree(work / "dying")
    f = copy_frames(base, work / "spots")
    add_spots(f, 5000, 9)
    both(f, "5,000 spurious spots")
    shutil.rmtree(f)

    print("| run | cycles | usable | misleading | worst mm | worst sigma (any axis) | worst NEES |")
    print("|---|---|---|---|---|---|---|")
    for r in results:
        nees = "-" if r["worst_nees"] is None else f"{r['worst_nees']:.1f}"
        print(
            f"| {r['tag']} | {r['cycles']} | {r['usable']} | {r['misleading']} | {r['worst_mm']:.2f} | "
            f"{r['worst_sigma']:.2f} | {nees} |"
        )
    total = sum(r["misleading"] for r in results)
    print(f"misleading fixes (> 20 mm or > 5 sigma of their own covariance): {total}")
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main())
