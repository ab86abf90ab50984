"""The self-survey's slow checks (docs/self_survey.md section 4; `make bench-survey`, not in
`make test`):

    python tests/bench/bench_survey.py survey OUT [--seeds 2,3,5] [--minutes 24] [--rate-hz 1]
        [--workers N | --serial | --scheduler ADDRESS]
    python tests/bench/bench_survey.py monitor OUT [--seed 2] [--frames 600]

`survey`: per seed, the demo's self-survey (`mfns map demo`, mfns.map.refine_demo: survey
flight with the fix log, `mfns map refine`, fresh frames flown with each map) for the stated
minutes, and the map's error against truth split the way a calibration engineer reads it
(map_figures): over all beacons and over those the flight saw, per coordinate and per beacon in
3-D, against the true positions and against the true positions in the survey's datum. A seed is
a study task (mfns.core.study, docs/studies.md): the seeds run on a local Dask cluster by
default, --serial in this process, --scheduler on a cluster; the table is in the seeds' order.

`monitor`: the in-flight monitor (firmware/nav/integrity/beacon_monitor.h) end to end. The module
scenario's LEDs with their survey error, one beacon moved along its wall (5, 3, 2 and 1 mm) or
camera y's mount turned (0.1 and 0.3 deg about its x axis) in the rendering only; frames at
18.6 Hz flown by mfns-nav on the table of the surveyed, unmoved map; the events mfns-ground
decodes (BEACON_BIASED, CAMERA_BIASED and integrity's beacon reports) with the cycle and
the number of usable fixes before each.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

HOST_TOOLS = Path(__file__).resolve().parents[2] / "host_tools"
sys.path.insert(0, str(HOST_TOOLS))

from mfns.cli import main as mfns_main  # noqa: E402
from mfns.core import study  # noqa: E402
from mfns.map import fixlog, refine_demo  # noqa: E402
from mfns.map.refine_demo import axis_rms, map_figures, summary_num  # noqa: E402
from mfns.model.camera import load_beacons, pose_from_position  # noqa: E402
from mfns.model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg, rot_exp  # noqa: E402
from mfns.simulate import nav as simnav  # noqa: E402
from mfns.tlm.tlm_dict import CYCLE_HZ  # noqa: E402

BEACON_EVENTS = ("BEACON_BIASED", "BEACON_EXCLUDED", "BEACON_REJECTED", "BEACON_MISSING")


def _summary(run: Path, name: str) -> dict:
    return json.loads((run / name / "report" / "summary.json").read_text())


def _nav_sigma(ground: Path) -> list[float]:
    """Median navigation 1-sigma x, y, z (mm) of the usable fixes (nav.csv)."""
    with open(ground / "nav.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] in fixlog.USABLE]
    return [
        float(np.median([float(r[f"sigma_{k}_mm"]) for r in rows])) if rows else float("nan") for k in "xyz"
    ]


@dataclass
class SurveySeed:
    """One seed's survey (a study task, mfns.core.study): its inputs."""

    seed: int
    out: str  # the bench's output folder, as given
    minutes: float
    rate_hz: float
    bin: str
    cwd: str  # relative paths above are from here (a worker may start elsewhere)


def survey_seed(t: SurveySeed) -> dict:
    """`mfns map demo` of one seed and its figures (a study task)."""
    if os.getcwd() != t.cwd:  # a worker runs one task at a time (study: one thread per worker)
        os.chdir(t.cwd)
    run = Path(t.out) / f"seed{t.seed}"
    argv = [str(run), "--minutes", str(t.minutes), "--rate-hz", str(t.rate_hz), "--seed", str(t.seed)]
    if mfns_main(["map", "demo", *argv, "--bin", t.bin]) != 0:
        raise RuntimeError(f"mfns map demo {' '.join(argv)} --bin {t.bin} failed")
    fig = map_figures(run)
    for m in ("surveyed-map", "refined-map", "refined-map-no-datum"):
        s = _summary(run, m)
        fig[m] = {
            "rms_mm": [axis_rms(s, k) for k in "xyz"],
            "sigma_mm": _nav_sigma(run / m / "ground"),
            "nees_mean": summary_num(s["nees"]["mean"]),
            "n_used": s["n_used"],
        }
    fig["seed"] = t.seed
    return fig


def survey(a) -> int:
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = [int(s) for s in a.seeds.split(",")]
    tasks = [SurveySeed(s, a.out, a.minutes, a.rate_hz, a.bin, os.getcwd()) for s in seeds]
    done = study.run_tasks(survey_seed, tasks, study.options_from_args(a), "survey", paths=[str(HOST_TOOLS)])
    rows = [r for r in done.results if r is not None]  # the seeds' order; a failed seed left out
    (out / "survey.json").write_text(json.dumps(rows, indent=1))
    print(survey_table(rows, a.minutes, a.rate_hz))
    (out / "survey.md").write_text(survey_table(rows, a.minutes, a.rate_hz))
    if done.failures:
        print(f"bench_survey: {done.failed_summary('seeds')}", file=sys.stderr)
    return done.exit_code


def survey_table(rows: list[dict], minutes: float, rate_hz: float) -> str:
    def pair(v):
        return f"{v[0]:.3f} / {v[1]:.3f}"

    head = "| | " + " | ".join(f"seed {r['seed']}" for r in rows) + " |"
    lines = [
        f"{minutes:g} min of survey flight at {rate_hz:g} Hz; "
        "beacon error RMS, mm, per coordinate / per beacon 3-D",
        "",
        head,
        "|---" * (len(rows) + 1) + "|",
    ]

    def line(label, fn):
        lines.append(f"| {label} | " + " | ".join(fn(r) for r in rows) + " |")

    line("usable fixes; beacons seen in < 10", lambda r: f"{r['fixes']}; {r['unseen'] or 'none'}")
    line("survey, all, vs truth", lambda r: pair(r["survey_all_truth"]))
    line("refined, all, vs truth", lambda r: pair(r["refined_all_truth"]))
    line("refined, seen, vs truth", lambda r: pair(r["refined_seen_truth"]))
    line("refined, all, in the survey's datum", lambda r: pair(r["refined_all_datum"]))
    line("refined, seen, in the survey's datum", lambda r: pair(r["refined_seen_datum"]))
    line("the survey's datum error itself", lambda r: pair(r["datum_error"]))
    line("written sigma, median", lambda r: f"{r['sigma_median']:.3f}")
    for m in ("surveyed-map", "refined-map", "refined-map-no-datum"):
        line(f"nav RMS x/y/z, {m}", lambda r, m=m: " / ".join(f"{v:.3f}" for v in r[m]["rms_mm"]))
        line(
            f"nav 1-sigma x/y/z (median), {m}",
            lambda r, m=m: " / ".join(f"{v:.3f}" for v in r[m]["sigma_mm"]),
        )
        line(f"mean NEES, fixes, {m}", lambda r, m=m: f"{r[m]['nees_mean']:.2f}, {r[m]['n_used']}")
    return "\n".join(lines) + "\n"


# -- the monitor end to end --------------------------------------------------------------


def _mfns(*args: str, log: Path) -> None:
    with open(log, "w") as f:
        res = subprocess.run(
            [sys.executable, "-m", "mfns", *args], stdout=f, stderr=subprocess.STDOUT, check=False
        )
    if res.returncode != 0:
        raise SystemExit(f"bench_survey: mfns {' '.join(args[:3])} failed ({log})")


def along_wall(p: np.ndarray) -> np.ndarray:
    """A unit vector in the plane of the wall the beacon at p sits on (the first axis that is
    not the wall's normal)."""
    normal = int(np.argmax(np.abs(p) / simnav.MODULE_HALF))
    e = np.zeros(3)
    e[(normal + 1) % 3] = 1.0
    return e


def most_seen_beacon(seed: int, frames: int, ids: np.ndarray, p: np.ndarray) -> int:
    """The map index of the beacon in view (any camera) in most poses of the fresh path."""
    scn = simnav.module_scenario(frames, CYCLE_HZ, len(ids), seed)
    count = np.zeros(len(ids), int)
    for rw, att in zip(scn.r_wb_w, scn.euler_deg, strict=True):
        c = euler213_deg_to_matrix(att)
        rb = pose_from_position(c, rw)
        vis = np.zeros(len(ids), bool)
        for cam in scn.cams:
            vis |= cam.project(c, rb, p)[1]
        count += vis
    return int(np.argmax(count))


def _events(ground: Path) -> list[dict]:
    with open(ground / "events.csv", newline="") as f:
        return list(csv.DictReader(f))


def _fixes_before(ground: Path, cycle: int) -> int:
    with open(ground / "nav.csv", newline="") as f:
        return sum(1 for r in csv.DictReader(f) if r["status"] in fixlog.USABLE and int(r["cycle"]) <= cycle)


def monitor(a) -> int:
    out = Path(a.out)
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    bins = Path(a.bin)
    base = out / "map"  # the surveyed map and the rig: the scenario's, written by a one-frame run
    _mfns(
        "sim",
        "nav",
        str(base),
        "--scenario",
        "module",
        "--frames",
        "1",
        "--seed",
        str(a.seed),
        "--quiet",
        log=out / "map.log",
    )
    ids, p, sig = load_beacons(base / "beacons.csv")
    calib = json.loads((base / "calib.json").read_text())
    fresh_seed = a.seed + refine_demo.FRESH_SEED - refine_demo.SEED
    b = most_seen_beacon(fresh_seed, a.frames, ids, p)
    wall = along_wall(p[b])
    table = out / "table.mfnstbl"
    _mfns(
        "table",
        "build",
        str(base / "calib.json"),
        str(base / "beacons.csv"),
        "-o",
        str(table),
        log=out / "table.log",
    )
    cases: list[tuple[str, float | None, float | None]] = [("clean", None, None)]
    cases += [(f"beacon {int(ids[b])} moved {d:g} mm along its wall", d, None) for d in (5.0, 3.0, 2.0, 1.0)]
    cases += [(f"camera y turned {t:g} deg", None, t) for t in (0.1, 0.3)]
    rows: list[dict[str, Any]] = []  # case, fixes, events (the report's rows)
    for k, (name, move_mm, turn_deg) in enumerate(cases):
        run = out / f"case{k}"
        run.mkdir()
        sim = [
            "sim",
            "nav",
            str(run / "frames"),
            "--scenario",
            "module",
            "--frames",
            str(a.frames),
            "--seed",
            str(fresh_seed),
            "--survey-error",
            "--survey-seed",
            str(a.seed),
            "--quiet",
        ]
        if move_mm is not None:
            q = p.copy()
            q[b] += move_mm * wall
            with open(run / "moved.csv", "w") as f:
                f.write("id,x_mm,y_mm,z_mm,sigma_mm\n")
                for i, x, s in zip(ids, q, sig, strict=True):
                    f.write(f"{int(i)},{x[0]:.4f},{x[1]:.4f},{x[2]:.4f},{s:.4f}\n")
            sim += ["--beacon-map", str(run / "moved.csv")]
        else:
            sim += ["--beacon-map", str(base / "beacons.csv")]
        if turn_deg is not None:
            doc = json.loads(json.dumps(calib))
            cam = next(c for c in doc["cameras"] if c["name"] == "y")
            c_k_b = np.asarray(cam["C_k_b"]) @ rot_exp(np.radians([turn_deg, 0.0, 0.0]))
            cam["C_k_b"] = c_k_b.tolist()
            cam["euler_213_deg"] = matrix_to_euler213_deg(c_k_b).tolist()
            (run / "turned.json").write_text(json.dumps(doc))
            sim += ["--rig", str(run / "turned.json")]
        _mfns(*sim, log=run / "sim.log")
        tlm = run / "telemetry.bin"
        with open(run / "nav.log", "w") as f:
            subprocess.run(
                [
                    str(bins / "mfns-nav"),
                    "--table",
                    str(table),
                    "--replay",
                    str(run / "frames"),
                    "--tlm-file",
                    str(tlm),
                    "--quiet",
                ],
                stdout=f,
                stderr=subprocess.STDOUT,
                check=True,
            )
        with open(run / "ground.log", "w") as f:
            subprocess.run(
                [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(run / "ground"), "--no-status"],
                stdout=f,
                stderr=subprocess.STDOUT,
                check=True,
            )
        for c in ("cam_x", "cam_y", "cam_z"):
            shutil.rmtree(run / "frames" / c, ignore_errors=True)
        found = []
        for e in _events(run / "ground"):
            if e["event"] in BEACON_EVENTS + ("CAMERA_BIASED",):
                cyc = int(e["cycle"])
                what = f"camera {e['subject']}" if e["event"] == "CAMERA_BIASED" else f"beacon {e['arg1']}"
                found.append(
                    f"{e['event']} {what} at cycle {cyc} ({_fixes_before(run / 'ground', cyc)} fixes; "
                    f"chi2 or count {e['arg0']})"
                )
        with open(run / "ground" / "nav.csv", newline="") as f:
            n_fix = sum(1 for r in csv.DictReader(f) if r["status"] in fixlog.USABLE)
        rows.append({"case": name, "fixes": n_fix, "events": found})
    lines = [
        f"Module seed {a.seed} LEDs (survey error), fresh path seed {fresh_seed}, {a.frames} frames at "
        "18.6 Hz, flown on the surveyed map's table",
        "",
        "| case | usable fixes | reports |",
        "|---|---|---|",
    ]
    lines += [f"| {r['case']} | {r['fixes']} | {'; '.join(r['events']) or 'none'} |" for r in rows]
    text = "\n".join(lines) + "\n"
    (out / "monitor.md").write_text(text)
    (out / "monitor.json").write_text(json.dumps(rows, indent=1))
    print(text)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench_survey", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("survey", help="the demo's self-survey per seed, the map's error against truth")
    s.add_argument("out", help="output folder (survey.md, survey.json, one folder per seed)")
    s.add_argument("--seeds", default="2,3,5", help="comma-separated seeds (default 2,3,5)")
    s.add_argument("--minutes", type=float, default=24.0, help="survey flight per seed (default 24 min)")
    s.add_argument("--rate-hz", type=float, default=1.0, help="survey frame rate (default 1 Hz)")
    s.add_argument("--bin", default="build/host-sim/bin", help="folder of mfns-nav and mfns-ground")
    study.add_arguments(s)
    m = sub.add_parser("monitor", help="the in-flight monitor end to end: a moved beacon, a turned camera")
    m.add_argument("out", help="output folder (emptied first; monitor.md, monitor.json)")
    m.add_argument("--seed", type=int, default=2, help="the module's LEDs and survey error (default 2)")
    m.add_argument("--frames", type=int, default=600, help="frames per case at 18.6 Hz (default 600)")
    m.add_argument("--bin", default="build/host-sim/bin", help="folder of mfns-nav and mfns-ground")
    a = ap.parse_args(argv)
    return survey(a) if a.cmd == "survey" else monitor(a)


if __name__ == "__main__":
    sys.exit(main())
