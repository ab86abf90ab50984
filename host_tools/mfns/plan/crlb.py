"""Cramer-Rao bound of the 6-DOF pose from the beacon observations of one pose.

Measurement model (docs/planning.md): every observation of beacon b in camera k is
u = h(pose, p_b, c_k) + n with
  n        pixel noise, N(0, sigma_px^2 I) per observation, independent;
  p_b      the surveyed position, off by N(0, sigma_b^2 I) (beacons.csv sigma_mm): the
           same error for every camera that sees b;
  c_k      camera k's calibration, off by N(0, diag sigma_c^2) (the calibration-results
           "sigma" entries, when given): the same error for every beacon camera k sees.
Linearised about the true values, u is Gaussian with covariance
  S = sigma_px^2 I + Jp Sb Jp^T + Jc Sc Jc^T,
so the Cramer-Rao bound of the pose increment (lens.h) is (J^T S^-1 J)^-1, J the pose
Jacobian. Without survey and calibration errors this is sigma_px^2 (J^T J)^-1, the
covariance the flight solver itself reports (firmware/nav/pose/pose_cov.c). The pose and
beacon Jacobians are the C core's (mfns_cam_project); the calibration Jacobian is a
central difference of the C projection, one 1-sigma step each way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.flight import CameraC
from ..model.rotations import euler213_deg_to_matrix, matrix_to_euler213, matrix_to_euler213_deg, rot_exp

# Calibration parameters with a 1-sigma in the calibration-results "sigma" entry.
CALIB_SCALARS = ("fx", "fy", "cx", "cy")


@dataclass
class Observation:
    cam: int
    beacon: int
    uv: np.ndarray  # (2,) px
    J: np.ndarray  # (2, 6) d uv / d increment
    Jp: np.ndarray  # (2, 3) d uv / d p_w


def observation_covariance(
    obs: list[Observation], sigma_px: float, beacon_sigma_mm, calib_jac=None, calib_sigma=None
):
    """S (2 M x 2 M): the covariance of the stacked observations (module docstring).

    calib_jac: (2 M, P) d uv / d calibration parameter (None: no calibration error);
    calib_sigma: (P,) their 1-sigma.
    """
    m = len(obs)
    S = np.eye(2 * m) * sigma_px**2
    bsig = np.asarray(beacon_sigma_mm, dtype=float)
    for i, oi in enumerate(obs):
        for j, oj in enumerate(obs):
            if oi.beacon == oj.beacon and bsig[oi.beacon] > 0:
                S[2 * i : 2 * i + 2, 2 * j : 2 * j + 2] += bsig[oi.beacon] ** 2 * oi.Jp @ oj.Jp.T
    if calib_jac is not None and calib_jac.size:
        S += (calib_jac * np.asarray(calib_sigma) ** 2) @ calib_jac.T
    return S


def information(obs: list[Observation], sigma_px: float, beacon_sigma_mm, calib_jac=None, calib_sigma=None):
    """The Fisher information J^T S^-1 J (6x6, increment coordinates): its inverse is the
    Cramer-Rao bound."""
    if not obs:
        return np.zeros((6, 6))
    J = np.concatenate([o.J for o in obs])  # (2m, 6)
    S = observation_covariance(obs, sigma_px, beacon_sigma_mm, calib_jac, calib_sigma)
    return J.T @ np.linalg.solve(S, J)


def flight_information(
    obs: list[Observation], sigma_px: float, beacon_sigma_mm, calib_jac=None, calib_sigma=None
):
    """The inverse of the flight solver's error covariance A S A^T, A = (J^T J)^-1 J^T.

    The flight solver fits pixels with equal weights (it models neither survey nor
    calibration errors), so with those errors present it is not efficient: its spread
    is this sandwich, at or above the Cramer-Rao bound (equal with pixel noise only)."""
    if not obs:
        return np.zeros((6, 6))
    J = np.concatenate([o.J for o in obs])
    S = observation_covariance(obs, sigma_px, beacon_sigma_mm, calib_jac, calib_sigma)
    A = np.linalg.solve(J.T @ J, J.T)
    return np.linalg.inv(A @ S @ A.T)


class CalibrationError:
    """The 1-sigma calibration errors of a calibration-results document and the
    Jacobian of an observation with respect to them (through the C projection)."""

    def __init__(self, core, doc: dict):
        self.core = core
        self.params: list[tuple[int, str, int, float]] = []  # (camera, key, index, sigma)
        self.euler = []
        for k, cam in enumerate(doc["cameras"]):
            e = cam.get("euler_213_deg")
            self.euler.append(
                np.asarray(e, dtype=float) if e is not None else matrix_to_euler213_deg(cam["C_k_b"])
            )
            sig = cam.get("sigma") or {}
            for key in CALIB_SCALARS:
                if sig.get(key):
                    self.params.append((k, key, 0, float(sig[key])))
            for key, n in (("dist", 5), ("euler_213_deg", 3), ("r_bk_b", 3)):
                vals = sig.get(key)
                if vals is None:
                    continue
                for i in range(n):
                    if vals[i]:
                        self.params.append((k, key, i, float(vals[i])))
        self.sigma = np.array([p[3] for p in self.params])

    def __bool__(self) -> bool:
        return bool(self.params)

    def _perturbed(self, k: int, key: str, i: int, delta: float) -> CameraC:
        c = CameraC.from_buffer_copy(self.core.rig.cam[k])
        if key in CALIB_SCALARS:
            setattr(c.k, key, getattr(c.k, key) + delta)
        elif key == "dist":
            c.k.dist[i] += delta
        elif key == "euler_213_deg":
            e = self.euler[k].copy()
            e[i] += delta
            m = euler213_deg_to_matrix(e)
            for r in range(3):
                for s in range(3):
                    c.C_k_b.m[r][s] = float(m[r, s])
        else:  # r_bk_b
            setattr(c.r_bk_b, "xyz"[i], getattr(c.r_bk_b, "xyz"[i]) + delta)
        return c

    def jacobian(self, obs: list[Observation], points_w, C_w_b, r_bw_b) -> np.ndarray:
        """(2 M, P): d uv / d parameter for each observation (zero for another camera's)."""
        out = np.zeros((2 * len(obs), len(self.params)))
        for p, (k, key, i, s) in enumerate(self.params):
            plus, minus = self._perturbed(k, key, i, s), self._perturbed(k, key, i, -s)
            for j, o in enumerate(obs):
                if o.cam != k:
                    continue
                a = self.core.project_with_camera(plus, C_w_b, r_bw_b, points_w[o.beacon])
                b = self.core.project_with_camera(minus, C_w_b, r_bw_b, points_w[o.beacon])
                if a is not None and b is not None:
                    out[2 * j : 2 * j + 2, p] = (a - b) / (2 * s)
        return out


# --------------------------------------------------------------------------- batched
def output_jacobian(C_w_b: np.ndarray, r_bw_b: np.ndarray, step: float = 1e-3) -> np.ndarray:
    """(6, 6) d(r_wb_w mm, roll/pitch/yaw rad)/d(increment), the mapping of
    mfns_pose_covariance (pose_cov.c) in numpy, for the optimiser's batched sigmas;
    tests/host/test_plan_core.py holds it to the C function."""
    C = np.asarray(C_w_b, dtype=float)
    r = np.asarray(r_bw_b, dtype=float)
    jo = np.zeros((6, 6))
    sk = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    jo[:3, :3] = -C.T @ sk
    jo[:3, 3:] = -C.T
    for c in range(3):
        d = np.zeros(3)
        d[c] = step
        ep = np.array(matrix_to_euler213(rot_exp(d) @ C))
        em = np.array(matrix_to_euler213(rot_exp(-d) @ C))
        de = (ep - em + np.pi) % (2 * np.pi) - np.pi
        jo[3:, c] = de / (2 * step)
    return jo


def sigma_batch(info: np.ndarray, jo: np.ndarray, rcond: float = 1e-10) -> np.ndarray:
    """info (P, 6, 6), jo (P, 6, 6) -> (P, 6) 1-sigma: x, y, z mm, roll, pitch, yaw deg.

    inf where the information matrix is singular (its reciprocal condition estimate below
    rcond, after scaling to unit diagonal)."""
    P = len(info)
    out = np.full((P, 6), np.inf)
    d = np.sqrt(np.clip(np.einsum("pii->pi", info), 0.0, None))
    ok = np.all(d > 0, axis=1)
    if not ok.any():
        return out
    dn = d[ok]
    scaled = info[ok] / (dn[:, :, None] * dn[:, None, :])
    w = np.linalg.eigvalsh(scaled)
    good = w[:, 0] > rcond * w[:, -1]
    idx = np.nonzero(ok)[0][good]
    cov = np.linalg.inv(scaled[good]) / (dn[good][:, :, None] * dn[good][:, None, :])
    var = np.einsum("pri,pij,prj->pr", jo[idx], cov, jo[idx])
    sd = np.sqrt(np.clip(var, 0.0, None))
    sd[:, 3:] = np.rad2deg(sd[:, 3:])
    out[idx] = sd
    return out
