"""The flight and ground programs a pip install carries: `mfns-nav` and `mfns-ground`.

The wheel holds the host (host-sim) builds of firmware/app (mfns-nav) and ground (mfns-ground)
in mfns/bin/, built by the Makefile's own targets during the wheel build (host_tools/setup.py,
mk/pkg.mk pkg-programs). These console scripts replace the Python process with the packaged
program (os.execv: its arguments, exit status, signals and standard streams are the
program's own), so `mfns sim nav` -> `mfns table build` -> `mfns-nav --replay` ->
`mfns-ground --file` -> `mfns report` runs from an installed wheel without the repository.

Which program runs, first found of:
1. the package's own mfns/bin/<name> (an installed wheel);
2. the tree's build/host-sim/bin/<name> (`make flight`; an editable install, `make venv`).
Neither: exit 2 with one line saying how to get one.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

PACKAGE_BIN = Path(__file__).resolve().parent / "bin"
TREE_BIN = Path(__file__).resolve().parents[2] / "build" / "host-sim" / "bin"
PROGRAMS = ("mfns-nav", "mfns-ground")


def program_path(name: str) -> Path | None:
    """The program `name` (one of PROGRAMS) this install runs, or None."""
    if name not in PROGRAMS:
        raise ValueError(f"{name}: not one of {', '.join(PROGRAMS)}")
    for d in (PACKAGE_BIN, TREE_BIN):
        p = d / name
        if p.is_file() and os.access(p, os.X_OK):
            return p
    return None


def _exec(name: str, argv: list[str] | None = None) -> int:
    p = program_path(name)
    if p is None:
        print(
            f"{name}: error: no {name} in this install ({PACKAGE_BIN}) nor a tree build "
            f"({TREE_BIN}): install the wheel (pip install ./host_tools) or run make flight",
            file=sys.stderr,
        )
        return 2
    args = sys.argv[1:] if argv is None else argv
    try:
        os.execv(p, [name, *args])
    except OSError as e:  # not reached when the exec succeeds
        print(f"{name}: error: cannot run {p}: {e}", file=sys.stderr)
        return 2
    return 2  # pragma: no cover (os.execv does not return)


def nav() -> int:
    """Console script `mfns-nav`: the flight program (firmware/app)."""
    return _exec("mfns-nav")


def ground() -> int:
    """Console script `mfns-ground`: the ground station (ground/)."""
    return _exec("mfns-ground")
