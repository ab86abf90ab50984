"""Read a calibration dataset folder (docs/calib-dataset.md) and detect its corners.

Every field of dataset.json and every row of angles.csv is checked before any image is
read (types: a bool is not a number; finite values; ranges), with one-line MfnsErrors.
Corner detection runs on all cores (one process per core, OpenCV single-threaded in each,
so the result does not depend on the core count) in a camera-interleaved order, and stops
early when a camera's first images do not show the board the dataset describes.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..analysis.calib_results import MAX_CAMERAS, camera_name_problem
from ..core.errors import MfnsError
from .model import ARCSEC, CHARUCO_DICTIONARIES, Board, ImageObs, Observations, pure_axis

FORMAT = "mfns-calib-dataset"
VERSION = 1
MAX_JSON_BYTES = 1 << 20
MAX_CSV_BYTES = 8 << 20
MAX_IMAGE_BYTES = 256 << 20
MAX_ROWS = 20000
MAX_CORNERS_SIDE = 200
KINDS = ("turntable", "prepared", "pure-Omega", "pure-omega")
FAIL_FAST_IMAGES = 4  # a camera whose first 4 images all miss the board stops the run
MIN_CHARUCO_CORNERS = 6


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


def detect_chessboard(img: np.ndarray, board: Board) -> np.ndarray | None:
    """All inner corners (N, 2) px with sub-pixel refinement, or None if the board is not found.

    cv2.findChessboardCornersSB searches the grid at half resolution first (3-4x faster; pixel
    i of cv2.pyrDown is at 2i + 0.5 in the full image), then at full resolution; either way
    cornerSubPix on the full image gives the final positions (they agree to 1e-4 px).
    """
    size = (board.cols, board.rows)
    ok, c = cv2.findChessboardCornersSB(cv2.pyrDown(img), size, flags=cv2.CALIB_CB_NORMALIZE_IMAGE)
    if ok:
        c = c.reshape(-1, 1, 2) * 2.0 + 0.5
    else:
        ok, c = cv2.findChessboardCornersSB(img, size, flags=cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not ok:  # (the legacy cv2.findChessboardCorners is no fallback: 1 s per miss, finds less)
        return None
    h, w = img.shape
    c = c.reshape(-1, 2)
    if np.any(c < 7.0) or np.any(c[:, 0] > w - 8.0) or np.any(c[:, 1] > h - 8.0):
        return None  # a corner at the border: its sub-pixel window leaves the image
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-5)
    c = cv2.cornerSubPix(img, c.reshape(-1, 1, 2).astype(np.float32), (6, 6), (-1, -1), crit)
    return orient_corners(c.reshape(-1, 2).astype(float), img, board)


BEYOND = "the printed board continues beyond the detected grid"
BEYOND_RATIO = 0.5  # colour steps past the grid / steps along the outer squares: ~0 margin, ~1 squares
BEYOND_IMAGES = 2  # images of one camera showing it before the run stops


def _sample(img: np.ndarray, h: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Mean of a 3x3 patch at board points (n, 2) in squares mapped by the homography h (NaN
    where the patch leaves the image)."""
    uv = cv2.perspectiveTransform(pts.reshape(-1, 1, 2).astype(np.float64), h).reshape(-1, 2)
    out = np.full(len(pts), np.nan)
    for i, (u, v) in enumerate(uv):
        x, y = int(round(u)), int(round(v))
        if 1 <= x < img.shape[1] - 1 and 1 <= y < img.shape[0] - 1:
            out[i] = float(img[y - 1 : y + 2, x - 1 : x + 2].mean())
    return out


def board_continues(img: np.ndarray, uv: np.ndarray, board: Board) -> list[str]:
    """Sides of the detected grid past which the printed board has more squares.

    A declared board smaller than the printed one is found inside it: every image fits alone
    (Zhang), only the turntable chain breaks, after the whole refinement. The images tell at
    once: past the declared outer squares a correct board has its white margin (uniform), a
    larger printed board another row of squares (alternating). Along each side, the colour
    steps between neighbouring cells just past the outer squares (inside the margin:
    min(0.3 square, half the margin) past them) are compared with the steps between the
    outer squares themselves; a ratio above BEYOND_RATIO means squares. Checked through the
    homography of the detected corners (lens distortion moves the samples by a few pixels,
    well inside a cell). Misses: a side the image cuts off or shows too small (undecided, not
    a failure); a wrong square_mm (the images fix the board only up to scale: a wrong square
    scales every position, which the chain absorbs)."""
    grid = np.stack(np.meshgrid(np.arange(board.cols), np.arange(board.rows)), axis=-1).reshape(-1, 2)
    h, _ = cv2.findHomography(grid.astype(np.float64), uv.astype(np.float64))
    if h is None:
        return []
    d = 1.0 + min(0.3, 0.5 * board.margin / board.square)
    sides = []
    along_x = np.arange(-1, board.cols) + 0.5  # cell centres along a row (outer squares included)
    along_y = np.arange(-1, board.rows) + 0.5
    for name, pts_out, pts_in in (
        ("before row 0", [(a, -d) for a in along_x], [(a, -0.5) for a in along_x]),
        (
            f"after row {board.rows - 1}",
            [(a, board.rows - 1 + d) for a in along_x],
            [(a, board.rows - 0.5) for a in along_x],
        ),
        ("before column 0", [(-d, a) for a in along_y], [(-0.5, a) for a in along_y]),
        (
            f"after column {board.cols - 1}",
            [(board.cols - 1 + d, a) for a in along_y],
            [(board.cols - 0.5, a) for a in along_y],
        ),
    ):
        out = _sample(img, h, np.array(pts_out))
        inn = _sample(img, h, np.array(pts_in))
        step_out, step_in = np.abs(np.diff(out)), np.abs(np.diff(inn))
        ok = np.isfinite(step_out) & np.isfinite(step_in)
        if ok.sum() < 2 or np.mean(step_in[ok]) < 10.0:  # too little of the side in view
            continue
        if np.mean(step_out[ok]) > BEYOND_RATIO * np.mean(step_in[ok]):
            sides.append(name)
    return sides


def detect_charuco(img: np.ndarray, board: Board) -> tuple[np.ndarray | None, str]:
    """(N, 2) px with NaN rows for corners not seen, or (None, reason)."""
    det = cv2.aruco.CharucoDetector(board.charuco())
    cc, ids, _mc, mids = det.detectBoard(img)
    n_markers = 0 if mids is None else len(mids)
    if ids is None or len(ids) < MIN_CHARUCO_CORNERS:
        n = 0 if ids is None else len(ids)
        return None, f"{n} ChArUco corners from {n_markers} markers (need >= {MIN_CHARUCO_CORNERS})"
    uv = np.full((board.n, 2), np.nan)
    ids = np.asarray(ids).ravel()
    if ids.max() >= board.n:
        return None, "ChArUco corner ids beyond the board (wrong inner_corners?)"
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-5)
    cc = cv2.cornerSubPix(img, np.asarray(cc, np.float32).reshape(-1, 1, 2), (6, 6), (-1, -1), crit)
    uv[ids] = cc.reshape(-1, 2)
    rows, cols = np.divmod(ids, board.cols)
    if len(set(rows.tolist())) < 2 or len(set(cols.tolist())) < 2:
        return None, "ChArUco corners on one line only"
    return uv, ""


def detect_corners(img: np.ndarray, board: Board) -> np.ndarray | None:
    """Corners (N, 2) px (NaN rows: not seen), or None if the board is not found."""
    if board.kind == "charuco":
        return detect_charuco(img, board)[0]
    return detect_chessboard(img, board)


def _detect_file(job: tuple[str, Board, tuple[int, int]]) -> tuple[np.ndarray | None, str]:
    """Worker: read one image and find its corners -> (uv or None, reason)."""
    path, board, size = job
    cv2.setNumThreads(1)  # results independent of the thread count
    img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if img is None:
        return None, "unreadable image (not a PNG/JPEG/... OpenCV can decode)"
    if (img.shape[1], img.shape[0]) != tuple(size):
        return None, f"size {img.shape[1]}x{img.shape[0]}, dataset.json says {size[0]}x{size[1]}"
    try:
        if board.kind == "charuco":
            return detect_charuco(img, board)
        uv = detect_chessboard(img, board)
    except cv2.error as exc:  # e.g. cornerSubPix on a corner found at the image border
        return None, f"OpenCV: {str(exc).strip().splitlines()[-1][:100]}"
    if uv is None:
        return None, f"no {board.cols}x{board.rows}-corner chessboard found"
    sides = board_continues(img, uv, board)
    return uv, f"{BEYOND} ({', '.join(sides)})" if sides else ""


# --- dataset.json --------------------------------------------------------------------------
def _where(path: Path, key: str) -> str:
    return f"{path.name}: {key}"


def _get(d: dict, key: str, path: Path, where: str):
    if not isinstance(d, dict):
        raise MfnsError(f"{_where(path, where)} must be an object")
    if key not in d:
        raise MfnsError(f"{_where(path, where + '.' + key if where else key)} missing")
    return d[key]


def _number(v, what: str, lo: float = -math.inf, hi: float = math.inf, lo_open: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise MfnsError(f"{what} must be a number, got {json.dumps(v)[:40]}")
    x = float(v)
    if not math.isfinite(x):
        raise MfnsError(f"{what} must be finite, got {v}")
    if x < lo or x > hi or (lo_open and x == lo):
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        raise MfnsError(f"{what} = {v} out of range {rng}")
    return x


def _integer(v, what: str, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise MfnsError(f"{what} must be an integer, got {json.dumps(v)[:40]}")
    if not lo <= v <= hi:
        raise MfnsError(f"{what} = {v} out of range [{lo}, {hi}]")
    return v


def _read_limited(path: Path, limit: int) -> bytes:
    if not path.is_file():
        raise MfnsError(f"{path}: missing (not a calibration dataset?)")
    size = path.stat().st_size
    if size > limit:
        raise MfnsError(f"{path}: {size} bytes, more than the {limit} a calibration dataset allows")
    with open(path, "rb") as f:
        data = f.read(limit + 1)
    if len(data) > limit:
        raise MfnsError(f"{path}: more than {limit} bytes")
    return data


def parse_board(d, path: Path) -> Board:
    if not isinstance(d, dict):
        raise MfnsError(f"{path.name}: board must be an object")
    kind = d.get("type", "chessboard")
    if kind not in ("chessboard", "charuco"):
        raise MfnsError(f"{path.name}: board.type {kind!r}, expected 'chessboard' or 'charuco'")
    ic = _get(d, "inner_corners", path, "board")
    if not isinstance(ic, list) or len(ic) != 2:
        raise MfnsError(f"{path.name}: board.inner_corners must be [cols, rows]")
    cols = _integer(ic[0], f"{path.name}: board.inner_corners cols", 2, MAX_CORNERS_SIDE)
    rows = _integer(ic[1], f"{path.name}: board.inner_corners rows", 2, MAX_CORNERS_SIDE)
    square = _number(_get(d, "square_mm", path, "board"), f"{path.name}: board.square_mm", 0.0, 1e4, True)
    margin = _number(d.get("margin_mm", 20.0), f"{path.name}: board.margin_mm", 0.0, 1e4)
    if kind == "chessboard":
        return Board(cols, rows, square, margin)  # symmetric ones: see halfturn.py
    dic = _get(d, "dictionary", path, "board")
    if dic not in CHARUCO_DICTIONARIES:
        raise MfnsError(
            f"{path.name}: board.dictionary {dic!r}, expected one of {list(CHARUCO_DICTIONARIES)}"
        )
    marker = _number(_get(d, "marker_mm", path, "board"), f"{path.name}: board.marker_mm", 0.0, square, True)
    if marker >= square:
        raise MfnsError(f"{path.name}: board.marker_mm must be smaller than square_mm")
    board = Board(cols, rows, square, margin, "charuco", dic, marker)
    n_markers = ((cols + 1) * (rows + 1)) // 2
    size = board.charuco().getDictionary().bytesList.shape[0]
    if n_markers > size:
        raise MfnsError(f"{path.name}: {n_markers} markers needed, {dic} has {size}")
    return board


@dataclass
class DatasetMeta:
    board: Board
    cameras: tuple[str, ...]
    image_size: tuple[int, int]
    caliper_height_mm: float
    caliper_sigma_mm: float
    angle_sigma_rad: float


def read_meta(folder: Path) -> DatasetMeta:
    meta_path = folder / "dataset.json"
    raw = _read_limited(meta_path, MAX_JSON_BYTES)
    try:
        meta = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, RecursionError) as exc:
        raise MfnsError(f"{meta_path}: not UTF-8 JSON ({type(exc).__name__})") from exc
    except json.JSONDecodeError as exc:
        raise MfnsError(f"{meta_path}: not valid JSON ({exc.msg} at line {exc.lineno})") from exc
    if not isinstance(meta, dict):
        raise MfnsError(f"{meta_path}: must be a JSON object, got {type(meta).__name__}")
    if meta.get("format") != FORMAT:
        raise MfnsError(f"{meta_path}: format {str(meta.get('format'))[:40]!r}, expected {FORMAT!r}")
    v = meta.get("version")
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= VERSION:
        raise MfnsError(f"{meta_path}: unsupported version {str(v)[:20]!r} (this tool reads {VERSION})")
    n = meta_path.name
    board = parse_board(_get(meta, "board", meta_path, ""), meta_path)
    cams = meta.get("cameras", ["x", "y", "z"])
    if not isinstance(cams, list) or not 1 <= len(cams) <= MAX_CAMERAS:
        raise MfnsError(f"{n}: cameras must be a list of 1 to {MAX_CAMERAS} names")
    for c in cams:
        problem = camera_name_problem(c)
        if problem:
            raise MfnsError(f"{n}: {problem}")
    if len(set(cams)) != len(cams):
        raise MfnsError(f"{n}: duplicate camera names {cams}")
    size = _get(meta, "image_size", meta_path, "")
    if not isinstance(size, list) or len(size) != 2:
        raise MfnsError(f"{n}: image_size must be [width, height]")
    w = _integer(size[0], f"{n}: image_size width", 16, 65535)
    h = _integer(size[1], f"{n}: image_size height", 16, 65535)
    cal = _get(meta, "caliper", meta_path, "")
    height = _number(_get(cal, "height_mm", meta_path, "caliper"), f"{n}: caliper.height_mm", 0.0, 1e5, True)
    cal_sigma = _number(_get(cal, "sigma_mm", meta_path, "caliper"), f"{n}: caliper.sigma_mm", 0.0, 1e3, True)
    tt = _get(meta, "turntable", meta_path, "")
    ang = _number(
        _get(tt, "angle_sigma_arcsec", meta_path, "turntable"),
        f"{n}: turntable.angle_sigma_arcsec",
        0.0,
        3600.0,
        True,
    )
    return DatasetMeta(board, tuple(cams), (w, h), height, cal_sigma, ang * ARCSEC)


@dataclass
class Row:
    camera: int
    image: Path
    rel: str
    kind: str
    omega_big_deg: float
    omega_small_deg: float


def _angle(s: str, what: str, where: str) -> float:
    try:
        v = float(s)
    except ValueError as exc:
        raise MfnsError(f"{where}: bad {what} {s[:30]!r}") from exc
    if not math.isfinite(v) or abs(v) > 360.0:
        raise MfnsError(f"{where}: {what} {s[:30]!r} not a finite angle within +-360 deg")
    return v


def read_rows(folder: Path, meta: DatasetMeta) -> list[Row]:
    csv_path = folder / "angles.csv"
    raw = _read_limited(csv_path, MAX_CSV_BYTES)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise MfnsError(f"{csv_path}: not UTF-8 text") from exc
    if "\0" in text:
        raise MfnsError(f"{csv_path}: contains NUL bytes")
    rows = list(csv.DictReader(io.StringIO(text, newline="")))
    need = {"camera", "image", "kind", "Omega_deg", "omega_deg"}
    if not rows or not need <= set(rows[0]):
        raise MfnsError(f"{csv_path}: needs a header with columns {sorted(need)} and at least one row")
    if len(rows) > MAX_ROWS:
        raise MfnsError(f"{csv_path}: {len(rows)} rows, more than {MAX_ROWS}")
    out: list[Row] = []
    seen: set[tuple[str, str]] = set()
    for i, row in enumerate(rows, start=2):
        where = f"angles.csv line {i}"
        if any(row.get(k) is None for k in need):
            raise MfnsError(f"{where}: too few fields")
        cam, kind, rel = row["camera"], row["kind"], row["image"]
        if cam not in meta.cameras:
            raise MfnsError(
                f"{where}: camera {cam[:20]!r} is not in dataset.json's cameras {list(meta.cameras)}"
            )
        if kind not in KINDS:
            raise MfnsError(f"{where}: kind {kind[:20]!r}, expected one of {list(KINDS)}")
        path = folder / rel  # lexical check: image folders may be symlinks, but no '..' or '/'
        if not rel or Path(rel).is_absolute() or ".." in Path(rel).parts or "\\" in rel:
            raise MfnsError(
                f"{where}: image path {rel[:60]!r} must be relative and inside the dataset folder"
            )
        if not path.is_file():
            raise MfnsError(f"{where}: {rel[:60]} missing")
        if path.stat().st_size > MAX_IMAGE_BYTES:
            raise MfnsError(f"{where}: {rel[:60]} larger than {MAX_IMAGE_BYTES} bytes")
        stem = Path(rel).stem
        if (cam, stem) in seen:
            raise MfnsError(f"{where}: camera {cam} has two images named {stem!r}")
        seen.add((cam, stem))
        a = b = float("nan")
        if kind != "prepared":
            a = _angle(row["Omega_deg"], "Omega_deg", where)
            b = _angle(row["omega_deg"], "omega_deg", where)
        out.append(Row(meta.cameras.index(cam), path, rel, kind, a, b))
    return out


def _interleaved(rows: list[Row]) -> list[int]:
    """Row indices in round-robin order over the cameras, so every camera is checked early."""
    per: dict[int, list[int]] = {}
    for i, r in enumerate(rows):
        per.setdefault(r.camera, []).append(i)
    order: list[int] = []
    queues = list(per.values())
    while any(queues):
        for q in queues:
            if q:
                order.append(q.pop(0))
    return order


def detect_all(rows: list[Row], meta: DatasetMeta, workers: int | None = None, progress: bool = False):
    """Corner detection of every row -> list of (uv or None, reason) in row order."""
    workers = max(1, min(workers or os.cpu_count() or 1, len(rows)))
    order = _interleaved(rows)
    jobs = [(str(rows[i].image), meta.board, meta.image_size) for i in order]
    results: list[tuple[np.ndarray | None, str] | None] = [None] * len(rows)
    tried: dict[int, int] = {}
    found: dict[int, int] = {}
    beyond: dict[int, int] = {}

    def record(i: int, res) -> None:
        results[i] = res
        cam = rows[i].camera
        tried[cam] = tried.get(cam, 0) + 1
        found[cam] = found.get(cam, 0) + (res[0] is not None)
        if res[0] is not None and res[1].startswith(BEYOND):
            beyond[cam] = beyond.get(cam, 0) + 1
            if beyond[cam] >= min(BEYOND_IMAGES, sum(r.camera == cam for r in rows)):
                b = meta.board
                raise MfnsError(
                    f"board.inner_corners {b.cols} x {b.rows} is smaller than the printed board: "
                    f"{rows[i].rel} shows squares past the detected grid ({res[1][len(BEYOND) + 2 : -1]}); "
                    "count the inner corners (where four squares meet) along each side"
                )
        if tried[cam] == min(FAIL_FAST_IMAGES, sum(r.camera == cam for r in rows)) and found[cam] == 0:
            raise MfnsError(
                f"camera {meta.cameras[cam]}: none of its first {tried[cam]} images shows the board "
                f"({res[1]}); check dataset.json (board, image_size) against the images"
            )

    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(rows), desc="corners", unit="img")
    if workers == 1:
        for i, job in zip(order, jobs, strict=True):
            record(i, _detect_file(job))
            if bar:
                bar.update(1)
    else:
        import multiprocessing

        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as ex:
            try:
                for i, res in zip(order, ex.map(_detect_file, jobs), strict=True):
                    record(i, res)
                    if bar:
                        bar.update(1)
            except BaseException:
                ex.shutdown(wait=True, cancel_futures=True)
                raise
    if bar:
        bar.close()
    return results


def load_dataset(
    folder: str | Path, progress: bool = True, workers: int | None = None
) -> tuple[Observations, list[tuple[str, str, str]]]:
    """Detect corners in every image; returns the observations and the rejected images as
    (camera, image path, reason)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise MfnsError(f"{folder}: not a folder")
    meta = read_meta(folder)
    rows = read_rows(folder, meta)
    results = detect_all(rows, meta, workers, progress)
    images: list[ImageObs] = []
    rejected: list[tuple[str, str, str]] = []
    for row, res in zip(rows, results, strict=True):
        assert res is not None
        uv, why = res
        if uv is None:
            rejected.append((meta.cameras[row.camera], row.rel, why))
            continue
        kind = "prepared" if row.kind == "prepared" else "turntable"
        if row.kind == "pure-Omega":
            pure = "Omega"
        elif row.kind == "pure-omega":
            pure = "omega"
        else:
            pure = (
                pure_axis(row.omega_big_deg, row.omega_small_deg, meta.angle_sigma_rad)
                if kind == "turntable"
                else ""
            )
        images.append(
            ImageObs(row.camera, kind, Path(row.rel).stem, uv, row.omega_big_deg, row.omega_small_deg, pure)
        )
    obs = Observations(
        meta.board,
        images,
        meta.caliper_height_mm,
        meta.caliper_sigma_mm,
        meta.angle_sigma_rad,
        meta.image_size,
        meta.cameras,
    )
    check_views(obs, rejected)
    return obs, rejected


def check_views(obs: Observations, rejected: list[tuple[str, str, str]]) -> None:
    """Every camera needs >= 4 images with the board (Zhang) and >= 3 on the turntable."""
    for k, name in enumerate(obs.camera_names):
        ims = obs.of_camera(k)
        n_tt = sum(im.kind == "turntable" for im in ims)
        bad = [r for r in rejected if r[0] == name]
        if len(ims) < 4 or n_tt < 3:
            why = f"; {len(bad)} without the board, e.g. {bad[0][1]}: {bad[0][2]}" if bad else ""
            raise MfnsError(
                f"camera {name}: {len(ims)} images with the board ({n_tt} on the turntable), "
                f"need >= 4 (>= 3 on the turntable){why}"
            )
