"""Zhang -> CPC (the paper) -> joint ML refinement, on one set of corner observations."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Camera
from .cpc import CpcResult, run_cpc
from .model import Observations, Rig
from .refine import RefineResult, Start, quantities, solve
from .zhang import ZhangResult, calibrate_camera


@dataclass
class Calibration:
    zhang: list[ZhangResult]
    cpc: CpcResult
    paper: Rig
    refined: RefineResult


def paper_rig(obs: Observations, zhang: list[ZhangResult], cpc: CpcResult) -> Rig:
    cams = []
    for k, z in enumerate(zhang):
        fx, fy, cx, cy, *dist = z.intrinsics
        cams.append(
            Camera(
                "xyz"[k],
                fx,
                fy,
                cx,
                cy,
                0.0,
                np.array(dist),
                obs.image_size[0],
                obs.image_size[1],
                cpc.C_k_b[k],
                cpc.r_bk_b[k],
            )
        )
    return Rig(cams, cpc.C_t_w, cpc.r_wt_w, cpc.r_tb_b)


def paper_quantities(cal: Calibration, ref: Rig) -> tuple[list[str], np.ndarray]:
    """The paper's estimates as quantities(); r_wb_w is its Eq. A14 value, not r_wt + C r_tb."""
    names, vals = quantities(cal.paper, ref)
    vals[-3:] = cal.cpc.r_wb_w
    return names, vals


def calibrate(obs: Observations, a10_iterations: int = 10) -> Calibration:
    zhang = [calibrate_camera(obs, k) for k in range(3)]
    cpc = run_cpc(obs, zhang, a10_iterations)
    paper = paper_rig(obs, zhang, cpc)
    prepared = []
    for im in obs.images:
        if im.kind == "prepared":
            z = zhang[im.camera]
            i = z.names.index(im.name)
            prepared.append((z.C_w_k[i], z.t[i]))
    start = Start.from_rig(paper, prepared)
    # The gauge of the refinement puts the body origin on Zt: start with r_tb = (0, 0, h) and
    # the paper's r_tb x, y moved into r_wt so the start reproduces the paper's geometry.
    start.r_wt_w = cpc.r_wt_w + cpc.C_t_w @ np.array([cpc.r_tb_b[0], cpc.r_tb_b[1], 0.0])
    start.r_bk_b = [r + np.array([cpc.r_tb_b[0], cpc.r_tb_b[1], 0.0]) for r in cpc.r_bk_b]
    n = sum(len(obs.of_camera(k)) for k in range(3)) * obs.board.n * 2
    sigma0 = float(np.sqrt(sum(z.rms_px**2 * len(z.names) for z in zhang) / sum(len(z.names) for z in zhang)))
    sigma0 = max(sigma0 * np.sqrt(n / max(n - 200, 1)), 1e-3)
    refined = solve(obs, start, sigma0)
    return Calibration(zhang, cpc, paper, refined)
