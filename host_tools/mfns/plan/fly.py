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
   the run's truth (mfns.analysis.report);
5. the measured one-call rate: the flight program started lost (a fresh process, no pose
   hint) at `starts` frames spread over the path, one cycle each (`mfns-nav --max-cycles
   1` on a folder whose frames.csv holds that frame alone, the images shared): a start
   counts when its first cycle gives a certified fix -- usable (FIX, DEGRADED), or held
   only for want of motion to test the cameras for a lag (LAG_UNTESTED: the flight sets it
   on a fix that passed identification, the certificate and integrity, nav_cycle.c
   lag_untested; the first two fixes after a gap always carry it). The planner's
   one-call figure is a prediction (usable with >= 5 beacons in view); this is the
   acquisition itself, with noise, ghost spots and the survey error of the path.

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


# The first cycle's outcomes that count as a fix certified in one call (step 5): a usable
# status, or a fix the flight holds only for its untested lag.
LAG_HELD_REASON = "LAG_UNTESTED"


def start_frames(frames: int, starts: int) -> list[int]:
    """The frames the lost starts begin at: `starts` spread evenly over 0..frames-1."""
    if starts <= 0 or frames <= 0:
        return []
    return sorted({int(v) for v in np.linspace(0, frames - 1, min(starts, frames)).round()})


def start_folder(fr: Path, frame: int, dest: Path) -> Path:
    """A frame folder holding frame `frame` of fr alone (its own frames.csv and
    scenario.json; the images through links to fr's camera folders)."""
    dest.mkdir(parents=True, exist_ok=True)
    with open(fr / "frames.csv", newline="") as f:
        lines = f.read().splitlines()
    rows = [ln for ln in lines[1:] if ln.split(",", 1)[0] == str(frame)]
    if not rows:
        raise MfnsError(f"fly check: frame {frame} is not in {fr / 'frames.csv'}")
    (dest / "frames.csv").write_text("\n".join([lines[0], *rows]) + "\n")
    (dest / "scenario.json").write_bytes((fr / "scenario.json").read_bytes())
    for cam in CAMERA_DIRS:
        link = dest / cam
        if not link.exists():
            link.symlink_to((fr / cam).resolve(), target_is_directory=True)
    return dest


def first_cycle_certified(status: str, reason: str) -> bool:
    """Whether a lost start's first cycle gave a certified fix (step 5)."""
    return status in rpt.GOOD_STATUS or reason == LAG_HELD_REASON


def one_call_summary(outcomes: Sequence[tuple[str, str]], predicted: Sequence[bool]) -> dict:
    """The measured one-call rate of lost starts (their first cycle's (status, reason))
    beside the planner's prediction on the same poses (usable with >= 5 in view)."""
    if len(outcomes) != len(predicted):
        raise ValueError("one outcome and one prediction per start")
    ok = [first_cycle_certified(s, r) for s, r in outcomes]
    n = len(ok)
    why = Counter(
        r if s not in rpt.GOOD_STATUS else s for (s, r), o in zip(outcomes, ok, strict=True) if not o
    )
    return {
        "starts": n,
        "certified_first_cycle": int(sum(ok)),
        "measured_pct": round(100.0 * sum(ok) / n, 2) if n else None,
        "predicted_pct": round(100.0 * sum(bool(p) for p in predicted) / n, 2) if n else None,
        "not_certified_reasons": dict(why.most_common()),
    }


def lost_starts(
    nav: Path, ground: Path, table: Path, fr: Path, work: Path, frames: list[int]
) -> list[tuple[str, str]]:
    """The first cycle (status, reason name) of the flight program started lost at each frame."""
    from ..core.flight import REASONS

    out = []
    for k in frames:
        d = start_folder(fr, k, work / f"{k:06d}")
        tlm = d / "telemetry.bin"
        cmd = [
            str(nav),
            "--table",
            str(table),
            "--replay",
            str(d),
            "--tlm-file",
            str(tlm),
            "--max-cycles",
            "1",
        ]
        _run(cmd, d / "nav.log", f"mfns-nav started lost at frame {k}")
        _run(
            [str(ground), "--file", str(tlm), "--out", str(d / "ground"), "-q"],
            d / "ground.log",
            "mfns-ground",
        )
        with open(d / "ground" / "nav.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        if not rows:
            raise MfnsError(f"fly check: no cycle from the start at frame {k} (see {d})")
        out.append((rows[0]["status"], _reason(rows[0]["reason"], REASONS)))
    return out


def fly(
    layout_csv: Path,
    plan_json: Path,
    work: Path,
    frames: int,
    seed: int,
    geom: ModuleGeometry = DEMO_MODULE,
    starts: int = 0,
) -> dict:
    """Fly the layout once in the module geom (module docstring), and start it lost at
    `starts` frames of the path (step 5); returns the counts."""
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
    # a 1-sigma needs two usable cycles (one has no spread: NaN, which JSON cannot carry)
    if int(good.sum()) >= 2:
        rep = rpt.build_report(log, rpt.load_truth(fr / "truth.csv"))
        sigma = {s.axis: round(s.sigma, 4) for s in rep.stats}
    sf = start_frames(len(log.t_s), starts)
    outcomes = lost_starts(nav, ground, table, fr, work / "starts", sf)
    subprocess.run(["rm", "-rf", str(work / "starts")], check=False)
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
        "start_frames": sf,
        "start_outcomes": [list(o) for o in outcomes],
        "error_sigma": sigma,
        "work": str(work),
    }
