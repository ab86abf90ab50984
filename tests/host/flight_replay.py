"""One flight of the replay chain for the host tests: the built `mfns-nav` on a frames
folder with a table, then `mfns-ground` on its telemetry file. Both must exit 0; the
caller reads what it needs from the ground's folder (nav.csv, events.csv, ...)."""

from __future__ import annotations

import csv
import subprocess
from dataclasses import dataclass
from pathlib import Path

NAV_TIMEOUT_S = 300
GROUND_TIMEOUT_S = 120


@dataclass
class Flight:
    nav_stderr: str
    ground_stderr: str
    ground: Path  # mfns-ground's output folder

    def rows(self, name: str = "nav.csv") -> list[dict]:
        """The rows of one of the ground's CSV files."""
        return read_csv(self.ground / name)


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fly_replay(
    bins: Path,
    table: Path,
    frames: Path,
    out: Path,
    *nav_args: str,
    tlm_name: str = "tlm.bin",
    ground_name: str = "ground",
) -> Flight:
    """mfns-nav --table table --replay frames --tlm-file out/tlm_name [nav_args], then
    mfns-ground --file that --out out/ground_name --no-status."""
    out.mkdir(parents=True, exist_ok=True)
    tlm = out / tlm_name
    nav = subprocess.run(
        [
            str(bins / "mfns-nav"),
            "--table",
            str(table),
            "--replay",
            str(frames),
            "--tlm-file",
            str(tlm),
            *nav_args,
        ],
        check=False,
        capture_output=True,
        text=True,
        timeout=NAV_TIMEOUT_S,
    )
    assert nav.returncode == 0, nav.stderr
    ground = out / ground_name
    g = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(ground), "--no-status"],
        check=False,
        capture_output=True,
        text=True,
        timeout=GROUND_TIMEOUT_S,
    )
    assert g.returncode == 0, g.stderr
    return Flight(nav.stderr, g.stderr, ground)
