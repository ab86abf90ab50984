"""The one table validator: the flight loader itself (mfns_caltable_load of
firmware/nav/table/caltable.c), reached through the shared library of the C core
(`make lib`, build/host-sim/lib/libmfns_core.so), and the C grid interpolation
(mfns_undistort_grid_px) the builder measures its grids with.

`mfns table show` and `mfns table build` accept exactly what the navigation
computer accepts: there is no Python copy of the checks. A refused table is
reported with the loader's status code, its message and the byte offset of the
offending field (named with the layout of format.py).
"""

from __future__ import annotations

import ctypes as ct
import os
import struct
from dataclasses import dataclass

import numpy as np

from ..core.binding import load as load_core
from ..core.errors import MfnsError
from . import format as fmt
from .generated import layout_gen


@dataclass
class LoadStatus:
    code: int  # mfns_caltable_status_t (0 = MFNS_CALTABLE_OK)
    message: str  # mfns_caltable_strerror
    offset: int  # byte offset of the offending field (0 when ok)

    @property
    def ok(self) -> bool:
        return self.code == 0


class TableRefused(MfnsError):
    """The flight loader refused a table (one line: status, message, offset, field)."""

    def __init__(self, status: LoadStatus, field: str):
        self.status = status
        self.field = field
        super().__init__(
            f"refused by the flight loader: {status.message} "
            f"(status {status.code}, byte offset {status.offset}: {field})"
        )


class CoreTables:
    """The loader and the grid evaluation of the C core (through the binding)."""

    def __init__(self, lib: str | os.PathLike | None = None):
        try:
            L = load_core(lib)  # the one loader, prototypes declared there (binding.py)
        except MfnsError as e:
            raise MfnsError(f"{e}: tables are checked by the C loader") from e
        self.lib = L
        self.max_bytes = int(L.mfns_caltable_host_max_bytes())
        self.max_grid_nodes = int(L.mfns_caltable_host_max_grid_nodes())
        self.max_beacons = int(L.mfns_caltable_host_max_beacons())
        self._out = ct.create_string_buffer(int(L.mfns_caltable_host_table_size()))

    def load(self, data: bytes) -> LoadStatus:
        """mfns_caltable_load over the whole buffer (as the flight program loads a file)."""
        off = ct.c_uint32(0)
        code = int(self.lib.mfns_caltable_load(bytes(data), len(data), self._out, ct.byref(off)))
        return LoadStatus(code, self.lib.mfns_caltable_strerror(code).decode(), int(off.value) if code else 0)

    def eval_grid(self, g: fmt.Grid, u_q8: np.ndarray, v_q8: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """mfns_undistort_grid_px at each pixel: (undistorted Q16.16 (N, 2) int64, inside mask)."""
        u = np.ascontiguousarray(u_q8, dtype=np.int32)
        v = np.ascontiguousarray(v_q8, dtype=np.int32)
        nodes = np.ascontiguousarray(g.nodes, dtype=np.int32)
        out = np.zeros((len(u), 2), dtype=np.int32)
        st = np.zeros(len(u), dtype=np.uint8)
        i32p = ct.POINTER(ct.c_int32)
        rc = self.lib.mfns_caltable_host_grid_eval(
            g.nx,
            g.ny,
            g.origin_u_q8,
            g.origin_v_q8,
            g.step_u_q8,
            g.step_v_q8,
            nodes.ctypes.data_as(i32p),
            len(u),
            u.ctypes.data_as(i32p),
            v.ctypes.data_as(i32p),
            out.ctypes.data_as(i32p),
            st.ctypes.data_as(ct.POINTER(ct.c_uint8)),
        )
        if rc != 0:
            raise MfnsError(f"grid {g.nx}x{g.ny}: header refused by the C core (status {rc})")
        return out.astype(np.int64), st == 0


_CORE: CoreTables | None = None


def core() -> CoreTables:
    global _CORE
    if _CORE is None:
        _CORE = CoreTables()
    return _CORE


def _fields(record: str) -> list[tuple[int, str]]:
    """(start offset, name) of each value of a record, from the generated layout: an array's
    elements by index, a matrix's (layout_gen.SHAPE) by row and column."""
    out = []
    for name, off, kind, count in layout_gen.FIELDS[record]:
        size = {"u8": 1, "char": 1, "u16": 2}.get(kind, 4)
        if count == 1 or kind == "char":
            out.append((off, name))
        elif name in layout_gen.SHAPE.get(record, {}):
            rows, cols = layout_gen.SHAPE[record][name]
            cells = [(r, c) for r in range(rows) for c in range(cols)]
            out += [(off + size * (cols * r + c), f"{name}[{r}][{c}]") for r, c in cells]
        else:
            out += [(off + size * i, f"{name}[{i}]") for i in range(count)]
    return out


_HEADER_FIELDS = _fields("header")
_GLOBAL_FIELDS = _fields("globals")
_CAMERA_FIELDS = _fields("camera")
_BEACON_FIELDS = _fields("beacon")
_INTEGRITY_FIELDS = _fields("integrity")
_MOTION_FIELDS = _fields("motion")
_GRID_NX = fmt.Record("camera").offset("grid.nx")  # then grid.ny
_BEACON_COUNT = fmt.Record("globals").offset("beacon_count")


def _name(fields: list[tuple[int, str]], rel: int) -> str:
    return [n for start, n in fields if start <= rel][-1]


def field_at(data: bytes, off: int) -> str:
    """Name of the table field at byte offset off (for messages), from the layout."""
    if off >= len(data):
        return f"the end of the {len(data)} bytes"
    if off < fmt.HEADER_SIZE:
        return f"header {_name(_HEADER_FIELDS, off)}"
    if off < fmt.HEADER_SIZE + fmt.GLOBALS_SIZE:
        return _name(_GLOBAL_FIELDS, off - fmt.HEADER_SIZE)
    pos = fmt.HEADER_SIZE + fmt.GLOBALS_SIZE
    for name in fmt.CAMERA_NAMES:
        if off < pos + fmt.CAMERA_FIXED_SIZE:
            return f"camera {name} {_name(_CAMERA_FIELDS, off - pos)}"
        if pos + fmt.CAMERA_FIXED_SIZE > len(data):
            return f"camera {name} record"
        nx, ny = struct.unpack_from("<HH", data, pos + _GRID_NX)
        pos += fmt.CAMERA_FIXED_SIZE
        if off < pos + nx * ny * fmt.NODE_SIZE:
            n = (off - pos) // fmt.NODE_SIZE
            return f"camera {name} grid node (i={n % nx}, j={n // nx})"
        pos += nx * ny * fmt.NODE_SIZE
    i, rel = divmod(off - pos, fmt.BEACON_SIZE)
    n_b = struct.unpack_from("<H", data, fmt.HEADER_SIZE + _BEACON_COUNT)[0]
    if i < n_b:
        return f"beacon {i} {_name(_BEACON_FIELDS, rel)}"
    pos += n_b * fmt.BEACON_SIZE
    if pos + fmt.COV_HEADER_SIZE > len(data):
        return "calibration covariance section"
    n_c = struct.unpack_from("<H", data, pos)[0]
    if off < pos + fmt.COV_HEADER_SIZE:
        return "calibration covariance " + ("parameter count" if off < pos + 2 else "reserved")
    pos += fmt.COV_HEADER_SIZE
    if n_c == fmt.CALIB_PARAMS and off < pos + 4 * n_c * (n_c + 1) // 2:
        r, c = _tri_element((off - pos) // 4, n_c)
        return f"calibration covariance ({_param_name(r)}, {_param_name(c)})"
    if n_c == fmt.CALIB_PARAMS:
        pos += 4 * n_c * (n_c + 1) // 2
    if pos + fmt.DATUM_HEADER_SIZE > len(data):
        return "map datum section"
    n_d = struct.unpack_from("<H", data, pos)[0]
    if off < pos + fmt.DATUM_HEADER_SIZE:
        rel = off - pos
        return "map datum " + (
            "parameter count" if rel < 2 else "reserved" if rel < 4 else f"c_w[{(rel - 4) // 4}]"
        )
    pos += fmt.DATUM_HEADER_SIZE
    if n_d == fmt.MAP_DATUM_PARAMS:
        if off < pos + 4 * n_d * (n_d + 1) // 2:
            r, c = _tri_element((off - pos) // 4, n_d)
            return f"map datum covariance ({fmt.MAP_DATUM_NAMES[r]}, {fmt.MAP_DATUM_NAMES[c]})"
        pos += 4 * n_d * (n_d + 1) // 2
    if off < pos + fmt.INTEGRITY.size:
        return f"integrity.{_name(_INTEGRITY_FIELDS, off - pos)}"
    pos += fmt.INTEGRITY.size
    if off < pos + fmt.MOTION.size:
        return f"motion.{_name(_MOTION_FIELDS, off - pos)}"
    pos += fmt.MOTION.size
    return f"map index section, byte {off - pos}"


def _tri_element(e: int, n: int) -> tuple[int, int]:
    """(row, column) of element e of an n x n upper triangle stored row-major."""
    r = 0
    while e >= n - r:  # row r of the upper triangle holds n - r entries
        e -= n - r
        r += 1
    return r, r + e


def _param_name(i: int) -> str:
    k, p = divmod(i, len(fmt.CALIB_PARAM_NAMES))
    return f"{fmt.CAMERA_NAMES[k]}.{fmt.CALIB_PARAM_NAMES[p]}"


def check_table(data: bytes) -> LoadStatus:
    """Raise TableRefused unless the flight loader accepts data; the status when it does."""
    st = core().load(data)
    if not st.ok:
        raise TableRefused(st, field_at(data, st.offset))
    return st


def read_table(data: bytes) -> fmt.Table:
    """The table of bytes the flight loader accepts (parsed for display by format.decode)."""
    check_table(data)
    return fmt.decode(data)
