"""Fly a layout before it is reported (issue 43): fresh paths, the flight program, the count.

A plan's prediction (usable.py) leaves out the acquisition, noise, ghost spots and memory
across cycles; the fly check measures them. For a beacons.csv and the workspace the layout
was planned for (plan.json table_workspace_mm), in a work folder:

1. `mfns sim nav --scenario module --beacon-map LAYOUT --seed SEED --frames N
   --survey-error [--module-size ..]`: a fresh path in the planned module (the seed is not
   the planner's), the LEDs where a survey of the map's sigma_mm leaves them;
2. `mfns table build CALIB LAYOUT --workspace PLAN.json`: the layout's flight table, the
   flight's default settings (integrity enforced, never monitor-only);
3. the flight program `mfns-nav --replay` (mfns.programs: the wheel's own, or the tree's
   build) and the ground station `mfns-ground --file` on its telemetry;
4. the count over nav.csv: usable cycles (FIX, DEGRADED), the reasons of the others, the
   cycle of the first fix (a lost-in-space start), and the per-axis error 1-sigma against
   the run's truth (mfns.analysis.report).

Runs the programs as subprocesses (their own exit codes checked); a failed step raises
MfnsError naming the step and its log.
"""

from __future__ import annotations

import csv
import subprocess
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..analysis import report as rpt
from ..core.errors import MfnsError
from ..programs import program_path
from ..simulate.module_geom import DEMO_MODULE, ModuleGeometry
from ..simulate.nav import CAMERA_DIRS


def _run(cmd: list[str], log: Path, what: str) -> None:
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, check=False)
    if r.returncode != 0:
        raise MfnsError(f"fly check: {what} failed (exit {r.returncode}; see {log})")


def _reason(text: str, names: Sequence[str]) -> str:
    """nav.csv's reason code as the core's name (the code itself when out of range)."""
    return names[int(text)] if text.isdigit() and int(text) < len(names) else text


def fly(
    layout_csv: Path, plan_json: Path, work: Path, frames: int, seed: int, geom: ModuleGeometry = DEMO_MODULE
) -> dict:
    """Fly the layout once in the module geom (module docstring); returns the counts."""
    from ..core.flight import REASONS

    nav, ground = program_path("mfns-nav"), program_path("mfns-ground")
    if nav is None or ground is None:
        raise MfnsError("fly check: no mfns-nav / mfns-ground (install the wheel, or make flight)")
    work.mkdir(parents=True, exist_ok=True)
    py = [sys.executable, "-m", "mfns"]
    fr = work / "frames"
    _run(
        [*py, "sim", "nav", str(fr), "--scenario", "module", "--beacon-map", str(layout_csv), "--seed",
         str(seed), "--frames", str(frames), "--survey-error", "--force", "-q", *geom.cli_args()],
        work / "sim.log",
        "mfns sim nav",
    )  # fmt: skip
    table = work / "table.mfnstbl"
    _run(
        [*py, "table", "build", str(fr / "calib.json"), str(layout_csv), "-o", str(table), "--workspace",
         str(plan_json), "-q"],
        work / "table.log",
        "mfns table build",
    )  # fmt: skip
    tlm = work / "telemetry.bin"
    cmd = [str(nav), "--table", str(table), "--replay", str(fr), "--tlm-file", str(tlm)]
    _run(cmd, work / "nav.log", "mfns-nav")
    cmd = [str(ground), "--file", str(tlm), "--out", str(work / "ground"), "-q"]
    _run(cmd, work / "ground.log", "mfns-ground")
    log = rpt.load_nav(work / "ground")
    good = np.isin(log.status, rpt.GOOD_STATUS)
    with open(work / "ground" / "nav.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    reasons = Counter(_reason(r["reason"], REASONS) for r, g in zip(rows, good, strict=True) if not g)
    first = int(np.argmax(good)) if good.any() else None
    sigma = None
    if good.any():
        rep = rpt.build_report(log, rpt.load_truth(fr / "truth.csv"))
        sigma = {s.axis: round(s.sigma, 4) for s in rep.stats}
    # the frames are large and made again by the seed: keep what describes the run
    for cam in CAMERA_DIRS:
        subprocess.run(["rm", "-rf", str(fr / cam)], check=False)
    return {
        "frames": int(len(log.t_s)),
        "seed": seed,
        "usable_pct": round(100.0 * float(good.mean()), 2) if len(good) else None,
        "usable": int(good.sum()),
        "unusable_reasons": dict(reasons.most_common()),
        "first_fix_cycle": first,
        "error_sigma": sigma,
        "work": str(work),
    }
