"""Zhang -> CPC (the paper) -> joint ML refinement, on one set of corner observations.

When the paper's CPC cannot run on the dataset, the refinement starts from the general
robot-world/hand-eye initialization (handeye.py) and `Calibration.paper_note` says why.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import MfnsError
from ..model.camera import Camera
from .corner_order import CornerOrder, decide_corner_order
from .cpc import CpcNotApplicable, CpcResult, run_cpc
from .halfturn import apply_half_turns, resolve_half_turns
from .handeye import HandEyeResult, solve_hand_eye
from .model import Observations, Rig
from .refine import RefineResult, Start, quantities, solve
from .zhang import ZhangResult, calibrate_camera


@dataclass
class Calibration:
    zhang: list[ZhangResult]
    cpc: CpcResult | None  # None: the paper's method was not applicable (paper_note says why)
    paper: Rig | None
    refined: RefineResult
    init: str  # what the refinement started from
    paper_note: str = ""
    hand_eye: HandEyeResult | None = None
    half_turned: int = 0  # symmetric chessboard: turntable images whose corner order was reversed
    corner_order: list[CornerOrder] = field(default_factory=list)  # cameras decided by the joint fit


def _cameras(obs: Observations, zhang: list[ZhangResult], c_k_b, r_bk_b) -> list[Camera]:
    cams = []
    for k, z in enumerate(zhang):
        fx, fy, cx, cy, *dist = z.intrinsics
        cams.append(
            Camera(
                obs.camera_names[k],
                fx,
                fy,
                cx,
                cy,
                0.0,
                np.array(dist),
                obs.image_size[0],
                obs.image_size[1],
                c_k_b[k],
                r_bk_b[k],
            )
        )
    return cams


def paper_rig(obs: Observations, zhang: list[ZhangResult], cpc: CpcResult) -> Rig:
    return Rig(_cameras(obs, zhang, cpc.C_k_b, cpc.r_bk_b), cpc.C_t_w, cpc.r_wt_w, cpc.r_tb_b)


def paper_quantities(cal: Calibration, ref: Rig) -> tuple[list[str], np.ndarray]:
    """The paper's estimates as quantities(); r_wb_w is its Eq. A14 value, not r_wt + C r_tb.

    NaN everywhere when the paper's method was not applicable.
    """
    if cal.paper is None or cal.cpc is None:
        names, vals = quantities(ref, ref)
        return names, np.full_like(vals, np.nan)
    names, vals = quantities(cal.paper, ref)
    vals[-3:] = cal.cpc.r_wb_w
    return names, vals


def _prepared_starts(obs: Observations, zhang: list[ZhangResult]):
    prepared = []
    for im in obs.images:
        if im.kind == "prepared":
            z = zhang[im.camera]
            i = z.names.index(im.name)
            prepared.append((z.C_w_k[i], z.t[i]))
    return prepared


CHAIN_MISFIT = 3.0  # refined RMS may exceed the per-camera Zhang RMS by this factor (and 0.3 px)
CHAIN_MISFIT_PX = 0.3


def check_chain_fits(zhang: list[ZhangResult], rms_px: float) -> None:
    """Each image fits a free pose (Zhang) but the turntable chain does not: wrong input.

    A board declared smaller than the printed one is found at different places inside it
    (every image fine alone, the chain broken), as are swapped angles or image rows.
    """
    zh = float(np.sqrt(sum(z.rms_px**2 * len(z.names) for z in zhang) / sum(len(z.names) for z in zhang)))
    if rms_px > max(CHAIN_MISFIT * zh, CHAIN_MISFIT_PX):
        raise MfnsError(
            f"the turntable chain does not fit the corners: refined RMS {rms_px:.2f} px, each image "
            f"alone (Zhang) {zh:.2f} px; check board.inner_corners (a board declared smaller than the "
            "printed one is found inside it), the recorded angles and which image each row names"
        )


def calibrate(obs: Observations, a10_iterations: int = 10) -> Calibration:
    zhang = [calibrate_camera(obs, k) for k in range(obs.n_cams)]
    flips: list[int] = []
    open_cams = None
    if obs.board.symmetric:  # which corner is the first: decided by the turntable chain
        turns = resolve_half_turns(obs, zhang)
        flips = turns.flips
        if flips:
            apply_half_turns(obs, flips)
            again = {obs.images[i].camera for i in flips}
            zhang = [calibrate_camera(obs, k) if k in again else z for k, z in enumerate(zhang)]
        if turns.open:
            open_cams = turns
    if open_cams is not None:  # cameras turning about one axis: the joint fit decides (corner_order.py)
        apart = frozenset(open_cams.open)
        cal, more, decisions = decide_corner_order(
            obs, zhang, open_cams, lambda z: _fit(obs, z, a10_iterations, check=False, apart=apart)
        )
        apply_half_turns(obs, more)
        check_chain_fits(cal.zhang, cal.refined.rms_px)
        cal.half_turned = len(set(flips) ^ set(more))
        cal.corner_order = decisions
        return cal
    cal = _fit(obs, zhang, a10_iterations)
    cal.half_turned = len(flips)
    return cal


def _fit(
    obs: Observations,
    zhang: list[ZhangResult],
    a10_iterations: int,
    check: bool = True,
    apart: frozenset[int] = frozenset(),
) -> Calibration:
    """Zhang's results -> CPC (or the hand-eye start) -> the joint refinement.

    check: refuse a chain that does not fit (check_chain_fits); the corner-order decision
    compares fits first and checks the chosen one. apart: cameras whose order is under test,
    kept out of the hand-eye start's turntable (handeye.solve_hand_eye).
    """
    prepared = _prepared_starts(obs, zhang)
    cpc = paper = hand_eye = None
    note = ""
    try:
        cpc = run_cpc(obs, zhang, a10_iterations)
    except CpcNotApplicable as exc:
        note = f"the paper's CPC is not applicable: {exc}"
    if cpc is not None:
        paper = paper_rig(obs, zhang, cpc)
        start = Start.from_rig(paper, prepared)
        # The gauge of the refinement puts the body origin on Zt: start with r_tb = (0, 0, h) and
        # the paper's r_tb x, y moved into r_wt so the start reproduces the paper's geometry.
        shift = np.array([cpc.r_tb_b[0], cpc.r_tb_b[1], 0.0])
        start.r_wt_w = cpc.r_wt_w + cpc.C_t_w @ shift
        start.r_bk_b = [r + shift for r in cpc.r_bk_b]
        init = "the paper's CPC"
    else:
        hand_eye = solve_hand_eye(obs, zhang, apart)
        rig = Rig(_cameras(obs, zhang, hand_eye.C_k_b, hand_eye.r_bk_b), hand_eye.C_t_w, hand_eye.r_wt_w)
        rig.r_tb_b = np.array([0.0, 0.0, hand_eye.h])
        start = Start.from_rig(rig, prepared)
        init = "the general robot-world/hand-eye initialization"
    n = sum(int(im.seen.sum()) for im in obs.images) * 2
    n_img = sum(len(z.names) for z in zhang)
    sigma0 = float(np.sqrt(sum(z.rms_px**2 * len(z.names) for z in zhang) / n_img))
    sigma0 = max(sigma0 * np.sqrt(n / max(n - 200, 1)), 1e-3)
    refined = solve(obs, start, sigma0, check=(lambda rms: check_chain_fits(zhang, rms)) if check else None)
    return Calibration(zhang, cpc, paper, refined, init, note, hand_eye)
