"""Read, validate and write the calibration-results JSON (docs/calib-results.md)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..core import validate as V
from ..core.errors import MfnsError
from ..core.validate import MIB
from ..model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg

FORMAT = "mfns-calib-results"
VERSION = 1
CAMERA_NAMES = ("x", "y", "z")  # the flight rig (calibration table, navigation)
MAX_CAMERAS = 8  # a calibration (mfns calib) may hold 1..8 cameras
NAME_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-")


MAX_BYTES = 1 * MIB  # three cameras ~5 KiB, ~50 KiB with the covariance; eight ~350 KiB

# The optional "covariance" (docs/calib-results.md): per camera, in this order; errors are
# estimate - truth; px, 1 (distortion), rad (theta: C_k_b(est) = exp([theta x]) C_k_b(true),
# about body axes), mm (r: r_bk_b, body frame). "skew" (px) only when it was estimated.
COVARIANCE_PARAMETERS = (
    "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3",
    "theta_x", "theta_y", "theta_z", "r_x", "r_y", "r_z",
)  # fmt: skip
COVARIANCE_OPTIONAL = ("skew",)
SYMMETRY_TOL = 1e-9  # |M_ij - M_ji| relative to sqrt(M_ii M_jj)
PSD_TOL = 1e-9  # smallest eigenvalue of the correlation matrix
SIGMA_TOL = 1e-6  # relative: sigma must be sqrt(diag) of the covariance where both exist


def camera_name_problem(name) -> str | None:
    """Why `name` cannot be a camera name (used in file names), or None."""
    if not isinstance(name, str) or not 1 <= len(name) <= 16 or not set(name) <= NAME_CHARS:
        return f"camera name {name!r:.40} must be 1-16 characters of A-Z a-z 0-9 _ -"
    return None


# The focal length a pinhole camera of this model can have, from the field of view it gives
# across the image: from MIN_FOV_DEG (a long telescope) to MAX_FOV_DEG (wider is a fisheye,
# which the pinhole-plus-radial model does not describe). Outside it the numbers are not a
# camera: the table's float32 grids overflow or degenerate (numpy warnings, then an error
# far from the cause), so the one reader of the format refuses them here, by name.
MIN_FOV_DEG, MAX_FOV_DEG = 0.5, 170.0


def focal_range_px(side_px: int) -> tuple[float, float]:
    """(lowest, highest) focal length in px for an image side of side_px pixels."""
    return (
        side_px / (2.0 * math.tan(math.radians(MAX_FOV_DEG) / 2.0)),
        side_px / (2.0 * math.tan(math.radians(MIN_FOV_DEG) / 2.0)),
    )


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
    for key, side in (("fx", w), ("fy", h)):
        lo, hi = focal_range_px(side)
        f = V.number(cam[key], f"{where} {key}", 0.0, None, lo_open=True)
        if not lo <= f <= hi:
            raise MfnsError(
                f"{where} {key}: {f:g} px outside {lo:.3g}..{hi:.3g} px, the focal lengths that give "
                f"an image {side} px across a field of view of {MIN_FOV_DEG:g} to {MAX_FOV_DEG:g} deg"
            )
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
    if "covariance" in doc:
        _covariance(doc["covariance"], cams)
    return doc


def _covariance(cov: object, cams: list[dict]) -> None:
    """The optional covariance: its parameters, symmetric PSD, and the sigma blocks agree."""
    where = "covariance"
    cov = V.obj(cov, where)
    V.keys(cov, where, ("parameters", "matrix"), ())
    names = cov["parameters"]
    if not isinstance(names, list) or not 1 <= len(names) <= MAX_CAMERAS * 16:
        raise MfnsError(f"{where} parameters: expected a list of 1 to {MAX_CAMERAS * 16} names")
    cam_names = [c["name"] for c in cams]
    allowed = {f"{c}.{p}" for c in cam_names for p in COVARIANCE_PARAMETERS + COVARIANCE_OPTIONAL}
    for i, n in enumerate(names):
        if not isinstance(n, str) or n not in allowed:
            raise MfnsError(
                f"{where} parameters[{i}]: {n!r:.40} is not <camera>.<parameter> of a camera of this "
                f"file with parameter one of {', '.join(COVARIANCE_PARAMETERS + COVARIANCE_OPTIONAL)}"
            )
    if len(set(names)) != len(names):
        raise MfnsError(f"{where} parameters: duplicate names")
    missing = [f"{c}.{p}" for c in cam_names for p in COVARIANCE_PARAMETERS if f"{c}.{p}" not in names]
    if missing:
        raise MfnsError(
            f"{where} parameters: missing {', '.join(missing[:4])}" + (" ..." if missing[4:] else "")
        )
    n = len(names)
    m = V.array(cov["matrix"], f"{where} matrix", (n, n))
    d = np.diag(m)
    if np.any(d < 0.0):
        raise MfnsError(f"{where} matrix: negative variance of {names[int(np.argmin(d))]}")
    scale = np.sqrt(np.outer(d, d))
    if np.any(np.abs(m - m.T) > SYMMETRY_TOL * scale):
        raise MfnsError(f"{where} matrix: not symmetric")
    pos = d > 0.0
    if np.any(m[~pos] != 0.0):
        raise MfnsError(f"{where} matrix: a zero variance with a nonzero covariance")
    if pos.any():
        s = np.sqrt(d[pos])
        with np.errstate(over="ignore", invalid="ignore"):
            corr = m[np.ix_(pos, pos)] / np.outer(s, s)
        # |correlation| <= 1 first: it also keeps inf/NaN (from extreme values) out of eigvalsh
        if not np.all(np.abs(corr) <= 1.0 + PSD_TOL) or np.linalg.eigvalsh(corr).min() < -PSD_TOL:
            raise MfnsError(f"{where} matrix: not positive semi-definite")
    index = {nm: i for i, nm in enumerate(names)}
    for cam in cams:
        sig = cam.get("sigma")
        if not isinstance(sig, dict):
            continue
        c = cam["name"]
        pairs = [(k, sig.get(k), k) for k in ("fx", "fy", "cx", "cy")]
        for key, params in (("dist", ("k1", "k2", "p1", "p2", "k3")), ("r_bk_b", ("r_x", "r_y", "r_z"))):
            vals = sig.get(key)
            if isinstance(vals, list) and len(vals) == len(params):
                pairs += [(f"{key}[{j}]", vals[j], p) for j, p in enumerate(params)]
        for key, v, par in pairs:
            if v is None:
                continue
            v = V.number(v, f"camera {c} sigma {key}", 0.0)
            ref = float(np.sqrt(m[index[f"{c}.{par}"], index[f"{c}.{par}"]]))
            if abs(v - ref) > SIGMA_TOL * max(ref, abs(v)):
                raise MfnsError(
                    f"camera {c} sigma {key} = {v:.6g} disagrees with the covariance (sqrt of its "
                    f"variance {ref:.6g})"
                )


def covariance(doc: dict) -> tuple[list[str], np.ndarray] | None:
    """(parameter names, matrix) of a validated document, or None: no covariance = unknown."""
    cov = doc.get("covariance")
    if cov is None:
        return None
    return list(cov["parameters"]), np.array(cov["matrix"], dtype=float)


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


def dumps(doc: dict) -> str:
    """The document as JSON text, indented, each covariance row on one line."""
    cov = doc.get("covariance")
    if cov is None:
        return json.dumps(doc, indent=2) + "\n"
    rows = cov["matrix"]
    marks = [f"@row{i}@" for i in range(len(rows))]
    text = json.dumps({**doc, "covariance": {**cov, "matrix": marks}}, indent=2)
    for mark, row in zip(marks, rows, strict=True):
        text = text.replace(json.dumps(mark), json.dumps(row), 1)
    return text + "\n"


def save(doc: dict, path: str | Path, flight: bool = True) -> None:
    validate(doc, flight)
    Path(path).write_text(dumps(doc))
