"""Corner 0 of a chessboard that looks the same turned by 180 degrees.

With both square counts odd or both even (e.g. the paper's ~9 x 7 inner corners, 10 x 8
squares) the detector's grid may be turned by a half turn, and no colour tells which corner
is the first. Zhang's method does not mind (a turned assignment is the same plane seen from
a pose turned by Rz(pi) about the board's centre), but the turntable chain does: the relative
rotation between two images of one camera, C_i^T C_j = C_k_b^T A_i^T A_j C_k_b, turns by
the same angle as the recorded A_i^T A_j, and a half-turned image (C -> Rz(pi) C) breaks that.

Per camera: the turntable images are put in one orientation by that angle test, then the
whole camera is turned so that its C_t_w (closed form, handeye.py) is the one nearer to the
identity: the turntable is set up aligned with the board (docs/system.md §5), so the world frame's
first corner is the one whose axes the turntable's zero points along. Prepared images need no
decision (their poses are free). The corners of a turned image are reversed (k -> N-1-k).

A camera whose turntable images turn about one axis only is put in one orientation by the
same angle test, but its own closed form cannot turn it as a whole (its C_t_w is free about
that axis): it is left open (HalfTurns.open) for the joint fit through the shared turntable
(corner_order.py) to decide.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import MfnsError
from ..model.rotations import rot_log, rz
from .handeye import check_turntable_geometry, rotations_closed_form
from .model import Observations, turntable_matrix
from .zhang import ZhangResult

MAX_MISFIT_DEG = 1.0  # relative turn angles must agree with the recorded ones this well


def _angle(r: np.ndarray) -> float:
    return float(np.rad2deg(np.linalg.norm(rot_log(r))))


def _misfit(tt, turned, done, j: int, t: bool) -> float:
    """Mean |turn angle of C_i^T C_j - recorded turn angle| over the decided images i."""
    half = rz(np.pi)
    cj = half @ tt[j][2] if t else tt[j][2]
    err = 0.0
    for i in done:
        ci = half @ tt[i][2] if turned[i] else tt[i][2]
        err += abs(_angle(ci.T @ cj) - _angle(tt[i][1].T @ tt[j][1]))
    return err / len(done)


def _relative_turns(obs: Observations, k: int, tt) -> list[bool]:
    """Which of camera k's turntable images [(index, A, C_k'_w)] are turned against its image 0."""
    turned = [False] * len(tt)
    done = [0]  # image 0 fixes the camera's orientation for now
    todo = list(range(1, len(tt)))
    # most decisive image first: a pair whose turn differs by ~90 deg about the board normal
    # cannot tell the two orientations apart, the others can
    while todo:
        costs = {j: (_misfit(tt, turned, done, j, False), _misfit(tt, turned, done, j, True)) for j in todo}
        j = max(todo, key=lambda m: abs(costs[m][0] - costs[m][1]))
        c0, c1 = costs[j]
        if min(c0, c1) > MAX_MISFIT_DEG:
            raise MfnsError(
                f"camera {obs.camera_names[k]}: image {obs.images[tt[j][0]].name} agrees with the "
                f"recorded turntable angles in neither orientation of the symmetric board "
                f"({min(c0, c1):.2f} deg off)"
            )
        turned[j] = c1 < c0
        done.append(j)
        todo.remove(j)
    return turned


def _camera_turns(obs: Observations, k: int, tt) -> list[bool]:
    """Which of camera k's turntable images are turned (camera turning about two axes)."""
    turned = _relative_turns(obs, k, tt)
    half = rz(np.pi)
    views = [(a, half @ c if t else c) for (_i, a, c), t in zip(tt, turned, strict=True)]
    c_t_w, _ = rotations_closed_form([views])
    if _angle(half @ c_t_w) < _angle(c_t_w):
        turned = [not t for t in turned]
    return turned


@dataclass
class HalfTurns:
    """What the per-camera test decided and what it left to the joint fit."""

    flips: list[int]  # images (indices into obs.images) whose corners must be reversed
    open: list[int] = field(default_factory=list)  # cameras turning about one axis: order open
    turntable: dict[int, list[int]] = field(default_factory=dict)  # open camera -> its turntable images


def resolve_half_turns(obs: Observations, zhang: list[ZhangResult]) -> HalfTurns:
    """Corner order of every camera's turntable images, as far as each camera alone decides it.

    A camera turning about two axes is decided whole; one turning about one axis only is put
    in one orientation (its `flips` relative to its first turntable image) and listed in `open`.
    """
    out = HalfTurns([])
    where = {id(im): n for n, im in enumerate(obs.images)}
    for k, z in enumerate(zhang):
        tt = []
        for i, im in enumerate(obs.of_camera(k)):
            if im.kind == "turntable":
                a = turntable_matrix(np.deg2rad(im.omega_big_deg), np.deg2rad(im.omega_small_deg))
                tt.append((where[id(im)], a, z.camera_in_world(i)[0]))
        if check_turntable_geometry(obs, k, [a for _i, a, _c in tt]):
            turned = _camera_turns(obs, k, tt)
        else:
            turned = _relative_turns(obs, k, tt)
            out.open.append(k)
            out.turntable[k] = [i for i, _a, _c in tt]
        out.flips += [i for (i, _a, _c), t in zip(tt, turned, strict=True) if t]
    return out


def apply_half_turns(obs: Observations, flips: list[int]) -> None:
    for i in flips:
        obs.images[i].uv = obs.images[i].uv[::-1].copy()
