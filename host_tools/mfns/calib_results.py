"""Read, validate and write the calibration-results JSON (docs/calib-results.md)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .errors import MfnsError
from .rotations import euler213_deg_to_matrix, matrix_to_euler213_deg

FORMAT = "mfns-calib-results"
VERSION = 1
CAMERA_NAMES = ("x", "y", "z")  # the flight rig (calibration table, navigation)
MAX_CAMERAS = 8  # a calibration (mfns calib) may hold 1..8 cameras
NAME_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-")


def _finite(name: str, values) -> None:
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise MfnsError(f"{name}: not finite")


def camera_name_problem(name) -> str | None:
    """Why `name` cannot be a camera name (used in file names), or None."""
    if not isinstance(name, str) or not 1 <= len(name) <= 16 or not set(name) <= NAME_CHARS:
        return f"camera name {name!r} must be 1-16 characters of A-Z a-z 0-9 _ -"
    return None


def validate(doc: dict, flight: bool = True) -> dict:
    """Check a calibration-results document; returns it. Raises MfnsError with one line.

    flight=True (the default: calibration table, navigation) needs exactly the cameras
    x, y, z; flight=False (what mfns calib writes) accepts 1..MAX_CAMERAS named cameras.
    """
    if not isinstance(doc, dict):
        raise MfnsError("not a calibration-results file (not a JSON object)")
    if doc.get("format") != FORMAT:
        raise MfnsError(f"not a calibration-results file (format {doc.get('format')!r}, expected {FORMAT!r})")
    version = doc.get("version")
    if not isinstance(version, int) or version < 1:
        raise MfnsError(f"bad version {version!r}")
    if version > VERSION:
        raise MfnsError(f"calibration-results version {version} is newer than this tool ({VERSION})")
    sigma = doc.get("pixel_noise_px")
    if not isinstance(sigma, (int, float)) or not (sigma > 0 and math.isfinite(sigma)):
        raise MfnsError("pixel_noise_px must be a positive number")
    cams = doc.get("cameras")
    if not isinstance(cams, list) or not all(isinstance(c, dict) for c in cams):
        raise MfnsError("cameras must be a list of camera objects")
    names = [c.get("name") for c in cams]
    if flight and names != list(CAMERA_NAMES):
        raise MfnsError(
            f"the flight rig (calibration table, navigation) needs exactly three cameras named x, y, z "
            f"in that order; this file has {len(cams)}: {names}"
        )
    if not 1 <= len(cams) <= MAX_CAMERAS:
        raise MfnsError(f"cameras: {len(cams)} cameras, expected 1 to {MAX_CAMERAS}")
    if len(set(map(str, names))) != len(names):
        raise MfnsError(f"cameras: duplicate names {names}")
    for i, cam in enumerate(cams):
        name = cam.get("name")
        problem = camera_name_problem(name)
        if problem:
            raise MfnsError(f"camera {i}: {problem}")
        for key in ("image_size", "fx", "fy", "cx", "cy", "skew", "dist", "C_k_b", "r_bk_b"):
            if key not in cam:
                raise MfnsError(f"camera {name}: missing {key!r}")
        w, h = cam["image_size"]
        if not (isinstance(w, int) and isinstance(h, int) and 0 < w <= 65535 and 0 < h <= 65535):
            raise MfnsError(f"camera {name}: bad image_size {cam['image_size']!r}")
        for key in ("fx", "fy", "cx", "cy", "skew"):
            _finite(f"camera {name} {key}", cam[key])
        if not (cam["fx"] > 0 and cam["fy"] > 0):
            raise MfnsError(f"camera {name}: focal lengths must be positive")
        if len(cam["dist"]) != 5:
            raise MfnsError(f"camera {name}: dist must have 5 coefficients [k1, k2, p1, p2, k3]")
        _finite(f"camera {name} dist", cam["dist"])
        c = np.asarray(cam["C_k_b"], dtype=float)
        if c.shape != (3, 3):
            raise MfnsError(f"camera {name}: C_k_b must be 3x3")
        _finite(f"camera {name} C_k_b", c)
        if np.max(np.abs(c.T @ c - np.eye(3))) > 1e-6 or np.linalg.det(c) <= 0:
            raise MfnsError(f"camera {name}: C_k_b is not a rotation")
        if len(cam["r_bk_b"]) != 3:
            raise MfnsError(f"camera {name}: r_bk_b must have 3 components")
        _finite(f"camera {name} r_bk_b", cam["r_bk_b"])
        if "euler_213_deg" in cam:
            d = euler213_deg_to_matrix(cam["euler_213_deg"])
            if np.max(np.abs(d - c)) > 1e-7:
                raise MfnsError(f"camera {name}: euler_213_deg disagrees with C_k_b")
    return doc


def load(path: str | Path, flight: bool = True) -> dict:
    try:
        doc = json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise MfnsError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from exc
    return validate(doc, flight)


def camera_entry(name, image_size, fx, fy, cx, cy, skew, dist, c_k_b, r_bk_b, sigma=None) -> dict:
    """One camera of the document, with the informational Euler angles filled in."""
    c = np.asarray(c_k_b, dtype=float)
    entry = {
        "name": name,
        "image_size": [int(image_size[0]), int(image_size[1])],
        "fx": float(fx),
        "fy": float(fy),
        "cx": float(cx),
        "cy": float(cy),
        "skew": float(skew),
        "dist": [float(v) for v in dist],
        "C_k_b": c.tolist(),
        "euler_213_deg": matrix_to_euler213_deg(c).tolist(),
        "r_bk_b": [float(v) for v in r_bk_b],
    }
    if sigma is not None:
        entry["sigma"] = sigma
    return entry


def save(doc: dict, path: str | Path, flight: bool = True) -> None:
    validate(doc, flight)
    Path(path).write_text(json.dumps(doc, indent=2) + "\n")
