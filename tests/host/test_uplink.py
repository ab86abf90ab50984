"""The command uplink end to end (docs/uplink.md): mfns-ground -> TC frames -> mfns-nav on
a replay run -> its events back through the telemetry.

- a round trip through FIFOs, both programs live: every command answered by CMD_ACCEPTED
  with its sequence count, housekeeping counts them, the pose hint is used;
- every rejection through a recorded command stream (--tc-file): an action refused by the
  state, a replayed and an out-of-order count, a CRC error, garbage, an unknown opcode, a
  bad table (TABLE_LOAD refused, the old table keeps running), then STANDBY, a camera
  disabled, a table swapped in, a wrong pose hint that never becomes a fix;
- the UDP side: every decoded packet forwarded byte-identical, a UDP command validated,
  re-stamped with the ground's sequence count and sent up; non-loopback refused.

Every command is signed (mfns-ground --tc-key, mfns-nav --tc-key --state-dir, docs/uplink.md
1a) with a key made here for the test; the authentication's own rejections are in
test_uplink_auth.py.

The frames of the link are checked with independent code here (binascii.crc_hqx is
CRC-16/CCITT-FALSE; a 10-line COBS), the numbered codes are read from the XTCE
dictionaries (contract/), not copied.
"""

from __future__ import annotations

import binascii
import csv
import datetime
import hashlib
import hmac
import os
import signal
import socket
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from mfns.table.generated.layout_gen import STATUS

REPO = Path(__file__).resolve().parents[2]
NS = {"x": "http://www.omg.org/spec/XTCE/20180204"}


def enum(xml: Path, type_name: str) -> dict[str, int]:
    root = ET.parse(xml).getroot()
    t = root.find(f".//*[@name='{type_name}']", NS)
    assert t is not None, type_name
    return {e.get("label"): int(e.get("value")) for e in t.find("x:EnumerationList", NS)}


TC_XML = REPO / "contract" / "mfns_tc.xml"
OP = enum(TC_XML, "opcode_t")
REJ = enum(TC_XML, "tc_status_t")


def cobs_encode(data: bytes) -> bytes:
    out, block = bytearray(), bytearray()
    for b in data:
        if b == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out += b"\xff" + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def cobs_decode(data: bytes) -> bytes:
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        out += data[i + 1 : i + code]
        i += code
        if code < 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def frame(packet: bytes) -> bytes:
    crc = binascii.crc_hqx(packet, 0xFFFF)  # CRC-16/CCITT-FALSE
    return cobs_encode(packet + crc.to_bytes(2, "big")) + b"\x00"


def tc_packet(opcode: int, seq: int, args: bytes = b"") -> bytes:
    """A TC packet by hand (the layout of docs/uplink.md), for opcodes the encoder refuses."""
    n = 2 + len(args)
    return (
        bytes([0x19, 0x81, 0xC0 | (seq >> 8), seq & 0xFF])
        + (n - 1).to_bytes(2, "big")
        + bytes([opcode, 0])
        + args
    )


def cfs_checksum(pkt: bytes) -> bytes:
    """pkt with the cFS checksum in byte 7, as Yamcs' CfsCommandPostprocessor writes it: 0xFF
    xor every byte, byte 7 taken as 0."""
    b = bytearray(pkt)
    b[7] = 0
    x = 0xFF
    for v in b:
        x ^= v
    b[7] = x
    return bytes(b)


def udp_bound(port: int, timeout_s: float = 10.0) -> bool:
    """Wait until a local UDP socket is bound to 127.0.0.1:port (Linux /proc/net/udp): a
    datagram sent before the receiver binds is lost, and a fixed sleep is a race on a loaded
    machine."""
    want = f"0100007F:{port:04X}"
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        table = Path("/proc/net/udp").read_text().splitlines()[1:]
        if any(line.split()[1] == want for line in table):
            return True
        time.sleep(0.02)
    return False


def make_key(path: Path, key_id: int = 1) -> bytes:
    """A fresh board key in a key file of mode 0600 (never one from the repository)."""
    key = os.urandom(32)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(f"# test key\n{key_id} {key.hex()}\n")
    return key


@pytest.fixture(scope="module")
def key(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("key") / "board.key"
    make_key(p)
    return p


def nav_auth(key: Path, state: Path) -> list[str]:
    """mfns-nav's options for signed commands (a fresh state directory: epoch 1)."""
    state.mkdir(exist_ok=True)
    return ["--tc-key", str(key), "--state-dir", str(state)]


def mfns(*args: str) -> None:
    res = subprocess.run([sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> dict:
    """A 40-frame replay of the module scenario and two tables of it."""
    d = tmp_path_factory.mktemp("uplink")
    frames = d / "frames"
    mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "40", "--seed", "3")
    mfns(
        "table",
        "build",
        str(frames / "calib.json"),
        str(frames / "beacons.csv"),
        "-o",
        str(d / "table.mfnstbl"),
    )
    mfns(
        "table", "build", str(frames / "calib.json"), str(frames / "beacons.csv"),
        "-o", str(d / "table2.mfnstbl"), "--pixel-sigma", "0.3",
    )  # fmt: skip
    truth = np.atleast_1d(np.genfromtxt(frames / "truth.csv", delimiter=",", names=True))
    return {
        "dir": d,
        "frames": frames,
        "table": d / "table.mfnstbl",
        "table2": d / "table2.mfnstbl",
        "truth": truth,
    }


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def cmd_events(ground: Path) -> list[dict]:
    return [e for e in rows(ground / "events.csv") if e["event"] in ("CMD_ACCEPTED", "CMD_REJECTED")]


def encode_commands(
    bins: Path,
    tmp: Path,
    cmds: list[str],
    seq_start: int,
    key: Path,
    count: int | None = None,
    epoch: int = 1,
) -> bytes:
    """TC frames of command lines, by mfns-ground (--tc-file), signed with key for epoch and
    anti-replay counts from count (default seq_start + 1); its source is an empty file."""
    src = tmp / "empty.bin"
    src.write_bytes(b"")
    out = tmp / f"tc-{seq_start}.bin"
    args = [
        str(bins / "mfns-ground"),
        "--file",
        str(src),
        "--out",
        str(tmp / "g-enc"),
        "--no-status",  # not -q: it silences the uplink counters read below
        "--tc-file",
        str(out),
    ]
    args += ["--tc-seq-start", str(seq_start), "--tc-key", str(key), "--tc-epoch", str(epoch)]
    args += ["--tc-count-start", str(seq_start + 1 if count is None else count)]
    for c in cmds:
        args += ["--cmd", c]
    res = subprocess.run(args, capture_output=True, text=True, check=False, timeout=30)
    # exit 3: no telemetry decoded (there is none); the commands were written
    assert res.returncode in (0, 3), res.stderr
    assert f"uplink: {len(cmds)} commands sent, 0 errors" in res.stderr, res.stderr
    return out.read_bytes()


def test_round_trip_through_fifos(bins, run, tmp_path, key):
    """Both programs live on FIFOs: command -> flight -> event, with the time it took. The
    ground re-synchronises the board to a fresh epoch (its authenticated uplink report asks for
    one at every start, docs/uplink.md 1a), then signs every command."""
    tlm, tc = tmp_path / "tlm.fifo", tmp_path / "tc.fifo"
    os.mkfifo(tlm)
    os.mkfifo(tc)
    first = run["truth"][0]
    hint = " ".join(f"{first[k]:.6f}" for k in ("x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg"))
    nav = subprocess.Popen(
        [
            str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
            "--realtime", "--tty", str(tlm), "--tc-tty", str(tc), *nav_auth(key, tmp_path / "state"),
        ],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    out = tmp_path / "ground"
    # the last command from a command file, one second later: the steady-state latency
    (tmp_path / "later.txt").write_text("# a comment line\nWAIT 1.0\nnoop   # names are case-insensitive\n")
    ground = subprocess.Popen(
        [
            str(bins / "mfns-ground"), "--tty", str(tlm), "--out", str(out), "--no-status",
            "--max-seconds", "60",
            "--tc-tty", str(tc), "--cmd", "NOOP", "--cmd", f"SET_POSE_HINT {hint}", "--cmd", "SET_MODE track",
            "--cmd-file", str(tmp_path / "later.txt"), "--tc-key", str(key),
            "--tc-state", str(tmp_path / "ground.state"),
        ],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        _, nav_err = nav.communicate(timeout=60)
        time.sleep(0.5)
        ground.send_signal(signal.SIGINT)
        _, g_err = ground.communicate(timeout=30)
    finally:
        for p in (nav, ground):
            if p.poll() is None:
                p.kill()
    assert nav.returncode == 0, nav_err
    assert ground.returncode == 0, g_err
    sent = rows(out / "commands.csv")
    assert [(r["seq"], r["opcode"], r["source"]) for r in sent] == [
        ("16383", "NOOP", "resync"), ("0", "NOOP", "cli"), ("1", "SET_POSE_HINT", "cli"),
        ("2", "SET_MODE", "cli"), ("3", "NOOP", "file"),
    ]  # fmt: skip
    ev = cmd_events(out)
    assert [(e["event"], int(e["subject"]), int(e["arg0"])) for e in ev] == [
        ("CMD_ACCEPTED", OP["NOOP"], 16383),  # the re-synchronisation: the count before the first
        ("CMD_ACCEPTED", OP["NOOP"], 0),
        ("CMD_ACCEPTED", OP["SET_POSE_HINT"], 1),
        ("CMD_ACCEPTED", OP["SET_MODE"], 2),
        ("CMD_ACCEPTED", OP["NOOP"], 3),
    ], ev
    hk = rows(out / "housekeeping.csv")[-1]
    assert (hk["n_cmd_accepted"], hk["n_cmd_rejected"], hk["cmd_seq_last"]) == ("5", "0", "3")
    assert "commands: 5 accepted, 0 rejected" in nav_err
    epoch = int(hk["tc_epoch"])  # the ground's: above anything it gave before and UTC seconds
    assert epoch >= int(time.time()) - 600, epoch
    assert f"authentication (epoch {epoch}): 5 passed" in nav_err and "1 re-synchronisations" in nav_err
    assert hk["tc_arsn_last"] == "5"
    assert f"max_epoch {epoch}\n" in (tmp_path / "ground.state").read_text()
    # command (ground clock, commands.csv) -> its event back (ground receive time)
    from datetime import datetime

    def utc(s: str) -> float:
        return datetime.fromisoformat(s.replace("Z", "+00:00")).timestamp()

    lat = [utc(e["ground_utc"]) - utc(s["utc"]) for e, s in zip(ev, sent, strict=True)]
    print(
        "\ncommand -> event round trip through FIFOs: at start-up "
        f"{', '.join(f'{x * 1e3:.0f}' for x in lat[:4])} ms "
        f"(links connecting, the first the re-synchronisation), steady state {lat[4] * 1e3:.0f} ms"
    )
    assert all(0 < x < 5.0 for x in lat)
    assert lat[4] < 0.5  # a few 53.8-ms cycles plus the ground's 100-ms poll
    # the hint was used: tracking from it, fixes close to the truth
    nav_rows = rows(out / "nav.csv")
    fixes = [r for r in nav_rows if r["status"] in ("FIX", "DEGRADED")]
    assert len(fixes) >= 30


def test_every_rejection_and_action_from_a_command_stream(bins, run, tmp_path, key):
    d = tmp_path
    # paths on the board are short (< 64 characters): relative to mfns-nav's working directory
    (d / "table2.mfnstbl").write_bytes(run["table2"].read_bytes())
    bad_table = d / "bad.mfnstbl"
    b = bytearray(run["table"].read_bytes())
    b[100] ^= 0xFF  # body CRC now wrong
    bad_table.write_bytes(bytes(b))
    wrong = run["truth"][0]
    # a hint 500 mm and 30 deg off: a prior only, it must never come out as a fix
    wrong_hint = (
        f"SET_POSE_HINT {wrong['x_mm'] + 500:.3f} {wrong['y_mm']:.3f} {wrong['z_mm']:.3f} "
        f"{wrong['roll_deg']:.3f} {wrong['pitch_deg']:.3f} {(wrong['yaw_deg'] + 30 + 180) % 360 - 180:.3f}"
    )
    f = lambda cmds, s, n=None: encode_commands(bins, d, cmds, s, key, n)  # noqa: E731
    noop1 = f(["NOOP"], 1)
    stream = b"".join(
        [
            # cycle 0 (4 per cycle)
            f(["SET_MODE track"], 0),  # no prior yet: STATE (the count stays usable)
            noop1,  # accepted
            noop1,  # replayed: its anti-replay count is used up (AUTH_REPLAY, before the sequence guard)
            noop1[:2] + bytes([noop1[2] ^ 0x20]) + noop1[3:],  # a flipped data bit: CRC
            # cycle 1
            bytes(range(1, 200)) + bytes(range(1, 200)) + b"\x00",  # garbage: OVERSIZE
            f(["SET_MODE standby", "TABLE_LOAD bad.mfnstbl", "TABLE_LOAD table2.mfnstbl"], 2),
            # cycle 2
            f(["NOOP"], 3, 6),  # freshly signed, but its count older than 4: SEQUENCE (out of order)
            f(["SET_MODE acquire", "CAMERA_DISABLE y"], 5, 7),
            frame(tc_packet(99, 7)),  # unknown opcode (a refused frame does not use up its count)
            # cycle 3
            f([wrong_hint, "CAMERA_ENABLE y", "RESET_COUNTERS"], 7, 9),
        ]
    )
    tcfile = d / "commands.bin"
    tcfile.write_bytes(stream)
    tlm = d / "tlm.bin"
    nav = subprocess.run(
        [
            str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
            "--tlm-file", str(tlm), "--tc-file", str(tcfile), *nav_auth(key, d / "state"),
        ],
        capture_output=True, text=True, timeout=120, check=False, cwd=d,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    out = d / "ground"
    g = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert g.returncode == 0, g.stderr
    ev = cmd_events(out)
    got = [(e["cycle"], e["event"][4:], int(e["subject"]), int(e["arg0"]), int(e["arg1"], 0)) for e in ev]
    acc, rej = "ACCEPTED", "REJECTED"
    want = [
        ("0", rej, OP["SET_MODE"], 0, REJ["STATE"]),
        ("0", acc, OP["NOOP"], 1, 0),
        ("0", rej, OP["NOOP"], 1, REJ["AUTH_REPLAY"]),
        ("0", rej, 0, -1, REJ["CRC"]),
        ("1", rej, 0, -1, REJ["OVERSIZE"]),
        ("1", acc, OP["SET_MODE"], 2, 4),
        ("1", rej, OP["TABLE_LOAD"], 3, REJ["TABLE"]),
        ("1", acc, OP["TABLE_LOAD"], 4, None),
        ("2", rej, OP["NOOP"], 3, REJ["SEQUENCE"]),
        ("2", acc, OP["SET_MODE"], 5, 1),
        ("2", acc, OP["CAMERA_DISABLE"], 6, 0b101),
        ("2", rej, 99, 7, REJ["OPCODE"]),
        ("3", acc, OP["SET_POSE_HINT"], 7, 0),
        ("3", acc, OP["CAMERA_ENABLE"], 8, 0b111),
        ("3", acc, OP["RESET_COUNTERS"], 9, 0),
    ]
    assert len(got) == len(want), got
    for g_, w in zip(got, want, strict=True):
        assert g_[:4] == w[:4] and (w[4] is None or g_[4] == w[4]), (g_, w)
    # the table swap: TABLE_REFUSED (the loader's CRC error), then TABLE_LOADED of table2
    all_ev = rows(out / "events.csv")
    tab = [e for e in all_ev if e["event"] in ("TABLE_LOADED", "TABLE_REFUSED") and e["cycle"] == "1"]
    assert [e["event"] for e in tab] == ["TABLE_REFUSED", "TABLE_LOADED"]
    hk = rows(out / "housekeeping.csv")
    assert hk[-1]["n_cmd_accepted"] == "0" and hk[-1]["n_cmd_rejected"] == "0"  # RESET_COUNTERS
    assert hk[-1]["cmd_seq_last"] == "9"
    assert hk[0]["table_crc32"] != hk[-1]["table_crc32"]  # table2 runs after the swap
    assert int(hk[-1]["table_crc32"], 16) == got[7][4] & 0xFFFFFFFF  # CMD_ACCEPTED arg1: the new table's CRC
    assert int(tab[1]["arg1"], 16) == got[7][4] & 0xFFFFFFFF
    assert hk[-1]["cams_enabled"] == "7"
    navr = {int(r["cycle"]): r for r in rows(out / "nav.csv")}
    assert navr[1]["mode"] == "STANDBY" and navr[1]["status"] == "NO_FIX"
    assert navr[2]["mode"] != "STANDBY"
    assert int(navr[2]["cams_used"]) & 0b010 == 0  # camera y disabled for cycle 2
    # the wrong hint is never a fix: every FIX/DEGRADED pose is close to the truth
    truth = run["truth"]
    n_fix = 0
    for k, r in navr.items():
        if r["status"] in ("FIX", "DEGRADED"):
            n_fix += 1
            assert abs(float(r["x_mm"]) - truth[k]["x_mm"]) < 3.0, (k, r["x_mm"])
            dyaw = (float(r["yaw_deg"]) - truth[k]["yaw_deg"] + 180) % 360 - 180
            assert abs(dyaw) < 0.2, (k, dyaw)
    assert n_fix >= 30  # the old / new table kept navigating
    assert "commands: 0 accepted, 0 rejected" in nav.stderr


def test_tcp_forward_is_lossless_for_a_slow_receiver(bins, run, tmp_path):
    """--tcp-forward: a receiver that connects late and then reads nothing for a while still
    gets every packet, in order, byte-identical (but for the UTC time, as --udp-forward), and
    the exit line says so; a second run with nobody connecting says what was never taken."""
    tlm = tmp_path / "tlm.bin"
    nav = subprocess.run(
        [
            str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
            "--tlm-file", str(tlm), "--max-cycles", "40",
        ],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    packets = [cobs_decode(fr)[:-2] for fr in tlm.read_bytes().split(b"\x00") if fr]
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    g = subprocess.Popen(
        [
            str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(tmp_path / "g"), "--no-status",
            "--tcp-forward", f"127.0.0.1:{port}",
        ],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    time.sleep(0.8)  # the whole file is decoded by now: the packets wait for a receiver
    rx = None
    for _ in range(100):
        try:
            rx = socket.create_connection(("127.0.0.1", port), timeout=5.0)
            break
        except OSError:
            time.sleep(0.02)
    assert rx is not None
    time.sleep(1.0)  # a receiver busy elsewhere
    data = b""
    while True:
        chunk = rx.recv(65536)
        if not chunk:
            break
        data += chunk
    rx.close()
    _, err = g.communicate(timeout=30)
    assert g.returncode == 0, err
    got = []
    while data:
        n = 7 + int.from_bytes(data[4:6], "big")
        got.append(data[:n])
        data = data[n:]
    assert [d[:6] + d[12:] for d in got] == [p[:6] + p[12:] for p in packets]
    assert f"TCP forward: {len(packets)} packets sent, 0 dropped, 0 never taken (1 clients)" in err, err
    g2 = subprocess.run(
        [
            str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(tmp_path / "g2"), "--no-status",
            "--tcp-forward", f"127.0.0.1:{port}",
        ],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert f"TCP forward: 0 packets sent, 0 dropped, {len(packets)} never taken (0 clients)" in g2.stderr


def test_udp_forward_and_udp_commands(bins, run, tmp_path, key):
    # a short recorded stream
    tlm = tmp_path / "tlm.bin"
    nav = subprocess.run(
        [
            str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
            "--tlm-file", str(tlm), "--max-cycles", "10",
        ],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    wire = tlm.read_bytes()
    packets = [cobs_decode(fr)[:-2] for fr in wire.split(b"\x00") if fr]
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(2.0)
    port = rx.getsockname()[1]
    g = subprocess.run(
        [
            str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(tmp_path / "g"), "--no-status",
            "--udp-forward", f"127.0.0.1:{port}",
        ],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert g.returncode == 0, g.stderr
    got = []
    try:
        while len(got) < len(packets):
            got.append(rx.recv(4096))
    except TimeoutError:
        pass
    rx.close()
    # every packet, in order, byte-identical but for its CUC time (bytes 6..11 after the
    # primary header): forwarded as UTC from the flight's time correlation (UNIX epoch,
    # docs/telemetry.md "Time"), which is the nav.csv utc column
    assert len(got) == len(packets)
    assert [d[:6] + d[12:] for d in got] == [p[:6] + p[12:] for p in packets]
    utc_rows = [r["utc"] for r in rows(tmp_path / "g" / "nav.csv")]
    fwd_nav = [d for d in got if int.from_bytes(d[0:2], "big") & 0x7FF == 257]
    assert len(fwd_nav) == len(utc_rows) == 10
    for d, u in zip(fwd_nav, utc_rows, strict=True):
        t = int.from_bytes(d[6:10], "big") + int.from_bytes(d[10:12], "big") / 65536.0
        want = datetime.datetime.fromisoformat(u.replace("Z", "+00:00")).timestamp()
        assert abs(t - want) < 2e-5, (t, u)
        assert abs(t - time.time()) < 600  # a real time, not 1970
    assert f"UDP forward: {len(packets)} packets sent, 0 refused by the socket" in g.stderr

    # a ground system's commands over UDP: validated, re-stamped, sent up
    fifo = tmp_path / "tlm.fifo"
    os.mkfifo(fifo)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    tc_port = s.getsockname()[1]
    s.close()  # free for mfns-ground (a race-free enough choice on loopback)
    up = tmp_path / "up.bin"
    ground = subprocess.Popen(
        [
            str(bins / "mfns-ground"), "--tty", str(fifo), "--out", str(tmp_path / "g2"), "--no-status",
            "--max-seconds", "3", "--tc-file", str(up), "--udp-tc", f"127.0.0.1:{tc_port}",
            "--tc-seq-start", "40", "--tc-key", str(key), "--tc-epoch", "3",
        ],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert udp_bound(tc_port), "mfns-ground never bound its UDP command port"
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    # Yamcs' CfsCommandPostprocessor: its own count and the cFS checksum in byte 7
    tx.sendto(cfs_checksum(tc_packet(OP["SET_MODE"], 1234, bytes([4]))), ("127.0.0.1", tc_port))
    tx.sendto(
        tc_packet(OP["SET_MODE"], 1235, bytes([3])), ("127.0.0.1", tc_port)
    )  # SAFE: refused on the ground
    tx.sendto(b"\x01\x02\x03", ("127.0.0.1", tc_port))
    bad = bytearray(cfs_checksum(tc_packet(OP["NOOP"], 1236)))
    bad[7] ^= 0x01
    tx.sendto(bytes(bad), ("127.0.0.1", tc_port))  # a wrong checksum: refused
    tx.sendto(cfs_checksum(tc_packet(OP["NOOP"], 7)), ("127.0.0.1", tc_port))  # behind 1234: renumbered
    tx.close()
    _, err = ground.communicate(timeout=30)
    assert ground.returncode == 3, err  # nothing decoded on the FIFO (no flight program)
    assert "UDP commands: 5 received, 3 refused" in err, err
    assert "sequence count 7, not after the uplink's last (1234): sent as 1235" in err, err
    frames = [fr for fr in up.read_bytes().split(b"\x00") if fr]
    assert len(frames) == 2
    second = cobs_decode(frames[1])[:-2]
    assert int.from_bytes(second[2:4], "big") & 0x3FFF == 1235 and second[16] == OP["NOOP"]
    pkt = cobs_decode(frames[0])
    assert binascii.crc_hqx(pkt[:-2], 0xFFFF) == int.from_bytes(pkt[-2:], "big")
    # the ground system's count 1234 kept (newer than the ground's last, 39: the flight's answer
    # names the command the ground system knows), the checksum byte cleared, and signed: the
    # security header after the primary header, the MAC (HMAC-SHA-256, first 16 bytes) over
    # everything before it, checked here with hashlib
    plain = tc_packet(OP["SET_MODE"], 1234, bytes([4]))
    spkt = pkt[:-2]
    assert len(spkt) == len(plain) + 26
    assert spkt[:4] == plain[:4] and int.from_bytes(spkt[4:6], "big") == len(spkt) - 7
    assert spkt[6:8] == b"\x00\x01" and int.from_bytes(spkt[8:16], "big") == (3 << 32) | 1
    assert spkt[16:-16] == plain[6:]
    k = bytes.fromhex(key.read_text().split("\n")[1].split()[1])
    assert spkt[-16:] == hmac.new(k, spkt[:-16], hashlib.sha256).digest()[:16]


@pytest.mark.parametrize(
    "args,needle",
    [
        (["--udp-forward", "10.1.2.3:5000"], "not a loopback address"),
        (["--udp-tc", "0.0.0.0:5000", "--tc-file", "x.bin"], "not a loopback address"),
        (["--cmd", "SET_MODE fly", "--tc-file", "x.bin"], "SET_MODE wants standby, acquire or track"),
        (["--cmd", "SET_POSE_HINT 0 0 0 0 95 0", "--tc-file", "x.bin"], "not a number in range"),
        (["--cmd", "TABLE_LOAD " + "p" * 70, "--tc-file", "x.bin"], "longer than 63"),
        (["--cmd", "NOOP"], "commands need a way up"),
        (["--cmd", "NOOP", "--uplink"], "--uplink sends on the source link"),
        (["--cmd", "NOOP", "--tc-file", "x.bin", "--tc-epoch", "2"], "give --tc-key FILE too"),
        (["--cmd", "NOOP", "--tc-file", "x.bin", "--tc-epoch", "0", "--tc-key", "k"], "--tc-epoch wants"),
    ],
)
def test_ground_refuses_bad_uplink_usage(bins, tmp_path, args, needle):
    src = tmp_path / "e.bin"
    src.write_bytes(b"")
    res = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(src), "--out", str(tmp_path / "g"), *args],
        capture_output=True, text=True, timeout=30, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert res.returncode == 2, res.stderr
    assert needle in res.stderr, res.stderr


def test_nav_refuses_uplink_on_a_fifo(bins, run, tmp_path):
    fifo = tmp_path / "t.fifo"
    os.mkfifo(fifo)
    res = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
         "--tty", str(fifo), "--uplink", "--tc-insecure"],
        capture_output=True, text=True, timeout=30, check=False,
    )  # fmt: skip
    assert res.returncode == 2
    assert "--uplink needs a tty" in res.stderr


def test_table_fifo_never_stalls_the_cycle(bins, run, tmp_path, key):
    """A TABLE_LOAD of a FIFO (and --table given one) is refused at once with its
    own loader code; the cycle goes on (it used to block until a signal)."""
    d = tmp_path
    os.mkfifo(d / "t.fifo")
    tcfile = d / "commands.bin"
    tcfile.write_bytes(encode_commands(bins, d, ["TABLE_LOAD t.fifo"], 1, key))
    tlm = d / "tlm.bin"
    nav = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
         "--tlm-file", str(tlm), "--tc-file", str(tcfile), *nav_auth(key, d / "state")],
        capture_output=True, text=True, timeout=60, check=False, cwd=d,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    out = d / "ground"
    subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"], check=True
    )
    refused = [e for e in rows(out / "events.csv") if e["event"] == "TABLE_REFUSED"]
    not_regular = next(v for v, (name, _) in STATUS.items() if name == "E_FILE_NOT_REGULAR")
    assert len(refused) == 1 and int(refused[0]["arg0"]) == not_regular, refused  # and the old table flies on
    navrows = rows(out / "nav.csv")
    assert len(navrows) == 40 and sum(r["status"] in ("FIX", "DEGRADED") for r in navrows[2:]) > 30
    start = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(d / "t.fifo"), "--replay", str(run["frames"])],
        capture_output=True, text=True, timeout=30, check=False,
    )  # fmt: skip
    assert start.returncode != 0 and "not a regular file" in start.stderr, start.stderr


def test_nav_exits_nonzero_when_no_telemetry_ever_left(bins, run, tmp_path):
    """--tty to a port that never appears: the run is not a success (it exited 0)."""
    res = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
         "--tty", str(tmp_path / "nonexistent" / "tty"), "--max-cycles", "5", "-q"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert res.returncode == 3, res.stderr
    assert "never opened" in res.stderr and "No such file or directory" in res.stderr


def test_packets_carry_utc_through_the_flight_time_correlation(bins, run, tmp_path):
    """Issue 24 item 5 / 26 item 1: housekeeping pairs its flight time with UTC and
    the ground gives every packet its UTC (the runs no longer land on 1970)."""
    tlm = tmp_path / "tlm.bin"
    t0 = time.time()
    subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
         "--tlm-file", str(tlm), "-q"],
        check=True, timeout=120,
    )  # fmt: skip
    out = tmp_path / "g"
    subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "-q"], check=True, timeout=60
    )
    t1 = time.time()

    def ts(u: str) -> float:
        return datetime.datetime.fromisoformat(u.replace("Z", "+00:00")).timestamp()

    hk = rows(out / "housekeeping.csv")
    nav = rows(out / "nav.csv")
    # a replay's recorded time is anchored at its first pair (when it started), so its
    # UTC runs as if flown in real time: up to the recording's span after the start
    span = float(nav[-1]["t_s"])
    assert hk and all(h["time_quality"] in ("SYSTEM", "SYNCED") for h in hk)
    for h in hk:
        u = int(h["utc_s"]) + int(h["utc_us"]) * 1e-6
        assert t0 - 1 <= u <= t1 + span + 1
        assert abs((u - ts(hk[0]["utc"])) - float(h["t_s"])) < 2e-5  # one anchor: UTC = anchor + t_s
        assert h["time_source"].startswith("FLIGHT_")
    assert hk[0]["n_cycles"] == "0"  # the start-up housekeeping: its pair precedes every nav packet
    later = nav
    assert all(r["time_source"] == hk[0]["time_source"] for r in later)
    for r in later:
        assert t0 - 1 <= ts(r["utc"]) <= t1 + span + 1
    # within one pair, UTC advances exactly as the flight time does
    a, b = later[0], later[1]
    assert abs((ts(b["utc"]) - ts(a["utc"])) - (float(b["t_s"]) - float(a["t_s"]))) < 2e-5


def test_table_huge_growing_or_device_never_stalls(bins, run, tmp_path, key):
    """Issue 25 item 4: a huge file is refused by its size before a byte is read
    (E_FILE_TOO_BIG), a device (/dev/zero) as not regular, a file that grows while it is
    loaded is read at most to the buffer's size + 1 (refused, or loaded as the bytes it had)
    -- and every cycle runs."""
    d = tmp_path
    huge = d / "huge.mfnstbl"
    with open(huge, "wb") as f:
        f.truncate(8 << 30)  # 8 GiB, sparse: reading it would take many cycles
    grow = d / "grow.mfnstbl"
    good = run["table"].read_bytes()
    grow.write_bytes(good)
    tcfile = d / "commands.bin"
    tcfile.write_bytes(
        encode_commands(bins, d, ["TABLE_LOAD huge.mfnstbl", "TABLE_LOAD /dev/zero"], 1, key)
        + encode_commands(bins, d, ["TABLE_LOAD grow.mfnstbl"], 3, key)
    )
    tlm = d / "tlm.bin"
    import threading

    stop = threading.Event()

    def grower() -> None:  # appends while mfns-nav runs (and loads it)
        with open(grow, "ab") as f:
            while not stop.is_set():
                f.write(b"\x55" * 65536)
                f.flush()
                time.sleep(0.001)

    th = threading.Thread(target=grower)
    th.start()
    try:
        t0 = time.monotonic()
        nav = subprocess.run(
            [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
             "--tlm-file", str(tlm), "--tc-file", str(tcfile), *nav_auth(key, d / "state")],
            capture_output=True, text=True, timeout=120, check=False, cwd=d,
        )  # fmt: skip
        wall = time.monotonic() - t0
    finally:
        stop.set()
        th.join()
    assert nav.returncode == 0, nav.stderr
    out = d / "ground"
    subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"], check=True
    )
    code = {name: v for v, (name, _) in STATUS.items()}
    tab = [(e["event"], int(e["arg0"])) for e in rows(out / "events.csv") if e["event"].startswith("TABLE_")]
    assert tab[0] == ("TABLE_LOADED", tab[0][1])  # the start-up table
    assert tab[1] == ("TABLE_REFUSED", code["E_FILE_TOO_BIG"])
    assert tab[2] == ("TABLE_REFUSED", code["E_FILE_NOT_REGULAR"])
    # the growing one: refused (too big, or the table's own size/CRC check on what was read)
    # or loaded with the bytes it had -- either way a decision, never a stall
    assert len(tab) == 4 and tab[3][0] in ("TABLE_REFUSED", "TABLE_LOADED"), tab
    navrows = rows(out / "nav.csv")
    assert len(navrows) == 40 and sum(r["status"] in ("FIX", "DEGRADED") for r in navrows[2:]) > 30
    print(f"\nhuge / device / growing table loads: {wall:.2f} s for the 40-cycle replay; growing: {tab[3]}")
