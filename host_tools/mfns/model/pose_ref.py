"""Host reference pose solver: Gauss-Newton on the reprojection error, in numpy (double).

This is NOT the flight solver. It exists so the host tools (the end-to-end extension of
`mfns mc`) can propagate calibration errors into pose errors before the C pose solver is
available through ctypes; anything that takes a `PoseSolver` accepts either.

Model (docs/conventions.md): p_b = C_w_b p_w + r_bw_b, p_k = C_k_b^T (p_b - r_bk_b), then
the camera's pinhole + distortion. Unknowns: a small rotation dtheta applied as
C_w_b <- exp(-[dtheta x]) C_w_b and a translation step on r_bw_b. Residuals in pixels,
unweighted (all observations are assumed to have the same pixel noise).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .camera import Camera
from .rotations import rot_exp


@dataclass
class PoseSolution:
    C_w_b: np.ndarray
    r_bw_b: np.ndarray
    converged: bool
    iterations: int
    rms_px: float


# solver(cams, cam_index (M,), points_w (M, 3), uv (M, 2), C_w_b0, r_bw_b0) -> PoseSolution
PoseSolver = Callable[
    [Sequence[Camera], np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], PoseSolution
]


def _skew_rows(v: np.ndarray) -> np.ndarray:
    """(N, 3) -> (N, 3, 3) cross-product matrices [v x]."""
    out = np.zeros((len(v), 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


def residuals_and_jacobian(cams, cam_idx, points_w, uv, c_w_b, r_bw_b) -> tuple[np.ndarray, np.ndarray]:
    """Stacked residuals (2M,) = predicted - measured and their Jacobian (2M, 6)."""
    m = len(cam_idx)
    res = np.zeros((m, 2))
    jac = np.zeros((m, 2, 6))
    q = points_w @ c_w_b.T  # C_w_b p_w
    p_b = q + r_bw_b
    for k, cam in enumerate(cams):
        sel = cam_idx == k
        if not np.any(sel):
            continue
        p_c = (p_b[sel] - cam.r_bk_b) @ cam.C_k_b
        pred, d_uv = cam.project_jacobian(p_c)
        res[sel] = pred - uv[sel]
        d_b = d_uv @ cam.C_k_b.T  # d uv / d p_b  (N, 2, 3)
        # d p_b / d dtheta = [q x] (C <- (I - [dtheta x]) C), d p_b / d r = I
        jac[sel, :, :3] = d_b @ _skew_rows(q[sel])
        jac[sel, :, 3:] = d_b
    return res.reshape(-1), jac.reshape(-1, 6)


def solve_pose_gn(
    cams: Sequence[Camera],
    cam_idx: np.ndarray,
    points_w: np.ndarray,
    uv: np.ndarray,
    C_w_b0: np.ndarray,
    r_bw_b0: np.ndarray,
    max_iterations: int = 30,
    step_tol: float = 1e-10,
) -> PoseSolution:
    """Gauss-Newton (with step halving) from the given initial pose. Needs >= 3 observations."""
    cam_idx = np.asarray(cam_idx, dtype=int)
    points_w = np.asarray(points_w, dtype=float)
    uv = np.asarray(uv, dtype=float)
    c = np.asarray(C_w_b0, dtype=float).copy()
    r = np.asarray(r_bw_b0, dtype=float).copy()
    if len(cam_idx) < 3:
        return PoseSolution(c, r, False, 0, float("nan"))
    res, jac = residuals_and_jacobian(cams, cam_idx, points_w, uv, c, r)
    cost = float(res @ res)
    converged = False
    it = 0
    for it in range(1, max_iterations + 1):  # noqa: B007 (it is reported)
        try:
            step = -np.linalg.solve(jac.T @ jac, jac.T @ res)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(step)):
            break
        if np.max(np.abs(step[:3])) < step_tol and np.max(np.abs(step[3:])) < 1e3 * step_tol:
            # At the minimum: take the last, tiny step and stop.
            c, r = rot_exp(-step[:3]) @ c, r + step[3:]
            res, jac = residuals_and_jacobian(cams, cam_idx, points_w, uv, c, r)
            cost = float(res @ res)
            converged = True
            break
        scale = 1.0
        accepted = False
        for _ in range(20):  # step halving, bounded
            c_new = rot_exp(-scale * step[:3]) @ c
            r_new = r + scale * step[3:]
            res_new, jac_new = residuals_and_jacobian(cams, cam_idx, points_w, uv, c_new, r_new)
            cost_new = float(res_new @ res_new)
            # A relative 1e-12 slack: near the minimum round-off makes the cost jitter.
            if np.isfinite(cost_new) and cost_new <= cost * (1.0 + 1e-12) + 1e-300:
                accepted = True
                break
            scale *= 0.5
        if not accepted:
            # No decrease along the Gauss-Newton direction: round-off at the minimum if the
            # step is below 1 microradian and 1 micrometre (far below any accuracy that
            # matters), else stuck.
            converged = bool(np.max(np.abs(step[:3])) < 1e-6 and np.max(np.abs(step[3:])) < 1e-3)
            break
        c, r, res, jac, cost = c_new, r_new, res_new, jac_new, cost_new
    rms = float(np.sqrt(cost / len(cam_idx))) if np.isfinite(cost) else float("nan")
    return PoseSolution(c, r, converged, it, rms)
