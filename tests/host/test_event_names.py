"""Issue 46: event names and arguments are named from one source.

mfns_tm.xml's AncillaryData on evt_subject / evt_arg0 / evt_arg1 say, per event code, what the
number names (a camera, a mode, a beacon, a command, a rejection code, a table status). The
operator view decodes through mfns.tlm.tlm_dict.event_text; the Yamcs event algorithm
(mfns_ground.xml flight_event, JavaScript: it cannot read the dictionary) carries the same lists,
held equal here."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from mfns.tlm import tlm_dict

NS = {"x": "http://www.omg.org/spec/XTCE/20180204"}


def js_lists() -> dict[str, set[str]]:
    root = ET.parse(tlm_dict.mdb_path().with_name("mfns_ground.xml")).getroot()
    alg = next(a for a in root.iter(f"{{{NS['x']}}}CustomAlgorithm") if a.get("name") == "flight_event")
    text = alg.find("x:AlgorithmText", NS).text
    return {m[0]: set(m[1].split()) for m in re.findall(r'var ([A-Z0-9_]+) = "([^"]*)";', text)}


def test_yamcs_event_algorithm_names_what_the_dictionary_says():
    dec = tlm_dict.event_decoders()
    js = js_lists()

    def codes(slot, kind):
        return {c for c, k in dec[slot].items() if k == kind}

    assert js["SUBJECT_CAMERA"] == codes("subject", "camera")
    assert js["SUBJECT_BEACON"] == codes("subject", "beacon")
    assert js["ARG0_MODE"] == codes("arg0", "mode")
    assert js["ARG1_MODE"] == codes("arg1", "mode")
    assert js["ARG1_CAMERA"] == codes("arg1", "camera")
    assert js["ARG1_BEACON"] == codes("arg1", "beacon")
    assert js["ARG1_TC_STATUS"] == codes("arg1", "tc_status")
    # named only in the view: commands by opcode (the CMD events' own message says it) and
    # table statuses (named by the C core's loader, which Yamcs does not have)
    kinds = {k for slot in dec.values() for k in slot.values()}
    assert kinds == {"camera", "beacon", "mode", "tc_status", "tc_opcode", "table_status"}


def test_every_listed_code_is_an_event_code():
    d = tlm_dict.load()
    labels = set(d.labels("event_code_t").values())
    for slot in tlm_dict.event_decoders(d).values():
        assert set(slot) <= labels, set(slot) - labels


def test_event_text_in_operators_words():
    t = tlm_dict.event_text
    assert t("CAMERA_LOST", 1, -5, 12) == "CAMERA_LOST camera y: arg0 -5, arg1 12"
    assert t("MODE_CHANGE", 0, 2, 4) == "MODE_CHANGE TRACK -> STANDBY (reason 0)"
    assert t("CAMERAS_DISAGREE", 0, 20, 2) == "CAMERAS_DISAGREE camera x: arg0 20, arg1 camera z"
    assert t("BEACON_MISSING", 12, 20, 12) == "BEACON_MISSING beacon 12: arg0 20, arg1 beacon 12"
    assert t("TLM_DROPPED", 0, 3, 0) == "TLM_DROPPED subject 0: arg0 3, arg1 0"
    assert t("CMD_REJECTED", 3, 7, 5).startswith("CMD_REJECTED SET_MODE (sequence count 7): ")
    assert "cannot be opened" in t("TABLE_REFUSED", 0, 30, 0)
    assert t("TABLE_LOADED", 0, 5, 741223092) == "TABLE_LOADED subject 0: arg0 5, arg1 0x2c2e2ab4"  # CRC, hex
