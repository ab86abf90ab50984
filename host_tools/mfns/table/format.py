"""The binary calibration table (docs/caltable.md): data model, writer and reader.

Little-endian throughout; floats are IEEE-754 binary32. The flight loader is
firmware/nav/caltable.c; this module mirrors its checks so that `mfns table show`
refuses what the flight code would refuse.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from ..errors import MfnsError

MAGIC = b"MFTB"
VERSION = 1
HEADER_SIZE = 16
GLOBALS_SIZE = 60
CAMERA_FIXED_SIZE = 116
NODE_SIZE = 8
BEACON_SIZE = 20
NUM_CAMERAS = 3
# Compile-time maxima of firmware/nav/nav_config.h (the flight loader refuses more).
MAX_BEACONS = 64
MAX_GRID_NODES = 8192
MAX_BYTES = HEADER_SIZE + GLOBALS_SIZE + NUM_CAMERAS * (CAMERA_FIXED_SIZE + NODE_SIZE * MAX_GRID_NODES)
MAX_BYTES += BEACON_SIZE * MAX_BEACONS
CAMERA_NAMES = ("x", "y", "z")

# Field order of the settings records (docs/caltable.md).
CENTROID_U16 = ("threshold_dn", "min_area_px", "max_area_px", "roi_half_size_px", "saturation_dn")
CENTROID_F32 = ("threshold_k_sigma", "max_elongation")
SOLVER_U16 = ("max_iterations", "max_hypotheses")
SOLVER_F32 = (
    "step_tol",
    "grad_tol",
    "huber_k",
    "outlier_gate_sigma",
    "max_residual_rms_px",
    "track_gate_px",
    "min_rcond",
)

_HEADER = struct.Struct("<4sHHII")
_GLOBALS = struct.Struct("<HHf" + "5HH2f" + "2H7f")
_CAMERA = struct.Struct("<4H5f5f9f3f2H4i")
_BEACON = struct.Struct("<HHffff")
assert _HEADER.size == HEADER_SIZE and _GLOBALS.size == GLOBALS_SIZE
assert _CAMERA.size == CAMERA_FIXED_SIZE and _BEACON.size == BEACON_SIZE


def f32(x):
    """Round to binary32, returned as Python float / float64 array (what the table stores)."""
    return np.asarray(x, dtype=np.float32).astype(np.float64)


@dataclass
class Grid:
    """Correction grid of one camera: nodes[j, i] = undistorted pixel (Q16.16 ints) of
    pixel (origin_u + i*step_u, origin_v + j*step_v); origin and step in 1/256 px."""

    origin_u_q8: int
    origin_v_q8: int
    step_u_q8: int
    step_v_q8: int
    nodes: np.ndarray  # (ny, nx, 2) int32

    @property
    def nx(self) -> int:
        return int(self.nodes.shape[1])

    @property
    def ny(self) -> int:
        return int(self.nodes.shape[0])


@dataclass
class CameraRecord:
    camera_id: int
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    skew: float
    dist: np.ndarray
    C_k_b: np.ndarray
    r_bk_b: np.ndarray
    grid: Grid


@dataclass
class Table:
    cameras: list[CameraRecord]
    beacon_ids: np.ndarray
    beacon_pos: np.ndarray  # (N, 3) mm
    beacon_sigma: np.ndarray  # (N,) mm
    pixel_sigma_px: float
    centroid: dict = field(default_factory=dict)
    solver: dict = field(default_factory=dict)
    version: int = VERSION
    crc32: int = 0
    size_bytes: int = 0


def encode(t: Table) -> bytes:
    """Serialize a table (values rounded to binary32). Raises MfnsError on values the
    format cannot carry (counts, ranges of the integer fields)."""
    if len(t.cameras) != NUM_CAMERAS:
        raise MfnsError(f"a table has exactly {NUM_CAMERAS} cameras, got {len(t.cameras)}")
    n_b = len(t.beacon_ids)
    if not 1 <= n_b <= MAX_BEACONS:
        raise MfnsError(f"beacon count {n_b} outside 1..{MAX_BEACONS}")
    try:
        body = bytearray(
            _GLOBALS.pack(
                NUM_CAMERAS,
                n_b,
                t.pixel_sigma_px,
                *(int(t.centroid[k]) for k in CENTROID_U16),
                0,
                *(float(t.centroid[k]) for k in CENTROID_F32),
                *(int(t.solver[k]) for k in SOLVER_U16),
                *(float(t.solver[k]) for k in SOLVER_F32),
            )
        )
        for c in t.cameras:
            g = c.grid
            if g.nx * g.ny > MAX_GRID_NODES:
                raise MfnsError(
                    f"camera {CAMERA_NAMES[c.camera_id]}: grid {g.nx}x{g.ny} has {g.nx * g.ny} nodes, "
                    f"more than MFNS_MAX_GRID_NODES ({MAX_GRID_NODES})"
                )
            body += _CAMERA.pack(
                c.camera_id,
                c.width,
                c.height,
                0,
                c.fx,
                c.fy,
                c.cx,
                c.cy,
                c.skew,
                *np.asarray(c.dist, dtype=float).tolist(),
                *np.asarray(c.C_k_b, dtype=float).ravel().tolist(),
                *np.asarray(c.r_bk_b, dtype=float).tolist(),
                g.nx,
                g.ny,
                g.origin_u_q8,
                g.origin_v_q8,
                g.step_u_q8,
                g.step_v_q8,
            )
            body += np.ascontiguousarray(g.nodes, dtype="<i4").tobytes()
        for bid, p, s in zip(t.beacon_ids, t.beacon_pos, t.beacon_sigma, strict=True):
            body += _BEACON.pack(int(bid), 0, float(p[0]), float(p[1]), float(p[2]), float(s))
    except struct.error as exc:
        raise MfnsError(f"value does not fit the table format: {exc}") from exc
    total = HEADER_SIZE + len(body)
    if total > MAX_BYTES:
        raise MfnsError(f"table of {total} bytes exceeds the flight maximum {MAX_BYTES}")
    return _HEADER.pack(MAGIC, VERSION, HEADER_SIZE, total, zlib.crc32(body)) + bytes(body)


def _need(cond: bool, msg: str) -> None:
    if not cond:
        raise MfnsError(msg)


def decode(data: bytes) -> Table:
    """Parse and check a table (header, CRC, counts, structure). Raises MfnsError with
    one line on the first problem, like the flight loader."""
    _need(
        len(data) >= HEADER_SIZE, f"truncated: {len(data)} bytes, shorter than the {HEADER_SIZE}-byte header"
    )
    magic, version, hsize, total, crc = _HEADER.unpack_from(data, 0)
    _need(magic == MAGIC, f"bad magic {magic!r}: not a calibration table (expected {MAGIC!r})")
    _need(version != 0, "format version 0 is invalid")
    _need(version <= VERSION, f"format version {version} is newer than this reader ({VERSION}): refused")
    _need(hsize == HEADER_SIZE, f"header size {hsize}, expected {HEADER_SIZE}")
    _need(HEADER_SIZE + GLOBALS_SIZE <= total <= MAX_BYTES, f"total size {total} out of range")
    _need(total <= len(data), f"truncated: header says {total} bytes, file has {len(data)}")
    body = data[HEADER_SIZE:total]
    actual = zlib.crc32(body)
    _need(actual == crc, f"CRC-32 mismatch: header 0x{crc:08x}, body 0x{actual:08x} (corrupt table)")
    _need(total == len(data), f"{len(data) - total} trailing bytes after the table's {total} bytes")
    g = _GLOBALS.unpack_from(data, HEADER_SIZE)
    n_cam, n_b, sigma = g[0], g[1], g[2]
    _need(n_cam == NUM_CAMERAS, f"camera count {n_cam}, expected {NUM_CAMERAS}")
    _need(1 <= n_b <= MAX_BEACONS, f"beacon count {n_b} outside 1..{MAX_BEACONS}")
    _need(g[8] == 0, "reserved centroid field is not zero")
    centroid = dict(zip(CENTROID_U16, g[3:8], strict=True))
    centroid.update(zip(CENTROID_F32, g[9:11], strict=True))
    solver = dict(zip(SOLVER_U16, g[11:13], strict=True))
    solver.update(zip(SOLVER_F32, g[13:20], strict=True))
    pos = HEADER_SIZE + GLOBALS_SIZE
    cams = []
    for k in range(NUM_CAMERAS):
        _need(pos + CAMERA_FIXED_SIZE <= total, f"camera {k}: record runs past the end")
        v = _CAMERA.unpack_from(data, pos)
        _need(v[0] == k, f"camera record {k} has id {v[0]}")
        nx, ny = v[26], v[27]
        _need(nx >= 2 and ny >= 2 and nx * ny <= MAX_GRID_NODES, f"camera {k}: bad grid dimensions {nx}x{ny}")
        pos += CAMERA_FIXED_SIZE
        nbytes = nx * ny * NODE_SIZE
        _need(pos + nbytes <= total, f"camera {k}: grid nodes run past the end")
        nodes = (
            np.frombuffer(data, dtype="<i4", count=nx * ny * 2, offset=pos)
            .reshape(ny, nx, 2)
            .astype(np.int32)
        )
        pos += nbytes
        floats = np.array(v[4:26], dtype=float)
        _need(bool(np.all(np.isfinite(floats))), f"camera {k}: a value is NaN or infinite")
        cams.append(
            CameraRecord(
                camera_id=k,
                width=v[1],
                height=v[2],
                fx=v[4],
                fy=v[5],
                cx=v[6],
                cy=v[7],
                skew=v[8],
                dist=np.array(v[9:14], dtype=float),
                C_k_b=np.array(v[14:23], dtype=float).reshape(3, 3),
                r_bk_b=np.array(v[23:26], dtype=float),
                grid=Grid(v[28], v[29], v[30], v[31], nodes),
            )
        )
    _need(pos + n_b * BEACON_SIZE == total, "beacon records do not end at the table's total size")
    ids, p, s = [], [], []
    for i in range(n_b):
        bid, res, x, y, z, sig = _BEACON.unpack_from(data, pos + i * BEACON_SIZE)
        _need(res == 0, f"beacon {i}: reserved field is not zero")
        ids.append(bid)
        p.append((x, y, z))
        s.append(sig)
    _need(len(set(ids)) == len(ids), "two beacons share an id")
    return Table(
        cameras=cams,
        beacon_ids=np.array(ids, dtype=int),
        beacon_pos=np.array(p, dtype=float),
        beacon_sigma=np.array(s, dtype=float),
        pixel_sigma_px=sigma,
        centroid=centroid,
        solver=solver,
        version=version,
        crc32=crc,
        size_bytes=total,
    )


def validate(t: Table) -> Table:
    """The flight loader's value checks (firmware/nav/caltable.c) on a decoded table."""
    from ..camera import Camera
    from .settings import SOLVER_RANGES

    _need(0 < t.pixel_sigma_px <= 10, f"pixel noise sigma {t.pixel_sigma_px} outside (0, 10] px")
    c = t.centroid
    _need(
        np.isfinite(c["threshold_k_sigma"]) and 0 <= c["threshold_k_sigma"] <= 100,
        "centroid threshold_k_sigma outside [0, 100]",
    )
    _need(c["threshold_dn"] > 0 or c["threshold_k_sigma"] > 0, "centroid: no threshold rule")
    _need(1 <= c["min_area_px"] <= c["max_area_px"], "centroid: need 1 <= min_area_px <= max_area_px")
    _need(c["roi_half_size_px"] >= 1, "centroid roi_half_size_px is 0")
    _need(1 <= c["max_elongation"] <= 100, "centroid max_elongation outside [1, 100]")
    s = t.solver
    _need(1 <= s["max_iterations"] <= 1000, "solver max_iterations outside 1..1000")
    _need(s["max_hypotheses"] >= 1, "solver max_hypotheses is 0")
    for k, (lo, hi) in SOLVER_RANGES.items():
        _need(lo < s[k] <= hi, f"solver {k} = {s[k]} outside ({lo}, {hi}]")
    for k, r in enumerate(t.cameras):
        name = CAMERA_NAMES[k]
        _need(r.width > 0 and r.height > 0, f"camera {name}: zero image size")
        _need(0 < r.fx <= 1e6 and 0 < r.fy <= 1e6, f"camera {name}: focal length not positive")
        _need(
            -0.5 <= r.cx <= r.width - 0.5 and -0.5 <= r.cy <= r.height - 0.5,
            f"camera {name}: principal point outside the image",
        )
        _need(
            abs(r.skew) <= r.fx and np.all(np.abs(r.dist) <= 1000),
            f"camera {name}: absurd skew or distortion",
        )
        C = np.asarray(r.C_k_b, dtype=np.float32)
        orth = np.max(np.abs(C.T @ C - np.eye(3, dtype=np.float32)))
        _need(
            orth <= 1e-5 and np.linalg.det(C) > 0, f"camera {name}: C_k_b not a rotation (error {orth:.2e})"
        )
        _need(np.all(np.abs(r.r_bk_b) <= 1e4), f"camera {name}: r_bk_b beyond 10 m")
        g = r.grid
        _need(
            256 <= g.step_u_q8 <= 65535 and 256 <= g.step_v_q8 <= 65535,
            f"camera {name}: grid step outside 1..255 px",
        )
        _need(
            g.origin_u_q8 <= -128
            and g.origin_v_q8 <= -128
            and g.origin_u_q8 + (g.nx - 1) * g.step_u_q8 >= 256 * r.width - 128
            and g.origin_v_q8 + (g.ny - 1) * g.step_v_q8 >= 256 * r.height - 128,
            f"camera {name}: grid does not cover the image",
        )
        cam = Camera(name, r.fx, r.fy, r.cx, r.cy, r.skew, np.asarray(r.dist), r.width, r.height)
        nodes = g.nodes.reshape(-1, 2) / 65536.0
        yy = (nodes[:, 1] - r.cy) / r.fy
        xx = (nodes[:, 0] - r.cx - r.skew * yy) / r.fx
        back = cam.distorted_to_pixel(cam.distort(np.column_stack([xx, yy])))
        iu, jv = np.meshgrid(np.arange(g.nx), np.arange(g.ny))
        want = np.column_stack(
            [
                (g.origin_u_q8 + iu.ravel() * g.step_u_q8) / 256.0,
                (g.origin_v_q8 + jv.ravel() * g.step_v_q8) / 256.0,
            ]
        )
        worst = float(np.max(np.abs(back - want)))
        _need(worst <= 0.01, f"camera {name}: grid node disagrees with the lens model by {worst:.3g} px")
    _need(
        bool(np.all(np.isfinite(t.beacon_pos)) and np.all(np.isfinite(t.beacon_sigma))),
        "beacon value not finite",
    )
    _need(bool(np.all(np.abs(t.beacon_pos) <= 1e7)), "beacon position absurd")
    _need(bool(np.all((t.beacon_sigma > 0) & (t.beacon_sigma <= 1e4))), "beacon sigma not positive")
    return t
