"""Step 1 of CPC: Zhang's method per camera (cv2.calibrateCamera, 5 coefficients, no skew)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..core.errors import MfnsError
from .model import Observations

INTRINSIC_NAMES = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")


MIN_ORIENTATIONS = 3
ORIENTATION_STEP_DEG = 5.0


def distinct_orientations(normals) -> int:
    """Board normals (in the camera frame) more than ORIENTATION_STEP_DEG apart, greedily."""
    reps: list[np.ndarray] = []
    cos_step = np.cos(np.deg2rad(ORIENTATION_STEP_DEG))
    for v in normals:
        v = np.asarray(v, float) / np.linalg.norm(v)
        if all(abs(float(v @ r)) < cos_step for r in reps):
            reps.append(v)
    return len(reps)


@dataclass
class ZhangResult:
    camera: int
    K: np.ndarray
    dist: np.ndarray  # [k1, k2, p1, p2, k3]
    sigma: np.ndarray  # 1-sigma of INTRINSIC_NAMES (OpenCV's estimate)
    rms_px: float
    names: list[str]
    C_w_k: list[np.ndarray]  # per image: board (world) -> camera rotation
    t: list[np.ndarray]  # per image: board origin in the camera frame, mm

    @property
    def intrinsics(self) -> np.ndarray:
        return np.array([self.K[0, 0], self.K[1, 1], self.K[0, 2], self.K[1, 2], *self.dist])

    def camera_in_world(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """(C_k'_w, r_wk'_w) of image i: the pose CPC starts from."""
        c = self.C_w_k[i].T
        return c, -c @ self.t[i]


def calibrate_camera(obs: Observations, k: int) -> ZhangResult:
    ims = obs.of_camera(k)
    if len(ims) < 4:
        raise MfnsError(f"camera {obs.camera_names[k]}: only {len(ims)} usable images (need >= 4)")
    obj = obs.board.object_points().astype(np.float32)
    seen = [im.seen for im in ims]  # partial views: only the corners seen
    objs = [obj[m] for m in seen]
    imgs = [im.uv[m].astype(np.float32).reshape(-1, 1, 2) for im, m in zip(ims, seen, strict=True)]
    w, h = obs.image_size
    k0 = np.array([[1500.0, 0, w / 2 - 0.5], [0, 1500.0, h / 2 - 0.5], [0, 0, 1]])
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    try:
        rms, K, dist, rvecs, tvecs, std_i, _std_e, _per_view = cv2.calibrateCameraExtended(
            objs, imgs, (w, h), k0, np.zeros(5), flags=0, criteria=crit
        )
    except cv2.error as exc:
        msg = str(exc).strip().splitlines()[-1][:120]
        raise MfnsError(f"camera {obs.camera_names[k]}: Zhang's calibration failed ({msg})") from exc
    if not (np.isfinite(rms) and np.all(np.isfinite(K)) and np.all(np.isfinite(dist))):
        raise MfnsError(f"camera {obs.camera_names[k]}: Zhang's calibration diverged (views too alike?)")
    rots0 = [cv2.Rodrigues(np.asarray(r, float))[0] for r in rvecs]
    n_orient = distinct_orientations([r[:, 2] for r in rots0])
    if n_orient < MIN_ORIENTATIONS:
        raise MfnsError(
            f"camera {obs.camera_names[k]}: its images show the board from {n_orient} distinct "
            f"orientation(s) (need >= {MIN_ORIENTATIONS}, {ORIENTATION_STEP_DEG:g} deg apart); "
            "the intrinsics are not determined"
        )
    dist = np.asarray(dist, float).ravel()[:5]
    std = np.asarray(std_i, float).ravel()[:9]
    rots = rots0
    ts = [np.asarray(t, float).ravel() for t in tvecs]
    return ZhangResult(k, np.asarray(K, float), dist, std, float(rms), [im.name for im in ims], rots, ts)
