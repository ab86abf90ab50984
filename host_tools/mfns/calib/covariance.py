"""The calibration's covariance in the parameters the flight solver uses (docs/calib-results.md).

Per camera k, in this order (CAMERA_PARAMETERS): fx fy cx cy (px), k1 k2 p1 p2 k3 (1),
theta_x theta_y theta_z (rad), r_x r_y r_z (mm). Errors are estimate minus truth; theta is
the small rotation of the mount about the BODY axes, C_k_b(est) = exp([theta x]) C_k_b(true),
r the error of r_bk_b (body frame). All cameras in one matrix: the joint estimate correlates
them (they share the turntable chain, C_t_w, r_wt_w and the caliper height).

- Refined (ML): the Gauss-Newton covariance of the refinement (refine.solve: (J^T J)^-1 of the
  whitened residuals, i.e. scaled by the corner noise re-estimated from the residuals) mapped
  to these parameters. The refinement's mount rotation is C_k_b = exp([d x]) C0 with d in the
  body frame, so a change e of d moves the rotation by theta = J_l(d) e, J_l the left Jacobian
  of SO(3) (left_jacobian); the intrinsics and r_bk_b are parameters of the refinement as
  they are. Marginalising over everything else (C_t_w, r_wt_w, h, angle errors, board poses)
  is taking the rows and columns of these parameters.
- Paper method (Zhang + CPC): the chained least squares is not efficient and its error is
  dominated by systematic terms (A10's rows, A11/A12's averaging, the caliper chain), which
  its own input noise does not describe. The ML estimate of the same data is available and
  efficient, so the paper's error e_p = theta_paper - theta_true splits into the measured
  deviation d = theta_paper - theta_ML and the ML error: Cov(paper) = Cov(ML) + d d^T, a
  rank-one term along the deviation actually made. With e_ML ~ N(0, Cov(ML)), the NEES of
  the truth under it is ~chi-square(N) + 1 whatever |d| (Sherman-Morrison), and the pose
  error it causes is propagated in the direction it has.
"""

from __future__ import annotations

import numpy as np

from ..analysis.calib_results import COVARIANCE_PARAMETERS
from ..model.rotations import matrix_to_euler213_deg, rot_exp, rot_log, skew
from .model import Rig
from .refine import N_CAM, RefineResult
from .zhang import INTRINSIC_NAMES

CAMERA_PARAMETERS = COVARIANCE_PARAMETERS  # the contract's order (calib_results.py)
N_PARAMETERS = len(CAMERA_PARAMETERS)  # per camera
# the refinement's per-camera block (refine.N_CAM) is fx .. k3, d (3), r_bk_b (3) in the same order
assert CAMERA_PARAMETERS[:9] == INTRINSIC_NAMES and N_PARAMETERS == N_CAM


def parameter_names(camera_names) -> list[str]:
    return [f"{cam}.{p}" for cam in camera_names for p in CAMERA_PARAMETERS]


def left_jacobian(w) -> np.ndarray:
    """Left Jacobian of SO(3): rot_exp(w + e) = rot_exp(left_jacobian(w) @ e) @ rot_exp(w) + O(e^2)."""
    w = np.asarray(w, dtype=float)
    th = float(np.linalg.norm(w))
    k = skew(w)
    if th < 1e-6:
        return np.eye(3) + 0.5 * k + k @ k / 6.0
    return np.eye(3) + (1.0 - np.cos(th)) / th**2 * k + (th - np.sin(th)) / th**3 * k @ k


def _symmetric(m: np.ndarray) -> np.ndarray:
    return 0.5 * (m + m.T)


def refined_covariance(ref: RefineResult) -> tuple[list[str], np.ndarray]:
    """(parameter names, covariance) of the refined estimate in the contract's parameters."""
    n_cams = len(ref.rig.cams)
    a = np.zeros((N_PARAMETERS * n_cams, len(ref.x)))
    for k in range(n_cams):
        row, col = N_PARAMETERS * k, N_CAM * k
        a[row : row + 9, col : col + 9] = np.eye(9)  # fx .. k3 are parameters as they are
        d = ref.x[col + 9 : col + 12]
        a[row + 9 : row + 12, col + 9 : col + 12] = left_jacobian(d)
        a[row + 12 : row + 15, col + 12 : col + 15] = np.eye(3)
    return parameter_names(c.name for c in ref.rig.cams), _symmetric(a @ ref.cov_params @ a.T)


def camera_vector(cams) -> np.ndarray:
    """fx .. k3 and r_bk_b of every camera in the contract's order, theta left 0."""
    v = []
    for c in cams:
        v += [c.fx, c.fy, c.cx, c.cy, *np.asarray(c.dist, float), 0.0, 0.0, 0.0, *np.asarray(c.r_bk_b, float)]
    return np.array(v, dtype=float)


def parameter_error(est: Rig, ref: Rig) -> np.ndarray:
    """est - ref in the contract's parameters (theta = log(C_k_b(est) C_k_b(ref)^T), rad)."""
    e = camera_vector(est.cams) - camera_vector(ref.cams)
    for k, (c, cr) in enumerate(zip(est.cams, ref.cams, strict=True)):
        e[N_PARAMETERS * k + 9 : N_PARAMETERS * k + 12] = rot_log(c.C_k_b @ cr.C_k_b.T)
    return e


def paper_covariance(paper: Rig, ref: RefineResult) -> tuple[list[str], np.ndarray]:
    """Cov(ML) + d d^T, d = paper - ML (module docstring): covers the paper's systematic error."""
    names, cov = refined_covariance(ref)
    d = parameter_error(paper, ref.rig)
    return names, _symmetric(cov + np.outer(d, d))


def nees(err: np.ndarray, cov: np.ndarray) -> float:
    """Normalised estimation error squared e^T Cov^-1 e.

    Solved on the correlation matrix: the variances span ~1e-10 rad^2 to ~1 px^2.
    """
    sd = np.sqrt(np.diag(cov))
    z = err / sd
    return float(z @ np.linalg.solve(cov / np.outer(sd, sd), z))


def euler_sigma(c: np.ndarray, cov_theta: np.ndarray) -> np.ndarray:
    """1-sigma of the 2-1-3 Euler angles (deg) of exp([theta x]) c, theta ~ N(0, cov_theta) (rad)."""
    jac = np.zeros((3, 3))
    for i in range(3):
        d = np.zeros(3)
        d[i] = 1e-7
        de = matrix_to_euler213_deg(rot_exp(d) @ c) - matrix_to_euler213_deg(rot_exp(-d) @ c)
        de = (de + 180.0) % 360.0 - 180.0
        jac[:, i] = de / 2e-7
    return np.sqrt(np.diag(jac @ cov_theta @ jac.T))


def sigma_block(names: list[str], cov: np.ndarray, cam: str, C_k_b: np.ndarray) -> dict:
    """A camera's `sigma` entry from the covariance: sqrt(diag), Euler angles propagated."""
    i = names.index(f"{cam}.fx")
    sd = np.sqrt(np.clip(np.diag(cov)[i : i + N_PARAMETERS], 0.0, None))
    th = cov[i + 9 : i + 12, i + 9 : i + 12]
    return {
        "fx": float(sd[0]),
        "fy": float(sd[1]),
        "cx": float(sd[2]),
        "cy": float(sd[3]),
        "dist": [float(v) for v in sd[4:9]],
        "euler_213_deg": [float(v) for v in euler_sigma(C_k_b, th)],
        "r_bk_b": [float(v) for v in sd[12:15]],
    }
