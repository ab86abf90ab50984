"""Authenticated telecommands end to end (docs/uplink.md 1a, 3a, 4a): mfns-ground signs,
mfns-nav verifies, every refusal comes back as CMD_REJECTED with its own code (arg1) in
events.csv, and the boot epoch in --state-dir makes a command signed before a reboot
useless after it.

- one boot: a signed command accepted; an unsigned one (AUTH_MISSING), one signed with a
  wrong key (AUTH_BAD_MAC), one with a key id the board does not have (AUTH_KEY_UNKNOWN), a
  replayed one (AUTH_REPLAY) each refused, and none of them uses anything up;
- the next boot with the same --state-dir: the first boot's command refused
  (AUTH_STALE_EPOCH), one signed for the new epoch accepted; housekeeping carries the epoch;
- key files with loose permissions refused at start, an uplink without a key refused unless
  --tc-insecure (a warning and a TC_AUTH event saying epoch 0);
- the ground's Unix socket intake (--tc-socket): created 0600, its commands signed.

Keys are made here (os.urandom) in temporary directories; the codes are read from the XTCE
dictionaries, not copied.
"""

from __future__ import annotations

import os
import socket
import stat
import subprocess
import time
import xml.etree.ElementTree as ET
from pathlib import Path

from test_uplink import (
    OP,
    REJ,
    REPO,
    cmd_events,
    cobs_decode,
    encode_commands,
    make_key,
    nav_auth,
    rows,
    tc_packet,
)
from test_uplink import run as _run

run = _run  # the fixture (the 40-frame replay), shared; bins is conftest's

NS = {"x": "http://www.omg.org/spec/XTCE/20180204"}
TM_XML = REPO / "contract" / "mfns_tm.xml"


def plain_commands(bins: Path, tmp: Path, cmds: list[str], seq_start: int) -> bytes:
    """Unsigned frames (mfns-ground without --tc-key): what anyone on the link could send."""
    src = tmp / "empty.bin"
    src.write_bytes(b"")
    out = tmp / f"plain-{seq_start}.bin"
    args = [str(bins / "mfns-ground"), "--file", str(src), "--out", str(tmp / "g-plain"), "-q",
            "--tc-file", str(out), "--tc-seq-start", str(seq_start)]  # fmt: skip
    for c in cmds:
        args += ["--cmd", c]
    res = subprocess.run(args, capture_output=True, text=True, check=False, timeout=30)
    assert res.returncode in (0, 3), res.stderr
    return out.read_bytes()


def fly(bins: Path, run: dict, d: Path, stream: bytes, key: Path, state: Path, name: str):
    """One boot of mfns-nav on the replay with stream as its command file; the ground's view."""
    tc = d / f"{name}.tc"
    tc.write_bytes(stream)
    tlm = d / f"{name}.tlm"
    nav = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
         "--tlm-file", str(tlm), "--tc-file", str(tc), *nav_auth(key, state), "--max-cycles", "12"],
        capture_output=True, text=True, timeout=120, check=False, cwd=d,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    out = d / f"{name}-ground"
    g = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert g.returncode == 0, g.stderr
    return nav, out


def test_signed_accepted_each_forgery_rejected_with_its_code_across_a_reboot(bins, run, tmp_path):
    d = tmp_path
    key, wrong, other_id = d / "board.key", d / "wrong.key", d / "id2.key"
    make_key(key, 1)
    make_key(wrong, 1)  # the right key id, another key: an attacker's guess
    make_key(other_id, 2)
    state = d / "state"
    enc = lambda cmds, s, k=key, n=None, e=1: encode_commands(bins, d, cmds, s, k, n, e)  # noqa: E731
    first = enc(["NOOP"], 0)  # signed for boot 1, count 1
    stream = b"".join(
        [
            first,  # accepted
            plain_commands(bins, d, ["NOOP"], 1),  # unsigned: AUTH_MISSING
            enc(["NOOP"], 1, wrong, 2),  # wrong key: AUTH_BAD_MAC
            enc(["NOOP"], 1, other_id, 2),  # key id 2 not on the board: AUTH_KEY_UNKNOWN
            first,  # replayed: AUTH_REPLAY
            enc(["SET_MODE standby"], 1, key, 2),  # nothing above used up seq 1 or count 2: accepted
        ]
    )
    nav, out = fly(bins, run, d, stream, key, state, "boot1")
    got = [(e["event"][4:], int(e["subject"]), int(e["arg0"]), int(e["arg1"], 0)) for e in cmd_events(out)]
    assert got == [
        ("ACCEPTED", OP["NOOP"], 0, 0),
        ("REJECTED", OP["NOOP"], 1, REJ["AUTH_MISSING"]),
        ("REJECTED", OP["NOOP"], 1, REJ["AUTH_BAD_MAC"]),
        ("REJECTED", OP["NOOP"], 1, REJ["AUTH_KEY_UNKNOWN"]),
        ("REJECTED", OP["NOOP"], 0, REJ["AUTH_REPLAY"]),
        ("ACCEPTED", OP["SET_MODE"], 1, 4),
    ], got
    summary = "authentication (epoch 1): 2 passed, refused 1 missing, 1 unknown key, 1 bad MAC, 1 replayed"
    assert summary in nav.stderr, nav.stderr
    ev = rows(out / "events.csv")
    auth = [e for e in ev if e["event"] == "TC_AUTH"]
    assert len(auth) == 1 and (auth[0]["arg0"], auth[0]["arg1"]) == ("1", "1"), auth  # epoch 1, one key
    hk = rows(out / "housekeeping.csv")[-1]
    assert (hk["tc_epoch"], hk["tc_arsn_last"]) == ("1", "2")
    assert (d / "state" / "tc_epoch").read_text() == "epoch 1\n"
    assert stat.S_IMODE((d / "state" / "tc_epoch").stat().st_mode) == 0o600
    # the key never reaches telemetry or logs
    k = key.read_text().split("\n")[1].split()[1]
    for p in list(out.iterdir()) + [d / "boot1.tlm"]:
        assert k.encode() not in p.read_bytes() and bytes.fromhex(k) not in p.read_bytes(), p
    assert k not in nav.stderr

    # reboot with the same state directory: epoch 2; boot 1's command is stale
    stream2 = first + enc(["NOOP"], 5, key, 1, 2)
    nav2, out2 = fly(bins, run, d, stream2, key, state, "boot2")
    got2 = [(e["event"][4:], int(e["arg0"]), int(e["arg1"], 0)) for e in cmd_events(out2)]
    assert got2 == [("REJECTED", 0, REJ["AUTH_STALE_EPOCH"]), ("ACCEPTED", 5, 0)], got2
    assert (d / "state" / "tc_epoch").read_text() == "epoch 2\n"
    assert rows(out2 / "housekeeping.csv")[-1]["tc_epoch"] == "2"
    assert "authentication (epoch 2): 1 passed" in nav2.stderr and "1 stale epoch" in nav2.stderr


def test_key_and_state_refusals_and_insecure_mode(bins, run, tmp_path):
    d = tmp_path
    key = d / "k"
    make_key(key)
    base = [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
            "--max-cycles", "2", "--tc-file", "/dev/null"]  # fmt: skip

    def nav(*extra: str) -> subprocess.CompletedProcess:
        return subprocess.run([*base, *extra], capture_output=True, text=True, timeout=60, check=False, cwd=d)

    r = nav()
    assert r.returncode == 2 and "--tc-insecure" in r.stderr and "--tc-key FILE --state-dir DIR" in r.stderr
    r = nav("--tc-key", str(key))
    assert r.returncode == 2 and "needs --state-dir" in r.stderr
    r = nav("--tc-key", str(key), "--tc-insecure", "--state-dir", str(d))
    assert r.returncode == 2 and "exclude each other" in r.stderr
    for mode in (0o644, 0o640, 0o604, 0o700):
        key.chmod(mode)
        r = nav("--tc-key", str(key), "--state-dir", str(d))
        assert r.returncode == 2 and "must be mode 0600 or 0400" in r.stderr, (oct(mode), r.stderr)
    key.chmod(0o400)
    assert nav("--tc-key", str(key), "--state-dir", str(d), "-q").returncode == 0
    # a broken or absent state degrades, never stops (issue 45): mfns-nav navigates, the uplink
    # refuses every command and says why; a broken state file is never read as epoch 0
    (d / "tc_epoch").write_text("epoch banana\n")
    r = nav("--tc-key", str(key), "--state-dir", str(d))
    assert r.returncode == 0 and "damaged" in r.stderr and "every command of the file refused" in r.stderr, (
        r.stderr
    )
    assert (d / "tc_epoch").read_text() == "epoch banana\n"  # never reset
    r = nav("--tc-key", str(key), "--state-dir", str(d / "absent"))
    assert r.returncode == 0 and "--state-dir" in r.stderr and "navigating" in r.stderr, r.stderr
    # insecure: a warning line, and a TC_AUTH event (WARNING, epoch 0) in the telemetry
    tlm = d / "i.tlm"
    r = nav("--tc-insecure", "--tlm-file", str(tlm))
    assert r.returncode == 0 and "WARNING: --tc-insecure" in r.stderr, r.stderr
    ig = [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(d / "ig"), "--no-status", "-q"]
    subprocess.run(ig, check=True)
    auth = [e for e in rows(d / "ig" / "events.csv") if e["event"] == "TC_AUTH"]
    assert len(auth) == 1 and auth[0]["arg0"] == "0" and auth[0]["severity"] == "WARNING", auth
    # the ground refuses a loose key file too
    key.chmod(0o644)
    g = subprocess.run(
        [str(bins / "mfns-ground"), "--file", "/dev/null", "--out", str(d / "g"), "--tc-file", str(d / "x"),
         "--tc-key", str(key), "--tc-epoch", "1", "--cmd", "NOOP"],
        capture_output=True, text=True, timeout=30, check=False,
    )  # fmt: skip
    assert g.returncode != 0 and "must be mode 0600 or 0400" in g.stderr, g.stderr


def test_tc_socket_is_private_and_its_commands_are_signed(bins, tmp_path):
    d = tmp_path
    key = d / "k"
    make_key(key)
    sock, up, fifo = d / "tc.sock", d / "up.bin", d / "tlm.fifo"
    os.mkfifo(fifo)
    (d / "not-a-socket").write_text("x")
    bad = subprocess.run(
        [str(bins / "mfns-ground"), "--file", "/dev/null", "--out", str(d / "g0"), "--tc-file", str(up),
         "--tc-socket", str(d / "not-a-socket")],
        capture_output=True, text=True, timeout=30, check=False,
    )  # fmt: skip
    assert bad.returncode != 0 and "not a socket" in bad.stderr and (d / "not-a-socket").read_text() == "x"
    ground = subprocess.Popen(
        [str(bins / "mfns-ground"), "--tty", str(fifo), "--out", str(d / "g"), "--no-status",
         "--max-seconds", "3", "--tc-file", str(up), "--tc-socket", str(sock), "--tc-key", str(key),
         "--tc-epoch", "4"],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    for _ in range(500):  # up to 10 s on a loaded machine; the ground's window is 3 s from its loop
        if sock.exists():
            break
        time.sleep(0.02)
    assert stat.S_ISSOCK(sock.stat().st_mode) and stat.S_IMODE(sock.stat().st_mode) == 0o600
    tx = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    tx.sendto(tc_packet(OP["NOOP"], 77), str(sock))
    tx.sendto(b"\x01\x02", str(sock))
    tx.close()
    _, err = ground.communicate(timeout=30)
    assert "socket commands: 2 received, 1 refused" in err, err
    assert not sock.exists()  # removed at exit
    frames = [cobs_decode(f) for f in up.read_bytes().split(b"\x00") if f]
    assert len(frames) == 1
    pkt = frames[0][:-2]
    assert pkt[6:8] == b"\x00\x01" and int.from_bytes(pkt[8:16], "big") == (4 << 32) | 1  # signed, epoch 4


def test_tm_dictionary_has_the_epoch_fields():
    root = ET.parse(TM_XML).getroot()
    hk = root.find(".//x:SequenceContainer[@name='housekeeping']", NS)
    refs = [e.get("parameterRef") for e in hk.find("x:EntryList", NS)]
    # appended after the time correlation, together (later fields follow them)
    i = refs.index("hk_tc_epoch")
    assert refs[i + 1] == "hk_tc_arsn_last" and i > refs.index("hk_time_quality")
