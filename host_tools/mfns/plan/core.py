"""The C core's projection, visibility and pose covariance, for the planner (ctypes).

Every decision the planner reports is the flight code's: a beacon is in view of camera k
when ``mfns_cam_project`` (math/lens.h) gives a pixel (in front, depth >= 1 mm) and
``mfns_cam_in_image`` puts it on the sensor -- the rule the navigation cycle uses to
predict beacons (firmware/nav/cycle/nav_cycle.c, track_windows). The Jacobians come from the
same call. The 6x6 pose covariance is mapped to the output axes (r_wb_w, 2-1-3 Euler)
by the flight code's ``mfns_pose_covariance`` (firmware/nav/pose/pose_cov.c).

numpy only prunes: :func:`prefilter` drops points that are behind a camera or so far
off its axis (undistorted normalized radius above PREFILTER_RADIUS_FACTOR times the
image's half-diagonal) that no lens of the calibration-results format can image them;
every surviving point is decided by the C call. tests/host/test_plan_core.py holds the
prefilter to the C decision (it never drops a point the C code keeps).
"""

from __future__ import annotations

import ctypes as ct

import numpy as np

from ..core.errors import MfnsError
from ..core.flight import V3, CameraC, Flight, SolutionC
from ..model.camera import Camera

# Prune beyond this multiple of the pinhole half-diagonal (normalized): the lenses of
# docs/system.md Table 2 image the corner at ~0.51, so 3x leaves a wide margin.
PREFILTER_RADIUS_FACTOR = 3.0

_F2 = ct.c_float * 2
_J26 = (ct.c_float * 6) * 2
_H66 = (ct.c_float * 6) * 6


class Core:
    """The rig as the C core sees it, and the calls the planner needs."""

    def __init__(self, cams: list[Camera], lib=None):
        self.flight = Flight(lib)
        self.lib = self.flight.lib  # prototypes: binding.py
        self.cams = cams
        self.rig = Flight.rig(cams)
        self.min_rcond = float(self.flight.config().s.min_rcond)

    # --- projection -------------------------------------------------------------
    def project(self, k: int, C_w_b, r_bw_b, points_w):
        """Points (N, 3) into camera k at one pose -> (uv (N, 2), in_view (N,), jac (N, 2, 6)).

        jac is d(u, v)/d(increment) (lens.h: dtheta rad, dt mm); rows of points not
        in view are zero. ``prefilter`` runs first; the C call decides the rest.
        """
        pts = np.atleast_2d(np.asarray(points_w, dtype=float))
        n = len(pts)
        uv = np.zeros((n, 2))
        jac = np.zeros((n, 2, 6))
        vis = np.zeros(n, dtype=bool)
        cand = np.nonzero(prefilter(self.cams[k], C_w_b, r_bw_b, pts))[0]
        if len(cand) == 0:
            return uv, vis, jac
        cam = ct.byref(self.rig.cam[k])
        kk = ct.byref(self.rig.cam[k].k)
        pose = Flight.pose(C_w_b, r_bw_b)
        pref = ct.byref(pose)
        u2, j = _F2(), _J26()
        for i in cand:
            p = pts[i]
            if self.lib.mfns_cam_project(cam, pref, V3(p[0], p[1], p[2]), ct.byref(u2), ct.byref(j)) != 0:
                continue
            if not self.lib.mfns_cam_in_image(kk, u2[0], u2[1]):
                continue
            vis[i] = True
            uv[i] = (u2[0], u2[1])
            jac[i] = np.ctypeslib.as_array(j)
        return uv, vis, jac

    def project_with_camera(self, cam_c: CameraC, C_w_b, r_bw_b, p_w) -> np.ndarray | None:
        """One point through a (perturbed) camera struct -> uv, or None when behind."""
        pose = Flight.pose(C_w_b, r_bw_b)
        u2 = _F2()
        if self.lib.mfns_cam_project(
            ct.byref(cam_c), ct.byref(pose), V3(*map(float, p_w)), ct.byref(u2), None
        ):
            return None
        return np.array([u2[0], u2[1]], dtype=float)

    # --- covariance ----------------------------------------------------------------
    def output_sigma(self, info: np.ndarray, C_w_b, r_bw_b) -> tuple[np.ndarray, np.ndarray] | None:
        """Pose information matrix (6x6, increment coordinates, 1/px^2 already applied)
        -> (sigma r_wb_w mm (3,), sigma roll/pitch/yaw deg (3,)) by mfns_pose_covariance,
        or None when the C code finds it singular (below the solver's min_rcond)."""
        h = _H66()
        for i in range(6):
            for j in range(6):
                h[i][j] = float(info[i, j])
        out = SolutionC()
        out.pose = Flight.pose(C_w_b, r_bw_b)
        if self.lib.mfns_pose_covariance(ct.byref(h), None, None, None, self.min_rcond, ct.byref(out)) != 0:
            return None
        return np.array(list(out.sigma_pos_mm), dtype=float), np.array(list(out.sigma_euler_deg), dtype=float)


def prefilter(cam: Camera, C_w_b, r_bw_b, points_w) -> np.ndarray:
    """Points that might be in view of cam (see the module docstring); a superset of the
    C decision."""
    p_c = cam.world_to_camera(C_w_b, r_bw_b, points_w)
    z = p_c[..., 2]
    half_diag = np.hypot(cam.width / (2 * cam.fx), cam.height / (2 * cam.fy))
    r = np.hypot(p_c[..., 0], p_c[..., 1])
    return (z >= 1.0) & (r <= PREFILTER_RADIUS_FACTOR * half_diag * np.maximum(z, 1.0))


def require_map_size(n: int) -> None:
    from ..core.flight import MAX_BEACONS

    if n > MAX_BEACONS:
        raise MfnsError(f"{n} beacons: the flight map holds at most {MAX_BEACONS}")
