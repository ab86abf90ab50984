"""The telemetry dictionary (XTCE mission database contract/mfns_tm.xml) for Python.

The file itself is contract/mfns_tm.xml (contract/README.md); the wheel carries a copy in
mfns/data (host_tools/setup.py), found by mfns.data.dictionary.

The XTCE file is the one definition of the telemetry packets: their CCSDS headers, every
parameter with its encoding, unit and calibration, and every numbered code (status, reason,
mode, camera state, event code, severity). This module reads it with the standard library
only, so the host tools take the codes' names from it instead of copying them, and it renders
the tables of docs/telemetry.md between their markers (``render_doc``, which ``make contracts``
runs; ``make contracts-check`` fails when the doc is stale). It also reads the telecommand dictionary
(``load_tc``). contract/gen_contracts.py generates the C codecs, codes, ground columns and doc tables
from both through this module (standard library only, so it runs before any venv exists).
"""

from __future__ import annotations

import re
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache, lru_cache
from pathlib import Path
from typing import Any

NS = {"x": "http://www.omg.org/spec/XTCE/20180204"}
_X = "{" + NS["x"] + "}"


def _req(e: ET.Element, path: str) -> ET.Element:
    """The element at PATH under E: a dictionary without it is malformed (a clear error, not None)."""
    found = e.find(path, NS)
    if found is None:
        raise ValueError(f"XTCE {e.get('name') or e.tag.removeprefix(_X)}: no {path}")
    return found


def _attr(e: ET.Element, name: str) -> str:
    """E's attribute NAME: a dictionary without it is malformed (a clear error, not None)."""
    v = e.get(name)
    if v is None:
        raise ValueError(f"XTCE {e.get('name') or e.tag.removeprefix(_X)}: no attribute {name}")
    return v


REPO = Path(__file__).resolve().parents[3]

# Framing per frame (docs/telemetry.md 2): CRC-16 (2), COBS overhead (1 below 254 bytes), 0x00.
FRAME_OVERHEAD = 4
CYCLE_HZ = 18.6
UART_BITS_PER_BYTE = 10  # 8N1
# Rates of the budget (docs/telemetry.md 5): frames per second of each packet.
RATES = {
    "nav": (CYCLE_HZ, "every cycle (18.6 Hz)"),
    "camera": (3 * CYCLE_HZ, "every cycle, one per camera (3 x 18.6 Hz)"),
    "housekeeping": (CYCLE_HZ / 19.0, "~1 Hz (every 19th cycle)"),
    "event": (1.0, "when it happens (budget: 1/s average)"),
    # the fix record (docs/self_survey.md): one fix of ~12 associations per second
    "fixobs": (12.0, "one fix per second, one per association (budget: 12/s)"),
}


def _dictionary(name: str) -> Path:
    """mfns.data.dictionary; loaded by path (contract/gen_contracts.py, no package), the
    repository's contract/ folder."""
    try:
        from mfns.data import dictionary
    except ImportError:
        return REPO / "contract" / name
    return dictionary(name)


def mdb_path() -> Path:
    """The XTCE file: contract/mfns_tm.xml, or the wheel's copy in mfns/data when installed."""
    return _dictionary("mfns_tm.xml")


@dataclass
class Field:
    param: str  # XTCE parameter name, e.g. nav_x_mm
    name: str  # the ground CSV column, e.g. x_mm
    type_name: str
    kind: str  # "int", "float" or "enum"
    bits: int
    encoding: str  # unsigned, twosComplement, IEEE754_1985
    coefficient: float | None  # engineering = raw * coefficient (None: raw)
    unit: str
    description: str
    enum: dict[int, tuple[str, str]] | None = None  # value -> (label, description)
    offset: int = 0  # bytes from the start of the payload (or packet, for the header)
    valid_range: tuple[float, float] | None = None  # raw (wire) inclusive bounds, XTCE ValidRange
    anc: dict[str, str] = field(default_factory=dict)  # the parameter's XTCE AncillaryData
    # the XTCE container the ground reads it in: the packet's own, or a part of it that
    # inherits it under a condition (nav_pose: only when nav_status is not NO_FIX). The bytes
    # are the same either way: the C codec and the CSV columns see one flat packet.
    container: str = ""

    @property
    def c_field(self) -> str:
        """The C struct member (firmware/tlm/generated/tlm_packets_gen.h), e.g. pos_um[0]."""
        return self.anc.get("c_field", self.name)

    @property
    def size(self) -> int:
        return self.bits // 8

    @property
    def wire_type(self) -> str:
        if self.encoding.startswith("IEEE754"):
            return f"f{self.bits}"
        return ("i" if self.encoding == "twosComplement" else "u") + str(self.bits)


@dataclass
class Packet:
    name: str
    apid: int
    description: str
    fields: list[Field] = field(default_factory=list)
    # its conditional parts: container -> (parameter, operator, value) of the XTCE restriction
    # under which the ground reads that part's fields (nav_pose: ("nav_status", "!=", "NO_FIX"))
    parts: dict[str, tuple[str, str, str]] = field(default_factory=dict)

    @property
    def payload_len(self) -> int:
        return sum(f.size for f in self.fields)

    def present(self, f: Field, values: Mapping[str, object]) -> bool:
        """Whether the ground reads field f in a packet of these values (parameter -> value,
        enumerations by label): the packet's own fields always, a part's when its restriction
        holds (nav_x_mm only when nav_status is not NO_FIX)."""
        cond = self.parts.get(f.container)
        if cond is None:
            return True
        param, op, value = cond
        return (str(values[param]) == value) == (op == "==")


@dataclass
class Dictionary:
    header: list[Field]
    packets: dict[str, Packet]
    enums: dict[str, dict[int, tuple[str, str]]]

    def by_apid(self, apid: int) -> Packet:
        return next(p for p in self.packets.values() if p.apid == apid)

    def labels(self, enum_type: str) -> dict[int, str]:
        return {v: lab for v, (lab, _) in self.enums[enum_type].items()}

    def parse_checked(self, definition, data: bytes) -> tuple[Packet, dict]:
        """One CCSDS packet parsed by an independent XTCE reader (space-packet-parser's
        `XtcePacketDefinition` of this dictionary) and held to the dictionary: a length
        mismatch is an error, except that a packet whose conditional part is not read (nav_pose
        on NO_FIX, Packet.parts) leaves exactly that part's bits and decodes none of its
        parameters. ValueError otherwise. Used by the host tests and the board test alike."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            parsed = definition.parse_bytes(data)
        packet = self.by_apid(int(parsed["ccsds_apid"]))
        read = [f for f in packet.fields if packet.present(f, parsed)]
        header_bits = sum(f.bits for f in self.header)
        left = 8 * len(data) - header_bits - sum(f.bits for f in read)
        expect = [f"Number of bits parsed ({8 * len(data) - left}b)"] if left else []
        got = [str(w.message) for w in caught]
        if len(got) != len(expect) or any(not g.startswith(e) for g, e in zip(got, expect, strict=False)):
            raise ValueError(f"{packet.name}: the XTCE reader warned {got}, expected {expect}")
        unread = [f.param for f in packet.fields if f not in read and f.param in parsed]
        if unread:
            raise ValueError(f"{packet.name}: parameters of an unread part decoded: {unread}")
        return packet, dict(parsed)


def _types(root: ET.Element) -> dict[str, dict]:
    out: dict[str, dict] = {}
    for t in _req(root, "x:TelemetryMetaData/x:ParameterTypeSet"):
        tag = t.tag.removeprefix(_X)
        enc = t.find("x:IntegerDataEncoding", NS)
        e = enc if enc is not None else _req(t, "x:FloatDataEncoding")
        unit = t.find("x:UnitSet/x:Unit", NS)
        term = t.find(".//x:PolynomialCalibrator/x:Term[@exponent='1']", NS)
        vr = t.find("x:ValidRange", NS)
        info: dict[str, Any] = {  # one type's fields, heterogeneous (read into Field / Arg)
            "valid_range": (float(_attr(vr, "minInclusive")), float(_attr(vr, "maxInclusive")))
            if vr is not None
            else None,
            "kind": {"IntegerParameterType": "int", "FloatParameterType": "float"}.get(tag, "enum"),
            "bits": int(_attr(e, "sizeInBits")),
            "encoding": e.get("encoding", "unsigned" if enc is not None else "IEEE754"),
            "coefficient": float(_attr(term, "coefficient")) if term is not None else None,
            "unit": unit.text if unit is not None else "",
            "description": t.get("shortDescription", ""),
            "enum": None,
        }
        if tag == "EnumeratedParameterType":
            info["enum"] = {
                int(_attr(x, "value")): (_attr(x, "label"), x.get("shortDescription", ""))
                for x in t.findall("x:EnumerationList/x:Enumeration", NS)
            }
        out[_attr(t, "name")] = info
    return out


def _fields(container: ET.Element, params: dict, types: dict, prefix: str, off: int = 0) -> list[Field]:
    out = []
    for entry in container.findall("x:EntryList/x:ParameterRefEntry", NS):
        pname = _attr(entry, "parameterRef")
        tname, desc, anc = params[pname]
        t = types[tname]
        f = Field(
            param=pname,
            name=pname.removeprefix(prefix),
            type_name=tname,
            kind=t["kind"],
            bits=t["bits"],
            encoding=t["encoding"],
            coefficient=t["coefficient"],
            unit=t["unit"],
            description=desc,
            enum=t["enum"],
            offset=off // 8,
            valid_range=t["valid_range"],
            anc=anc,
            container=_attr(container, "name"),
        )
        off += f.bits
        out.append(f)
    return out


def _ancillary(e: ET.Element) -> dict[str, str]:
    return {_attr(a, "name"): (a.text or "") for a in e.findall("x:AncillaryDataSet/x:AncillaryData", NS)}


PREFIX = {"nav": "nav_", "camera": "cam_", "housekeeping": "hk_", "event": "evt_", "fixobs": "fix_"}


@lru_cache(maxsize=4)
def load(path: str | None = None) -> Dictionary:
    root = ET.parse(path or mdb_path()).getroot()
    types = _types(root)
    params = {
        _attr(p, "name"): (_attr(p, "parameterTypeRef"), p.get("shortDescription", ""), _ancillary(p))
        for p in root.findall("x:TelemetryMetaData/x:ParameterSet/x:Parameter", NS)
    }
    header: list[Field] = []
    packets: dict[str, Packet] = {}
    for c in root.findall("x:TelemetryMetaData/x:ContainerSet/x:SequenceContainer", NS):
        name = _attr(c, "name")
        if c.get("abstract") == "true":
            header = _fields(c, params, types, "")
            continue
        base = _attr(_req(c, "x:BaseContainer"), "containerRef")
        if base in packets:  # a conditional part of a packet (nav_pose): its fields follow the parent's
            parent = packets[base]
            parent.fields += _fields(c, params, types, PREFIX[base], 8 * parent.payload_len)
            cmp = _req(c, "x:BaseContainer/x:RestrictionCriteria/x:Comparison")
            op = cmp.get("comparisonOperator", "==")
            if op not in ("==", "!="):
                raise ValueError(f"{name}: restriction operator {op} (this reader knows == and !=)")
            parent.parts[name] = (_attr(cmp, "parameterRef"), op, _attr(cmp, "value"))
            continue
        apid = int(_attr(_req(c, "x:BaseContainer/x:RestrictionCriteria/x:Comparison"), "value"))
        packets[name] = Packet(
            name, apid, c.get("shortDescription", ""), _fields(c, params, types, PREFIX[name])
        )
    enums = {n: t["enum"] for n, t in types.items() if t["enum"] is not None}
    return Dictionary(header, packets, enums)


# --------------------------------------------------------------------------- telecommands
def tc_mdb_path() -> Path:
    """The telecommand XTCE: contract/mfns_tc.xml, or the wheel's copy (like the telemetry one)."""
    return _dictionary("mfns_tc.xml")


@dataclass
class Arg:
    name: str  # XTCE argument name, e.g. x_mm
    type_name: str
    kind: str  # "int", "enum", "string" or "binary" (a fixed-size block of bytes)
    bits: int
    signed: bool
    description: str
    valid_range: tuple[int, int] | None = None  # inclusive, XTCE ValidRange
    enum: dict[int, tuple[str, str]] | None = None
    offset: int = 0  # bytes from the start of the arguments
    anc: dict[str, str] = field(default_factory=dict)
    unit: str = ""
    scale: float = 1.0  # engineering units per wire count (XTCE calibrator), e.g. 0.001 mm

    @property
    def size(self) -> int:
        return self.bits // 8

    @property
    def c_field(self) -> str:
        """Its member of tc_cmd_t.u (firmware/tlm/tc_packets.h), e.g. pose.pos_um[0]."""
        return self.anc.get("c_field", self.name)


@dataclass
class Command:
    name: str
    opcode: int
    description: str
    args: list[Arg] = field(default_factory=list)

    @property
    def arg_len(self) -> int:
        return sum(a.size for a in self.args)


@dataclass
class TcDictionary:
    apid: int
    header: list[tuple[str, int]]  # (argument, bits) of the abstract header, in order
    commands: dict[str, Command]  # by opcode order
    statuses: dict[int, tuple[str, str]]  # tc_status_t: value -> (label, description)


def _tc_types(root: ET.Element) -> dict[str, dict]:
    out: dict[str, dict] = {}
    for t in _req(root, "x:CommandMetaData/x:ArgumentTypeSet"):
        tag = t.tag.removeprefix(_X)
        vr = t.find("x:ValidRangeSet/x:ValidRange", NS)
        unit = t.find("x:UnitSet/x:Unit", NS)
        info: dict[str, Any] = {  # one type's fields, heterogeneous (read into Field / Arg)
            "description": t.get("shortDescription", ""),
            "enum": None,
            "unit": unit.text if unit is not None else "",
        }
        # an argument in engineering units (mm, deg) carried as an integer count: its calibrator
        # maps the engineering value to the count (Yamcs' direction for arguments), so its
        # coefficient is counts per unit; the range is in units; ranges and C checks are in counts
        term = t.find(
            "x:IntegerDataEncoding/x:DefaultCalibrator/x:PolynomialCalibrator/x:Term[@exponent='1']", NS
        )
        per_unit = float(_attr(term, "coefficient")) if term is not None else 1.0
        info["scale"] = 1.0 / per_unit
        if vr is None:
            info["range"] = None
        elif term is None:
            info["range"] = (int(_attr(vr, "minInclusive")), int(_attr(vr, "maxInclusive")))
        else:
            info["range"] = tuple(
                round(float(_attr(vr, k)) * per_unit) for k in ("minInclusive", "maxInclusive")
            )
        if tag in ("StringArgumentType", "BinaryArgumentType"):  # binary: the security trailer (MAC)
            kind = "string" if tag == "StringArgumentType" else "binary"
            info.update(kind=kind, bits=int(_req(t, ".//x:FixedValue").text or ""), signed=False)
        else:
            enc = _req(t, "x:IntegerDataEncoding")
            info.update(
                kind="enum" if tag == "EnumeratedArgumentType" else "int",
                bits=int(_attr(enc, "sizeInBits")),
                signed=enc.get("encoding") == "twosComplement",
            )
        if tag == "EnumeratedArgumentType":
            info["enum"] = {
                int(_attr(x, "value")): (_attr(x, "label"), x.get("shortDescription", ""))
                for x in t.findall("x:EnumerationList/x:Enumeration", NS)
            }
        out[_attr(t, "name")] = info
    return out


@lru_cache(maxsize=4)
def load_tc(path: str | None = None) -> TcDictionary:
    root = ET.parse(path or tc_mdb_path()).getroot()
    types = _tc_types(root)
    statuses = {
        int(_attr(x, "value")): (_attr(x, "label"), x.get("shortDescription", ""))
        for x in root.findall(
            "x:TelemetryMetaData/x:ParameterTypeSet/x:EnumeratedParameterType[@name='tc_status_t']//x:Enumeration",
            NS,
        )
    }
    opcodes = {lab: v for v, (lab, _) in types["opcode_t"]["enum"].items()}
    header: list[tuple[str, int]] = []
    cmds: list[Command] = []
    apid: int | None = None
    for mc in root.findall("x:CommandMetaData/x:MetaCommandSet/x:MetaCommand", NS):
        decl = {_attr(a, "name"): a for a in mc.findall("x:ArgumentList/x:Argument", NS)}
        order = [
            _attr(e, "argumentRef")
            for e in mc.findall("x:CommandContainer/x:EntryList/x:ArgumentRefEntry", NS)
        ]
        if sorted(order) != sorted(decl):
            raise ValueError(f"{mc.get('name')}: every argument must be placed exactly once")
        if mc.get("abstract") == "true":
            header = [(n, types[_attr(decl[n], "argumentTypeRef")]["bits"]) for n in order]
            continue
        assign = {
            _attr(a, "argumentName"): _attr(a, "argumentValue")
            for a in mc.findall(".//x:ArgumentAssignment", NS)
        }
        apid = int(assign["ccsds_apid"])
        cmd = Command(_attr(mc, "name"), opcodes[assign["opcode"]], mc.get("shortDescription", ""))
        off = 0
        for n in order:
            tname = _attr(decl[n], "argumentTypeRef")
            t = types[tname]
            a = Arg(
                n,
                tname,
                t["kind"],
                t["bits"],
                t["signed"],
                decl[n].get("shortDescription") or t["description"],
                t["range"],
                t["enum"],
                off // 8,
                _ancillary(decl[n]),
                t["unit"],
                t.get("scale", 1.0),
            )
            off += t["bits"]
            cmd.args.append(a)
        if int(assign["ccsds_length"]) != 2 + cmd.arg_len - 1:
            raise ValueError(f"{cmd.name}: ccsds_length disagrees with its arguments")
        cmds.append(cmd)
    if apid is None:
        raise ValueError("XTCE: no telecommand (the ccsds_apid is given by the commands)")
    cmds.sort(key=lambda c: c.opcode)
    return TcDictionary(apid, header, {c.name: c for c in cmds}, statuses)


def reason_names() -> tuple[str, ...]:
    """Reason code -> name (firmware/nav/pose/pose.h mfns_pose_reason_t), as a tuple indexed by code."""
    r = load().labels("nav_reason_t")
    assert sorted(r)[0] == 0, "reason codes start at 0"
    # a code a parallel branch holds (each appends only in its own range) is named, never shifted
    return tuple(r.get(k, f"RESERVED_{k}") for k in range(max(r) + 1))


def usable_status_names() -> tuple[str, ...]:
    """The nav statuses that carry a usable pose (all but NO_FIX)."""
    return tuple(lab for v, lab in sorted(load().labels("nav_status_t").items()) if lab != "NO_FIX")


# --------------------------------------------------------------------------- event text
EVENT_NAMERS = (
    "camera_when",
    "mode_when",
    "beacon_when",
    "tc_opcode_when",
    "tc_status_when",
    "table_status_when",
)


def event_decoders(d: Dictionary | None = None) -> dict[str, dict[str, str]]:
    """For the event's subject, arg0 and arg1: event code label -> what the number names
    (`camera`, `mode`, `beacon`, `tc_opcode`, `tc_status`), from the AncillaryData of
    evt_subject / evt_arg0 / evt_arg1 in mfns_tm.xml (its header says what each means)."""
    d = d or load()
    fields = {f.param: f for p in d.packets.values() for f in p.fields}
    out: dict[str, dict[str, str]] = {}
    for slot, pname in (("subject", "evt_subject"), ("arg0", "evt_arg0"), ("arg1", "evt_arg1")):
        per: dict[str, str] = {}
        for key in EVENT_NAMERS:
            for code in fields[pname].anc.get(key, "").split():
                assert code not in per, f"{pname}: {code} named twice"
                per[code] = key.removesuffix("_when")
        out[slot] = per
    return out


@cache
def _event_names():
    d = load()
    tc = load_tc()
    dec = event_decoders(d)
    arg1 = next(f for p in d.packets.values() for f in p.fields if f.param == "evt_arg1")
    for code in arg1.anc.get("ground_hex_when", "").split():  # a CRC-32, as events.csv prints it
        dec["arg1"].setdefault(code, "hex")
    return (
        dec,
        d.labels("camera_id_t"),
        d.labels("mode_t"),
        {c.opcode: c.name for c in tc.commands.values()},
        {v: lab for v, (lab, _desc) in tc.statuses.items()},
    )


@cache
def _table_status(code: int) -> str:
    """The loader's own words for a table status (the C core: mfns_caltable_strerror), with the
    number; the number alone when the core library is not there."""
    try:
        from ..core import binding

        text = binding.load().mfns_caltable_strerror(int(code)).decode()
    except Exception:  # no core library: the number is still right
        return str(code)
    return f"{code} ({text})"


def event_args(code: str, subject: int, arg0: int, arg1: int) -> dict[str, str]:
    """An event's subject and arguments as an operator reads them: camera names (x|y|z), modes,
    beacons (`beacon 12`), commands and rejection codes by name; a number without a name
    stays a number (e.g. a loader error code: no dictionary names them)."""
    dec, cams, modes, opcodes, statuses = _event_names()
    out = {}
    for slot, v in (("subject", subject), ("arg0", arg0), ("arg1", arg1)):
        kind = dec[slot].get(code)
        v = int(v)
        if kind == "camera":
            out[slot] = f"camera {cams.get(v, v)}"
        elif kind == "mode":
            out[slot] = modes.get(v, str(v))
        elif kind == "beacon":
            out[slot] = f"beacon {v}" + (" (id above 254)" if slot == "subject" and v == 255 else "")
        elif kind == "tc_opcode":
            out[slot] = opcodes.get(v, f"opcode {v}")
        elif kind == "tc_status":
            out[slot] = statuses.get(v, str(v))
        elif kind == "table_status":
            out[slot] = _table_status(v)
        elif kind == "hex":
            out[slot] = f"0x{v & 0xFFFFFFFF:08x}"
        else:
            out[slot] = str(v)
    return out


def event_text(code: str, subject: int, arg0: int, arg1: int) -> str:
    """One line: `CAMERA_LOST camera y: arg0 -5, arg1 12`; MODE_CHANGE `TRACK -> STANDBY`."""
    a = event_args(code, subject, arg0, arg1)
    if code == "MODE_CHANGE":
        return f"MODE_CHANGE {a['arg0']} -> {a['arg1']} (reason {a['subject']})"
    if code == "CMD_REJECTED":
        return f"CMD_REJECTED {a['subject']} (sequence count {a['arg0']}): {a['arg1']}"
    if code == "CMD_ACCEPTED":
        return f"CMD_ACCEPTED {a['subject']} (sequence count {a['arg0']})"
    dec = _event_names()[0]
    head = f"{code} {a['subject']}" if code in dec["subject"] else f"{code} subject {a['subject']}"
    return f"{head}: arg0 {a['arg0']}, arg1 {a['arg1']}"


# --------------------------------------------------------------------------- doc tables
def _num(x: float) -> str:
    return f"{x:g}"


def _unit(f: Field) -> str:
    if f.enum is not None:
        if len(f.enum) > 6:
            return f"code: {f.type_name} (table below)"
        return ", ".join(f"{v} {lab}" for v, (lab, _) in sorted(f.enum.items()))
    if f.coefficient is not None:
        raw = "2^-30" if abs(f.coefficient - 2.0**-30) < 1e-20 else _num(f.coefficient)
        return f"{f.unit} (count x {raw})"
    return f.unit


def _payload_table(p: Packet) -> str:
    rows = ["| off | size | type | field | unit / codes | meaning |", "|---|---|---|---|---|---|"]
    for f in p.fields:
        rows.append(f"| {f.offset} | {f.size} | {f.wire_type} | {f.name} | {_unit(f)} | {f.description} |")
    return "\n".join(rows)


def _header_table(d: Dictionary) -> str:
    rows = ["| bits | field | meaning |", "|---|---|---|"]
    bit = 0
    for f in d.header:
        rows.append(f"| {bit}-{bit + f.bits - 1} | {f.param} | {f.description} |")
        bit += f.bits
    return "\n".join(rows)


def _apid_table(d: Dictionary) -> str:
    rows = [
        "| APID | packet | rate | payload bytes | packet bytes | wire bytes |",
        "|---|---|---|---|---|---|",
    ]
    for p in d.packets.values():
        n = 12 + p.payload_len
        rows.append(
            f"| 0x{p.apid:03X} | {p.name}: {p.description} | {RATES[p.name][1]} | {p.payload_len} | {n} "
            f"| {n + FRAME_OVERHEAD} |"
        )
    return "\n".join(rows)


def _enum_table(d: Dictionary, enum_type: str, head: str) -> str:
    rows = [f"| code | name | {head} |", "|---|---|---|"]
    for v, (lab, desc) in sorted(d.enums[enum_type].items()):
        rows.append(f"| {v} | {lab} | {desc} |")
    return "\n".join(rows)


def budget(d: Dictionary | None = None) -> dict:
    d = d or load()
    streams, total_bps, total_fps = [], 0.0, 0.0
    for p in d.packets.values():
        wire = 12 + p.payload_len + FRAME_OVERHEAD
        fps = RATES[p.name][0]
        streams.append((p.name, wire, fps, wire * fps))
        total_bps += wire * fps
        total_fps += fps
    wire_of = {n: w for n, w, _, _ in streams}
    per_cycle = wire_of["nav"] + 3 * wire_of["camera"]  # what one cycle sends
    return {"streams": streams, "bytes_per_s": total_bps, "frames_per_s": total_fps, "per_cycle": per_cycle}


def _budget_table(d: Dictionary) -> str:
    b = budget(d)
    rows = ["| stream | bytes/frame (wire) | frames/s | bytes/s |", "|---|---|---|---|"]
    for name, wire, fps, bps in b["streams"]:
        rows.append(f"| {name} | {wire} | {fps:.2f} | {bps:.1f} |")
    rows.append(
        f"| **total** | | {b['frames_per_s']:.1f} | **{b['bytes_per_s']:.1f}** "
        f"({b['bytes_per_s'] * 8 / 1000:.1f} kbit/s) |"
    )
    rows += [
        "",
        f"| baud | capacity (bytes/s) | load | per 53.8-ms cycle: {b['per_cycle']} bytes take |",
        "|---|---|---|---|",
    ]
    for baud in (115200, 921600):
        cap = baud / UART_BITS_PER_BYTE
        rows.append(
            f"| {baud} | {cap:.0f} | **{100 * b['bytes_per_s'] / cap:.1f} %** "
            f"| {1000 * b['per_cycle'] / cap:.1f} ms |"
        )
    return "\n".join(rows)


def tables(d: Dictionary | None = None) -> dict[str, str]:
    """Every generated table of docs/telemetry.md, by marker name."""
    d = d or load()
    return {
        "header": _header_table(d),
        "apids": _apid_table(d),
        "nav": _payload_table(d.packets["nav"]),
        "camera": _payload_table(d.packets["camera"]),
        "housekeeping": _payload_table(d.packets["housekeeping"]),
        "event": _payload_table(d.packets["event"]),
        "event_codes": _enum_table(d, "event_code_t", "subject, arg0, arg1"),
        "reasons": _enum_table(d, "nav_reason_t", "meaning"),
        "budget": _budget_table(d),
    }


_MARK = re.compile(r"(<!-- BEGIN tlm_dict:(\w+) -->\n)(.*?)(<!-- END tlm_dict:\2 -->)", re.S)


def render_doc(text: str, d: Dictionary | None = None) -> str:
    """text with every marked table replaced by the dictionary's; unknown markers raise."""
    t = tables(d)
    seen = set()

    def sub(m: re.Match) -> str:
        seen.add(m.group(2))
        return m.group(1) + t[m.group(2)] + "\n" + m.group(4)

    out = _MARK.sub(sub, text)
    missing = set(t) - seen
    if missing:
        raise ValueError(f"docs/telemetry.md lacks the markers of {sorted(missing)}")
    return out
