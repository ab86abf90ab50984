"""The paper's checkerboard-fixed post-processing calibration (CPC), Appendix A.

Starts from Zhang's per-image camera poses (C_k'_w, r_wk'_w) and the recorded turntable
angles. Steps, each a least-squares problem solved on its own (the error propagation between
them is what the paper's discussion names):

1. Eq. A10: C_t_w and C_z_b from camera Z's images with the small-angle model
   C_z'_w = (I - [a x]) C_b'_b (I - [p x]); rows as in the paper (elements 31, 32, 13, 23 of
   pure-Omega images, 12, 13, 21, 31 of pure-omega images; all nine of mixed images).
   One pass is the paper's solution; it leaves a second-order error (~0.01 deg for the
   ~1 deg angles of Table 3), so by default the same linear step is repeated about the new
   estimate (Gauss-Newton) until it stops changing: exact on noise-free data.
2. Eqs. A11/A12: C_k_b = (C_t_w C_b'_b)^T C_k'_w, averaged over camera k's images
   (chordal mean, projected onto SO(3)).
3. Eq. A16: zx, zy of r_bz_b from differences of camera Z's pure-Omega images; Eq. A14 with
   the caliper height (b_z = -height) gives b_x, b_y, z_z.
4. Eq. A15: r_wt_w and r_tb_b from all of camera Z's turntable images.
5. Eqs. A17/A18: r_bx_b and r_by_b from cameras X and Y's images.

Every other camera of an N-camera rig is treated like X and Y (A11/A12, A17/A18); camera Z
(named "z") is the reference. Pure-axis images are those `ImageObs.pure` marks (recorded angle
within the turntable's noise of zero, or the kind in angles.csv); for them the equations use
the commanded zero, as the paper does. When the dataset lacks what the chain needs, run_cpc
raises CpcNotApplicable with the reason (the refinement then starts from mfns.calib.handeye).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import MfnsError
from ..model.rotations import rot_exp, skew
from .model import PURE_AXIS_SIGMAS, Observations, turntable_matrix
from .zhang import ZhangResult

PURE_OMEGA_ROWS = ((2, 0), (2, 1), (0, 2), (1, 2))  # elements 31, 32, 13, 23
PURE_SMALL_OMEGA_ROWS = ((0, 1), (0, 2), (1, 0), (2, 0))  # elements 12, 13, 21, 31
ALL_ROWS = tuple((i, j) for i in range(3) for j in range(3))


REFERENCE_CAMERA = "z"


class CpcNotApplicable(MfnsError):
    """The paper's chain cannot run on this dataset (the message says why)."""


@dataclass
class CpcResult:
    C_t_w: np.ndarray
    C_k_b: list[np.ndarray]
    r_bk_b: list[np.ndarray]
    r_wb_w: np.ndarray
    r_wt_w: np.ndarray
    r_tb_b: np.ndarray
    a10_iterations: int


def _so3(m: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(m)
    d = np.sign(np.linalg.det(u @ vt))
    return u @ np.diag([1.0, 1.0, d]) @ vt


def _turntable_poses(obs: Observations, zhang: ZhangResult, k: int):
    """(Omega, omega) in radians, C_k'_w, r_wk'_w for camera k's turntable images.

    The angle of a pure-axis image's other axis is the commanded zero, not its noisy record.
    """
    out = []
    for i, im in enumerate(obs.of_camera(k)):
        if im.kind != "turntable":
            continue
        c, r = zhang.camera_in_world(i)
        big = 0.0 if im.pure == "omega" else np.deg2rad(im.omega_big_deg)
        small = 0.0 if im.pure == "Omega" else np.deg2rad(im.omega_small_deg)
        out.append((big, small, c, r))
    return out


def solve_a10(poses, iterations: int = 10, tol: float = 1e-13):
    """C_t_w, C_z_b from camera Z's (Omega, omega, C_z'_w, r) by the small-angle LSQ of Eq. A10."""
    t_w, z_b = np.eye(3), np.eye(3)
    n_done = 0
    for _ in range(max(1, iterations)):
        rows, rhs = [], []
        for big, small, c_meas, _r in poses:
            pure_big, pure_small = abs(small) < 1e-12, abs(big) < 1e-12
            sel = PURE_OMEGA_ROWS if pure_big else PURE_SMALL_OMEGA_ROWS if pure_small else ALL_ROWS
            g = t_w @ turntable_matrix(big, small) @ z_b
            cols = [-skew(e) @ g for e in np.eye(3)] + [-g @ skew(e) for e in np.eye(3)]
            res = c_meas - g
            for i, j in sel:
                rows.append([c[i, j] for c in cols])
                rhs.append(res[i, j])
        x, *_ = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)
        t_w = rot_exp(-x[:3]) @ t_w
        z_b = z_b @ rot_exp(-x[3:])
        n_done += 1
        if np.max(np.abs(x)) < tol:
            break
    return t_w, z_b, n_done


def run_cpc(obs: Observations, zhang: list[ZhangResult], a10_iterations: int = 10) -> CpcResult:
    names = obs.camera_names
    if REFERENCE_CAMERA not in names:
        raise CpcNotApplicable(
            f"the paper's chain starts from camera {REFERENCE_CAMERA!r}; cameras are {list(names)}"
        )
    iz = names.index(REFERENCE_CAMERA)
    poses = [_turntable_poses(obs, zhang[k], k) for k in range(obs.n_cams)]
    for k in range(obs.n_cams):
        if len(poses[k]) < 2:
            raise CpcNotApplicable(f"camera {names[k]}: CPC needs >= 2 turntable images, has {len(poses[k])}")
    pz = poses[iz]
    n_pure = sum(p[1] == 0.0 for p in pz)
    if n_pure < 2 or not any(p[1] != 0.0 for p in pz):
        raise CpcNotApplicable(
            f"camera z: CPC needs >= 2 pure-Omega images (omega = 0 within "
            f"{PURE_AXIS_SIGMAS:g} sigma of the angle noise) and one with omega != 0; "
            f"has {n_pure} pure-Omega of {len(pz)}"
        )
    t_w, z_b, n_it = solve_a10(pz, a10_iterations)
    others = [k for k in range(obs.n_cams) if k != iz]
    c_k_b: list = [None] * obs.n_cams
    c_k_b[iz] = z_b
    for k in others:  # Eqs. A11, A12
        acc = sum((t_w @ turntable_matrix(a, b)).T @ c for a, b, c, _ in poses[k])
        c_k_b[k] = _so3(acc)
    # Eq. A16: differences of pure-Omega images give zx, zy
    pure = [(t_w @ turntable_matrix(a, b), r) for a, b, _c, r in pz if b == 0.0]
    a_mean = sum(a for a, _ in pure) / len(pure)
    r_mean = sum(r for _, r in pure) / len(pure)
    m = np.vstack([(a - a_mean)[:, :2] for a, _ in pure])
    y = np.concatenate([r - r_mean for _, r in pure])
    zxy, *_ = np.linalg.lstsq(m, y, rcond=None)
    # Eq. A14 with the caliper: b_z = -height; unknowns b_x, b_y, z_z
    bz = -obs.caliper_height_mm
    m = np.vstack([np.column_stack([np.eye(3)[:, 0], np.eye(3)[:, 1], a[:, 2]]) for a, _ in pure])
    y = np.concatenate([r - a @ np.array([zxy[0], zxy[1], 0.0]) - np.array([0.0, 0.0, bz]) for a, r in pure])
    (bx, by, zz), *_ = np.linalg.lstsq(m, y, rcond=None)
    r_bz = np.array([zxy[0], zxy[1], zz])
    r_wb = np.array([bx, by, bz])
    # Eq. A15: all camera-Z turntable images; unknowns r_wt_w, r_tb_b
    full = [(t_w @ turntable_matrix(a, b), r) for a, b, _c, r in pz]
    m = np.vstack([np.hstack([np.eye(3), a]) for a, _ in full])
    y = np.concatenate([r - a @ r_bz for a, r in full])
    sol, *_ = np.linalg.lstsq(m, y, rcond=None)
    r_wt, r_tb = sol[:3], sol[3:]
    r_bk: list = [None] * obs.n_cams
    r_bk[iz] = r_bz
    for k in others:  # Eqs. A17, A18
        est = [(t_w @ turntable_matrix(a, b)).T @ (r - r_wt) - r_tb for a, b, _c, r in poses[k]]
        r_bk[k] = np.mean(est, axis=0)
    return CpcResult(t_w, c_k_b, r_bk, r_wb, r_wt, r_tb, n_it)
