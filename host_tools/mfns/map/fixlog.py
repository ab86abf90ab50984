"""Reader of the fix record (docs/self_survey.md): the on-board log `mfns-nav --fixlog DIR`
writes (files fixlog_NNNNNN.tlm) or a telemetry recording (`mfns-ground --record`), both
streams of the link's wire frames. Every layout comes from the telemetry dictionary
(mfns.tlm.tlm_dict: offsets, wire types, calibrations); nothing here restates a packet.

A fix is the NAV packet of a usable cycle (its pose and covariance) joined with the FIXOBS
packets of the same cycle (one per association: camera, beacon survey id, measured centroid
and its covariance). A fix whose associations did not all arrive is left out (counted).
"""

from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.csv_formats import COV_COLUMNS, COV_PAIRS
from ..core.errors import MfnsError
from ..model.rotations import euler213_deg_to_matrix
from ..tlm import tlm_dict

# big-endian struct code of each wire type of the dictionary (tlm_dict.Field.wire_type)
_FMT = {"u8": "B", "u16": "H", "i16": "h", "u32": "I", "i32": "i", "f32": "f"}
USABLE = tlm_dict.usable_status_names()  # the nav statuses that carry a pose


@dataclass
class Fix:
    cycle: int
    t_s: float
    status: str
    C_w_b: np.ndarray  # (3, 3)
    r_wb_w: np.ndarray  # (3,) mm
    cov: np.ndarray  # (6, 6): x, y, z mm, rx, ry, rz deg (world axes), docs/telemetry.md
    camera: np.ndarray = field(default_factory=lambda: np.zeros(0, int))  # (M,)
    beacon_id: np.ndarray = field(default_factory=lambda: np.zeros(0, int))  # (M,)
    used: np.ndarray = field(default_factory=lambda: np.ones(0, bool))  # (M,) an inlier of the fix
    uv: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (M, 2) px
    cov_uv: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))  # (M, 2, 2) px^2


def unframe(data: bytes) -> list[bytes]:
    """CCSDS packets of a wire stream: split at 0x00, COBS-decode, check and strip the
    CRC-16/CCITT-FALSE (docs/telemetry.md 2). Frames that fail are left out."""
    out = []
    for frame in data.split(b"\0"):
        raw, i, ok = bytearray(), 0, bool(frame)
        while ok and i < len(frame):
            code = frame[i]
            if code == 0 or i + code > len(frame):
                ok = False
                break
            raw += frame[i + 1 : i + code]
            i += code
            if code < 0xFF and i < len(frame):
                raw.append(0)
        if (
            ok
            and len(raw) > 2
            and binascii.crc_hqx(bytes(raw[:-2]), 0xFFFF) == int.from_bytes(raw[-2:], "big")
        ):
            out.append(bytes(raw[:-2]))
    return out


def _header(d: tlm_dict.Dictionary, pkt: bytes) -> dict:
    bits = int.from_bytes(pkt[: sum(f.bits for f in d.header) // 8], "big")
    total = sum(f.bits for f in d.header)
    out, pos = {}, 0
    for f in d.header:
        v = (bits >> (total - pos - f.bits)) & ((1 << f.bits) - 1)
        out[f.param] = v * f.coefficient if f.coefficient is not None else v
        pos += f.bits
    return out


def decode(pkt: bytes, d: tlm_dict.Dictionary | None = None) -> tuple[str, float, dict] | None:
    """One CCSDS packet -> (container name, time s, {column: engineering value}), by the
    dictionary; None for an APID it does not define or a length that disagrees."""
    d = d or tlm_dict.load()
    h = _header(d, pkt)
    hlen = sum(f.bits for f in d.header) // 8
    try:
        p = d.by_apid(int(h["ccsds_apid"]))
    except StopIteration:
        return None
    if len(pkt) != hlen + p.payload_len:
        return None
    vals = {}
    for f in p.fields:
        (raw,) = struct.unpack_from(">" + _FMT[f.wire_type], pkt, hlen + f.offset)
        vals[f.name] = raw * f.coefficient if f.coefficient is not None else raw
    return p.name, float(h["time_coarse_s"]) + float(h["time_fine"]), vals


def _pose_cov(n: dict) -> np.ndarray:
    """The 21 upper-triangle entries (x, y, z, rx, ry, rz; row-major) -> (6, 6)."""
    c = np.zeros((6, 6))
    for (i, j), name in zip(COV_PAIRS, COV_COLUMNS, strict=True):
        c[i, j] = c[j, i] = n[name]
    return c


def fixes_from_packets(packets: list[bytes]) -> tuple[list[Fix], int]:
    """Join NAV and FIXOBS packets by cycle -> (complete fixes in order, incomplete ones)."""
    d = tlm_dict.load()
    status = d.labels("nav_status_t")
    navs: dict[int, tuple[float, dict]] = {}
    obs: dict[int, list[dict]] = {}
    for pkt in packets:
        got = decode(pkt, d)
        if got is None:
            continue
        name, t, v = got
        if name == "nav" and status.get(int(v["status"])) in USABLE:
            navs[int(v["cycle"])] = (t, v)
        elif name == "fixobs":
            obs.setdefault(int(v["cycle"]), []).append(v)
    fixes, incomplete = [], 0
    for cycle in sorted(obs):
        rows = obs[cycle]
        if cycle not in navs or len({r["index"] for r in rows}) != rows[0]["count"]:
            incomplete += 1
            continue
        t, n = navs[cycle]
        rows = sorted({r["index"]: r for r in rows}.values(), key=lambda r: r["index"])
        c = euler213_deg_to_matrix([n["roll_deg"], n["pitch_deg"], n["yaw_deg"]])
        fixes.append(
            Fix(
                cycle=cycle,
                t_s=t,
                status=status[int(n["status"])],
                C_w_b=c,
                r_wb_w=np.array([n["x_mm"], n["y_mm"], n["z_mm"]]),
                cov=_pose_cov(n),
                camera=np.array([int(r["camera"]) for r in rows]),
                beacon_id=np.array([int(r["beacon_id"]) for r in rows]),
                used=np.array([bool(r["used"]) for r in rows]),
                uv=np.array([[r["u_px"], r["v_px"]] for r in rows]),
                cov_uv=np.array(
                    [[[r["cov_uu_px2"], r["cov_uv_px2"]], [r["cov_uv_px2"], r["cov_vv_px2"]]] for r in rows]
                ),
            )
        )
    return fixes, incomplete


def log_files(path: Path) -> list[Path]:
    """A fixlog directory's files in their order, or the one file given."""
    path = Path(path)
    if path.is_dir():
        files = sorted(path.glob("fixlog_*.tlm"))
        if not files:
            raise MfnsError(f"{path}: no fixlog_*.tlm files (mfns-nav --fixlog DIR writes them)")
        return files
    if not path.is_file():
        raise MfnsError(f"{path}: no such fix log (a --fixlog directory or a telemetry recording)")
    return [path]


def read(path: Path) -> tuple[list[Fix], int]:
    """The fixes of a fix log (directory or file) -> (fixes, incomplete fixes left out)."""
    packets = []
    for f in log_files(path):
        packets += unframe(f.read_bytes())
    return fixes_from_packets(packets)
