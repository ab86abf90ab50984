#!/usr/bin/env python3
"""make callgrind (docs/budgets.md "Cycle cost on the target"): the instruction
count of every navigation cycle of the flight program, by valgrind's callgrind.

mfns-nav (the host-sim build, -O2 -g) flies replays of the module scenario
under `valgrind --tool=callgrind --collect-atstart=no
--toggle-collect=mfns_nav_cycle --dump-after=mfns_nav_cycle`: one profile per
call of the navigation core's cycle, so each dump's total is exactly the
instructions of one cycle (centroiding, acquisition or tracking, integrity;
not the camera driver, the telemetry or the wait). The ground decodes the
telemetry, so each cycle's mode is known, and the housekeeping's
acq_units_max gives the acquisition work of the interval, hence the
instructions per work unit.

The counts are x86-64 instructions of the development host; an AArch64 build
of the same C executes a similar number (same compiler, -O2, float code; no
counting tool for AArch64 runs here: qemu-user has no plugins in Debian), so
the target times below carry that uncertainty as well as the CPI's.

Writes build/callgrind/results.json and prints a summary.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

from sim_case import module_case

REPO = Path(__file__).resolve().parents[1]
BIN = REPO / "build" / "host-sim" / "bin"
FRAME_PERIOD_MS = 53.8  # 18.6 Hz (README)
# The targets: clock, and the cycles per instruction assumed (low, mid, high).
# A53: in-order, dual issue (peak IPC 2); A72: out-of-order, 3-wide decode (peak
# IPC 3). The mid values are assumptions for branchy float code with a working
# set that mostly fits L2 (the calibration grids, ~100 kB), to be replaced by
# `perf stat -e instructions,cycles` on the board (docs/budgets.md).
TARGETS = {
    "Cortex-A53 @ 1.2 GHz": {"hz": 1.2e9, "cpi": (1.0, 1.5, 2.0)},
    "Cortex-A72 @ 1.5 GHz": {"hz": 1.5e9, "cpi": (0.6, 0.8, 1.1)},
}


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)
    if r.returncode != 0:
        sys.exit(f"callgrind: {' '.join(cmd[:3])} ... failed ({r.returncode}): {r.stderr[-1500:]}")
    return r


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fly(out: Path, seed: int, frames: int, map_of: Path | None = None) -> dict:
    """One replay under callgrind; map_of: another run's beacons.csv for the table (a wrong map:
    acquisition never confirms, so every cycle spends its whole budget -- the worst case)."""
    d = out / (f"seed{seed}" if map_of is None else f"seed{seed}-wrong-map")
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    table = module_case(d, seed, frames, map_of)
    cg = d / "cg"
    cg.mkdir()
    run(
        [
            "valgrind",
            "--tool=callgrind",
            "--collect-atstart=no",
            "--toggle-collect=mfns_nav_cycle",
            "--dump-after=mfns_nav_cycle",
            f"--callgrind-out-file={cg}/cg.%p",
            str(BIN / "mfns-nav"),
            "--table",
            str(table),
            "--replay",
            str(d / "frames"),
            "--file",
            str(d / "tlm.bin"),
            "-q",
        ]
    )
    dumps = {}
    for f in cg.iterdir():
        m = re.fullmatch(r"cg\.\d+\.(\d+)", f.name)
        if m:
            tot = re.search(r"^totals:\s*(\d+)", f.read_text(errors="replace"), re.M)
            dumps[int(m.group(1))] = int(tot.group(1)) if tot else 0
    per_cycle = [dumps[i] for i in sorted(dumps)]  # dump i (1-based) = cycle i - 1
    run([str(BIN / "mfns-ground"), "--file", str(d / "tlm.bin"), "--out", str(d / "g"), "-q"])
    nav = rows(d / "g" / "nav.csv")
    hk = rows(d / "g" / "housekeeping.csv")
    assert len(nav) == len(per_cycle), (len(nav), len(per_cycle))
    # a cycle that ran acquisition: mode ACQUIRE in its packet, or the one that acquired (ACQUIRE before it)
    acq = [
        i for i, r in enumerate(nav) if r["mode"] == "ACQUIRE" or (i == 0 or nav[i - 1]["mode"] == "ACQUIRE")
    ]
    trk = [i for i in range(len(nav)) if i not in acq]
    units_max = max((int(h["acq_units_max"]) for h in hk), default=0)
    worst = max(range(len(per_cycle)), key=lambda i: per_cycle[i])
    return {
        "seed": seed,
        "map": "own" if map_of is None else f"wrong ({map_of.parent.parent.name})",
        "cycles": len(per_cycle),
        "acquisition_cycles": len(acq),
        "worst_cycle": worst,
        "worst_cycle_mode": nav[worst]["mode"],
        "worst_instructions": per_cycle[worst],
        "worst_acquisition_instructions": max((per_cycle[i] for i in acq), default=0),
        "tracking_median_instructions": int(statistics.median([per_cycle[i] for i in trk])) if trk else 0,
        "tracking_max_instructions": max((per_cycle[i] for i in trk), default=0),
        "acq_units_max": units_max,
        "per_cycle": per_cycle,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="2,5", help="module-scenario seeds (default 2, the demo's, and 5)")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--out", type=Path, default=REPO / "build" / "callgrind")
    a = ap.parse_args()
    if shutil.which("valgrind") is None:
        sys.exit("callgrind: valgrind is not installed (mk/deps.sh installs it)")
    os.environ["PYTHONPATH"] = str(REPO / "host_tools") + os.pathsep + os.environ.get("PYTHONPATH", "")
    a.out.mkdir(parents=True, exist_ok=True)
    seeds = [int(s) for s in a.seeds.split(",")]
    runs = [fly(a.out, s, a.frames) for s in seeds]
    if len(seeds) > 1:  # the budget-limited case: the first seed's frames, the second's beacon map
        runs.append(
            fly(a.out, seeds[0], a.frames // 2, map_of=a.out / f"seed{seeds[1]}" / "frames/beacons.csv")
        )
    worst = max(runs, key=lambda r: r["worst_acquisition_instructions"])
    # the work-unit cost from the runs whose acquisition spent most (the budget-limited one)
    n = worst["worst_acquisition_instructions"]
    est = {}
    for name, t in TARGETS.items():
        ms = [n * c / t["hz"] * 1e3 for c in t["cpi"]]
        est[name] = {"cpi": t["cpi"], "ms": ms, "margin_ms_mid": FRAME_PERIOD_MS - ms[1]}
    per_unit = n / worst["acq_units_max"] if worst["acq_units_max"] else None
    res = {
        "frame_period_ms": FRAME_PERIOD_MS,
        "runs": runs,
        "worst_acquisition_instructions": n,
        "worst_seed": worst["seed"],
        "instructions_per_work_unit": per_unit,
        "targets": est,
    }
    (a.out / "results.json").write_text(json.dumps(res, indent=1) + "\n")
    for r in runs:
        print(
            f"callgrind: seed {r['seed']} ({r['map']} map): {r['cycles']} cycles, "
            f"{r['acquisition_cycles']} acquiring; worst cycle {r['worst_cycle']} ({r['worst_cycle_mode']}) "
            f"{r['worst_instructions']:,} instructions; tracking "
            f"median {r['tracking_median_instructions']:,}, max {r['tracking_max_instructions']:,}; "
            f"acquisition work max {r['acq_units_max']} units"
        )
    print(
        f"callgrind: worst acquisition cycle {n:,} instructions (seed {worst['seed']})"
        + (f", {per_unit:,.0f} per work unit of its interval's most" if per_unit else "")
    )
    for name, e in est.items():
        lo, mid, hi = e["ms"]
        print(
            f"callgrind: {name}: CPI {e['cpi'][0]}..{e['cpi'][2]} (assumed {e['cpi'][1]}): "
            f"{lo:.1f}..{hi:.1f} ms ({mid:.1f} ms), frame period {FRAME_PERIOD_MS} ms"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
