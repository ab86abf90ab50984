"""The telecommand dictionary contract/mfns_tc.xml (XTCE), the master, against the C codec
generated from it (firmware/tlm/generated/tc_codes_gen.h, tc_packets_gen.c by contract/gen_contracts.py,
through the core shared library): any difference fails, so these test the generator's output.

Checked: the schema; the opcode names and numbers; per command, the argument layout
(order, sizes, signedness) by packing a packet from the XTCE alone and comparing it
byte for byte with the C encoder's, and decoding it with the C decoder; the header
assignments (version, type, secondary header flag, APID, sequence flags, length);
every argument range (C accepts exactly the XTCE's valid values, at and beyond each
bound); and the rejection codes (XTCE tc_status_t = C tc_status_name).
"""

from __future__ import annotations

import ctypes as ct
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from mfns.core.binding import TC_PATH_MAX as PATH_MAX
from mfns.core.binding import TcCmd as Cmd
from mfns.core.binding import load as load_core

REPO = Path(__file__).resolve().parents[2]
TC_XML = REPO / "contract" / "mfns_tc.xml"
NS = {"x": "http://www.omg.org/spec/XTCE/20180204"}


@pytest.fixture(scope="module")
def lib(core_lib):
    if not core_lib.exists():
        pytest.fail(f"{core_lib} missing: run `make lib`")
    return load_core(core_lib)  # tc_cmd_t is binding.TcCmd, held to tc_packets.h by make lib


def tree():
    return ET.parse(TC_XML).getroot()


def arg_types(root) -> dict[str, dict]:
    """name -> {bits, signed, kind, range, enum}."""
    out = {}
    for t in root.find("x:CommandMetaData/x:ArgumentTypeSet", NS):
        kind = t.tag.split("}")[1]
        d = {"kind": kind, "range": None, "enum": None}
        if kind in ("StringArgumentType", "BinaryArgumentType"):  # binary: the MAC trailer (tc_mac_t)
            d["bits"] = int(t.find(".//x:FixedValue", NS).text)
            d["signed"] = False
        else:
            enc = t.find("x:IntegerDataEncoding", NS)
            d["bits"] = int(enc.get("sizeInBits"))
            d["signed"] = enc.get("encoding") == "twosComplement"
        vr = t.find("x:ValidRangeSet/x:ValidRange", NS)
        # engineering units (mm, deg) carried as integer counts: the calibrator maps the value to
        # the count (counts per unit, Yamcs' direction for arguments), the range is in units;
        # here both are in counts
        term = t.find("x:IntegerDataEncoding/x:DefaultCalibrator/x:PolynomialCalibrator/x:Term", NS)
        per_unit = float(term.get("coefficient")) if term is not None else None
        if vr is not None:
            lo, hi = vr.get("minInclusive"), vr.get("maxInclusive")
            d["range"] = (
                (int(lo), int(hi))
                if per_unit is None
                else (round(float(lo) * per_unit), round(float(hi) * per_unit))
            )
        if kind == "EnumeratedArgumentType":
            d["enum"] = {e.get("label"): int(e.get("value")) for e in t.find("x:EnumerationList", NS)}
        out[t.get("name")] = d
    return out


def commands(root) -> tuple[list[tuple[str, str]], dict[str, dict]]:
    """The abstract header's (name, type) layout and each concrete command's
    assignments and own (name, type) arguments in container order."""
    mcs = root.find("x:CommandMetaData/x:MetaCommandSet", NS)
    header: list[tuple[str, str]] = []
    cmds: dict[str, dict] = {}
    for mc in mcs:
        args = {a.get("name"): a.get("argumentTypeRef") for a in mc.findall("x:ArgumentList/x:Argument", NS)}
        order = [
            e.get("argumentRef") for e in mc.findall("x:CommandContainer/x:EntryList/x:ArgumentRefEntry", NS)
        ]
        assert sorted(order) == sorted(args), mc.get("name")  # every argument placed exactly once
        if mc.get("abstract") == "true":
            header = [(n, args[n]) for n in order]
            continue
        base = mc.find("x:BaseMetaCommand", NS)
        assert base is not None and base.get("metaCommandRef") == "MFNS_TC"
        assert mc.find("x:CommandContainer/x:BaseContainer", NS).get("containerRef") == "MFNS_TC_header"
        assign = {
            a.get("argumentName"): a.get("argumentValue") for a in base.findall(".//x:ArgumentAssignment", NS)
        }
        cmds[mc.get("name")] = {"assign": assign, "args": [(n, args[n]) for n in order]}
    return header, cmds


def pack(fields: list[tuple[int, int, bool]]) -> bytes:
    """(value, bits, signed) big-endian, bit-packed, as XTCE lays them out."""
    acc, nbits = 0, 0
    for v, bits, signed in fields:
        if signed and v < 0:
            v += 1 << bits
        assert 0 <= v < (1 << bits)
        acc = (acc << bits) | v
        nbits += bits
    assert nbits % 8 == 0
    return acc.to_bytes(nbits // 8, "big")


def xtce_packet(header, cmd, types, values: dict, seq: int) -> bytes:
    """The packet built from the XTCE alone."""
    fields = []
    for name, tname in header:
        t = types[tname]
        raw = seq if name == "ccsds_seq_count" else cmd["assign"][name]
        v = t["enum"][raw] if t["enum"] and raw in t["enum"] else int(raw)
        fields.append((v, t["bits"], t["signed"]))
    out = pack(fields)
    for name, tname in cmd["args"]:
        t = types[tname]
        v = values[name]
        if t["kind"] == "StringArgumentType":
            b = v.encode()
            out += b + bytes(t["bits"] // 8 - len(b))
        elif t["kind"] == "BinaryArgumentType":  # a fixed-size block, as given
            assert len(v) == t["bits"] // 8, name
            out += bytes(v)
        else:
            out += pack([(t["enum"][v] if t["enum"] else v, t["bits"], t["signed"])])
    return out


def c_cmd(lib, name: str, values: dict) -> Cmd:
    c = Cmd()
    opcode = next(i for i in range(256) if lib.tc_opcode_name(i).decode() == name)
    c.opcode = opcode
    if "mode" in values:
        c.u.mode = {"ACQUIRE": 1, "TRACK": 2, "STANDBY": 4}.get(values["mode"], values["mode"])
    if "camera" in values:
        c.u.camera = {"x": 0, "y": 1, "z": 2}.get(values["camera"], values["camera"])
    if "x_mm" in values:  # the counts on the wire (um, udeg)
        for i, k in enumerate(("x_mm", "y_mm", "z_mm")):
            c.u.pose.pos_um[i] = values[k]
        for i, k in enumerate(("roll_deg", "pitch_deg", "yaw_deg")):
            c.u.pose.att_udeg[i] = values[k]
    if "path" in values:
        c.u.path = values["path"].encode()
    if name == "UPLOAD_START":
        c.u.upload_start.size = values["size"]
        c.u.upload_start.crc32 = values["crc32"]
        c.u.upload_start.name = values["name"].encode()
    if name == "UPLOAD_DATA":
        c.u.upload_data.offset = values["offset"]
        c.u.upload_data.len = values["length"]
        c.u.upload_data.bytes[:] = list(values["data"])
    return c


def c_encode(lib, c: Cmd, seq: int) -> tuple[int, bytes]:
    buf = ct.create_string_buffer(256)
    n = ct.c_size_t(0)
    rc = lib.tc_packet_encode(ct.byref(c), seq, buf, 256, ct.byref(n))
    return rc, buf.raw[: n.value]


def c_decode(lib, pkt: bytes) -> tuple[int, Cmd]:
    c = Cmd()
    rc = lib.tc_packet_decode(pkt, len(pkt), ct.byref(c))
    return rc, c


SAMPLES = {
    "NOOP": {},
    "RESET_COUNTERS": {},
    "SET_MODE": {"mode": "STANDBY"},
    "SET_POSE_HINT": {
        "x_mm": 480741,  # counts: 480.741 mm
        "y_mm": -276091,
        "z_mm": 1000000000,
        "roll_deg": -180000000,  # counts: -180 deg
        "pitch_deg": 89999999,
        "yaw_deg": 168279078,
    },
    "CAMERA_ENABLE": {"camera": "z"},
    "CAMERA_DISABLE": {"camera": "x"},
    "TABLE_LOAD": {"path": "/data/tables/next.mfnstbl"},
    "UPLOAD_START": {"size": 106780, "crc32": 0x9A521E07, "name": "table2.mfnstbl"},
    # every byte value, the last ones past length (they travel, the board ignores them)
    "UPLOAD_DATA": {
        "offset": 0xFEDCBA98,
        "length": 200,
        "data": bytes((i * 7 + 3) & 0xFF for i in range(200)),
    },
    "UPLOAD_END": {},
    "UPLOAD_ABORT": {},
}


def test_schema_valid():
    from space_packet_parser.xtce.validation import validate_xtce

    # level "schema": the library's structural pass knows telemetry containers only
    # (it reads a command container's BaseContainer as a missing SequenceContainer)
    res = validate_xtce(
        TC_XML, level="schema", allow_schema_download=False, raise_on_error=False, print_results=False
    )
    assert res, str(res)


def test_opcodes_match(lib):
    types = arg_types(tree())
    xtce = types["opcode_t"]["enum"]
    c = {lib.tc_opcode_name(i).decode(): i for i in range(256) if lib.tc_opcode_name(i).decode() != "?"}
    assert xtce == c
    _, cmds = commands(tree())
    assert set(cmds) == set(c)  # one MetaCommand per opcode
    assert set(SAMPLES) == set(c)


def test_every_command_layout_is_bit_identical(lib):
    root = tree()
    types = arg_types(root)
    header, cmds = commands(root)
    assert [n for n, _ in header] == [
        "ccsds_version", "ccsds_type", "ccsds_sec_hdr", "ccsds_apid", "ccsds_seq_flags",
        "ccsds_seq_count", "ccsds_length", "opcode", "reserved",
    ]  # fmt: skip
    for name, cmd in cmds.items():
        opcode = types["opcode_t"]["enum"][name]
        arg_bits = sum(types[t]["bits"] for _, t in cmd["args"])
        assert lib.tc_arg_len(opcode) * 8 == arg_bits, name
        assert cmd["assign"]["opcode"] == name
        for seq in (0, 1, 0x1234, 16383):
            want = xtce_packet(header, cmd, types, SAMPLES[name], seq)
            assert int(cmd["assign"]["ccsds_length"]) == len(want) - 7, name  # CCSDS: bytes after header - 1
            rc, got = c_encode(lib, c_cmd(lib, name, SAMPLES[name]), seq)
            assert rc == 0, (name, rc)
            assert got == want, (name, got.hex(), want.hex())
            rc, back = c_decode(lib, want)
            assert rc == 0, (name, lib.tc_status_name(rc))
            assert back.opcode == opcode and back.seq == seq and back.have_seq and back.have_opcode


def status_code(lib, label: str) -> int:
    return next(i for i in range(64) if lib.tc_status_name(i).decode() == label)


def test_argument_ranges_match(lib):
    """C accepts exactly the values the XTCE calls valid, at and around each bound."""
    root = tree()
    types = arg_types(root)
    header, cmds = commands(root)
    arg_err = status_code(lib, "ARG")
    for name, cmd in cmds.items():
        for aname, tname in cmd["args"]:
            t = types[tname]
            if t["kind"] in ("StringArgumentType", "BinaryArgumentType"):
                continue  # strings: test_path_rules, test_upload_name_rules; a binary block has no range
            if t["enum"]:
                candidates = range(256)
                valid = set(t["enum"].values())
            elif t["range"] is None:  # an integer without a ValidRange: every value valid
                candidates = [0, 1, (1 << t["bits"]) - 1]
                valid = set(candidates)
            else:
                lo, hi = t["range"]
                candidates = [lo - 1, lo, lo + 1, 0, hi - 1, hi, hi + 1]
                candidates = [v for v in candidates if -(1 << 31) <= v < (1 << 31) if t["signed"] or v >= 0]
                candidates = [v for v in candidates if v < (1 << t["bits"])]
                valid = {v for v in candidates if lo <= v <= hi}
            for v in candidates:
                vals = dict(SAMPLES[name])
                vals[aname] = v if not t["enum"] else next((k for k, x in t["enum"].items() if x == v), None)
                raw = dict(vals)
                if t["enum"] and raw[aname] is None:
                    # not in the enumeration: pack the raw number
                    types_raw = dict(types)
                    types_raw[tname] = {**t, "enum": None}
                    raw[aname] = v
                    pkt = xtce_packet(header, cmd, types_raw, raw, 5)
                else:
                    pkt = xtce_packet(header, cmd, types, vals, 5)
                rc, _ = c_decode(lib, pkt)
                assert (rc == 0) == (v in valid), (name, aname, v, rc)
                if rc != 0:
                    assert rc == arg_err


def test_path_rules(lib):
    """TABLE_LOAD: 1..63 printable characters, NUL-padded (the XTCE's fixed 512-bit string)."""
    root = tree()
    types = arg_types(root)
    header, cmds = commands(root)
    assert types["path_t"]["bits"] == PATH_MAX * 8
    cmd = cmds["TABLE_LOAD"]
    for path, ok in (("a", True), ("x" * 63, True), ("", False), ("\x01bad", False), ("t\x7f", False)):
        pkt = xtce_packet(header, cmd, types, {"path": path}, 1)
        rc, back = c_decode(lib, pkt)
        assert (rc == 0) == ok, (path, rc)
        if ok:
            assert back.u.path.decode() == path


def test_upload_name_rules(lib):
    """UPLOAD_START's name: 1..31 printable characters, NUL-padded to 32 bytes (the XTCE's
    fixed 256-bit string); the board's receiver is stricter (UPLOAD_NAME, nav_upload.h)."""
    root = ET.parse(TC_XML).getroot()
    types = arg_types(root)
    header, cmds = commands(root)
    assert types["upload_name_t"]["bits"] == 32 * 8
    cmd = cmds["UPLOAD_START"]
    for name, ok in (("a", True), ("x" * 31, True), ("", False), ("t\x01", False)):
        pkt = xtce_packet(header, cmd, types, {"size": 1, "crc32": 2, "name": name}, 1)
        rc, back = c_decode(lib, pkt)
        assert (rc == 0) == ok, (name, rc)
        if ok:
            assert back.u.upload_start.name.decode() == name and back.u.upload_start.size == 1


def test_upload_data_carries_its_block(lib):
    """UPLOAD_DATA's 200-byte block decodes byte for byte; length outside 1..200 is ARG."""
    root = ET.parse(TC_XML).getroot()
    types = arg_types(root)
    header, cmds = commands(root)
    vals = dict(SAMPLES["UPLOAD_DATA"])
    rc, back = c_decode(lib, xtce_packet(header, cmds["UPLOAD_DATA"], types, vals, 9))
    assert (
        rc == 0
        and bytes(back.u.upload_data.bytes) == vals["data"]
        and back.u.upload_data.offset == vals["offset"]
    )
    for n, ok in ((0, False), (1, True), (200, True), (201, False)):
        rc, _ = c_decode(lib, xtce_packet(header, cmds["UPLOAD_DATA"], types, {**vals, "length": n}, 9))
        assert (rc == 0) == ok, (n, rc)


def test_rejection_codes_match(lib):
    root = tree()
    t = root.find(".//x:EnumeratedParameterType[@name='tc_status_t']", NS)
    xtce = {int(e.get("value")): e.get("label") for e in t.find("x:EnumerationList", NS)}
    c = {i: lib.tc_status_name(i).decode() for i in range(1, 64) if lib.tc_status_name(i).decode() != "?"}
    assert xtce == c
    assert lib.tc_status_name(0).decode() == "OK"


def test_a_changed_dictionary_fails(lib, tmp_path):
    """The comparison is real: an opcode renumbered in a copy of the XTCE is caught."""
    global TC_XML
    bad = tmp_path / "tc.xml"
    bad.write_text(
        TC_XML.read_text().replace('value="5" label="CAMERA_ENABLE"', 'value="9" label="CAMERA_ENABLE"')
    )
    saved, TC_XML = TC_XML, bad
    try:
        with pytest.raises(AssertionError):
            test_opcodes_match(lib)
    finally:
        TC_XML = saved


def test_docs_tables_match_the_dictionary():
    """docs/uplink.md's opcode and rejection-code tables say what the XTCE says."""
    import re

    text = (REPO / "docs" / "uplink.md").read_text()
    sec1 = text.split("## 1.")[1].split("## 2.")[0]
    sec2 = text.split("## 2.")[1].split("## 3.")[0]
    row = re.compile(r"^\| (\d+) \| ([A-Z_]+) \|", re.M)
    root = tree()
    assert {n: int(v) for v, n in row.findall(sec1)} == arg_types(root)["opcode_t"]["enum"]
    t = root.find(".//x:EnumeratedParameterType[@name='tc_status_t']", NS)
    xtce = {e.get("label"): int(e.get("value")) for e in t.find("x:EnumerationList", NS)}
    assert {n: int(v) for v, n in row.findall(sec2)} == xtce


def test_opcode_list_is_generated_from_the_dictionary():
    """TC_OPCODE_LIST (the X-macro the flight command table is built from) lists every XTCE
    command with its opcode, argument bytes and argument count, in opcode order."""
    import re

    text = (REPO / "firmware" / "tlm" / "generated" / "tc_codes_gen.h").read_text()
    assert text.startswith("/* GENERATED by contract/gen_contracts.py from contract/mfns_tc.xml")
    rows = re.findall(r"^\s+X\((\w+), (\d+), (\d+)u, (\d+)u\)", text, re.M)
    types = arg_types(tree())
    _header, cmds = commands(tree())
    want = []
    for name, cmd in cmds.items():
        nbytes = sum(types[t]["bits"] // 8 for _n, t in cmd["args"])
        want.append((name, str(types["opcode_t"]["enum"][name]), str(nbytes), str(len(cmd["args"]))))
    assert rows == sorted(want, key=lambda r: int(r[1]))
