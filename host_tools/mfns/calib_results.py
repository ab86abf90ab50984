"""Read, validate and write the calibration-results JSON (docs/calib-results.md)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from . import validate as V
from .errors import MfnsError
from .rotations import euler213_deg_to_matrix, matrix_to_euler213_deg
from .validate import MIB

FORMAT = "mfns-calib-results"
VERSION = 1
CAMERA_NAMES = ("x", "y", "z")  # the flight rig (calibration table, navigation)
MAX_CAMERAS = 8  # a calibration (mfns calib) may hold 1..8 cameras
NAME_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-")


MAX_BYTES = 1 * MIB  # a calibration of three cameras is ~5 KiB


def camera_name_problem(name) -> str | None:
    """Why `name` cannot be a camera name (used in file names), or None."""
    if not isinstance(name, str) or not 1 <= len(name) <= 16 or not set(name) <= NAME_CHARS:
        return f"camera name {name!r:.40} must be 1-16 characters of A-Z a-z 0-9 _ -"
    return None


def _camera(i: int, cam: object) -> None:
    where = f"camera {i}"
    cam = V.obj(cam, where)
    name = cam.get("name")
    problem = camera_name_problem(name)
    if problem:
        raise MfnsError(f"{where}: {problem}")
    where = f"camera {name}"
    V.keys(cam, where, ("image_size", "fx", "fy", "cx", "cy", "skew", "dist", "C_k_b", "r_bk_b"))
    size = cam["image_size"]
    if not isinstance(size, list) or len(size) != 2:
        raise MfnsError(f"{where} image_size: expected [width, height], got {size!r:.40}")
    w = V.integer(size[0], f"{where} image_size width", 1, 65535)
    h = V.integer(size[1], f"{where} image_size height", 1, 65535)
    V.number(cam["fx"], f"{where} fx", 0.0, None, lo_open=True)
    V.number(cam["fy"], f"{where} fy", 0.0, None, lo_open=True)
    V.number(cam["cx"], f"{where} cx", -0.5, w - 0.5)
    V.number(cam["cy"], f"{where} cy", -0.5, h - 0.5)
    V.number(cam["skew"], f"{where} skew")
    V.array(cam["dist"], f"{where} dist [k1, k2, p1, p2, k3]", (5,))
    c = V.array(cam["C_k_b"], f"{where} C_k_b", (3, 3))
    if np.max(np.abs(c.T @ c - np.eye(3))) > 1e-6 or np.linalg.det(c) <= 0:
        raise MfnsError(f"{where}: C_k_b is not a rotation")
    V.array(cam["r_bk_b"], f"{where} r_bk_b", (3,))
    if "euler_213_deg" in cam:
        e = V.array(cam["euler_213_deg"], f"{where} euler_213_deg", (3,))
        if np.max(np.abs(euler213_deg_to_matrix(e) - c)) > 1e-7:
            raise MfnsError(f"{where}: euler_213_deg disagrees with C_k_b")


def validate(doc: object, flight: bool = True) -> dict:
    """Check a calibration-results document; returns it. Raises MfnsError with one line.

    flight=True (the default: calibration table, navigation) needs exactly the cameras
    x, y, z; flight=False (what mfns calib writes) accepts 1..MAX_CAMERAS named cameras.
    """
    doc = V.obj(doc, "calibration results")
    if doc.get("format") != FORMAT:
        raise MfnsError(
            f"not a calibration-results file (format {doc.get('format')!r:.40}, expected {FORMAT!r})"
        )
    version = V.integer(doc.get("version"), "version", 1, 2**31)
    if version > VERSION:
        raise MfnsError(f"calibration-results version {version} is newer than this tool ({VERSION})")
    V.number(doc.get("pixel_noise_px"), "pixel_noise_px", 0.0, None, lo_open=True)
    cams = doc.get("cameras")
    if not isinstance(cams, list):
        raise MfnsError(
            "cameras must be a list of exactly three cameras (x, y, z) for the flight rig"
            if flight
            else "cameras must be a list of camera objects"
        )
    for i, cam in enumerate(cams[: MAX_CAMERAS + 1]):
        V.obj(cam, f"camera {i}")
    names = [c.get("name") for c in cams[: MAX_CAMERAS + 1]]
    if flight and names != list(CAMERA_NAMES):
        raise MfnsError(
            f"cameras must be a list of exactly three cameras named x, y, z (in that order) for the "
            f"flight rig (calibration table, navigation); this file has {len(cams)}: {names[:8]}"
        )
    if not 1 <= len(cams) <= MAX_CAMERAS:
        raise MfnsError(f"cameras: {len(cams)} cameras, expected 1 to {MAX_CAMERAS}")
    if len(set(map(str, names))) != len(names):
        raise MfnsError(f"cameras: duplicate names {names[:8]}")
    for i, cam in enumerate(cams):
        _camera(i, cam)
    return doc


def load(path: str | Path, flight: bool = True) -> dict:
    doc = V.load_json(path, "calibration results", MAX_BYTES)
    try:
        return validate(doc, flight)
    except MfnsError as exc:
        raise MfnsError(f"{path}: {exc}") from exc


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
