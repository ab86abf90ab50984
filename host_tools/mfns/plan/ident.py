"""The identification margin column, from the acquisition's map analysis (issue 11).

For one pose sample, the C core's map analysis (firmware/host/acquire_certify.h, the one
`mfns table build` runs over its workspace to set the certificate) makes the frame the rig
sees from that pose and runs the flight acquisition on it without stopping early: every
correspondence that explains the blobs within the noise is found. The margin is the number
of beacons in view minus the inliers of the strongest wrong identification: how many more
blobs the right answer explains than any other. 0 or less: the view is ambiguous, the
flight code refuses it (AMBIGUOUS). None: fewer than 4 beacons in view (no fix to identify).
"""

from __future__ import annotations

import numpy as np

from ..core.flight import Flight
from ..table.mapindex import ANALYSIS_BUDGET_FACTOR


class IdentMargin:
    """The map index of one map, rig and workspace box, and the per-pose analysis."""

    def __init__(self, flight: Flight, rig, beacons_w, sigma_mm, lo, hi, sigma_px: float):
        self.fl = flight
        self.rig = rig
        self.bmap = flight.beacon_map(beacons_w, np.asarray(sigma_mm, dtype=float))
        self.idx = flight.build_index(rig, self.bmap, lo, hi)
        self.cfg = flight.config(sigma_px=sigma_px)
        self.budget = ANALYSIS_BUDGET_FACTOR * self.idx.budget_units  # as `mfns table build` analyses

    def margin(self, C_w_b, r_bw_b) -> float | None:
        pose = self.fl.pose(C_w_b, r_bw_b)
        res = self.fl.certify(self.rig, self.bmap, self.idx, self.cfg, [pose], self.budget)
        if res.usable == 0:
            return None
        frame, _ = self.fl.view(self.rig, self.bmap, self.idx, pose)
        return float(sum(frame.count) - res.max_rival)


def identification_margin(ident: IdentMargin | None, C_w_b: np.ndarray, r_bw_b: np.ndarray) -> float | None:
    """The margin of one pose sample (see the module), or None without an analysis or a view."""
    return None if ident is None else ident.margin(C_w_b, r_bw_b)
