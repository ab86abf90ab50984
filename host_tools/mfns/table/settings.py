"""Default centroid and solver settings of the calibration table (docs/caltable.md
"Default settings" gives the reasons). `mfns table build --settings FILE` overrides any
of them from a JSON object {"centroid": {...}, "solver": {...}}."""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..errors import MfnsError
from .format import CENTROID_F32, CENTROID_U16, SOLVER_F32, SOLVER_U16

DEFAULT_CENTROID = {
    "threshold_dn": 0,  # 0: use the k-sigma rule below
    "threshold_k_sigma": 6.0,
    "min_area_px": 3,
    "max_area_px": 2000,
    "max_elongation": 3.0,
    "roi_half_size_px": 32,
    "saturation_dn": 0,  # 0: the maximum of the pixel format
}

DEFAULT_SOLVER = {
    "max_iterations": 20,
    "step_tol": 1e-6,
    "grad_tol": 1e-6,
    "huber_k": 3.0,
    "outlier_gate_sigma": 30.0,
    "max_residual_rms_px": 2.0,
    "track_gate_px": 20.0,
    "max_hypotheses": 4096,
    "min_rcond": 1e-7,
}

# Ranges the flight loader accepts (firmware/nav/caltable.c): (lo exclusive, hi inclusive).
SOLVER_RANGES = {
    "step_tol": (0.0, 1.0),
    "grad_tol": (0.0, 1.0),
    "huber_k": (0.0, 1000.0),
    "outlier_gate_sigma": (0.0, 1e5),
    "max_residual_rms_px": (0.0, 1000.0),
    "track_gate_px": (0.0, 4096.0),
    "min_rcond": (0.0, 0.999),
}


def _check(centroid: dict, solver: dict) -> None:
    for k in CENTROID_U16 + SOLVER_U16:
        v = centroid.get(k, solver.get(k))
        if not isinstance(v, int) or not 0 <= v <= 65535:
            raise MfnsError(f"setting {k} must be an integer in 0..65535, got {v!r}")
    for k in CENTROID_F32 + SOLVER_F32:
        v = centroid.get(k, solver.get(k))
        if not isinstance(v, (int, float)) or not math.isfinite(v):
            raise MfnsError(f"setting {k} must be a finite number, got {v!r}")
    c = centroid
    if not 0 <= c["threshold_k_sigma"] <= 100 or (c["threshold_dn"] == 0 and c["threshold_k_sigma"] <= 0):
        raise MfnsError("centroid threshold: need threshold_dn > 0 or threshold_k_sigma in (0, 100]")
    if not 1 <= c["min_area_px"] <= c["max_area_px"]:
        raise MfnsError("centroid areas: need 1 <= min_area_px <= max_area_px")
    if not 1 <= c["max_elongation"] <= 100:
        raise MfnsError("centroid max_elongation must be in [1, 100]")
    if c["roi_half_size_px"] < 1:
        raise MfnsError("centroid roi_half_size_px must be >= 1")
    s = solver
    if not 1 <= s["max_iterations"] <= 1000:
        raise MfnsError("solver max_iterations must be in 1..1000")
    if s["max_hypotheses"] < 1:
        raise MfnsError("solver max_hypotheses must be >= 1")
    for k, (lo, hi) in SOLVER_RANGES.items():
        if not lo < s[k] <= hi:
            raise MfnsError(f"solver {k} = {s[k]} outside ({lo}, {hi}]")


def load_settings(path: str | Path | None) -> tuple[dict, dict]:
    centroid, solver = dict(DEFAULT_CENTROID), dict(DEFAULT_SOLVER)
    if path is not None:
        try:
            doc = json.loads(Path(path).read_text())
        except json.JSONDecodeError as exc:
            raise MfnsError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from exc
        if not isinstance(doc, dict) or set(doc) - {"centroid", "solver"}:
            raise MfnsError(f"{path}: expected an object with keys 'centroid' and/or 'solver'")
        for name, dst in (("centroid", centroid), ("solver", solver)):
            extra = set(doc.get(name, {})) - set(dst)
            if extra:
                raise MfnsError(f"{path}: unknown {name} setting(s) {sorted(extra)}")
            dst.update(doc.get(name, {}))
    _check(centroid, solver)
    return centroid, solver
