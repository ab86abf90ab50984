"""A calibration table over the link end to end (docs/uplink.md 5a, issue 44 item 5):
mfns-ground --upload FILE -> UPLOAD_START / UPLOAD_DATA segments / UPLOAD_END, every one a
signed telecommand -> mfns-nav on a real-time replay -> its answers back in the telemetry.

- a valid table: stored in the state directory and flown (housekeeping's table CRC changes
  to the new table's), exit 0, the time it took at the FIFO link's rate;
- a corrupted table (its body CRC wrong, the file's CRC-32 consistent): the board's table
  loader refuses it at UPLOAD_END, CMD_REJECTED TABLE, exit 1 naming it, the old table flies on;
- an upload interrupted mid-way (SIGINT to mfns-ground): UPLOAD_ABORT sent, nothing stored,
  the old table flies on.

Links as in test_uplink.py: FIFOs for telemetry and commands, commands signed with a key
made here. After the upload's ground has ended, a second mfns-ground reads the same
telemetry FIFO for a few seconds (the board re-opens its link) to see housekeeping. Codes
are read from the XTCE dictionary, not copied.
"""

from __future__ import annotations

import csv
import math
import os
import re
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
NS = {"x": "http://www.omg.org/spec/XTCE/20180204"}
TC_XML = REPO / "contract" / "mfns_tc.xml"
SEG = 200  # UPLOAD_DATA bytes per segment (upload_seg_t: 1600 bits), checked below from the XTCE


def enum(type_name: str) -> dict[str, int]:
    root = ET.parse(TC_XML).getroot()
    t = root.find(f".//*[@name='{type_name}']", NS)
    assert t is not None, type_name
    return {e.get("label"): int(e.get("value")) for e in t.find("x:EnumerationList", NS)}


OP = enum("opcode_t")
REJ = enum("tc_status_t")


def mfns(*args: str) -> None:
    res = subprocess.run([sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> dict:
    """A 360-frame replay of the module scenario (19 s in real time) and two tables of it
    (the second with another pixel sigma: the same rig and beacons, another CRC)."""
    d = tmp_path_factory.mktemp("upload")
    frames = d / "frames"
    mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "360", "--seed", "3")
    for name, extra in (("table.mfnstbl", []), ("table2.mfnstbl", ["--pixel-sigma", "0.3"])):
        mfns(
            "table",
            "build",
            str(frames / "calib.json"),
            str(frames / "beacons.csv"),
            "-o",
            str(d / name),
            *extra,
        )
    key = d / "board.key"
    fd = os.open(key, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(f"# test key\n1 {os.urandom(32).hex()}\n")
    return {"frames": frames, "table": d / "table.mfnstbl", "table2": d / "table2.mfnstbl", "key": key}


class Board:
    """mfns-nav on the replay with FIFO links and a fresh state directory."""

    def __init__(self, bins: Path, run: dict, d: Path):
        self.bins, self.run, self.d = bins, run, d
        self.tlm, self.tc, self.state = d / "tlm.fifo", d / "tc.fifo", d / "state"
        os.mkfifo(self.tlm)
        os.mkfifo(self.tc)
        self.state.mkdir()
        self.err = open(d / "nav.err", "w")  # noqa: SIM115 (closed in stop)
        self.nav = subprocess.Popen(
            [
                str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
                "--realtime", "--tty", str(self.tlm), "--tc-tty", str(self.tc),
                "--tc-key", str(run["key"]), "--state-dir", str(self.state),
            ],
            stderr=self.err,
        )  # fmt: skip

    def ground(self, out: str, *extra: str) -> subprocess.Popen:
        return subprocess.Popen(
            [
                str(self.bins / "mfns-ground"), "--tty", str(self.tlm), "--out", str(self.d / out),
                "--no-status", "--max-seconds", "45", "--tc-tty", str(self.tc),
                "--tc-key", str(self.run["key"]), "--tc-state", str(self.d / "ground.state"), *extra,
            ],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip

    def housekeeping_crcs(self, out: str) -> list[str]:
        """A second ground on the telemetry FIFO for 3 s: the table CRCs housekeeping reports."""
        res = subprocess.run(
            [str(self.bins / "mfns-ground"), "--tty", str(self.tlm), "--out", str(self.d / out),
             "--no-status", "--max-seconds", "3"],
            capture_output=True, text=True, timeout=30, check=False,
        )  # fmt: skip
        assert res.returncode == 0, res.stderr
        return [r["table_crc32"] for r in rows(self.d / out / "housekeeping.csv")]

    def stop(self) -> str:
        if self.nav.poll() is None:
            self.nav.send_signal(signal.SIGINT)
        try:
            self.nav.wait(timeout=20)
        finally:
            if self.nav.poll() is None:
                self.nav.kill()
            self.err.close()
        return (self.d / "nav.err").read_text()


def upload_events(ground: Path) -> list[tuple[str, str, int]]:
    """(event, opcode name, arg1) of the answers to UPLOAD_* commands."""
    names = {v: k for k, v in OP.items()}
    return [
        (e["event"], names.get(int(e["subject"]), "?"), int(e["arg1"]))
        for e in rows(ground / "events.csv")
        if e["event"] in ("CMD_ACCEPTED", "CMD_REJECTED")
        and names.get(int(e["subject"]), "").startswith("UPLOAD")
    ]


def test_segment_size_is_the_dictionarys():
    root = ET.parse(TC_XML).getroot()
    t = root.find(".//x:BinaryArgumentType[@name='upload_seg_t']", NS)
    assert int(t.find(".//x:FixedValue", NS).text) == SEG * 8


def test_a_valid_table_is_stored_and_flown(bins, run, tmp_path):
    board = Board(bins, run, tmp_path)
    try:
        t0 = time.monotonic()
        g = board.ground("g", "--upload", str(run["table2"]))
        out, err = g.communicate(timeout=60)
        wall = time.monotonic() - t0
        assert g.returncode == 0, out + err
        m = re.search(
            r"upload table2\.mfnstbl: (\d+) bytes \(crc (\w+)\) in ([\d.]+) s .*: stored and loaded, "
            r"table crc (\w+)",
            out,
        )
        assert m, out
        size, secs, new_crc = int(m.group(1)), float(m.group(3)), "0x" + m.group(4)
        data = run["table2"].read_bytes()
        assert size == len(data)
        crcs = board.housekeeping_crcs("g2")
    finally:
        nav_err = board.stop()
    old_hk = [r["table_crc32"] for r in rows(tmp_path / "g" / "housekeeping.csv")]
    assert old_hk and set(old_hk) == {old_hk[0]}  # the old table flew during the upload
    assert crcs and set(crcs) == {new_crc} and new_crc != old_hk[0], (old_hk, crcs)
    # stored: the table store's active table is the uploaded file, byte for byte
    assert (board.state / "table.mfnstbl").read_bytes() == data
    # the received file was only the load's input: the store's copy is the record, none stays behind
    assert not (board.state / "upload.mfnstbl").exists()
    sent = rows(tmp_path / "g" / "commands.csv")
    n_data = sum(r["opcode"] == "UPLOAD_DATA" for r in sent)
    assert n_data == math.ceil(size / SEG)  # a lossless FIFO: no segment sent twice
    ev = upload_events(tmp_path / "g")
    assert ev[0] == ("CMD_ACCEPTED", "UPLOAD_START", 0)
    assert ev[-1] == (
        "CMD_ACCEPTED",
        "UPLOAD_END",
        int(new_crc, 16) - (1 << 32 if int(new_crc, 16) >= 1 << 31 else 0),
    )
    data_acks = [a for e, o, a in ev if o == "UPLOAD_DATA"]
    assert data_acks == [min((i + 1) * SEG, size) for i in range(n_data)]  # the next expected offsets
    assert "re-bound, the track goes on" in nav_err or "TABLE_LOAD" in nav_err
    cycles = secs / 0.0538
    print(
        f"\nupload of a {size}-byte table ({n_data} segments) over FIFOs at the board's command bound: "
        f"{secs:.2f} s ({size / secs:.0f} B/s, {n_data / cycles:.2f} segments per 53.8-ms cycle; "
        f"mfns-ground's whole run {wall:.1f} s with its start and re-synchronisation)"
    )


def test_a_corrupted_table_is_refused_and_the_old_one_flies_on(bins, run, tmp_path):
    bad = tmp_path / "bad.mfnstbl"
    b = bytearray(run["table2"].read_bytes())
    b[100] ^= 0xFF  # the table's body CRC now wrong; the file's CRC-32 (the upload's) is this file's
    bad.write_bytes(bytes(b))
    board = Board(bins, run, tmp_path)
    try:
        g = board.ground("g", "--upload", str(bad))
        out, err = g.communicate(timeout=60)
        crcs = board.housekeeping_crcs("g2")
    finally:
        nav_err = board.stop()
    assert g.returncode == 1, out + err
    assert "refused: TABLE (" in out, out
    ev = upload_events(tmp_path / "g")
    assert ev[-1] == ("CMD_REJECTED", "UPLOAD_END", REJ["TABLE"])
    old = [r["table_crc32"] for r in rows(tmp_path / "g" / "housekeeping.csv")]
    assert crcs and set(crcs) == {old[0]}  # the old table keeps flying
    assert not (board.state / "upload.mfnstbl").exists()  # a refused file is never written
    assert (board.state / "table.mfnstbl").read_bytes() != bytes(b)
    assert "refused by the table loader" in nav_err


def test_an_upload_aborted_mid_way_stores_nothing(bins, run, tmp_path):
    board = Board(bins, run, tmp_path)
    try:
        g = board.ground("g", "--upload", str(run["table2"]))
        log = tmp_path / "g" / "commands.csv"
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:  # a quarter of the segments sent
            if log.exists() and log.read_text().count("UPLOAD_DATA") >= 130:
                break
            time.sleep(0.05)
        g.send_signal(signal.SIGINT)
        out, err = g.communicate(timeout=30)
        time.sleep(0.5)  # the abort through a cycle
        crcs = board.housekeeping_crcs("g2")
    finally:
        nav_err = board.stop()
    assert g.returncode == 1, out + err
    m = re.search(r"interrupted at offset (\d+) of (\d+): UPLOAD_ABORT sent", out)
    assert m and 0 < int(m.group(1)) < int(m.group(2)), out
    assert "upload aborted: nothing stored" in nav_err, nav_err
    assert not (board.state / "upload.mfnstbl").exists()
    old = [r["table_crc32"] for r in rows(tmp_path / "g" / "housekeeping.csv")]
    assert crcs and set(crcs) == {old[0]}
