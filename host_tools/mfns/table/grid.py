"""The distortion-correction grid: build it, evaluate it exactly as the flight code does
(math/undistort.c, integer arithmetic), and measure its worst-case error.

Nodes hold the undistorted (ideal pinhole) pixel position u' = fx x + skew y + cx,
v' = fy y + cy of pixel (origin + i*step) in Q16.16 pixels; inputs are px_q8 (1/256 px).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Camera
from ..errors import MfnsError
from .format import MAX_GRID_NODES, CameraRecord, Grid

DEFAULT_GRID = (93, 75)  # 14 px spacing on 1280 x 1024 (docs/distortion-grid.md)
ORIGIN_Q8 = -128  # pixel -0.5: the image corner under the pixel-centre convention
MIN_STEP_Q8, MAX_STEP_Q8 = 256, 65535


def record_camera(rec: CameraRecord) -> Camera:
    """The numpy camera of a table record (its binary32 values, in double)."""
    return Camera(
        name="xyz"[rec.camera_id],
        fx=float(rec.fx),
        fy=float(rec.fy),
        cx=float(rec.cx),
        cy=float(rec.cy),
        skew=float(rec.skew),
        dist=np.asarray(rec.dist, dtype=float),
        width=rec.width,
        height=rec.height,
        C_k_b=np.asarray(rec.C_k_b, dtype=float),
        r_bk_b=np.asarray(rec.r_bk_b, dtype=float),
    )


def ideal_pixels(cam: Camera, uv: np.ndarray) -> np.ndarray:
    """Exact (double Newton) undistorted pixel positions of pixels uv (N, 2); raises when
    the lens model has no inverse there."""
    xy = cam.undistort_pixels(uv)
    back = cam.distorted_to_pixel(cam.distort(xy))
    if not np.all(np.isfinite(back)) or np.max(np.abs(back - uv)) > 1e-6:
        raise MfnsError(f"camera {cam.name}: the distortion model has no inverse over the grid")
    return np.stack([cam.fx * xy[:, 0] + cam.skew * xy[:, 1] + cam.cx, cam.fy * xy[:, 1] + cam.cy], axis=-1)


def step_q8(size_px: int, n: int) -> int:
    """Node spacing (1/256 px) so that n nodes from the corner span the whole image."""
    if n < 2:
        raise MfnsError("a grid needs at least 2 nodes per axis")
    s = -(-size_px * 256 // (n - 1))
    if not MIN_STEP_Q8 <= s <= MAX_STEP_Q8:
        raise MfnsError(f"{n} nodes over {size_px} px give a spacing of {s / 256:.2f} px, outside 1..255 px")
    return s


def build_grid(cam: Camera, nx: int, ny: int, max_nodes: int = MAX_GRID_NODES) -> Grid:
    """max_nodes: the flight limit; lifted only by studies of grids beyond it."""
    if nx * ny > max_nodes:
        raise MfnsError(
            f"grid {nx}x{ny} has {nx * ny} nodes, more than MFNS_MAX_GRID_NODES ({MAX_GRID_NODES})"
        )
    su, sv = step_q8(cam.width, nx), step_q8(cam.height, ny)
    gu = (ORIGIN_Q8 + su * np.arange(nx)) / 256.0
    gv = (ORIGIN_Q8 + sv * np.arange(ny)) / 256.0
    uu, vv = np.meshgrid(gu, gv)
    ideal = ideal_pixels(cam, np.column_stack([uu.ravel(), vv.ravel()]))
    if np.max(np.abs(ideal)) >= 32767:
        raise MfnsError(f"camera {cam.name}: undistorted positions beyond the Q16.16 range")
    nodes = np.round(ideal * 65536.0).astype(np.int64).reshape(ny, nx, 2).astype(np.int32)
    return Grid(ORIGIN_Q8, ORIGIN_Q8, su, sv, nodes)


def _round_shift16(v: np.ndarray) -> np.ndarray:
    """Round-to-nearest (ties away from zero) of v / 2^16, as mfns_q16_lerp."""
    a = np.abs(v)
    return np.sign(v) * ((a + (1 << 15)) >> 16)


def _lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    return a + _round_shift16((b - a) * t)


def _axis(p: np.ndarray, origin: int, step: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    d = p - origin
    inside = (d >= 0) & (d <= (n - 1) * step)
    dc = np.clip(d, 0, (n - 1) * step)
    i = np.minimum(dc // step, n - 2)
    t = dc - i * step
    w = ((t << 16) + step // 2) // step
    return i, w, inside


def eval_grid(g: Grid, u_q8: np.ndarray, v_q8: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Integer emulation of mfns_undistort_grid_px: (undistorted Q16.16 (N, 2), inside mask)."""
    u_q8 = np.asarray(u_q8, dtype=np.int64)
    v_q8 = np.asarray(v_q8, dtype=np.int64)
    i, wx, in_u = _axis(u_q8, g.origin_u_q8, g.step_u_q8, g.nx)
    j, wy, in_v = _axis(v_q8, g.origin_v_q8, g.step_v_q8, g.ny)
    n = g.nodes.astype(np.int64)
    out = np.empty((len(u_q8), 2), dtype=np.int64)
    for c in range(2):
        top = _lerp(n[j, i, c], n[j, i + 1, c], wx)
        bot = _lerp(n[j + 1, i, c], n[j + 1, i + 1, c], wx)
        out[:, c] = _lerp(top, bot, wy)
    return out, in_u & in_v


@dataclass
class GridError:
    max_px: float  # worst Euclidean error over the samples
    rms_px: float
    worst_uv: tuple[float, float]
    samples: int


def grid_error(cam: Camera, g: Grid, sample_px: float = 1.75) -> GridError:
    """Worst-case error of the grid over the whole image [-0.5, W-0.5) x [-0.5, H-0.5),
    sampled every sample_px (incommensurate with the node spacing, so samples fall at
    every phase inside the cells), against the exact inverse of the same pixel."""
    u = np.arange(-0.5, cam.width - 0.5, sample_px)
    v = np.arange(-0.5, cam.height - 0.5, sample_px)
    uu, vv = np.meshgrid(np.append(u, cam.width - 0.5 - 1 / 256), np.append(v, cam.height - 0.5 - 1 / 256))
    u_q8 = np.round(uu.ravel() * 256).astype(np.int64)
    v_q8 = np.round(vv.ravel() * 256).astype(np.int64)
    val, inside = eval_grid(g, u_q8, v_q8)
    if not np.all(inside):
        raise MfnsError(f"camera {cam.name}: the grid does not cover the image")
    exact = ideal_pixels(cam, np.column_stack([u_q8, v_q8]) / 256.0)
    err = np.hypot(*(val / 65536.0 - exact).T)
    k = int(np.argmax(err))
    return GridError(
        float(err[k]), float(np.sqrt(np.mean(err**2))), (u_q8[k] / 256.0, v_q8[k] / 256.0), int(err.size)
    )
