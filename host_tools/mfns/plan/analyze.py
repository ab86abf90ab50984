"""Analysis of one beacon map over a workspace: in view, fix, Cramer-Rao 1-sigma.

Per pose sample: the beacons in view of each camera (the C core's decision, core.py),
whether a fix is possible, the Cramer-Rao 1-sigma of the six output axes (crlb.py), the
1-sigma the flight solver is expected to reach (equal-weight pixel fit: the same with
pixel noise only, above the bound with survey or calibration errors) and the
identification margin (ident.py: the acquisition's map analysis on the sample's view).

Fix rule (firmware/nav/acquire/acquire.h): the flight code acquires only from a redundant solve
using at least four beacons (three are never acquired); tracking keeps a fix on three
when they agree with the prediction.
So a fix is *possible* (``fix``) with >= FIX_MIN_IN_VIEW distinct beacons in view, and a
fix can be *held* by tracking (``track``) with >= TRACK_MIN_IN_VIEW.

For an ordered workspace (the turntable sweep, a recorded truth.csv) ``fix_flight`` plays
the navigation cycle's rule along the sequence (firmware/nav/cycle/nav_cycle.c): acquire with
>= FIX_MIN_IN_VIEW, then track with >= TRACK_MIN_IN_VIEW while the fixes are unbroken.
A coast is not counted on to recover the track: after a coast the cycle predicts with
no velocity (it takes velocity only between two real fixes), so a robot turning faster
than the track gate per cycle (the turntable's 0.6 deg = 17 px > 15 px) loses it. The
rare cold fix from exactly three beacons (no rival pose) is not counted either.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..table.generated.layout_gen import CONSTANTS
from .core import Core
from .crlb import CalibrationError, Observation, flight_information, information
from .ident import IdentMargin, identification_margin
from .workspace import Workspace

FIX_MIN_IN_VIEW = 4
# Beacons in view the acquisition can certify in one call: the certificate's floor
# (beacon_index.h MFNS_BIDX_MIN_CERT, generated). A view of exactly FIX_MIN_IN_VIEW is
# below it: certified only by the exhaustive completion, over 1-31 cycles' budget on the
# module's planned layouts (docs/planning.md), so the share of such views bounds a layout's
# one-call rate.
CERT_MIN_IN_VIEW = CONSTANTS["MFNS_BIDX_MIN_CERT"]
TRACK_MIN_IN_VIEW = 3


@dataclass
class Analysis:
    ws: Workspace
    in_view_cam: np.ndarray  # (n, 3) beacons in view per camera
    in_view: np.ndarray  # (n,) distinct beacons in view (any camera)
    sigma: np.ndarray  # (n, 6) Cramer-Rao 1-sigma per core.csv_formats.POSE_COLUMNS; nan when not determined
    margin: list  # (n,) identification margin or None
    flight_sigma: np.ndarray  # (n, 6) the flight solver's expected 1-sigma (crlb.flight_information)

    @property
    def fix(self) -> np.ndarray:
        return self.in_view >= FIX_MIN_IN_VIEW

    @property
    def track(self) -> np.ndarray:
        return self.in_view >= TRACK_MIN_IN_VIEW

    @property
    def fix_flight(self) -> np.ndarray | None:
        """The navigation cycle's fixes along an ordered workspace, else None."""
        return flight_sequence_fix(self.in_view) if self.ws.ordered else None


def flight_sequence_fix(in_view: np.ndarray) -> np.ndarray:
    """Fix per cycle of the navigation cycle's acquire / track / coast rule (docstring)."""
    out = np.zeros(len(in_view), dtype=bool)
    for i, n in enumerate(in_view):
        out[i] = n >= FIX_MIN_IN_VIEW or (i > 0 and out[i - 1] and n >= TRACK_MIN_IN_VIEW)
    return out


def observe(core: Core, beacons_w: np.ndarray, C_w_b, r_bw_b) -> tuple[list[Observation], list[np.ndarray]]:
    """The observations of every beacon in view at one pose, and per camera the indices."""
    obs, per_cam = [], []
    for k in range(3):
        uv, vis, jac = core.project(k, C_w_b, r_bw_b, beacons_w)
        idx = np.nonzero(vis)[0]
        per_cam.append(idx)
        for b in idx:
            obs.append(Observation(k, int(b), uv[b], jac[b], jac[b][:, 3:] @ C_w_b))
    return obs, per_cam


def pose_sigma(
    core, obs, C_w_b, r_bw_b, sigma_px, beacon_sigma, calib: CalibrationError | None, beacons_w, flight=False
):
    """(6,) Cramer-Rao 1-sigma (core.csv_formats.POSE_COLUMNS), or with flight=True the flight
    solver's expected 1-sigma (crlb.flight_information); nan when fewer than three beacons or
    singular."""
    return pose_sigmas(core, obs, C_w_b, r_bw_b, sigma_px, beacon_sigma, calib, beacons_w)[1 if flight else 0]


def pose_sigmas(core, obs, C_w_b, r_bw_b, sigma_px, beacon_sigma, calib: CalibrationError | None, beacons_w):
    """(Cramer-Rao 1-sigma (6,), flight solver's expected 1-sigma (6,)), nan where not
    determined (fewer than three beacons, or singular for the C covariance)."""
    none = np.full(6, np.nan)
    if len({o.beacon for o in obs}) < 3:
        return none, none
    cj = calib.jacobian(obs, beacons_w, C_w_b, r_bw_b) if calib else None
    cs = calib.sigma if calib else None
    out = []
    for f in (information, flight_information):
        try:
            res = core.output_sigma(f(obs, sigma_px, beacon_sigma, cj, cs), C_w_b, r_bw_b)
        except np.linalg.LinAlgError:
            res = None
        out.append(none if res is None else np.concatenate(res))
    return out[0], out[1]


def analyze(
    core: Core,
    beacons_w: np.ndarray,
    beacon_sigma_mm: np.ndarray,
    ws: Workspace,
    sigma_px: float,
    calib: CalibrationError | None = None,
    progress: bool = False,
    desc: str = "plan analyze",
    ident: bool = False,
) -> Analysis:
    from tqdm import tqdm

    n = ws.n
    cam_counts = np.zeros((n, 3), dtype=int)
    distinct = np.zeros(n, dtype=int)
    sigma = np.full((n, 6), np.nan)
    flight_sigma = np.full((n, 6), np.nan)
    margin = []
    im = None
    if ident and n:
        lo, hi = ws.r_wb_w.min(axis=0), ws.r_wb_w.max(axis=0)
        span = np.maximum(hi - lo, 1.0)  # a box even for one position (the turntable)
        im = IdentMargin(
            core.flight,
            core.rig,
            beacons_w,
            beacon_sigma_mm,
            lo - 0.05 * span - 1.0,
            hi + 0.05 * span + 1.0,
            sigma_px,
        )
    for i in tqdm(range(n), desc=desc, unit="pose", disable=not progress):
        C, r = ws.C_w_b[i], ws.r_bw_b(i)
        obs, per_cam = observe(core, beacons_w, C, r)
        cam_counts[i] = [len(x) for x in per_cam]
        distinct[i] = len({o.beacon for o in obs})
        sigma[i], flight_sigma[i] = pose_sigmas(core, obs, C, r, sigma_px, beacon_sigma_mm, calib, beacons_w)
        margin.append(identification_margin(im, C, r))
    return Analysis(ws, cam_counts, distinct, sigma, margin, flight_sigma)
