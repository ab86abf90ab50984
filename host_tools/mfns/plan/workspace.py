"""Pose samples of a workspace: where the robot may be, and how it may be turned.

Three kinds (docs/planning.md):

- ``turntable``: the paper's navigation experiment (docs/system.md §6, ``mfns sim nav
  --scenario turntable``): body origin at the world origin, attitude (0, 0, yaw) with yaw
  swept evenly from ``yaw_start_deg`` over ``yaw_span_deg`` -- the same yaws the
  simulator renders for the same frame count.
- ``module``: the space-station module of ``mfns sim nav --scenario module`` (a
  ModuleGeometry: the demo's, or the one --module-size / --module-path-amp give): the body
  origin anywhere in the box its trajectory covers (its path amplitude about the centre),
  roll and pitch within the trajectory's wobble, yaw over the full circle (the robot
  turns round as it crosses the module).
- ``box``: a box of positions given by the user; attitude uniform over SO(3) or uniform
  in given roll / pitch / yaw ranges.
- ``truth``: the poses of a recorded ``truth.csv`` (docs/nav-frames.md), in order: the
  exact poses of a simulated run, to compare the plan with the run.

Samples are drawn from ``numpy.random.default_rng(seed)``: the same seed, the same poses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import MfnsError
from ..model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg, random_rotations
from ..simulate.module_geom import DEMO_MODULE, ModuleGeometry
from ..simulate.nav import MODULE_ATT_AMP_DEG


@dataclass
class Workspace:
    kind: str
    r_wb_w: np.ndarray  # (n, 3) body position in the world, mm
    C_w_b: np.ndarray  # (n, 3, 3)
    euler_deg: np.ndarray  # (n, 3) 2-1-3 angles of C_w_b
    description: str
    ordered: bool = False  # samples are a time sequence (the nav cycle's rule applies)

    @property
    def n(self) -> int:
        return len(self.r_wb_w)

    def r_bw_b(self, i: int) -> np.ndarray:
        return -self.C_w_b[i] @ self.r_wb_w[i]


def _from_matrices(kind: str, pos: np.ndarray, C: np.ndarray, text: str, ordered: bool = False) -> Workspace:
    euler = np.array([matrix_to_euler213_deg(c) for c in C]).reshape(-1, 3)
    return Workspace(kind, np.asarray(pos, dtype=float).reshape(-1, 3), C, euler, text, ordered)


def from_truth(path) -> Workspace:
    """The poses of a truth.csv (frame,t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg)."""
    from ..analysis.report import load_truth

    t = load_truth(path)
    v = t.values
    euler = np.column_stack([v["roll"], v["pitch"], v["yaw"]])
    pos = np.column_stack([v["x"], v["y"], v["z"]])
    C = np.array([euler213_deg_to_matrix(e) for e in euler]).reshape(-1, 3, 3)
    return _from_matrices("truth", pos, C, f"the {len(C)} poses of {path}", ordered=True)


def turntable(n: int, yaw_start_deg: float = 0.0, yaw_span_deg: float = 120.0) -> Workspace:
    """The yaw sweep of `mfns sim nav --scenario turntable --frames n` (deterministic)."""
    _check_n(n)
    yaw = yaw_start_deg + yaw_span_deg * np.arange(n) / n
    C = np.array([euler213_deg_to_matrix([0.0, 0.0, y]) for y in yaw])
    return _from_matrices(
        "turntable",
        np.zeros((n, 3)),
        C,
        f"turntable yaw sweep {yaw_start_deg:g} deg + {yaw_span_deg:g} deg, {n} samples",
        ordered=True,
    )


def box(
    n: int,
    lo_mm,
    hi_mm,
    rng: np.random.Generator,
    attitude: str = "uniform",
    roll_deg=(-180.0, 180.0),
    pitch_deg=(-180.0, 180.0),
    yaw_deg=(-180.0, 180.0),
    kind: str = "box",
) -> Workspace:
    """Positions uniform in [lo, hi]; attitude 'uniform' (SO(3)) or 'ranges' (uniform angles)."""
    _check_n(n)
    lo, hi = np.asarray(lo_mm, dtype=float), np.asarray(hi_mm, dtype=float)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(hi >= lo) or not np.all(np.isfinite([lo, hi])):
        raise MfnsError("box: need finite corners with lo <= hi on every axis")
    pos = rng.uniform(lo, hi, size=(n, 3))
    if attitude == "uniform":
        C = random_rotations(rng, n)
        att = "attitude uniform over all rotations"
    elif attitude == "ranges":
        for name, r in (("roll", roll_deg), ("pitch", pitch_deg), ("yaw", yaw_deg)):
            if len(r) != 2 or not r[0] <= r[1]:
                raise MfnsError(f"{name} range must be LO,HI with LO <= HI")
        ang = np.column_stack([rng.uniform(r[0], r[1], n) for r in (roll_deg, pitch_deg, yaw_deg)])
        C = np.array([euler213_deg_to_matrix(a) for a in ang])
        att = f"roll {roll_deg}, pitch {pitch_deg}, yaw {yaw_deg} deg (uniform)"
    else:
        raise MfnsError(f"attitude must be 'uniform' or 'ranges', not {attitude!r}")
    return _from_matrices(
        kind, pos, C, f"{kind}: position in {lo.tolist()}..{hi.tolist()} mm, {att}, {n} samples"
    )


def module(n: int, rng: np.random.Generator, geom: ModuleGeometry = DEMO_MODULE) -> Workspace:
    """The module scenario's reachable poses (see the module docstring) in the module geom."""
    amp = geom.pos_amp_mm
    return box(
        n,
        -amp,
        amp,
        rng,
        attitude="ranges",
        roll_deg=(-MODULE_ATT_AMP_DEG[0], MODULE_ATT_AMP_DEG[0]),
        pitch_deg=(-MODULE_ATT_AMP_DEG[1], MODULE_ATT_AMP_DEG[1]),
        yaw_deg=(-180.0, 180.0),
        kind="module",
    )


# Pose samples of one workspace: each holds a pose, its view and its bound (about 1 ms of
# analysis, 50 ms with the identification margin), so 100,000 is minutes to hours of work and
# tens of MB of samples.csv; more is a typo (1e9 ended in a MemoryError). Every command that
# samples a workspace comes through here.
MAX_SAMPLES = 100_000


def _check_n(n: int) -> None:
    if not 1 <= n <= MAX_SAMPLES:
        raise MfnsError(f"--samples {n}: expected 1..{MAX_SAMPLES} pose samples")
