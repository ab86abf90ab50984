"""The distortion-correction grid: build it with the C builder (mfns_undist_grid_build),
measure its worst-case error with the flight code's own interpolation
(mfns_undistort_grid_px through the C core), and size it for the lens at hand.

Nodes hold the undistorted (ideal pinhole) pixel position u' = fx x + skew y + cx,
v' = fy y + cy of pixel (origin + i*step) in Q16.16 pixels; inputs are px_q8 (1/256 px).
"""

from __future__ import annotations

import ctypes as ct
from dataclasses import dataclass

import numpy as np

from ..analysis.calib_results import CAMERA_NAMES
from ..core.binding import PX_Q8_ONE as Q8
from ..core.binding import Q16_16_ONE as Q16
from ..core.binding import UNDIST_BAD_INPUT, UndistGrid
from ..core.binding import UNDIST_GRID_ORIGIN_Q8 as ORIGIN_Q8
from ..core.errors import MfnsError
from ..core.flight import Flight
from ..model.camera import Camera
from .format import CameraRecord, Grid
from .generated import layout_gen

MAX_GRID_ERROR_PX = 0.01  # worst-case correction error a table may carry (docs/distortion-grid.md)
MAX_STEP_PX = layout_gen.CONSTANTS["MFNS_UNDIST_GRID_MAX_STEP_Q8"] / Q8  # the loader's widest node spacing
U16_MAX = 0xFFFF  # the builder's node counts and image sizes are uint16


def record_camera(rec: CameraRecord) -> Camera:
    """The numpy camera of a table record (its binary32 values, in double)."""
    return Camera(
        name=CAMERA_NAMES[rec.camera_id],
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
    """Node spacing (1/256 px) so that n nodes from the corner span the whole image: the C
    builder's own (mfns_undist_grid_step), or MfnsError when it refuses the spacing."""
    from .check import core

    if n < 2:
        raise MfnsError("a grid needs at least 2 nodes per axis")
    if not (0 <= size_px <= U16_MAX and n <= U16_MAX):
        raise MfnsError(f"{n} nodes over {size_px} px: beyond the builder's 16-bit range")
    s = ct.c_int32()
    if not core().lib.mfns_undist_grid_step(size_px, n, ct.byref(s)):
        raise MfnsError(
            f"{n} nodes over {size_px} px give a spacing of {size_px / (n - 1):.2f} px, "
            f"outside 1..{int(MAX_STEP_PX)} px"
        )
    return s.value


def build_grid(cam: Camera, nx: int, ny: int, max_nodes: int | None = None) -> Grid:
    """The grid of nx x ny nodes over cam's whole image, built by the C builder
    (math/undistort.h mfns_undist_grid_build, through the binding): the nodes that fly are
    the C core's. max_nodes: the flight limit (MFNS_MAX_GRID_NODES of the C core when
    None); lifted only by studies of grids beyond it."""
    from .check import core

    if max_nodes is None:
        max_nodes = core().max_grid_nodes
    if nx * ny > max_nodes:
        raise MfnsError(f"grid {nx}x{ny} has {nx * ny} nodes, more than MFNS_MAX_GRID_NODES ({max_nodes})")
    step_q8(cam.width, nx), step_q8(cam.height, ny)  # the spacing's own message when out of range
    lib = core().lib
    k = Flight.intrinsics(cam)
    nodes = np.zeros((ny, nx, 2), dtype=np.int32)
    g = UndistGrid()
    st = lib.mfns_undist_grid_build(ct.byref(k), nx, ny, nodes.ctypes.data, nx * ny, ct.byref(g))
    if st == UNDIST_BAD_INPUT:  # dims and steps were checked above: a node beyond Q16.16
        raise MfnsError(f"camera {cam.name}: undistorted positions beyond the Q16.16 range")
    if st != 0:
        raise MfnsError(
            f"camera {cam.name}: the distortion model has no inverse over the grid "
            f"({lib.mfns_undist_strerror(st).decode()})"
        )
    assert (g.origin_u_q8, g.origin_v_q8) == (ORIGIN_Q8, ORIGIN_Q8)
    return Grid(g.origin_u_q8, g.origin_v_q8, g.step_u_q8, g.step_v_q8, nodes)


@dataclass
class GridError:
    max_px: float  # worst Euclidean error over the samples
    rms_px: float
    worst_uv: tuple[float, float]
    samples: int


@dataclass
class ErrorSamples:
    """Pixels (q8) spread over the whole image and their exact undistorted positions: computed
    once per camera, reused for every grid measured against it."""

    u_q8: np.ndarray
    v_q8: np.ndarray
    exact: np.ndarray  # (N, 2) px


def error_samples(cam: Camera, sample_px: float = 1.75) -> ErrorSamples:
    """The whole image [-0.5, W-0.5) x [-0.5, H-0.5) every sample_px (incommensurate with
    the node spacing, so samples fall at every phase inside the cells) plus the last row
    and column."""
    u = np.arange(-0.5, cam.width - 0.5, sample_px)
    v = np.arange(-0.5, cam.height - 0.5, sample_px)
    uu, vv = np.meshgrid(np.append(u, cam.width - 0.5 - 1 / Q8), np.append(v, cam.height - 0.5 - 1 / Q8))
    u_q8 = np.round(uu.ravel() * Q8).astype(np.int64)
    v_q8 = np.round(vv.ravel() * Q8).astype(np.int64)
    return ErrorSamples(u_q8, v_q8, ideal_pixels(cam, np.column_stack([u_q8, v_q8]) / Q8))


REFINE_WITHIN = 0.97  # cells whose lattice maximum is within 3 % of the worst are resampled
REFINE_MAX_CELLS = 16
REFINE_STEP_Q8 = 64  # 1/4 px inside a resampled cell


def _errors(cam: Camera, g: Grid, u_q8: np.ndarray, v_q8: np.ndarray, exact: np.ndarray) -> np.ndarray:
    from .check import core

    val, inside = core().eval_grid(g, u_q8, v_q8)
    if not np.all(inside):
        raise MfnsError(f"camera {cam.name}: the grid does not cover the image")
    return np.hypot(*(val / Q16 - exact).T)


def _refine(
    cam: Camera, g: Grid, s: ErrorSamples, err: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Errors on a 1/4 px lattice inside the (at most REFINE_MAX_CELLS) cells where the
    coarse lattice came within REFINE_WITHIN of its maximum: the maximum of a bilinear
    cell can fall between the coarse samples (1.75 px measured 0.0100 where 1/8 px finds
    0.0101)."""
    ci = (s.u_q8 - g.origin_u_q8) // g.step_u_q8
    cj = (s.v_q8 - g.origin_v_q8) // g.step_v_q8
    hot = err >= REFINE_WITHIN * err.max()
    cells = np.unique(np.stack([ci[hot], cj[hot]], axis=1), axis=0)
    cells = cells[np.argsort(-np.array([err[hot & (ci == i) & (cj == j)].max() for i, j in cells]))]
    us, vs = [], []
    for i, j in cells[:REFINE_MAX_CELLS]:
        u0, v0 = g.origin_u_q8 + i * g.step_u_q8, g.origin_v_q8 + j * g.step_v_q8
        # inside the image [-0.5, W - 0.5): from the corner to the last q8 before the far edge
        u = np.arange(
            max(u0, ORIGIN_Q8), min(u0 + g.step_u_q8, Q8 * cam.width + ORIGIN_Q8 - 1) + 1, REFINE_STEP_Q8
        )
        v = np.arange(
            max(v0, ORIGIN_Q8), min(v0 + g.step_v_q8, Q8 * cam.height + ORIGIN_Q8 - 1) + 1, REFINE_STEP_Q8
        )
        uu, vv = np.meshgrid(u, v)
        us.append(uu.ravel())
        vs.append(vv.ravel())
    u_q8, v_q8 = np.concatenate(us).astype(np.int64), np.concatenate(vs).astype(np.int64)
    exact = ideal_pixels(cam, np.column_stack([u_q8, v_q8]) / Q8)
    return _errors(cam, g, u_q8, v_q8, exact), u_q8, v_q8


def grid_error(
    cam: Camera, g: Grid, sample_px: float = 1.75, samples: ErrorSamples | None = None
) -> GridError:
    """Worst-case error of the grid as the flight code evaluates it (mfns_undistort_grid_px
    of the C core, table/check.py) against the exact inverse of the same pixel: a lattice
    over the whole image, then a fine lattice inside the cells near its maximum."""
    s = samples if samples is not None else error_samples(cam, sample_px)
    err = _errors(cam, g, s.u_q8, s.v_q8, s.exact)
    fine, fu, fv = _refine(cam, g, s, err)
    if fine.max() > err.max():
        k = int(np.argmax(fine))
        worst, where = float(fine[k]), (fu[k] / Q8, fv[k] / Q8)
    else:
        k = int(np.argmax(err))
        worst, where = float(err[k]), (s.u_q8[k] / Q8, s.v_q8[k] / Q8)
    return GridError(worst, float(np.sqrt(np.mean(err**2))), where, int(err.size + fine.size))


def _candidates(cam: Camera, max_nodes: int) -> list[tuple[int, int]]:
    """Grids of near-square cells spanning the image, by increasing density, within max_nodes
    and the step range."""
    out = []
    for nx in range(2, cam.width + 2):
        ny = max(2, round((nx - 1) * cam.height / cam.width) + 1)
        if nx * ny > max_nodes:
            break
        try:
            step_q8(cam.width, nx), step_q8(cam.height, ny)
        except MfnsError:
            continue
        out.append((nx, ny))
    return out


def size_grid(cam: Camera, max_nodes: int, target_px: float = MAX_GRID_ERROR_PX) -> tuple[Grid, GridError]:
    """The coarsest grid whose worst-case error (measured with the C interpolation) is within
    target_px; MfnsError with the figure when even the densest grid within max_nodes is not."""
    cands = _candidates(cam, max_nodes)
    if not cands:
        raise MfnsError(
            f"camera {cam.name}: no grid of 1..{int(MAX_STEP_PX)} px spacing fits {max_nodes} nodes"
        )
    samples = error_samples(cam)
    measured: dict[int, tuple[Grid, GridError]] = {}

    def measure(i: int) -> tuple[Grid, GridError]:
        if i not in measured:
            g = build_grid(cam, *cands[i], max_nodes=max_nodes)
            measured[i] = (g, grid_error(cam, g, samples=samples))
        return measured[i]

    last = len(cands) - 1
    g, e = measure(last)
    if e.max_px > target_px:
        raise MfnsError(
            f"camera {cam.name}: the lens cannot be corrected to {target_px} px within {max_nodes} nodes: "
            f"the densest grid ({g.nx}x{g.ny}, {g.step_u_q8 / Q8:.1f} px spacing) leaves {e.max_px:.4f} px "
            f"at ({e.worst_uv[0]:.1f}, {e.worst_uv[1]:.1f})"
        )
    lo, hi = 0, last  # error shrinks with density (~h^2): bisect for the coarsest within target
    while lo < hi:
        mid = (lo + hi) // 2
        if measure(mid)[1].max_px <= target_px:
            hi = mid
        else:
            lo = mid + 1
    return measure(lo)
