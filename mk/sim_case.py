"""The module scenario as the budget scripts fly it (mk/callgrind.py, mk/latency.py): one
place that writes a replay and builds its table, so both measure the same case."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def mfns(*args: str) -> None:
    """Runs `python -m mfns ARGS`; exits with the tool's last words when it fails."""
    r = subprocess.run([sys.executable, "-m", "mfns", *args], capture_output=True, text=True, check=False)
    if r.returncode != 0:
        sys.exit(f"{Path(sys.argv[0]).stem}: mfns {args[0]} failed: {r.stderr[-1500:]}")


def module_case(d: Path, seed: int, frames: int, map_of: Path | None = None) -> Path:
    """Writes the module scenario's replay to d/frames and its table to d/t.mfnstbl (returned).
    map_of: another run's beacons.csv for the table instead of this run's own (a wrong map)."""
    mfns(
        "sim",
        "nav",
        str(d / "frames"),
        "--quiet",
        "--scenario",
        "module",
        "--frames",
        str(frames),
        "--seed",
        str(seed),
    )
    beacons = map_of if map_of is not None else d / "frames/beacons.csv"
    table = d / "t.mfnstbl"
    mfns("table", "build", str(d / "frames/calib.json"), str(beacons), "-o", str(table))
    return table
