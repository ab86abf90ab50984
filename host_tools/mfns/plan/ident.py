"""The identification margin column: the plug for the map self-similarity analysis.

How far a pose's view of the map is from being confused with another correspondence
(the acquisition issue, #11) is computed by the map analysis another engineer is
building for the table builder. The planner does not compute its own: until that
analysis exists, :func:`identification_margin` returns None and the CSV column
``ident_margin`` stays empty (never a made-up value). To plug it in, replace the body of
this one function; nothing else in mfns.plan changes (the optimiser does not use it).
"""

from __future__ import annotations

import numpy as np


def identification_margin(
    beacons_w: np.ndarray, in_view: list[np.ndarray], C_w_b: np.ndarray, r_bw_b: np.ndarray
) -> float | None:
    """Identification margin of one pose sample, or None while no analysis is plugged in.

    beacons_w: (N, 3) the map (mm); in_view: per camera, the indices of the beacons in view
    at the pose (C_w_b, r_bw_b). Expected from issue 11: a number, larger = safer, of the
    sample's view against the rest of the map.
    """
    del beacons_w, in_view, C_w_b, r_bw_b
    return None
