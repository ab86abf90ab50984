"""The flight pose solver (firmware/nav/pose/pose.h, through mfns.core.flight) as a `PoseSolver`.

`mfns mc`'s end-to-end extension calls a solver with known correspondences and an initial
pose; this adapter runs the C refinement (`mfns_pose_refine`, ML mode) with those
correspondences from that pose, so the extension measures the code the navigation computer
runs (one implementation, host and flight).

Semantics made to match the host reference (mfns.model.pose_ref.solve_pose_gn): plain least
squares on the pixel reprojection error, every observation kept. The flight defaults are
built to reject measurement outliers, which here would hide exactly what the extension
measures (a miscalibrated rig gives residuals of several pixels on every beacon), so:
  huber_k = 0 (no robust loss), outlier_gate_sigma = 0 (no gate),
  max_residual_rms_sigma = inf (a large residual is the result, not a failure),
min_rcond = 0 (the pose pool already excludes near-critical geometry by its dilution), and a
tighter step tolerance (1e-7 rad and 1e-4 mm) so the solve ends at the float round-off of the
minimum rather than at the flight's 1 microradian. sigma_px = 1 only scales the gradient test.
What remains between the two solvers is float: on weakly conditioned poses up to ~0.02 px
times the pose's dilution (docs/error-analysis.md).
The normalized coordinates (x, y) the C frame also carries are undistorted with the rig the
solver believes, as the flight pipeline corrects its blobs with its calibration table.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..core.errors import MfnsError
from ..model.camera import Camera
from ..model.pose_ref import PoseSolution

SOLVERS = ("flight", "reference")
SOLVER_NAMES = {
    "flight": "flight solver (firmware/nav/pose/pose.h mfns_pose_refine via ctypes, libmfns_core.so)",
    "reference": "host reference solver (mfns.model.pose_ref, Python Gauss-Newton)",
}


class FlightPoseSolver:
    """A `PoseSolver` running the C refinement. lib: path of libmfns_core.so (default: the build)."""

    name = SOLVER_NAMES["flight"]

    def __init__(self, lib=None, max_iterations: int = 50):
        from ..core import flight

        try:
            self.flight = flight.Flight(lib)
        except OSError as e:  # present but not loadable
            raise MfnsError(f"flight solver: cannot load the core library ({e}); run: make lib") from e
        except MfnsError as e:
            raise MfnsError(f"flight solver: {e}; or use --solver reference") from e
        self.cfg = self.flight.config(
            sigma_px=1.0,
            max_iterations=max_iterations,
            step_tol=1e-7,
            grad_tol=1e-7,
            huber_k=0.0,
            outlier_gate_sigma=0.0,
            max_residual_rms_sigma=math.inf,
            min_rcond=0.0,
        )
        self._ncam = flight.NUM_CAMERAS

    def __call__(
        self,
        cams: Sequence[Camera],
        cam_idx: np.ndarray,
        points_w: np.ndarray,
        uv: np.ndarray,
        C_w_b0: np.ndarray,
        r_bw_b0: np.ndarray,
    ) -> PoseSolution:
        cam_idx = np.asarray(cam_idx, dtype=int)
        points_w = np.asarray(points_w, dtype=float).reshape(-1, 3)
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        if len(cams) != self._ncam:
            raise MfnsError(f"flight solver: {len(cams)} cameras, the flight rig has {self._ncam}")
        # One map entry per distinct point, so a beacon seen by two cameras is one beacon.
        uniq, inv = np.unique(points_w, axis=0, return_inverse=True)
        inv = np.asarray(inv).reshape(-1)
        obs, ids = [], []
        for k, cam in enumerate(cams):
            sel = np.nonzero(cam_idx == k)[0]
            xy = cam.undistort_pixels(uv[sel]) if len(sel) else np.zeros((0, 2))
            obs.append(np.hstack([uv[sel], xy]))
            ids.append(inv[sel])
        f = self.flight
        sol = f.refine(
            f.rig(cams),
            f.beacon_map(uniq),
            f.frame(obs),
            f.assoc(ids),
            f.pose(C_w_b0, r_bw_b0),
            self.cfg,
        )
        # C reports the RMS per coordinate; pose_ref's rms_px is per observation (u and v).
        rms = sol.residual_rms_px * math.sqrt(2.0) if sol.ok else float("nan")
        return PoseSolution(sol.C_w_b, sol.r_bw_b, bool(sol.ok), int(sol.iterations), float(rms))


def make_solver(kind: str, lib=None):
    """(PoseSolver, description) for --solver flight|reference."""
    if kind == "flight":
        s = FlightPoseSolver(lib)
        return s, s.name
    if kind == "reference":
        from ..model.pose_ref import solve_pose_gn

        return solve_pose_gn, SOLVER_NAMES["reference"]
    raise MfnsError(f"unknown solver {kind!r} (choose from {', '.join(SOLVERS)})")
