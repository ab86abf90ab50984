"""The binary calibration table (docs/caltable.md): data model, writer and reader.

Little-endian throughout; floats are IEEE-754 binary32. The flight loader
(firmware/nav/caltable.c) is the only validator of a table: table/check.py calls it
through the shared library; decode() here only parses a table it has accepted.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from ..calib_results import COVARIANCE_PARAMETERS
from ..errors import MfnsError

MAGIC = b"MFTB"
VERSION = 3
HEADER_SIZE = 16
GLOBALS_SIZE = 60
CAMERA_FIXED_SIZE = 116
NODE_SIZE = 8
BEACON_SIZE = 20
NUM_CAMERAS = 3
# The calibration-covariance section (after the beacon records): u16 count (0 or
# CALIB_PARAMS), u16 reserved, the upper triangle row-major as f32.
COV_HEADER_SIZE = 4
# Per camera x, y, z, in the order of nav_config.h mfns_calib_param_t: the calibration-
# results contract's own parameter list (docs/calib-results.md), defined once there.
CALIB_PARAM_NAMES = COVARIANCE_PARAMETERS
CALIB_PARAMS = NUM_CAMERAS * len(CALIB_PARAM_NAMES)
# The map-index section after the beacon records is written by the C core
# (mfns_bidx_encode, firmware/nav/beacon_index.h); only its header is read here.
INDEX_HEADER = struct.Struct("<HBBBBHI3f3fI4B")
CAMERA_NAMES = ("x", "y", "z")

# Field order of the settings records (docs/caltable.md).
CENTROID_U16 = (
    "threshold_dn",
    "min_area_px",
    "max_area_px",
    "roi_half_size_px",
    "saturation_dn",
    "gain_dn_per_e_q12",  # offset 34, reserved (0) before the centroid covariance used it
)
CENTROID_F32 = ("threshold_k_sigma", "max_elongation")
SOLVER_U16 = ("max_iterations",)  # then a reserved u16 (version 1: max_hypotheses)
SOLVER_F32 = (
    "step_tol",
    "grad_tol",
    "huber_k",
    "outlier_gate_sigma",
    "max_residual_rms_sigma",
    "track_gate_px",
    "min_rcond",
)

_HEADER = struct.Struct("<4sHHII")
_GLOBALS = struct.Struct("<HHf" + "6H2f" + "2H7f")
_CAMERA = struct.Struct("<4H5f5f9f3f2H4i")
_BEACON = struct.Struct("<HHffff")
assert _HEADER.size == HEADER_SIZE and _GLOBALS.size == GLOBALS_SIZE
assert _CAMERA.size == CAMERA_FIXED_SIZE and _BEACON.size == BEACON_SIZE and INDEX_HEADER.size == 44


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
    index_section: bytes = b""  # the map index, as mfns_bidx_encode wrote it
    # (45, 45) covariance of the calibration (CALIB_PARAM_NAMES per camera), None = unknown
    calib_cov: np.ndarray | None = None
    version: int = VERSION
    crc32: int = 0
    size_bytes: int = 0


def encode(t: Table) -> bytes:
    """Serialize a table (values rounded to binary32). Raises MfnsError on values the
    format cannot carry (counts, ranges of the integer fields)."""
    if len(t.cameras) != NUM_CAMERAS:
        raise MfnsError(f"a table has exactly {NUM_CAMERAS} cameras, got {len(t.cameras)}")
    n_b = len(t.beacon_ids)
    if not t.index_section:
        raise MfnsError("a table needs its map index section (mfns.table.builder builds it)")
    try:
        body = bytearray(
            _GLOBALS.pack(
                NUM_CAMERAS,
                n_b,
                t.pixel_sigma_px,
                *(int(t.centroid[k]) for k in CENTROID_U16),
                *(float(t.centroid[k]) for k in CENTROID_F32),
                *(int(t.solver[k]) for k in SOLVER_U16),
                0,
                *(float(t.solver[k]) for k in SOLVER_F32),
            )
        )
        for c in t.cameras:
            g = c.grid
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
        body += encode_calib_cov(t.calib_cov)
        body += t.index_section
    except struct.error as exc:
        raise MfnsError(f"value does not fit the table format: {exc}") from exc
    total = HEADER_SIZE + len(body)
    return _HEADER.pack(MAGIC, VERSION, HEADER_SIZE, total, zlib.crc32(body)) + bytes(body)


def encode_calib_cov(cov: np.ndarray | None) -> bytes:
    """The calibration-covariance section (docs/caltable.md): None -> count 0."""
    if cov is None:
        return struct.pack("<HH", 0, 0)
    a = np.asarray(cov, dtype=float)
    if a.shape != (CALIB_PARAMS, CALIB_PARAMS):
        raise MfnsError(f"calibration covariance: expected ({CALIB_PARAMS}, {CALIB_PARAMS}), got {a.shape}")
    iu = np.triu_indices(CALIB_PARAMS)
    return struct.pack("<HH", CALIB_PARAMS, 0) + a[iu].astype("<f4").tobytes()


def decode_calib_cov(data: bytes, pos: int) -> tuple[np.ndarray | None, int]:
    """(covariance or None, position after the section)."""
    n = struct.unpack_from("<H", data, pos)[0]
    pos += COV_HEADER_SIZE
    if n == 0:
        return None, pos
    m = n * (n + 1) // 2
    tri = np.frombuffer(data, dtype="<f4", count=m, offset=pos).astype(float)
    a = np.zeros((n, n))
    a[np.triu_indices(n)] = tri
    a = a + np.triu(a, 1).T
    return a, pos + 4 * m


def decode(data: bytes) -> Table:
    """Parse a table the flight loader has accepted (table/check.py: read_table), for
    display and tests. No checks here: the loader is the one validator; bytes after the
    header's total_size are ignored, as the loader ignores them."""
    magic, version, hsize, total, crc = _HEADER.unpack_from(data, 0)
    g = _GLOBALS.unpack_from(data, HEADER_SIZE)
    n_b, sigma = g[1], g[2]
    centroid = dict(zip(CENTROID_U16, g[3:9], strict=True))
    centroid.update(zip(CENTROID_F32, g[9:11], strict=True))
    solver = dict(zip(SOLVER_U16, g[11:12], strict=True))
    solver.update(zip(SOLVER_F32, g[13:20], strict=True))
    pos = HEADER_SIZE + GLOBALS_SIZE
    cams = []
    for k in range(NUM_CAMERAS):
        v = _CAMERA.unpack_from(data, pos)
        nx, ny = v[26], v[27]
        pos += CAMERA_FIXED_SIZE
        nodes = (
            np.frombuffer(data, dtype="<i4", count=nx * ny * 2, offset=pos)
            .reshape(ny, nx, 2)
            .astype(np.int32)
        )
        pos += nx * ny * NODE_SIZE
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
    ids, p, s = [], [], []
    for i in range(n_b):
        bid, _, x, y, z, sig = _BEACON.unpack_from(data, pos + i * BEACON_SIZE)
        ids.append(bid)
        p.append((x, y, z))
        s.append(sig)
    pos += n_b * BEACON_SIZE
    calib_cov, pos = decode_calib_cov(data, pos)
    return Table(
        cameras=cams,
        beacon_ids=np.array(ids, dtype=int),
        beacon_pos=np.array(p, dtype=float).reshape(-1, 3),
        beacon_sigma=np.array(s, dtype=float),
        pixel_sigma_px=sigma,
        centroid=centroid,
        solver=solver,
        index_section=bytes(data[pos:total]),
        calib_cov=calib_cov,
        version=version,
        crc32=crc,
        size_bytes=total,
    )


def index_summary(t: Table) -> dict:
    """The header of a decoded table's map index (docs/caltable.md "Map index")."""
    h = INDEX_HEADER.unpack_from(t.index_section, 0)
    return {
        "beacons": h[0],
        "k_nbr": h[1],
        "max_missing": h[2],
        "max_unexplained": h[3],
        "analysis_max_rival": h[5],
        "budget_units": h[6],
        "workspace_min_mm": list(h[7:10]),
        "workspace_max_mm": list(h[10:13]),
        "analysis_samples": h[13],
        "cert_inliers": list(h[14 : 15 + h[2]]),
    }
