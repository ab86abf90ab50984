"""`mfns sim calib OUT`: the CPC calibration experiment (docs/system.md §5) as a dataset folder.

A fixed checkerboard, the MFNS on a two-axis turntable (C_b'_b = Rx(omega) Rz(Omega), 8"
angle noise), truth from the paper's Tables 2-3 and the §5 set-up geometry. Turntable angles
are chosen automatically from a grid so that every camera sees the whole board; each camera
also gets "prepared beforehand" free poses for Zhang's method. Images are rendered by mapping
every pixel centre back through the exact distortion model onto the board, with an analytic
per-pixel area integral of the pattern (box filter), optional supersampling, optical blur,
vignetting, shot and read noise, 8-bit PNG. Format: docs/calib-dataset.md.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from ..analysis.calib_results import CAMERA_NAMES, MAX_CAMERAS, load
from ..analysis.calib_results import FORMAT as RESULTS_FORMAT
from ..analysis.calib_results import VERSION as RESULTS_VERSION
from ..calib.dataset import FORMAT as DATASET_FORMAT
from ..calib.model import (
    ARCSEC,
    CHARUCO_DICTIONARIES,
    Board,
    ImageObs,
    Observations,
    Rig,
    pure_axis,
    world_to_pixels,
)
from ..core.errors import MfnsError
from ..model.camera import Camera, rig_from_doc
from ..model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg, rz

DATASET_VERSION = 1
PAPER_CALIB = Path(__file__).resolve().parents[1] / "data" / "paper_calib.json"

# Set-up geometry (docs/system.md §5): turntable centre 684.7 mm and body origin 576.9 mm from the
# board (paper Table 3), r_tb_b = (0, 0, 107.8). The x, y of r_wt_w put the main axis Zt
# under the board so camera Z sees it centred (the paper's board origin is not given).
TRUE_C_T_W_DEG = (-0.0110, 0.1263, 0.0861)
TRUE_R_WT_W = (66.0949, 31.0719, -684.7134)
TRUE_R_TB_B = (0.0, 0.0, 684.7134 - 576.9100)
CALIPER_SIGMA_MM = 0.25
ANGLE_SIGMA_ARCSEC = 8.0


MIRRORED = {"xm": "x", "ym": "y"}  # extra cameras: x / y turned 180 deg about Zb (looking along -Xb / -Yb)


def default_truth(cameras=CAMERA_NAMES) -> Rig:
    """The paper's rig, or some of its cameras and mirrored copies ("xm", "ym") in the given order."""
    paper = {c.name: c for c in rig_from_doc(load(PAPER_CALIB))}
    cams = []
    for name in cameras:
        if name in paper:
            cams.append(paper[name])
        elif name in MIRRORED:
            src = paper[MIRRORED[name]]
            turn = rz(np.pi)
            cams.append(replace(src, name=name, C_k_b=turn @ src.C_k_b, r_bk_b=turn @ src.r_bk_b))
        else:
            raise MfnsError(f"--cameras: unknown camera {name!r} (built in: x, y, z, xm, ym)")
    return Rig(
        cams=cams,
        C_t_w=euler213_deg_to_matrix(TRUE_C_T_W_DEG),
        r_wt_w=np.array(TRUE_R_WT_W),
        r_tb_b=np.array(TRUE_R_TB_B),
    )


@dataclass
class Shot:
    """One image: camera index, kind, recorded angles (deg), true pose."""

    camera: int
    kind: str
    name: str
    omega_big_deg: float  # recorded (nominal) turntable angles; nan for prepared images
    omega_small_deg: float
    true_omega_big_deg: float
    true_omega_small_deg: float
    C_k_w: np.ndarray
    r_wk_w: np.ndarray


# --- choosing views ------------------------------------------------------------------------
def _pattern_points(board: Board) -> np.ndarray:
    """Inner corners plus the outer corners of the squares (the detector needs those too)."""
    s = board.square
    c, r = np.meshgrid(np.arange(-1, board.cols + 1), np.arange(-1, board.rows + 1))
    return np.column_stack([c.ravel() * s, r.ravel() * s, np.zeros(c.size)])


def inside_fraction(cam: Camera, C_k_w, r_wk_w, board: Board, margin_px: float = 25.0) -> float:
    """Fraction of the board's inner corners in the image with a margin."""
    uv, vis = world_to_pixels(cam, C_k_w, r_wk_w, board.object_points())
    m = margin_px
    ok = (
        vis
        & (uv[:, 0] >= m)
        & (uv[:, 1] >= m)
        & (uv[:, 0] <= cam.width - 1 - m)
        & (uv[:, 1] <= cam.height - 1 - m)
    )
    return float(np.mean(ok))


def view_ok(
    cam: Camera,
    C_k_w,
    r_wk_w,
    board: Board,
    margin_px: float = 25.0,
    max_tilt_deg=55.0,
    max_outside: float = 0.0,
) -> bool:
    """Camera in front of the board, not too oblique, and the whole pattern in the image with a
    margin, or (max_outside > 0, ChArUco) at most that fraction of the inner corners outside."""
    if r_wk_w[2] >= -50.0:
        return False
    axis = C_k_w[:, 2]
    if axis[2] < np.cos(np.deg2rad(max_tilt_deg)):
        return False
    if max_outside > 0.0:
        return inside_fraction(cam, C_k_w, r_wk_w, board, margin_px) >= 1.0 - max_outside
    uv, vis = world_to_pixels(cam, C_k_w, r_wk_w, _pattern_points(board))
    if not vis.all():
        return False
    return bool(
        uv[:, 0].min() >= margin_px
        and uv[:, 1].min() >= margin_px
        and uv[:, 0].max() <= cam.width - 1 - margin_px
        and uv[:, 1].max() <= cam.height - 1 - margin_px
    )


def _spread(points: np.ndarray, n: int, rng) -> list[int]:
    """Farthest-point sampling of n rows of `points` (deterministic given rng)."""
    if len(points) <= n:
        return list(range(len(points)))
    scale = np.maximum(points.max(axis=0) - points.min(axis=0), 1e-9)
    p = points / scale
    chosen = [int(rng.integers(len(p)))]
    d = np.linalg.norm(p - p[chosen[0]], axis=1)
    while len(chosen) < n:
        i = int(np.argmax(d))
        chosen.append(i)
        d = np.minimum(d, np.linalg.norm(p - p[i], axis=1))
    return chosen


def choose_turntable_angles(
    truth: Rig,
    board: Board,
    k: int,
    n: int,
    rng,
    step_deg: float = 2.5,
    pure_omega_views: bool = True,
    max_outside: float = 0.0,
    single_axis: bool = False,
):
    """Nominal (Omega, omega) in degrees for camera k, >= n views with the board in view.

    Camera Z gets pure-Omega views (omega = 0, Eqs. A14/A16), pure-omega views (Omega = 0,
    Eq. A10) and mixed ones; without `pure_omega_views` it gets pure-omega and mixed views only
    (the paper's chain cannot start). Other cameras get views spread over the feasible set.
    `single_axis`: every view on one line of the turntable (single_axis_line), so the
    camera's images turn about one axis only.
    """
    if single_axis:
        return single_axis_line(truth, board, k, n, rng, max_outside)
    cam = truth.cams[k]
    big = np.arange(-180.0, 180.0, step_deg)
    small = np.arange(-90.0, 90.0 + 1e-9, step_deg)
    feas_ab: list[tuple[float, float]] = []
    for a in big:
        for b in small:
            pose = truth.camera_pose(k, np.deg2rad(a), np.deg2rad(b))
            if view_ok(cam, *pose, board, max_outside=max_outside):
                feas_ab.append((a, b))
    feas = np.array(feas_ab).reshape(-1, 2)
    fine = np.arange(-90.0, 90.0 + 1e-9, 0.5)  # camera Z tolerates only a few degrees of tilt
    pure_small = np.array(
        [
            (0.0, b)
            for b in fine
            if b != 0.0
            and view_ok(cam, *truth.camera_pose(k, 0.0, np.deg2rad(b)), board, max_outside=max_outside)
        ]
    ).reshape(-1, 2)
    if cam.name != "z" or not pure_omega_views:
        if cam.name == "z":  # no pure-Omega views: the fine pure-omega line and mixed views
            feas = np.vstack([feas[np.abs(feas[:, 1]) > 1e-9], pure_small])
        if len(feas) < n:
            raise MfnsError(f"camera {cam.name}: only {len(feas)} turntable views see the board")
        return [tuple(feas[i]) for i in _spread(feas, n, rng)]
    pure_big = feas[np.abs(feas[:, 1]) < 1e-9]
    mixed = feas[(np.abs(feas[:, 0]) > 1e-9) & (np.abs(feas[:, 1]) > 1e-9)]
    n_big = max(4, (n * 5) // 12)
    n_small = max(3, n // 3)
    if len(pure_big) < n_big or len(pure_small) < n_small:
        raise MfnsError("camera z: too few pure-axis turntable views see the board")
    sel = [tuple(pure_big[i]) for i in _spread(pure_big, n_big, rng)]
    sel += [tuple(pure_small[i]) for i in _spread(pure_small, n_small, rng)]
    n_mixed = n - len(sel)
    if n_mixed > 0:
        sel += [tuple(mixed[i]) for i in _spread(mixed, n_mixed, rng)]
    return sel


def single_axis_line(truth: Rig, board: Board, k: int, n: int, rng, max_outside: float = 0.0):
    """n views of camera k on one line of the turntable: a fixed Omega with omega turning (turns
    about the auxiliary axis) or a fixed omega with Omega turning (about the main axis),
    whichever line spans the widest turn (ties: the main axis). Images that turn about one axis
    only: the camera's own hand-eye problem cannot fix its mount, the shared turntable can."""
    cam = truth.cams[k]
    fine = 0.5

    def ok(a, b):
        return view_ok(
            cam, *truth.camera_pose(k, np.deg2rad(a), np.deg2rad(b)), board, max_outside=max_outside
        )

    best: tuple[float, list] = (0.0, [])
    for fixed in np.arange(-90.0, 90.0 + 1e-9, 2.5):  # omega fixed, Omega turning
        line = [(a, fixed) for a in np.arange(-180.0, 180.0, fine) if ok(a, fixed)]
        span = line[-1][0] - line[0][0] if line else 0.0
        if span > best[0] + 1e-9:
            best = (span, line)
    for fixed in np.arange(-180.0, 180.0, 2.5):  # Omega fixed, omega turning
        line = [(fixed, b) for b in np.arange(-90.0, 90.0 + 1e-9, fine) if ok(fixed, b)]
        span = line[-1][1] - line[0][1] if line else 0.0
        if span > best[0] + 1e-9:
            best = (span, line)
    views = np.array(best[1]).reshape(-1, 2)
    if len(views) < n:
        raise MfnsError(f"camera {cam.name}: only {len(views)} single-axis turntable views see the board")
    return [tuple(views[i]) for i in _spread(views, n, rng)]


def _look_at(center_w, target_w, roll) -> np.ndarray:
    z = target_w - center_w
    z = z / np.linalg.norm(z)
    x = np.array([1.0, 0.0, 0.0]) - z[0] * z
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    c, s = np.cos(roll), np.sin(roll)
    x, y = c * x + s * y, -s * x + c * y
    return np.column_stack([x, y, z])  # C_k_w: columns are the camera axes in the world


def prepared_pose(cam: Camera, board: Board, rng, tries: int = 2000, max_outside: float = 0.0):
    """A random 'prepared beforehand' pose: tilted 10-45 deg, whole board in view (or, with
    max_outside, up to that fraction of it outside); 380-700 mm for the default board's size,
    scaled with the board's extent."""
    centre = np.array([(board.cols - 1) * board.square / 2, (board.rows - 1) * board.square / 2, 0.0])
    scale = max(1.0, max(board.cols + 1, 1.4 * (board.rows + 1)) * board.square / 250.0)
    shift = 0.5 * max_outside * np.array([board.cols, board.rows]) * board.square
    for _ in range(tries):
        tilt = np.deg2rad(rng.uniform(10.0, 45.0))
        az = rng.uniform(0, 2 * np.pi)
        d = rng.uniform(380.0, 700.0) * scale
        back = np.array([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), -np.cos(tilt)])
        off = np.array(
            [rng.uniform(-40 - shift[0], 40 + shift[0]), rng.uniform(-30 - shift[1], 30 + shift[1]), 0.0]
        )
        target = centre + off
        c = target + d * back
        C = _look_at(c, target, rng.uniform(-np.pi / 6, np.pi / 6))
        if view_ok(cam, C, c, board, max_outside=max_outside):
            return C, c
    raise MfnsError(f"camera {cam.name}: no prepared pose found")


def make_plan(
    truth: Rig,
    board: Board,
    rng,
    n_turntable: int = 12,
    n_prepared: int = 10,
    angle_sigma_arcsec: float = ANGLE_SIGMA_ARCSEC,
    *,
    angle_log: str = "commanded",
    pure_omega_views: bool = True,
    max_outside: float = 0.0,
    single_axis: tuple[str, ...] = (),
) -> list[Shot]:
    """The shots of a dataset. angle_log "commanded": the log holds the commanded angles and
    the true ones are off by N(0, sigma); "encoder": the true angles are commanded + N(0, sigma)
    and the log holds them with the encoder's N(0, sigma) noise (pure-axis images then log e.g.
    omega = 0.0021 deg instead of 0). The cameras named in `single_axis` get turntable views
    about one axis only (single_axis_line)."""
    if angle_log not in ("commanded", "encoder"):
        raise MfnsError(f"angle log {angle_log!r}: expected commanded or encoder")
    shots: list[Shot] = []
    for k in range(len(truth.cams)):
        views = choose_turntable_angles(
            truth,
            board,
            k,
            n_turntable,
            rng,
            pure_omega_views=pure_omega_views,
            max_outside=max_outside,
            single_axis=truth.cams[k].name in single_axis,
        )
        for i, (a, b) in enumerate(views):
            ta = a + rng.normal(0.0, angle_sigma_arcsec) / 3600.0
            tb = b + rng.normal(0.0, angle_sigma_arcsec) / 3600.0
            if angle_log == "encoder":
                a = ta + rng.normal(0.0, angle_sigma_arcsec) / 3600.0
                b = tb + rng.normal(0.0, angle_sigma_arcsec) / 3600.0
            C, r = truth.camera_pose(k, np.deg2rad(ta), np.deg2rad(tb))
            shots.append(Shot(k, "turntable", f"tt_{i:02d}", a, b, ta, tb, C, r))
        for i in range(n_prepared):
            C, r = prepared_pose(truth.cams[k], board, rng, max_outside=max_outside)
            shots.append(Shot(k, "prepared", f"prep_{i:02d}", np.nan, np.nan, np.nan, np.nan, C, r))
    return shots


def corner_observations(
    truth: Rig,
    board: Board,
    shots: list[Shot],
    rng,
    sigma_px: float,
    caliper_height_mm: float | None = None,
    caliper_sigma_mm: float = CALIPER_SIGMA_MM,
    angle_sigma_arcsec: float = ANGLE_SIGMA_ARCSEC,
) -> Observations:
    """Corner observations simulated directly (no images): truth projection + N(0, sigma_px)."""
    obj = board.object_points()
    images = []
    sigma_rad = angle_sigma_arcsec * ARCSEC
    for s in shots:
        cam = truth.cams[s.camera]
        uv, vis = world_to_pixels(cam, s.C_k_w, s.r_wk_w, obj)
        uv = uv + rng.normal(0.0, sigma_px, uv.shape)
        if board.kind == "charuco":  # partial views: corners outside the image are not seen
            uv[~vis] = np.nan
        pure = pure_axis(s.omega_big_deg, s.omega_small_deg, sigma_rad) if s.kind == "turntable" else ""
        images.append(ImageObs(s.camera, s.kind, s.name, uv, s.omega_big_deg, s.omega_small_deg, pure))
    if caliper_height_mm is None:
        caliper_height_mm = -truth.r_wb_w[2] + rng.normal(0.0, caliper_sigma_mm)
    return Observations(
        board,
        images,
        float(caliper_height_mm),
        caliper_sigma_mm,
        sigma_rad,
        (truth.cams[0].width, truth.cams[0].height),
        tuple(c.name for c in truth.cams),
    )


# --- rendering -------------------------------------------------------------------------------
def _wave(s: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Square wave sign(sin(pi s)) box-filtered over width w (units of squares), w << 1."""
    n = np.round(s)
    parity = 1.0 - 2.0 * np.mod(n, 2.0)
    return np.clip(2.0 * (s - n) / w, -1.0, 1.0) * parity


def _inside(s, lo, hi, w):
    return np.clip((s - lo) / w + 0.5, 0.0, 1.0) * np.clip((hi - s) / w + 0.5, 0.0, 1.0)


MARKER_TEXELS_PER_MM = 8.0


def marker_texture(board: Board) -> np.ndarray:
    """ChArUco markers only (1 = black marker cell, 0 = elsewhere), MARKER_TEXELS_PER_MM texels
    per mm over the squares; the chessboard itself is rendered analytically."""
    sq = int(round(board.square * MARKER_TEXELS_PER_MM))
    w, h = (board.cols + 1) * sq, (board.rows + 1) * sq
    img = board.charuco().generateImage((w, h), marginSize=0, borderBits=1).astype(np.float32) / 255.0
    dark = 1.0 - img
    for j in range(board.rows + 1):  # clear the black squares: only the markers stay
        for i in range(board.cols + 1):
            if (i + j) % 2 == 0:
                dark[j * sq : (j + 1) * sq, i * sq : (i + 1) * sq] = 0.0
    return dark


class Renderer:
    """Renders one camera's board images; the per-pixel rays are computed once."""

    def __init__(
        self,
        cam: Camera,
        board: Board,
        supersample: int = 1,
        blur_px: float = 0.7,
        read_noise_dn: float = 1.2,
        full_well_dn: float = 255.0 * 40.0,
    ):
        self.cam, self.board, self.ss = cam, board, supersample
        self.blur, self.read_noise, self.gain = blur_px, read_noise_dn, full_well_dn / 255.0
        offs = (np.arange(supersample) + 0.5) / supersample - 0.5
        v, u = np.mgrid[0 : cam.height, 0 : cam.width].astype(float)
        self.rays = []
        for dv in offs:
            for du in offs:
                xy = cam.undistort_pixels(np.stack([u + du, v + dv], axis=-1))
                x, y = xy[..., 0], xy[..., 1]
                self.rays.append((x, y))
        rr = ((u - cam.cx) ** 2 + (v - cam.cy) ** 2) / (cam.fx**2)
        self.vignette = 1.0 / (1.0 + rr) ** 2  # cos^4 of the field angle
        self.markers = marker_texture(board) if board.kind == "charuco" else None

    def _sample(self, C_k_w, r_wk_w, x, y, spacing):
        """Board intensity (0..1, linear) seen along rays (x, y, 1) from the pose."""
        b = self.board
        d = C_k_w[:, 0, None, None] * x + C_k_w[:, 1, None, None] * y + C_k_w[:, 2, None, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -r_wk_w[2] / d[2]
        hit = t > 0
        t = np.where(hit, t, 0.0)
        sx = (r_wk_w[0] + t * d[0]) / b.square
        sy = (r_wk_w[1] + t * d[1]) / b.square
        gx = np.gradient(sx)
        gy = np.gradient(sy)
        wx = np.maximum((np.abs(gx[0]) + np.abs(gx[1])) * spacing, 1e-6)
        wy = np.maximum((np.abs(gy[0]) + np.abs(gy[1])) * spacing, 1e-6)
        # the pattern's outline is filtered by `pat`; clamping keeps the square wave from also
        # ramping there (that would draw a grey line around the pattern)
        cx = np.clip(sx, -0.5, b.cols - 0.5)
        cy = np.clip(sy, -0.5, b.rows - 0.5)
        checker = _wave(cx, wx) * _wave(cy, wy)
        pat = _inside(sx, -1.0, b.cols, wx) * _inside(sy, -1.0, b.rows, wy)
        m = b.margin / b.square
        brd = _inside(sx, -1.0 - m, b.cols + m, wx) * _inside(sy, -1.0 - m, b.rows + m, wy) * hit
        black, white, bg = 0.07, 0.82, 0.30
        board_val = white - (white - black) * pat * 0.5 * (1.0 + checker)  # checker +1: black square
        if self.markers is not None:  # ArUco markers inside the white squares (bilinear texture)
            tex = (np.stack([sx, sy], axis=-1) + 1.0) * (b.square * MARKER_TEXELS_PER_MM) - 0.5
            tex = tex.astype(np.float32)
            m = cv2.remap(self.markers, tex[..., 0], tex[..., 1], cv2.INTER_LINEAR, borderValue=0.0)
            board_val = board_val + (black - board_val) * m * hit
        return brd * board_val + (1.0 - brd) * bg

    def render(self, C_k_w, r_wk_w, rng, exposure: float = 1.0) -> np.ndarray:
        acc = np.zeros((self.cam.height, self.cam.width))
        for x, y in self.rays:
            acc += self._sample(C_k_w, r_wk_w, x, y, 1.0 / self.ss)
        img = acc / len(self.rays) * self.vignette * exposure * 255.0
        if self.blur > 0:
            img = cv2.GaussianBlur(img, (0, 0), self.blur)
        electrons = np.maximum(img, 0.0) * self.gain
        img = rng.normal(electrons, np.sqrt(electrons + 1e-9)) / self.gain
        img = img + rng.normal(0.0, self.read_noise, img.shape)
        return np.clip(np.round(img), 0, 255).astype(np.uint8)


# --- writing the dataset ---------------------------------------------------------------------
def truth_document(truth: Rig, shots: list[Shot], caliper_true: float, seed: int) -> dict:
    c_t_w = np.asarray(truth.C_t_w)
    return {
        "format": RESULTS_FORMAT,
        "version": RESULTS_VERSION,
        "source": f"mfns sim calib truth (seed {seed})",
        "pixel_noise_px": 0.1,
        "cameras": [c.to_entry() for c in truth.cams],
        "rig": {
            "C_t_w": c_t_w.tolist(),
            "euler_t_w_deg": matrix_to_euler213_deg(c_t_w).tolist(),
            "r_wt_w": np.asarray(truth.r_wt_w).tolist(),
            "r_wb_w": truth.r_wb_w.tolist(),
            "r_tb_b": np.asarray(truth.r_tb_b).tolist(),
        },
        "truth": {
            "caliper_height_true_mm": caliper_true,
            "images": [
                {
                    "camera": truth.cams[s.camera].name,
                    "name": s.name,
                    "kind": s.kind,
                    "Omega_deg": s.true_omega_big_deg if s.kind == "turntable" else None,
                    "omega_deg": s.true_omega_small_deg if s.kind == "turntable" else None,
                    "C_k_w": s.C_k_w.tolist(),
                    "r_wk_w": s.r_wk_w.tolist(),
                }
                for s in shots
            ],
        },
    }


def truth_from_document(doc: dict) -> Rig:
    rig = doc.get("rig")
    if rig is None:
        raise MfnsError("truth file has no 'rig' section")
    return Rig(
        [Camera.from_entry(e) for e in doc["cameras"]],
        np.asarray(rig["C_t_w"], float),
        np.asarray(rig["r_wt_w"], float),
        np.asarray(rig["r_tb_b"], float),
    )


def write_dataset(
    out: Path,
    truth: Rig,
    board: Board,
    shots: list[Shot],
    rng,
    *,
    seed: int,
    supersample: int,
    caliper_measured: float,
    angle_sigma_arcsec: float,
    progress: bool = True,
    read_noise_dn: float = 1.2,
    blur_px: float = 0.7,
) -> None:
    out.mkdir(parents=True, exist_ok=True)
    names = [c.name for c in truth.cams]
    for name in names:
        (out / "images" / name).mkdir(parents=True, exist_ok=True)
    bar = tqdm(total=len(shots), desc="rendering", unit="img", disable=not progress)
    for k in range(len(names)):
        renderer = Renderer(
            truth.cams[k], board, supersample=supersample, blur_px=blur_px, read_noise_dn=read_noise_dn
        )
        for s in (s for s in shots if s.camera == k):
            img = renderer.render(s.C_k_w, s.r_wk_w, rng, exposure=rng.uniform(0.9, 1.1))
            cv2.imwrite(str(out / "images" / names[k] / f"{s.name}.png"), img)
            bar.update(1)
    bar.close()
    with open(out / "angles.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["camera", "image", "kind", "Omega_deg", "omega_deg"])
        for s in shots:
            tt = s.kind == "turntable"
            w.writerow(
                [
                    names[s.camera],
                    f"images/{names[s.camera]}/{s.name}.png",
                    s.kind,
                    f"{s.omega_big_deg:.6f}" if tt else "",
                    f"{s.omega_small_deg:.6f}" if tt else "",
                ]
            )
    meta = {
        "format": DATASET_FORMAT,
        "version": DATASET_VERSION,
        "source": f"mfns sim calib (seed {seed})",
        "image_size": [truth.cams[0].width, truth.cams[0].height],
        "cameras": names,
        "board": board.to_dict(),
        "turntable": {
            "convention": "C_b'_b = Rx(omega) Rz(Omega); Omega about the inner main axis Zt, "
            "omega about the auxiliary axis Xt; angles in angles.csv are the recorded ones",
            "angle_sigma_arcsec": angle_sigma_arcsec,
        },
        "caliper": {
            "height_mm": caliper_measured,
            "sigma_mm": CALIPER_SIGMA_MM,
            "meaning": "board plane to body origin along Zw at zero turntable angles, = -r_wb_w[2]",
        },
        "body_origin_on_main_axis": True,
    }
    (out / "dataset.json").write_text(json.dumps(meta, indent=2) + "\n")
    caliper_true = float(-truth.r_wb_w[2])
    (out / "truth.json").write_text(
        json.dumps(truth_document(truth, shots, caliper_true, seed), indent=1) + "\n"
    )


def run(args) -> int:
    out = Path(args.out)
    if out.exists() and any(out.iterdir()) and not args.force:
        raise MfnsError(f"{out}: exists and is not empty (use --force)")
    rng = np.random.default_rng(args.seed)
    names = tuple(n.strip() for n in args.cameras.split(",")) if args.cameras else None
    if names is not None and not 1 <= len(names) <= MAX_CAMERAS:
        raise MfnsError(f"--cameras: 1 to {MAX_CAMERAS} names")
    if args.truth is None:
        truth = default_truth(names or CAMERA_NAMES)
    else:
        truth = truth_from_document(load(args.truth, flight=False))
        if names is not None:
            by_name = {c.name: c for c in truth.cams}
            missing = [n for n in names if n not in by_name]
            if missing:
                raise MfnsError(f"--cameras: {missing} not in {args.truth}")
            truth = replace(truth, cams=[by_name[n] for n in names])
    if not (3 <= args.cols <= 40 and 3 <= args.rows <= 40 and 1.0 <= args.square <= 500.0):
        raise MfnsError("--cols and --rows must be 3 to 40, --square 1 to 500 mm")
    if args.board == "charuco":
        if not 0.0 < args.marker < args.square:
            raise MfnsError("--marker must be between 0 and --square")
        board = Board(
            args.cols, args.rows, args.square, kind="charuco", dictionary=args.dictionary, marker=args.marker
        )
    else:
        board = Board(args.cols, args.rows, args.square)
    if not 0.0 <= args.max_outside <= 0.6 or (args.max_outside > 0 and args.board != "charuco"):
        raise MfnsError("--max-outside must be 0 to 0.6, and > 0 only with --board charuco")
    n_tt, n_prep, ss = args.turntable_views, args.prepared_views, args.supersample
    if args.small:
        n_tt, n_prep, ss = 10, 4, 1
    if not (args.noise >= 0 and args.blur >= 0 and args.angle_noise >= 0 and args.supersample >= 1):
        raise MfnsError("--noise, --blur and --angle-noise must be >= 0, --supersample >= 1")
    if n_tt < 10:
        raise MfnsError("--turntable-views must be >= 10")
    single = tuple(n.strip() for n in args.single_axis.split(",") if n.strip())
    unknown = [n for n in single if n not in [c.name for c in truth.cams]]
    if unknown:
        raise MfnsError(f"--single-axis: {unknown} not among the cameras {[c.name for c in truth.cams]}")
    shots = make_plan(
        truth,
        board,
        rng,
        n_tt,
        n_prep,
        args.angle_noise,
        angle_log=args.angle_log,
        pure_omega_views=not args.no_pure_omega,
        max_outside=args.max_outside,
        single_axis=single,
    )
    caliper = float(-truth.r_wb_w[2] + rng.normal(0.0, CALIPER_SIGMA_MM))
    write_dataset(
        out,
        truth,
        board,
        shots,
        rng,
        seed=args.seed,
        supersample=ss,
        caliper_measured=caliper,
        angle_sigma_arcsec=args.angle_noise,
        progress=not args.quiet,
        read_noise_dn=args.noise,
        blur_px=args.blur,
    )
    if not args.quiet:
        print(f"wrote {len(shots)} images, angles.csv, dataset.json and truth.json to {out}")
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calib",
        help="simulate the turntable calibration experiment (images, angles, truth)",
        description="Render the CPC calibration experiment (docs/system.md §5) into a dataset folder "
        "(docs/calib-dataset.md) with truth.json inside it.",
    )
    p.add_argument("out", metavar="OUT", help="dataset folder to create")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument(
        "--truth",
        help="calibration-results JSON with a 'rig' section to use as truth "
        "(default: the paper's Tables 2-3 and the §5 set-up)",
    )
    p.add_argument("--turntable-views", type=int, default=12, help="turntable images per camera (>= 10)")
    p.add_argument("--prepared-views", type=int, default=10, help="prepared-beforehand images per camera")
    p.add_argument("--cols", type=int, default=9, help="inner corners along the board's x (default 9)")
    p.add_argument("--rows", type=int, default=6, help="inner corners along the board's y (default 6)")
    p.add_argument("--square", type=float, default=25.0, help="square size in mm (default 25)")
    p.add_argument(
        "--angle-noise",
        type=float,
        default=ANGLE_SIGMA_ARCSEC,
        help="turntable angle noise, 1 sigma, arc-seconds (default 8)",
    )
    p.add_argument("--noise", type=float, default=1.2, help="image read noise, 1 sigma, DN (default 1.2)")
    p.add_argument("--blur", type=float, default=0.7, help="optical blur, Gaussian sigma, px (default 0.7)")
    p.add_argument(
        "--supersample",
        type=int,
        default=1,
        help="sub-samples per pixel side on top of the analytic area integral (default 1)",
    )
    p.add_argument(
        "--cameras",
        help="comma-separated camera names, 1-8 (default x,y,z; built in: x, y, z and the mirrored xm, ym; "
        "with --truth: names from that file)",
    )
    p.add_argument(
        "--angle-log",
        choices=("commanded", "encoder"),
        default="commanded",
        help="what angles.csv records: the commanded angles (default) or encoder readings with the "
        "turntable's noise (pure-axis images then log small non-zero angles)",
    )
    p.add_argument(
        "--no-pure-Omega",
        dest="no_pure_omega",
        action="store_true",
        help="camera z gets no pure-Omega (omega = 0) views: the paper's CPC cannot run",
    )
    p.add_argument(
        "--single-axis",
        default="",
        metavar="CAMS",
        help="comma-separated cameras whose turntable images turn about one axis only (one line of "
        "the turntable: a fixed Omega or a fixed omega); the others fix the turntable",
    )
    p.add_argument("--board", choices=("chessboard", "charuco"), default="chessboard", help="board type")
    p.add_argument(
        "--dictionary", choices=CHARUCO_DICTIONARIES, default="DICT_5X5_250", help="ChArUco marker dictionary"
    )
    p.add_argument("--marker", type=float, default=18.0, help="ChArUco marker side, mm (default 18)")
    p.add_argument(
        "--max-outside",
        type=float,
        default=0.0,
        help="ChArUco: views may have up to this fraction of the inner corners outside the image (0-0.6)",
    )
    p.add_argument("--small", action="store_true", help="10 turntable + 4 prepared views per camera")
    p.add_argument("--force", action="store_true", help="write into a non-empty OUT")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(func=run)
