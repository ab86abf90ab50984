"""General initialization: a robot-world/hand-eye solve over the turntable chain.

Used when the paper's CPC cannot run (no camera "z", no pure-Omega views, ...). Every
turntable image of camera k gives, from Zhang's board pose (C_k'_w, r_wk'_w) and the recorded
angles A_i = Rx(omega) Rz(Omega):

    C_k'_w = X A_i Z_k                       X = C_t_w, Z_k = C_k_b
    r_wk'_w = r_wt_w + X A_i p_k             p_k = r_tb_b + r_bk_b

the robot-world/hand-eye problem AX = ZB with a shared X. (The pinned OpenCV 5.0 has no
cv2.calibrateRobotWorldHandEye, and it would solve one camera at a time.) Closed form:
X A_i - C_i Y_k = 0 with Y_k = Z_k^T is linear and homogeneous in (vec X, vec Y_1..Y_n), one
SVD over all cameras (Li et al. 2010, Kronecker form); the result is scaled to det X = 1 and
projected onto SO(3). With X fixed, the positions are one linear least-squares problem in
(r_wt_w, p_1..p_n); the caliper height then fixes h of r_tb_b = (0, 0, h) and
r_bk_b = p_k - (0, 0, h). The joint ML refinement (refine.py) takes it from there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import MfnsError
from ..model.rotations import rot_log
from .model import Observations, turntable_matrix
from .zhang import ZhangResult

MIN_AXIS_SPREAD_DEG = 5.0  # relative rotations must turn about axes this far apart


@dataclass
class HandEyeResult:
    C_t_w: np.ndarray
    r_wt_w: np.ndarray
    h: float
    C_k_b: list[np.ndarray]
    r_bk_b: list[np.ndarray]


def _so3(m: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(m)
    return u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt


def _turntable_views(obs: Observations, zhang: ZhangResult, k: int):
    out = []
    for i, im in enumerate(obs.of_camera(k)):
        if im.kind == "turntable":
            c, r = zhang.camera_in_world(i)
            a = turntable_matrix(np.deg2rad(im.omega_big_deg), np.deg2rad(im.omega_small_deg))
            out.append((a, c, r))
    return out


def turn_axes_spread(mats: list[np.ndarray]) -> bool:
    """True when the relative turns of these turntable matrices are about two different axes."""
    axes = []
    for a in mats[1:]:
        v = rot_log(mats[0].T @ a)
        if np.linalg.norm(v) > np.deg2rad(1.0):
            axes.append(v / np.linalg.norm(v))
    spread = max(
        (np.linalg.norm(np.cross(u, v)) for i, u in enumerate(axes) for v in axes[i + 1 :]), default=0.0
    )
    return bool(spread >= np.sin(np.deg2rad(MIN_AXIS_SPREAD_DEG)))


def check_turntable_geometry(obs: Observations, k: int, mats: list[np.ndarray]) -> bool:
    """Camera k has turntable images to start from; True when they turn about two axes.

    Turns about one axis only do not fix the camera's own hand-eye problem, but they do when
    the turntable is fixed by the other cameras (the joint model: whether the rig is
    observable is decided from its Jacobian, refine.check_observable, not here).
    """
    name = obs.camera_names[k]
    if len(mats) < 1:
        raise MfnsError(
            f"calibration: the images do not determine camera {name} mount attitude C_k_b and mount "
            f"position r_bk_b (no turntable image with the board found); what would fix it: "
            f"turntable images in which camera {name} sees the board"
        )
    return turn_axes_spread(mats)


def rotations_closed_form(views: list[list[tuple[np.ndarray, np.ndarray]]]):
    """(C_t_w, [C_k_b]) from per camera [(A_i, C_k'_w)]: C_k'_w = C_t_w A_i C_k_b, one SVD."""
    n = len(views)
    eye = np.eye(3)
    rows = []
    for k, v in enumerate(views):
        for a, c in v:
            blk = np.zeros((9, 9 * (n + 1)))
            blk[:, :9] = np.kron(a.T, eye)  # vec(X A) = (A^T (x) I) vec X   (column-major vec)
            blk[:, 9 * (k + 1) : 9 * (k + 2)] = -np.kron(eye, c)  # vec(C Y) = (I (x) C) vec Y
            rows.append(blk)
    _u, _sv, vt = np.linalg.svd(np.vstack(rows), full_matrices=False)
    vec = vt[-1]
    x = vec[:9].reshape(3, 3, order="F")
    det = np.linalg.det(x)
    if not np.isfinite(det) or abs(det) < 1e-12:
        raise MfnsError("hand-eye initialization: the turntable rotation C_t_w is not determined")
    s = np.sign(det) * abs(det) ** (1.0 / 3.0)
    c_t_w = _so3(x / s)
    c_k_b = [_so3(vec[9 * (k + 1) : 9 * (k + 2)].reshape(3, 3, order="F") / s).T for k in range(n)]
    return c_t_w, c_k_b


def solve_hand_eye(
    obs: Observations, zhang: list[ZhangResult], apart: frozenset[int] = frozenset()
) -> HandEyeResult:
    """apart: cameras left out of the turntable's closed form (C_t_w, r_wt_w) when another
    camera remains; their mounts are then fitted to the turntable the others give (the corner
    order's joint decision, corner_order.py: an order under test must not move the turntable)."""
    if apart and len(apart) < obs.n_cams:
        return _hand_eye_apart(obs, zhang, apart)
    views = [_turntable_views(obs, zhang[k], k) for k in range(obs.n_cams)]
    both = [check_turntable_geometry(obs, k, [a for a, _c, _r in v]) for k, v in enumerate(views)]
    n = obs.n_cams
    eye = np.eye(3)
    # C_t_w from every camera's turns at once (one camera about Zt and another about Xt fix it
    # as well as one camera about both); each mount then from the shared C_t_w: a camera whose
    # images turn about one axis only gets C_k_b = (C_t_w A_i)^T C_k'_w averaged over its images,
    # which its own hand-eye problem could not give.
    try:
        c_t_w, c_k_b = rotations_closed_form([[(a, c) for a, c, _r in v] for v in views])
    except MfnsError:
        # every camera turns about one and the same axis: C_t_w is not determined about it.
        # Start from the set-up's alignment with the board (docs/system.md §5); the Jacobian
        # test of the joint model (refine.check_observable) then names what is undetermined.
        c_t_w, c_k_b, both = np.eye(3), [np.eye(3)] * n, [False] * n
    for k, v in enumerate(views):
        if not both[k]:
            c_k_b[k] = _so3(sum((c_t_w @ a).T @ c for a, c, _r in v))
    # positions: r_i = r_wt + C_t_w A_i p_k, linear in (r_wt, p_1..p_n)
    rows, rhs = [], []
    for k, v in enumerate(views):
        for a, _c, r in v:
            blk = np.zeros((3, 3 * (n + 1)))
            blk[:, :3] = eye
            blk[:, 3 * (k + 1) : 3 * (k + 2)] = c_t_w @ a
            rows.append(blk)
            rhs.append(r)
    sol, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)
    r_wt = sol[:3]
    p = [sol[3 * (k + 1) : 3 * (k + 2)] for k in range(n)]
    if abs(c_t_w[2, 2]) < 0.1:
        raise MfnsError("hand-eye initialization: the turntable's main axis is not towards the board")
    # caliper: -height = r_wb_w[2] = r_wt[2] + (C_t_w (0, 0, h))[2]
    h = float((-obs.caliper_height_mm - r_wt[2]) / c_t_w[2, 2])
    r_bk = [pk - np.array([0.0, 0.0, h]) for pk in p]
    return HandEyeResult(c_t_w, r_wt, h, c_k_b, r_bk)


def _hand_eye_apart(obs: Observations, zhang: list[ZhangResult], apart: frozenset[int]) -> HandEyeResult:
    """solve_hand_eye of the cameras not `apart`, then each camera apart on that turntable:
    C_k_b = (C_t_w A_i)^T C_k'_w averaged, p_k = (C_t_w A_i)^T (r_wk'_w - r_wt_w) averaged."""
    from dataclasses import replace

    from .model import Observations as Obs

    keep = [k for k in range(obs.n_cams) if k not in apart]
    sub = Obs(
        obs.board,
        [replace(im, camera=keep.index(im.camera)) for im in obs.images if im.camera in keep],
        obs.caliper_height_mm,
        obs.caliper_sigma_mm,
        obs.angle_sigma_rad,
        obs.image_size,
        tuple(obs.camera_names[k] for k in keep),
    )
    part = solve_hand_eye(sub, [zhang[k] for k in keep])
    c_k_b: list[np.ndarray] = []
    r_bk: list[np.ndarray] = []
    for k in range(obs.n_cams):
        if k in keep:
            c_k_b.append(part.C_k_b[keep.index(k)])
            r_bk.append(part.r_bk_b[keep.index(k)])
            continue
        views = _turntable_views(obs, zhang[k], k)
        check_turntable_geometry(obs, k, [a for a, _c, _r in views])
        c_k_b.append(_so3(sum((part.C_t_w @ a).T @ c for a, c, _r in views)))
        p = np.mean([(part.C_t_w @ a).T @ (r - part.r_wt_w) for a, _c, r in views], axis=0)
        r_bk.append(p - np.array([0.0, 0.0, part.h]))
    return HandEyeResult(part.C_t_w, part.r_wt_w, part.h, c_k_b, r_bk)
