"""The binary calibration table (docs/caltable.md): data model, writer and reader.

Little-endian throughout; floats are IEEE-754 binary32. The flight loader
(firmware/nav/table/caltable.c) is the only validator of a table: table/check.py calls it
through the shared library; decode() here only parses a table it has accepted.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..analysis.calib_results import CAMERA_NAMES, COVARIANCE_PARAMETERS  # noqa: F401 (CAMERA_NAMES: re-exported)
from ..core.errors import MfnsError
from .generated import layout_gen as L

# The layout is generated from the one definition (contract/caltable_layout.toml,
# contract/gen_caltable.py): sizes, field order and types, struct formats.
MAGIC = L.MAGIC
VERSION = L.VERSION
HEADER_SIZE = L.SIZE["header"]
GLOBALS_SIZE = L.SIZE["globals"]
CAMERA_FIXED_SIZE = L.SIZE["camera"]
NODE_SIZE = L.SIZE["node"]
BEACON_SIZE = L.SIZE["beacon"]
NUM_CAMERAS = L.CONSTANTS["MFNS_NUM_CAMERAS"]
# The calibration-covariance section (after the beacon records): u16 count (0 or
# CALIB_PARAMS), u16 reserved, the upper triangle row-major as f32.
COV_HEADER_SIZE = L.SIZE["calib_cov"]
# Per camera x, y, z, in the order of nav_settings.h mfns_calib_param_t: the calibration-
# results contract's own parameter list (docs/calib-results.md), defined once there.
CALIB_PARAM_NAMES = COVARIANCE_PARAMETERS
CALIB_PARAMS = NUM_CAMERAS * len(CALIB_PARAM_NAMES)
assert CALIB_PARAMS == L.CONSTANTS["MFNS_CALIB_PARAMS"]
# The map datum section (after the calibration covariance, format version 5): u16 count (0
# or MAP_DATUM_PARAMS), u16 reserved, the turn's centre c_w (3 x f32 mm), the upper
# triangle row-major of the covariance over (shift x y z mm, turn x y z rad) as f32.
DATUM_HEADER_SIZE = L.SIZE["map_datum"]
MAP_DATUM_PARAMS = L.CONSTANTS["MFNS_MAP_DATUM_PARAMS"]
MAP_DATUM_NAMES = ("shift x", "shift y", "shift z", "turn x", "turn y", "turn z")  # nav_settings.h order
assert len(MAP_DATUM_NAMES) == MAP_DATUM_PARAMS


class Record:
    """One fixed-size record of the layout: pack/unpack by field name (arrays as tuples;
    reserved fields are written 0)."""

    def __init__(self, key: str):
        self.key = key
        self.size = L.SIZE[key]
        self.fields = L.FIELDS[key]
        self.reserved = set(L.RESERVED.get(key, ()))
        self.struct = struct.Struct(L.STRUCT[key])
        assert self.struct.size == self.size

    def offset(self, name: str) -> int:
        return next(off for n, off, _, _ in self.fields if n == name)

    def pack(self, values: dict) -> bytes:
        flat: list[object] = []
        for name, _, kind, count in self.fields:
            v: Any = 0 if name in self.reserved else values[name]  # a value of the caller's dict
            if count > 1 and kind != "char":
                flat.extend(v)
            else:
                flat.append(v)
        return self.struct.pack(*flat)

    def unpack(self, data: bytes, offset: int) -> dict:
        it = iter(self.struct.unpack_from(data, offset))
        return {
            name: tuple(next(it) for _ in range(count)) if count > 1 and kind != "char" else next(it)
            for name, _, kind, count in self.fields
        }


_HEADER = Record("header")
_GLOBALS = Record("globals")
_CAMERA = Record("camera")
_BEACON = Record("beacon")
_COV = Record("calib_cov")
_DATUM = Record("map_datum")


class SettingsRecord(Record):
    """A record of settings of its own (integrity, motion): its fields without the reserved
    ones, the integer ones among them, and the record from a values dict over the layout's
    defaults (a field not given is the default)."""

    def __init__(self, key: str):
        super().__init__(key)
        self.names = tuple(n for n, _, _, _ in self.fields if n not in self.reserved)
        self.ints = tuple(n for n, _, k, _ in self.fields if k in ("u8", "u16") and n not in self.reserved)

    def pack_settings(self, values: dict) -> bytes:
        v = {**L.DEFAULTS[self.key], **values}
        return self.pack({k: int(v[k]) if k in self.ints else float(v[k]) for k in self.names})

    def unpack_settings(self, data: bytes, offset: int) -> dict:
        v = self.unpack(data, offset)
        return {k: v[k] for k in self.names}


# The integrity settings (after the map datum), then the navigation filter's motion bound.
INTEGRITY = SettingsRecord("integrity")
MOTION = SettingsRecord("motion")
# The map-index section after the beacon records is written by the C core
# (mfns_bidx_encode, firmware/nav/map/beacon_index.h); only its header is read here.
_INDEX = Record("index")
INDEX_HEADER = _INDEX.struct


def _settings(prefix: str, kind: str) -> tuple[str, ...]:
    return tuple(
        n[len(prefix) :]
        for n, _, k, _ in L.FIELDS["globals"]
        if n.startswith(prefix) and k == kind and n not in _GLOBALS.reserved
    )


# The settings records' fields by type (docs/caltable.md "Globals").
CENTROID_U16 = _settings("centroid.", "u16")
CENTROID_F32 = _settings("centroid.", "f32")
SOLVER_U16 = _settings("solver.", "u16")
SOLVER_F32 = _settings("solver.", "f32")


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
class MapDatum:
    """The map's shared rigid error (docs/caltable.md "Map datum covariance"): cov (6, 6)
    over (shift x y z mm, turn x y z rad about c_w_mm)."""

    c_w_mm: np.ndarray
    cov: np.ndarray


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
    # the map's shared error; None = none (each beacon's sigma is its whole error)
    map_datum: MapDatum | None = None
    # integrity settings (INTEGRITY.names); empty = the defaults
    integrity: dict = field(default_factory=dict)
    # the motion bound (MOTION.names); empty = the defaults
    motion: dict = field(default_factory=dict)
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
                {
                    "camera_count": NUM_CAMERAS,
                    "beacon_count": n_b,
                    "pixel_sigma_px": t.pixel_sigma_px,
                    **{f"centroid.{k}": int(t.centroid[k]) for k in CENTROID_U16},
                    **{f"centroid.{k}": float(t.centroid[k]) for k in CENTROID_F32},
                    **{f"solver.{k}": int(t.solver[k]) for k in SOLVER_U16},
                    **{f"solver.{k}": float(t.solver[k]) for k in SOLVER_F32},
                }
            )
        )
        for c in t.cameras:
            g = c.grid
            body += _CAMERA.pack(
                {
                    "camera_id": c.camera_id,
                    "width": c.width,
                    "height": c.height,
                    "fx": c.fx,
                    "fy": c.fy,
                    "cx": c.cx,
                    "cy": c.cy,
                    "skew": c.skew,
                    "dist": np.asarray(c.dist, dtype=float).tolist(),
                    "C_k_b": np.asarray(c.C_k_b, dtype=float).ravel().tolist(),
                    "r_bk_b": np.asarray(c.r_bk_b, dtype=float).tolist(),
                    "grid.nx": g.nx,
                    "grid.ny": g.ny,
                    "grid.origin_u_q8": g.origin_u_q8,
                    "grid.origin_v_q8": g.origin_v_q8,
                    "grid.step_u_q8": g.step_u_q8,
                    "grid.step_v_q8": g.step_v_q8,
                }
            )
            body += np.ascontiguousarray(g.nodes, dtype="<i4").tobytes()
        for bid, p, s in zip(t.beacon_ids, t.beacon_pos, t.beacon_sigma, strict=True):
            body += _BEACON.pack({"id": int(bid), "p_w": [float(x) for x in p[:3]], "sigma_mm": float(s)})
        body += encode_calib_cov(t.calib_cov)
        body += encode_map_datum(t.map_datum)
        body += INTEGRITY.pack_settings(t.integrity)
        body += MOTION.pack_settings(t.motion)
        body += t.index_section
    except struct.error as exc:
        raise MfnsError(f"value does not fit the table format: {exc}") from exc
    total = HEADER_SIZE + len(body)
    header = {"magic": MAGIC, "version": VERSION, "header_size": HEADER_SIZE, "total_size": total}
    return _HEADER.pack({**header, "crc32": zlib.crc32(body)}) + bytes(body)


def _tri_bytes(a: np.ndarray) -> bytes:
    """The upper triangle of a symmetric matrix, row-major, as little-endian f32."""
    return a[np.triu_indices(len(a))].astype("<f4").tobytes()


def _tri_read(data: bytes, pos: int, n: int) -> tuple[np.ndarray, int]:
    """(the n x n symmetric matrix whose upper triangle is stored at pos, the position
    after it)."""
    m = n * (n + 1) // 2
    a = np.zeros((n, n))
    a[np.triu_indices(n)] = np.frombuffer(data, dtype="<f4", count=m, offset=pos).astype(float)
    return a + np.triu(a, 1).T, pos + 4 * m


def encode_calib_cov(cov: np.ndarray | None) -> bytes:
    """The calibration-covariance section (docs/caltable.md): None -> count 0."""
    if cov is None:
        return _COV.pack({"count": 0})
    a = np.asarray(cov, dtype=float)
    if a.shape != (CALIB_PARAMS, CALIB_PARAMS):
        raise MfnsError(f"calibration covariance: expected ({CALIB_PARAMS}, {CALIB_PARAMS}), got {a.shape}")
    return _COV.pack({"count": CALIB_PARAMS}) + _tri_bytes(a)


def encode_map_datum(d: MapDatum | None) -> bytes:
    """The map datum section (docs/caltable.md): None -> count 0, centre 0."""
    if d is None:
        return _DATUM.pack({"count": 0, "c_w": [0.0, 0.0, 0.0]})
    n = MAP_DATUM_PARAMS
    a = np.asarray(d.cov, dtype=float)
    c = np.asarray(d.c_w_mm, dtype=float)
    if a.shape != (n, n) or c.shape != (3,):
        raise MfnsError(f"map datum: expected a ({n}, {n}) covariance and a 3-vector centre")
    return _DATUM.pack({"count": n, "c_w": c.tolist()}) + _tri_bytes(a)


def decode_map_datum(data: bytes, pos: int) -> tuple[MapDatum | None, int]:
    """(datum or None, position after the section)."""
    v = _DATUM.unpack(data, pos)
    n = v["count"]
    pos += DATUM_HEADER_SIZE
    if n == 0:
        return None, pos
    a, pos = _tri_read(data, pos, n)
    return MapDatum(np.array(v["c_w"], dtype=float), a), pos


def decode_calib_cov(data: bytes, pos: int) -> tuple[np.ndarray | None, int]:
    """(covariance or None, position after the section)."""
    n = _COV.unpack(data, pos)["count"]
    pos += COV_HEADER_SIZE
    if n == 0:
        return None, pos
    return _tri_read(data, pos, n)


def decode(data: bytes) -> Table:
    """Parse a table the flight loader has accepted (table/check.py: read_table), for
    display and tests. No checks here: the loader is the one validator; bytes after the
    header's total_size are ignored, as the loader ignores them."""
    h = _HEADER.unpack(data, 0)
    version, total, crc = h["version"], h["total_size"], h["crc32"]
    g = _GLOBALS.unpack(data, HEADER_SIZE)
    n_b, sigma = g["beacon_count"], g["pixel_sigma_px"]
    centroid = {k: g[f"centroid.{k}"] for k in CENTROID_U16 + CENTROID_F32}
    solver = {k: g[f"solver.{k}"] for k in SOLVER_U16 + SOLVER_F32}
    pos = HEADER_SIZE + GLOBALS_SIZE
    cams = []
    for k in range(NUM_CAMERAS):
        v = _CAMERA.unpack(data, pos)
        nx, ny = v["grid.nx"], v["grid.ny"]
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
                width=v["width"],
                height=v["height"],
                fx=v["fx"],
                fy=v["fy"],
                cx=v["cx"],
                cy=v["cy"],
                skew=v["skew"],
                dist=np.array(v["dist"], dtype=float),
                C_k_b=np.array(v["C_k_b"], dtype=float).reshape(3, 3),
                r_bk_b=np.array(v["r_bk_b"], dtype=float),
                grid=Grid(
                    v["grid.origin_u_q8"],
                    v["grid.origin_v_q8"],
                    v["grid.step_u_q8"],
                    v["grid.step_v_q8"],
                    nodes,
                ),
            )
        )
    ids, p, s = [], [], []
    for i in range(n_b):
        b = _BEACON.unpack(data, pos + i * BEACON_SIZE)
        ids.append(b["id"])
        p.append(b["p_w"])
        s.append(b["sigma_mm"])
    pos += n_b * BEACON_SIZE
    calib_cov, pos = decode_calib_cov(data, pos)
    map_datum, pos = decode_map_datum(data, pos)
    integrity = INTEGRITY.unpack_settings(data, pos)
    pos += INTEGRITY.size
    motion = MOTION.unpack_settings(data, pos)
    pos += MOTION.size
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
        map_datum=map_datum,
        integrity=integrity,
        motion=motion,
        version=version,
        crc32=crc,
        size_bytes=total,
    )


def index_summary(t: Table) -> dict:
    """The header of a decoded table's map index (docs/caltable.md "Map index")."""
    h = _INDEX.unpack(t.index_section, 0)
    return {
        "beacons": h["beacons"],
        "k_nbr": h["k_nbr"],
        "max_missing": h["max_missing"],
        "max_unexplained": h["max_unexplained"],
        "analysis_max_rival": h["analysis_max_rival"],
        "budget_units": h["budget_units"],
        "workspace_min_mm": list(h["ws_min_w"]),
        "workspace_max_mm": list(h["ws_max_w"]),
        "analysis_samples": h["analysis_samples"],
        "cert_inliers": list(h["cert_inliers"][: 1 + h["max_missing"]]),
    }
