"""Read a calibration dataset folder (docs/calib-dataset.md) and detect its corners."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from ..errors import MfnsError
from .model import ARCSEC, CAMERA_NAMES, Board, ImageObs, Observations

FORMAT = "mfns-calib-dataset"
VERSION = 1


def orient_corners(corners: np.ndarray, img: np.ndarray, board: Board) -> np.ndarray:
    """Reorder detected corners to the board's row-major order with corner 0 at the origin.

    The detector may return the grid mirrored or turned by 180 deg. A camera in front of the
    board sees its grid right-handed in the image (u right, v down); the first square is black
    and, with an odd + even square count, the 180-deg turn is told apart by colour.
    """
    g = corners.reshape(board.rows, board.cols, 2)
    a, b = g[0, 1] - g[0, 0], g[1, 0] - g[0, 0]
    if a[0] * b[1] - a[1] * b[0] < 0:
        g = g[::-1]

    def square_value(i: int, j: int) -> float:
        p = (g[i, j] + g[i, j + 1] + g[i + 1, j] + g[i + 1, j + 1]) / 4.0
        x, y = int(round(p[0])), int(round(p[1]))
        return float(img[max(y - 1, 0) : y + 2, max(x - 1, 0) : x + 2].mean())

    if square_value(0, 0) > square_value(0, 1):
        g = g[::-1, ::-1]
    return g.reshape(-1, 2).astype(float)


def detect_corners(img: np.ndarray, board: Board) -> np.ndarray | None:
    """All inner corners (N, 2) px with sub-pixel refinement, or None if the board is not found."""
    ok, c = cv2.findChessboardCornersSB(img, (board.cols, board.rows), flags=cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not ok:
        ok, c = cv2.findChessboardCorners(
            img, (board.cols, board.rows), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        )
        if not ok:
            return None
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-5)
    c = cv2.cornerSubPix(img, c.astype(np.float32), (6, 6), (-1, -1), crit)
    return orient_corners(c.reshape(-1, 2).astype(float), img, board)


def _float(s: str, what: str) -> float:
    try:
        v = float(s)
    except ValueError as exc:
        raise MfnsError(f"angles.csv: bad {what} {s!r}") from exc
    if not math.isfinite(v):
        raise MfnsError(f"angles.csv: {what} not finite")
    return v


def load_dataset(folder: str | Path, progress: bool = True) -> tuple[Observations, list[str]]:
    """Detect corners in every image; returns the observations and the names of rejected images."""
    folder = Path(folder)
    meta_path = folder / "dataset.json"
    if not meta_path.is_file():
        raise MfnsError(f"{folder}: no dataset.json (not a calibration dataset)")
    try:
        meta = json.loads(meta_path.read_text())
    except json.JSONDecodeError as exc:
        raise MfnsError(f"{meta_path}: not valid JSON ({exc.msg})") from exc
    if meta.get("format") != FORMAT:
        raise MfnsError(f"{meta_path}: format {meta.get('format')!r}, expected {FORMAT!r}")
    if not isinstance(meta.get("version"), int) or meta["version"] > VERSION:
        raise MfnsError(f"{meta_path}: unsupported version {meta.get('version')!r}")
    try:
        board = Board.from_dict(meta["board"])
        cal = meta["caliper"]
        height, cal_sigma = float(cal["height_mm"]), float(cal["sigma_mm"])
        ang_sigma = float(meta["turntable"]["angle_sigma_arcsec"]) * ARCSEC
        size = tuple(int(v) for v in meta["image_size"])
    except (KeyError, TypeError, ValueError) as exc:
        raise MfnsError(f"{meta_path}: missing or bad field ({exc})") from exc
    if not (cal_sigma > 0 and ang_sigma > 0):
        raise MfnsError(f"{meta_path}: caliper and angle sigmas must be positive")
    csv_path = folder / "angles.csv"
    if not csv_path.is_file():
        raise MfnsError(f"{folder}: no angles.csv")
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    need = {"camera", "image", "kind", "Omega_deg", "omega_deg"}
    if not rows or not need <= set(rows[0]):
        raise MfnsError(f"{csv_path}: needs columns {sorted(need)}")
    images: list[ImageObs] = []
    rejected: list[str] = []
    for row in tqdm(rows, desc="corners", unit="img", disable=not progress):
        if row["camera"] not in CAMERA_NAMES:
            raise MfnsError(f"{csv_path}: unknown camera {row['camera']!r}")
        if row["kind"] not in ("turntable", "prepared"):
            raise MfnsError(f"{csv_path}: unknown kind {row['kind']!r}")
        path = folder / row["image"]
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise MfnsError(f"{path}: cannot read image")
        if (img.shape[1], img.shape[0]) != size:
            raise MfnsError(f"{path}: size {img.shape[1]}x{img.shape[0]}, dataset says {size[0]}x{size[1]}")
        uv = detect_corners(img, board)
        if uv is None:
            rejected.append(row["image"])
            continue
        a = b = float("nan")
        if row["kind"] == "turntable":
            a, b = _float(row["Omega_deg"], "Omega_deg"), _float(row["omega_deg"], "omega_deg")
        name = Path(row["image"]).stem
        images.append(ImageObs(CAMERA_NAMES.index(row["camera"]), row["kind"], name, uv, a, b))
    obs = Observations(board, images, height, cal_sigma, ang_sigma, size)  # type: ignore[arg-type]
    return obs, rejected
