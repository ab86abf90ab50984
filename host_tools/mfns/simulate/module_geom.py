"""The space-station module's geometry: one definition for the simulator and the planner.

`mfns sim nav --scenario module` renders a module, `mfns plan --workspace module` samples
the poses its path can reach and `mfns plan --surfaces module` puts candidate beacons on
its walls; all three read a ModuleGeometry, so the same options give the same module:

- ``size_mm``: the module's inside extents along Xw (its length), Yw, Zw; world origin at
  its centre. The demo's module is 4000 x 2000 x 2000 mm (DEMO_SIZE_MM).
- ``path_amp_mm``: the box about the centre the body origin stays in on every path (the
  trajectory's sinusoid amplitudes), which is also the robot's workspace its flight
  tables are built over. By default the demo's (800, 300, 300) mm scaled axis by axis
  with the size: a module of other proportions gets a path of the same proportions, the
  same share of the module crossed.
- the wall beacons keep EDGE_MARGIN_MM from the walls' edges; the turn-around half-width
  scales with the length (the robot turns as it crosses the module's middle).

Attitude wobble and the periods of the path are the robot's, not the module's: they do
not change with the size. Options: add_arguments / from_args (both commands).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import MfnsError

# the demo's module (make demo, docs/nav-frames.md), mm: length Xw, width Yw, height Zw
DEMO_SIZE_MM = (4000.0, 2000.0, 2000.0)
# the demo's path: the body origin within this of the centre (>= 700 mm from every wall)
DEMO_POS_AMP_MM = (800.0, 300.0, 300.0)
# Half-width (mm of Xw) of the turn-around manoeuvre at the demo module's centre.
DEMO_TURN_WIDTH_MM = 250.0
# Beacons keep this far from a wall's edges (corners are hard to survey and to see).
EDGE_MARGIN_MM = 150.0
# The body origin keeps at least this far from every wall on every path: about the
# robot's half-size with its cameras (a path closer than this would put the rig in a wall).
MIN_WALL_CLEARANCE_MM = 300.0
# A module's side must leave room for a wall beacon inside the edge margins.
MIN_SIZE_MM = 2 * EDGE_MARGIN_MM + 100.0
# Beyond this a "module" is a typo (100 m), not a station module.
MAX_SIZE_MM = 100_000.0


@dataclass(frozen=True)
class ModuleGeometry:
    size_mm: tuple[float, float, float] = DEMO_SIZE_MM
    path_amp_mm: tuple[float, float, float] | None = None  # None: the demo's, scaled with the size

    def __post_init__(self) -> None:
        s = self.size_mm
        if len(s) != 3 or not all(math.isfinite(v) and MIN_SIZE_MM <= v <= MAX_SIZE_MM for v in s):
            raise MfnsError(
                f"module size {list(s)}: expected three lengths of {MIN_SIZE_MM:g} to {MAX_SIZE_MM:g} mm"
            )
        a = self.pos_amp_mm
        if not np.all(np.isfinite(a)) or np.any(a < 0):
            raise MfnsError(f"module path amplitude {a.tolist()}: expected three lengths >= 0 mm")
        room = self.half - MIN_WALL_CLEARANCE_MM
        if np.any(a > room + 1e-9):
            raise MfnsError(
                f"module path amplitude {a.tolist()} mm: the body would come within "
                f"{MIN_WALL_CLEARANCE_MM:g} mm of a wall of the {self.describe()} module "
                f"(at most {np.maximum(room, 0).tolist()} mm)"
            )

    @property
    def half(self) -> np.ndarray:
        """Half-extents (mm) along Xw, Yw, Zw."""
        return np.asarray(self.size_mm, dtype=float) / 2.0

    @property
    def pos_amp_mm(self) -> np.ndarray:
        """The path's amplitude about the centre (mm): given, or the demo's scaled."""
        if self.path_amp_mm is not None:
            return np.asarray(self.path_amp_mm, dtype=float)
        return np.asarray(DEMO_POS_AMP_MM) * (np.asarray(self.size_mm) / np.asarray(DEMO_SIZE_MM))

    @property
    def turn_width_mm(self) -> float:
        return DEMO_TURN_WIDTH_MM * self.size_mm[0] / DEMO_SIZE_MM[0]

    @property
    def is_demo(self) -> bool:
        return tuple(self.size_mm) == DEMO_SIZE_MM and np.array_equal(self.pos_amp_mm, DEMO_POS_AMP_MM)

    def workspace(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi): the box the body origin stays in on every path (the robot's workspace)."""
        amp = self.pos_amp_mm
        return -amp.copy(), amp.copy()

    def describe(self) -> str:
        return " x ".join(f"{v:g}" for v in self.size_mm) + " mm"

    def cli_args(self) -> list[str]:
        """The options that give this module to `mfns sim nav` / `mfns plan` (none for the demo's)."""
        if self.is_demo:
            return []
        out = ["--module-size", ",".join(f"{v:g}" for v in self.size_mm)]
        if self.path_amp_mm is not None:
            out += ["--module-path-amp", ",".join(f"{v:g}" for v in self.path_amp_mm)]
        return out

    def to_doc(self) -> dict:
        return {
            "size_mm": [float(v) for v in self.size_mm],
            "path_amp_mm": [float(v) for v in self.pos_amp_mm],
            "path_amp_from": "given" if self.path_amp_mm is not None else "the demo's, scaled with the size",
            "edge_margin_mm": EDGE_MARGIN_MM,
        }


DEMO_MODULE = ModuleGeometry()


def _triple(text: str, flag: str) -> tuple[float, float, float]:
    try:
        v = [float(t) for t in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise MfnsError(f"{flag} {text!r}: expected three lengths X,Y,Z in mm (e.g. 3000,2000,2000)")
    return v[0], v[1], v[2]


def parse(size: str | None, path_amp: str | None) -> ModuleGeometry:
    """--module-size / --module-path-amp texts (None: the default) -> ModuleGeometry."""
    s = _triple(size, "--module-size") if size is not None else DEMO_SIZE_MM
    a = _triple(path_amp, "--module-path-amp") if path_amp is not None else None
    return ModuleGeometry(s, a)


def given(args) -> bool:
    """Whether the arguments name a module geometry (either option)."""
    return (
        getattr(args, "module_size", None) is not None or getattr(args, "module_path_amp", None) is not None
    )


def from_args(args) -> ModuleGeometry:
    return parse(getattr(args, "module_size", None), getattr(args, "module_path_amp", None))


def add_arguments(p, what: str) -> None:
    """--module-size and --module-path-amp on a parser or group; what: what they shape."""
    sx, sy, sz = (f"{v:g}" for v in DEMO_SIZE_MM)
    ax, ay, az = (f"{v:g}" for v in DEMO_POS_AMP_MM)
    p.add_argument(
        "--module-size",
        metavar="X,Y,Z",
        help=f"module: inside extents along Xw (length), Yw, Zw, mm, world origin at the centre; "
        f"{what} (default the demo's {sx},{sy},{sz})",
    )
    p.add_argument(
        "--module-path-amp",
        metavar="X,Y,Z",
        help=f"module: the box about the centre the body origin stays in on every path (the "
        f"robot's workspace), mm; at least {MIN_WALL_CLEARANCE_MM:g} mm from every wall (default "
        f"{ax},{ay},{az} scaled with --module-size)",
    )
