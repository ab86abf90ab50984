"""Soak test of mfns-nav (see mk/soak.mk): long replay under ASan/UBSan, RSS flat, counters consistent.

Prints one line per check and "soak: N passed, M failed" at the end; exit 1 on any failure.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

RATE_HZ = 18.6
BASE_FRAMES = 100


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    res = subprocess.run(cmd, check=False, capture_output=True, text=True, **kw)
    if res.returncode != 0:
        sys.exit(f"soak: {' '.join(cmd[:4])} failed: {res.stderr.strip()[-500:]}")
    return res


def make_base(work: Path) -> Path:
    base = work / "base"
    py = [sys.executable, "-m", "mfns"]
    frames = base / "frames"
    # The frames are kept between runs (mfns sim nav is deterministic); the table is
    # always rebuilt: a cached one may be of an older format than the loader takes.
    if not (frames / "frames.csv").exists():
        shutil.rmtree(base, ignore_errors=True)
        base.mkdir(parents=True)
        run(
            [
                *py,
                "sim",
                "nav",
                str(frames),
                "--quiet",
                "--scenario",
                "module",
                "--frames",
                str(BASE_FRAMES),
                "--seed",
                "3",
            ]
        )
    run(
        [
            *py,
            "table",
            "build",
            str(frames / "calib.json"),
            str(frames / "beacons.csv"),
            "-o",
            str(base / "table.mfnstbl"),
        ]
    )
    return base


def make_loop(base: Path, work: Path, minutes: float) -> Path:
    """A folder whose frames.csv plays the base frames forwards and backwards for the whole run."""
    loop = work / "loop"
    shutil.rmtree(loop, ignore_errors=True)
    loop.mkdir()
    src = base / "frames"
    for name in ("cam_x", "cam_y", "cam_z", "scenario.json"):
        os.symlink(src.resolve() / name, loop / name)
    rows = {}
    for r in csv.DictReader(open(src / "frames.csv", newline="")):
        rows[(int(r["frame"]), r["camera"])] = r
    n = math.ceil(minutes * 60 * RATE_HZ * 1.1) + 10
    period = 2 * (BASE_FRAMES - 1)
    with open(loop / "frames.csv", "w") as f:
        f.write("frame,t_s,camera,file,exposure_us,gain_db\n")
        for i in range(n):
            k = i % period
            src_frame = k if k < BASE_FRAMES else period - k
            for cam in "xyz":
                r = rows[(src_frame, cam)]
                f.write(f"{i},{i / RATE_HZ:.6f},{cam},{r['file']},{r['exposure_us']},{r['gain_db']}\n")
    return loop


def rss_kb(pid: int) -> int:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, required=True)
    ap.add_argument("--bin", type=Path, required=True)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--sample-s", type=float, default=5.0)
    a = ap.parse_args()
    if not a.minutes > 0:
        sys.exit("soak: --minutes wants a positive number")
    a.work.mkdir(parents=True, exist_ok=True)
    base = make_base(a.work)
    loop = make_loop(base, a.work, a.minutes)
    first = (base / "frames" / "truth.csv").read_text().splitlines()[1].split(",")[2:8]
    tlm = a.work / "tlm.bin"
    log = open(a.work / "soak.log", "w")
    env = dict(
        os.environ,
        ASAN_OPTIONS="detect_leaks=1:halt_on_error=1",
        UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1",
    )
    cmd = [
        str(a.bin / "mfns-nav"),
        "--table",
        str(base / "table.mfnstbl"),
        "--replay",
        str(loop),
        "--realtime",
    ]
    cmd += ["--tlm-file", str(tlm), "--init-pose=" + ",".join(first)]
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    samples: list[tuple[float, int]] = []
    end = t0 + a.minutes * 60
    while time.monotonic() < end and p.poll() is None:
        time.sleep(min(a.sample_s, max(0.0, end - time.monotonic())))
        if p.poll() is None:
            samples.append((time.monotonic() - t0, rss_kb(p.pid)))
            print(f"t={samples[-1][0]:.0f}s rss={samples[-1][1]} kB", file=log, flush=True)
    ended_early = p.poll() is not None
    if not ended_early:
        p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    log.write(err)
    log.close()
    checks: list[tuple[str, bool, str]] = []
    sanitizer = [ln for ln in err.splitlines() if "Sanitizer" in ln or "runtime error" in ln]
    checks.append(("no sanitizer report", not sanitizer, "; ".join(sanitizer[:3])))
    checks.append(
        (
            "ran the whole time and stopped on the signal",
            not ended_early and p.returncode == 0 and "stopped (signal)" in err,
            f"exit {p.returncode}",
        )
    )
    warm = max(20.0, 0.1 * a.minutes * 60)
    after = [r for t, r in samples if t >= warm]
    if len(after) >= 2:
        base_rss, peak = after[0], max(after)
        growth = (peak - base_rss) / base_rss * 100.0
        checks.append(
            (
                "RSS flat within 1 %",
                growth <= 1.0,
                f"{base_rss} kB at {warm:.0f} s, max {peak} kB, min {min(after)} kB, {growth:+.2f} %"
                f" over {len(after)} samples",
            )
        )
    else:
        checks.append(
            ("RSS flat within 1 %", False, f"only {len(after)} samples after the {warm:.0f} s warm-up")
        )
    summary = next((ln for ln in err.splitlines() if "stopped (" in ln), "")
    m = re.search(
        r"after (\d+) cycles: (\d+) fix, (\d+) degraded, (\d+) no fix, (\d+) telemetry frames dropped",
        summary,
    )
    cycles, n_fix, n_deg, n_nofix, dropped = (int(v) for v in m.groups()) if m else (-1, -1, -1, -1, -1)
    out = a.work / "ground"
    shutil.rmtree(out, ignore_errors=True)
    g = subprocess.run(
        [str(a.bin / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"],
        check=False,
        capture_output=True,
        text=True,
        env=env,
    )
    nav = list(csv.DictReader(open(out / "nav.csv", newline=""))) if g.returncode == 0 else []
    hk = list(csv.DictReader(open(out / "housekeeping.csv", newline=""))) if g.returncode == 0 else []
    status = [r["status"] for r in nav]
    ok = g.returncode == 0 and "crc_errors=0 truncated=0" in g.stderr and dropped == 0
    ok = ok and cycles == len(nav) == n_fix + n_deg + n_nofix
    ok = ok and (status.count("FIX"), status.count("DEGRADED"), status.count("NO_FIX")) == (
        n_fix,
        n_deg,
        n_nofix,
    )
    ok = ok and bool(hk) and int(hk[-1]["n_cycles"]) == cycles
    ok = ok and (int(hk[-1]["n_fix"]), int(hk[-1]["n_degraded"]), int(hk[-1]["n_no_fix"])) == (
        n_fix,
        n_deg,
        n_nofix,
    )
    ok = ok and [int(r["cycle"]) for r in nav] == list(range(cycles))
    checks.append(
        (
            "counters consistent",
            ok,
            f"{cycles} cycles, {n_fix} fix, {n_deg} degraded, {n_nofix} no fix,"
            f" {len(nav)} nav packets decoded, {dropped} telemetry frames dropped",
        )
    )
    passed = 0
    for name, good, detail in checks:
        print(f"soak: {'ok  ' if good else 'FAIL'} {name}: {detail}")
        passed += good
    print(f"soak: {passed} passed, {len(checks) - passed} failed ({a.minutes:g} min, {cycles} cycles)")
    return 0 if passed == len(checks) else 1


if __name__ == "__main__":
    sys.exit(main())
