"""The uplink and the board's state against lies and loss (issue 45, docs/uplink.md 1a):
each case tried as a hostile tester would, asserting the refusal or the graceful path.

- wiped and restored state: the commands of a live session, recorded on the wire, replayed
  into a board whose state directory was wiped, then into one restored from a backup: every
  one refused (the recorded re-synchronisation is bound to another boot's challenge: BAD_MAC;
  the rest AUTH_RESYNC_NEEDED); the ground then gives a strictly greater epoch;
- forged housekeeping: a recording whose uplink reports were altered (epoch, count
  4294967295, state bits) or stripped of their key id makes the ground sign nothing and
  write no state; the genuine recording makes it send a re-synchronisation whose MAC binds
  the board's challenge (checked here with hmac) and then the command;
- exhausted counter: a validly signed count 0xFFFFFFFF (and one inside the reserved margin)
  refused AUTH_COUNT_EXHAUSTED without using anything up: the next command is accepted;
  a count past the low-water mark raises the COUNT_LOW bit (the ground re-synchronises);
- bad state disk: a file in place of the state directory, a full tmpfs and a read-only
  tmpfs (mount namespaces, `unshare -m`; skipped where refused, with the reason): mfns-nav
  navigates and sends telemetry (exit 0), the uplink works through the ground's
  re-synchronisation or refuses safely, housekeeping and events say why; the fix log on a
  full or read-only disk says how many records it lost, never that they were written;
- unsafe configuration: tc_insecure from a world-writable file or one owned by another user
  is refused (exit 2); from a safe file it is reported (stderr, TC_UNPROTECTED, hk bit).

Keys are made here (os.urandom); codes come from the XTCE dictionaries and the state bits
from firmware/linux/tc_auth.h (parsed, not copied).
"""

from __future__ import annotations

import hashlib
import hmac
import os
import re
import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest
from test_uplink import OP, REJ, REPO, cobs_decode, encode_commands, frame, make_key, rows
from test_uplink import run as _run

from mfns.tlm import tlm_dict

run = _run  # the 40-frame replay fixture, shared; bins is conftest's

HDR = 12  # CCSDS primary + secondary (time) header of a telemetry packet


def _bits() -> dict[str, int]:
    text = (REPO / "firmware" / "linux" / "tc_auth.h").read_text()
    return {m[1]: int(m[2], 16) for m in re.finditer(r"#define TC_AUTH_ST_(\w+) (0x[0-9a-fA-F]+)u", text)}


ST = _bits()
COUNT_MARGIN = int(
    re.search(r"TC_AUTH_COUNT_MARGIN (\d+)u", (REPO / "firmware/linux/tc_auth.h").read_text())[1]
)
COUNT_MAX = 0xFFFFFFFF - COUNT_MARGIN
HK = tlm_dict.load().packets["housekeeping"]
HK_OFF = {f.name: (HDR + f.offset, f.size) for f in HK.fields}


def key_bytes(key: Path) -> bytes:
    line = next(ln for ln in key.read_text().splitlines() if ln and not ln.startswith("#"))
    return bytes.fromhex(line.split()[1])


def sec_packet(key: bytes, opcode: int, seq: int, epoch: int, count: int, spi: int = 1) -> bytes:
    """A secured TC packet signed here (docs/uplink.md 1a), for counts the ground refuses to sign."""
    body = bytes([opcode, 0])
    n = 6 + 2 + 8 + len(body) + 16
    head = bytes([0x19, 0x81, 0xC0 | (seq >> 8), seq & 0xFF]) + (n - 7).to_bytes(2, "big")
    auth = head + spi.to_bytes(2, "big") + ((epoch << 32) | count).to_bytes(8, "big") + body
    return auth + hmac.new(key, auth, hashlib.sha256).digest()[:16]


def tc_frames(data: bytes) -> list[bytes]:
    """The CRC-checked packets of a TC (or TM) byte stream."""
    return [cobs_decode(f)[:-2] for f in data.split(b"\x00") if f]


def ground_read(bins: Path, tlm: Path, out: Path) -> subprocess.CompletedProcess:
    g = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert g.returncode == 0, g.stderr
    return g


def cmd_codes(out: Path) -> list[tuple[str, int]]:
    return [
        (e["event"][4:], int(e["arg1"], 0))
        for e in rows(out / "events.csv")
        if e["event"] in ("CMD_ACCEPTED", "CMD_REJECTED")
    ]


class Relay:
    """mfns-ground -> FIFO -> here (recorded) -> FIFO -> mfns-nav: the wire, as an eavesdropper
    on the uplink would record it."""

    def __init__(self, src: Path, dst: Path):
        self.src_fd = os.open(src, os.O_RDONLY | os.O_NONBLOCK)  # a reader before the ground opens
        self.dst = dst
        self.data = bytearray()
        self.stop = threading.Event()
        self.t = threading.Thread(target=self._run, daemon=True)
        self.t.start()

    def _run(self) -> None:
        dst_fd = -1
        while not self.stop.is_set():
            if dst_fd < 0:
                try:
                    dst_fd = os.open(self.dst, os.O_WRONLY | os.O_NONBLOCK)
                except OSError:
                    time.sleep(0.02)
                    continue
            try:
                b = os.read(self.src_fd, 4096)
            except BlockingIOError:
                b = b""
            if not b:
                time.sleep(0.01)
                continue
            self.data += b
            os.write(dst_fd, b)
        if dst_fd >= 0:
            os.close(dst_fd)
        os.close(self.src_fd)

    def close(self) -> bytes:
        self.stop.set()
        self.t.join(timeout=5)
        return bytes(self.data)


def live_session(bins, run, d: Path, name: str, key: Path, state: Path, gstate: Path, cmds: list[str]):
    """mfns-nav (paced replay) and mfns-ground live on FIFOs; returns (nav stderr, ground out
    folder, the uplink bytes as recorded on the wire)."""
    tlm, gtc, ntc = d / f"{name}-tlm.fifo", d / f"{name}-gtc.fifo", d / f"{name}-ntc.fifo"
    for f in (tlm, gtc, ntc):
        os.mkfifo(f)
    nav = subprocess.Popen(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]), "--realtime",
         "--tty", str(tlm), "--tc-tty", str(ntc), "--tc-key", str(key), "--state-dir", str(state)],
        stderr=subprocess.PIPE, text=True, cwd=d,
    )  # fmt: skip
    relay = Relay(gtc, ntc)
    out = d / f"{name}-ground"
    args = [str(bins / "mfns-ground"), "--tty", str(tlm), "--out", str(out), "--no-status",
           "--max-seconds", "60",
            "--tc-tty", str(gtc), "--tc-key", str(key), "--tc-state", str(gstate)]  # fmt: skip
    for c in cmds:
        args += ["--cmd", c]
    ground = subprocess.Popen(args, stderr=subprocess.PIPE, text=True)
    try:
        _, nav_err = nav.communicate(timeout=90)
        time.sleep(0.5)
        ground.send_signal(2)
        _, g_err = ground.communicate(timeout=30)
    finally:
        for p in (nav, ground):
            if p.poll() is None:
                p.kill()
        wire = relay.close()
    assert nav.returncode == 0, nav_err
    assert ground.returncode == 0, g_err
    return nav_err, out, wire


def replay_session(bins, run, d: Path, name: str, key: Path, state: Path, wire: bytes):
    """mfns-nav live (paced, --tc-tty FIFO) with the recorded bytes written into its uplink and
    no ground: an attacker replaying what it heard."""
    ntc = d / f"{name}-ntc.fifo"
    os.mkfifo(ntc)
    tlm = d / f"{name}.tlm"
    nav = subprocess.Popen(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]), "--realtime",
         "--tlm-file", str(tlm), "--tc-tty", str(ntc), "--tc-key", str(key), "--state-dir", str(state)],
        stderr=subprocess.PIPE, text=True, cwd=d,
    )  # fmt: skip
    fd = -1
    for _ in range(500):
        try:
            fd = os.open(ntc, os.O_WRONLY | os.O_NONBLOCK)
            break
        except OSError:
            time.sleep(0.01)
    assert fd >= 0
    os.write(fd, wire)
    _, err = nav.communicate(timeout=90)
    os.close(fd)
    assert nav.returncode == 0, err
    out = d / f"{name}-ground"
    ground_read(bins, tlm, out)
    return err, out


def test_wiped_and_restored_state_never_bring_old_commands_back(bins, run, tmp_path):
    d = tmp_path
    key = d / "board.key"
    make_key(key)
    state, gstate = d / "state", d / "ground.state"
    state.mkdir()
    nav_err, out1, wire = live_session(bins, run, d, "s1", key, state, gstate, ["NOOP", "SET_MODE acquire"])
    got1 = cmd_codes(out1)
    assert got1 == [("ACCEPTED", 0), ("ACCEPTED", 0), ("ACCEPTED", 1)], got1  # resync, NOOP, SET_MODE
    e1 = int(rows(out1 / "housekeeping.csv")[-1]["tc_epoch"])
    assert (state / "tc_epoch").read_text() == f"epoch {e1}\n"
    assert f"max_epoch {e1}\n" in gstate.read_text()
    assert len(tc_frames(wire)) == 3
    backup = d / "backup"
    shutil.copytree(state, backup)

    # wiped: the same bytes replayed, no ground: nothing accepted
    shutil.rmtree(state)
    state.mkdir()
    err2, out2 = replay_session(bins, run, d, "s2", key, state, wire)
    got2 = cmd_codes(out2)
    want = [("REJECTED", REJ["AUTH_BAD_MAC"])] + [("REJECTED", REJ["AUTH_RESYNC_NEEDED"])] * 2
    assert got2 == want, got2
    hk = rows(out2 / "housekeeping.csv")[-1]
    assert int(hk["tc_state"]) & ST["RESYNC_NEEDED"] and int(hk["tc_state"]) & ST["STATE_MISSING"], hk
    assert "1 awaiting" not in err2 and "2 awaiting re-synchronisation" in err2, err2
    print(f"\nwiped state: {len(got2)} replayed commands, all refused: {got2}")

    # restored from the backup: the same
    shutil.rmtree(state)
    shutil.copytree(backup, state)
    _, out3 = replay_session(bins, run, d, "s3", key, state, wire)
    got3 = cmd_codes(out3)
    assert got3 == want, got3
    assert rows(out3 / "housekeeping.csv")[-1]["tc_epoch"] == str(e1)  # the floor it reports
    print(f"restored state: {len(got3)} replayed commands, all refused: {got3}")

    # the genuine ground: a strictly greater epoch, accepted
    _, out4, _ = live_session(bins, run, d, "s4", key, state, gstate, ["NOOP"])
    assert cmd_codes(out4) == [("ACCEPTED", 0), ("ACCEPTED", 0)]
    e4 = int(rows(out4 / "housekeeping.csv")[-1]["tc_epoch"])
    assert e4 > e1, (e4, e1)
    print(f"epochs given by the ground: {e1}, then {e4}")


def hk_patch(pkt: bytes, **fields: int) -> bytes:
    b = bytearray(pkt)
    for name, v in fields.items():
        off, size = HK_OFF[name]
        b[off : off + size] = v.to_bytes(size, "big")
    return bytes(b)


def forge(tlm: bytes, **fields: int) -> bytes:
    """Every housekeeping packet of a recording altered (re-framed with a good CRC: the link
    check proves nothing about the sender)."""
    out = bytearray()
    for p in tc_frames(tlm):
        apid = int.from_bytes(p[0:2], "big") & 0x7FF
        out += frame(hk_patch(p, **fields) if apid == HK.apid else p)
    return bytes(out)


def ground_offline(bins, d: Path, name: str, tlm: Path, key: Path, gstate: Path):
    up = d / f"{name}.tc"
    g = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(d / f"{name}-g"), "--no-status",
         "--tc-file", str(up), "--tc-key", str(key), "--tc-state", str(gstate), "--cmd", "NOOP"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    return g, up.read_bytes() if up.exists() else b""


def test_forged_housekeeping_cannot_steer_the_ground(bins, run, tmp_path):
    d = tmp_path
    key = d / "board.key"
    make_key(key)
    state = d / "state"
    state.mkdir()
    os.mkfifo(d / "tc.fifo")
    tlm = d / "genuine.tlm"
    nav = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
         "--tlm-file", str(tlm), "--tc-tty", str(d / "tc.fifo"), "--tc-key", str(key),
         "--state-dir", str(state),
         "--max-cycles", "12"],
        capture_output=True, text=True, timeout=60, check=False, cwd=d,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    genuine = tlm.read_bytes()
    hks = [p for p in tc_frames(genuine) if int.from_bytes(p[0:2], "big") & 0x7FF == HK.apid]
    assert len(hks) >= 2
    nonce = int.from_bytes(hks[-1][HK_OFF["tc_nonce_hi"][0] : HK_OFF["tc_nonce_lo"][0] + 4], "big")
    assert nonce != 0

    cases = {
        "count": {"tc_arsn_last": 0xFFFFFFFF, "tc_state": 0, "tc_epoch": 7},  # MAC no longer matches
        "epoch": {"tc_epoch": 123456, "tc_state": ST["RESYNC_NEEDED"]},
        "nonce": {"tc_nonce_lo": 0x01020304},  # steer a resync to an attacker's challenge
        "unsigned": {"tc_report_spi": 0, "tc_arsn_last": 0xFFFFFFFF},
    }
    for name, fields in cases.items():
        forged = d / f"forged-{name}.tlm"
        forged.write_bytes(forge(genuine, **fields))
        gstate = d / f"g-{name}.state"
        g, up = ground_offline(bins, d, name, forged, key, gstate)
        assert g.returncode == 1, (name, g.stderr)  # commands not sent: an error at exit
        assert up == b"", (name, tc_frames(up))  # nothing signed, no re-synchronisation
        assert not gstate.exists(), name  # nothing given, nothing recorded
        assert "no authenticated uplink report" in g.stderr, g.stderr
        print(
            f"\nforged housekeeping ({name}: {fields}): ground signed 0 frames: "
            f"{g.stderr.strip().splitlines()[-2]}"
        )

    # the genuine recording: a re-synchronisation bound to the board's challenge, then the command
    gstate = d / "g-genuine.state"
    g, up = ground_offline(bins, d, "genuine", tlm, key, gstate)
    assert g.returncode == 0, g.stderr
    pkts = tc_frames(up)
    assert len(pkts) == 2, pkts
    k = key_bytes(key)
    rs, noop = pkts
    arsn = int.from_bytes(rs[8:16], "big")
    epoch = arsn >> 32
    assert arsn & 0xFFFFFFFF == 1 and rs[16] == OP["NOOP"]
    want = hmac.new(k, b"MFNS-TC-RESYNC-v1" + nonce.to_bytes(8, "big") + rs[:-16], hashlib.sha256).digest()[
        :16
    ]
    assert rs[-16:] == want  # bound to this boot's challenge
    assert rs[-16:] != hmac.new(k, rs[:-16], hashlib.sha256).digest()[:16]  # not an ordinary command MAC
    assert int.from_bytes(noop[8:16], "big") == (epoch << 32) | 2
    assert noop[-16:] == hmac.new(k, noop[:-16], hashlib.sha256).digest()[:16]
    assert gstate.read_text() == f"max_epoch {epoch}\nepoch {epoch}\nnext_count 3\n"
    assert (gstate.stat().st_mode & 0o777) == 0o600


def test_exhausted_counter_refused_without_wedging_the_uplink(bins, run, tmp_path):
    d = tmp_path
    key = d / "board.key"
    make_key(key)
    k = key_bytes(key)
    state = d / "state"
    state.mkdir()
    # a recorded command file: the local epoch (1 for a fresh state directory)
    stream = b"".join(
        [
            frame(sec_packet(k, OP["NOOP"], 0, 1, 0xFFFFFFFF)),  # the top: refused, nothing used up
            frame(sec_packet(k, OP["NOOP"], 0, 1, COUNT_MAX + 1)),  # inside the reserved margin
            encode_commands(bins, d, ["NOOP"], 0, key, 2),  # still usable: accepted
            frame(sec_packet(k, OP["NOOP"], 1, 1, COUNT_MAX - 1)),  # valid: accepted, COUNT_LOW raised
            frame(sec_packet(k, OP["NOOP"], 2, 1, COUNT_MAX)),  # the last usable count
            frame(sec_packet(k, OP["NOOP"], 3, 1, 0xFFFFFFFF)),  # still refused, same code
        ]
    )
    (d / "c.tc").write_bytes(stream)
    tlm = d / "c.tlm"
    nav = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
         "--tlm-file", str(tlm),
         "--tc-file", str(d / "c.tc"), "--tc-key", str(key), "--state-dir", str(state), "--max-cycles", "12"],
        capture_output=True, text=True, timeout=60, check=False, cwd=d,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    out = d / "g"
    ground_read(bins, tlm, out)
    got = cmd_codes(out)
    ex = REJ["AUTH_COUNT_EXHAUSTED"]
    assert got == [("REJECTED", ex), ("REJECTED", ex), ("ACCEPTED", 0), ("ACCEPTED", 0), ("ACCEPTED", 0),
                   ("REJECTED", ex)], got  # fmt: skip
    hk = rows(out / "housekeeping.csv")[-1]
    assert int(hk["tc_arsn_last"]) == COUNT_MAX and int(hk["tc_state"]) & ST["COUNT_LOW"]
    assert "3 count exhausted" in nav.stderr
    print(f"\nexhausted counter: {got}")


def nav_fifo_session(
    bins,
    run,
    d: Path,
    key: Path,
    state_dir: str,
    extra: list[str] | None = None,
    wrap: list[str] | None = None,
    gstate: Path | None = None,
):
    """mfns-nav live with a ground (re-synchronising) whose state dir is state_dir; wrap: a
    command prefix (unshare ... sh -c)."""
    tlm, tc = d / "tlm.fifo", d / "tc.fifo"
    for f in (tlm, tc):
        if not f.exists():
            os.mkfifo(f)
    cmd = [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]), "--realtime",
           "--tty", str(tlm), "--tc-tty", str(tc), "--tc-key", str(key),
           "--state-dir", state_dir, *(extra or [])]  # fmt: skip
    if wrap is not None:
        cmd = [*wrap, " ".join(f"'{c}'" for c in cmd)]
    nav = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, cwd=d)
    out = d / "ground"
    ground = subprocess.Popen(
        [str(bins / "mfns-ground"), "--tty", str(tlm), "--out", str(out), "--no-status",
         "--max-seconds", "60",
         "--tc-tty", str(tc), "--tc-key", str(key), "--tc-state", str(gstate or d / "g.state"),
         "--cmd", "NOOP"],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        _, nav_err = nav.communicate(timeout=90)
        time.sleep(0.5)
        ground.send_signal(2)
        _, g_err = ground.communicate(timeout=30)
    finally:
        for p in (nav, ground):
            if p.poll() is None:
                p.kill()
    return nav, nav_err, out, g_err


def test_a_file_in_place_of_the_state_dir_degrades(bins, run, tmp_path):
    d = tmp_path
    key = d / "board.key"
    make_key(key)
    bad = d / "state"
    bad.write_text("not a directory\n")
    nav, err, out, _ = nav_fifo_session(bins, run, d, key, str(bad))
    assert nav.returncode == 0, err  # never exit 2 (was: a restart loop under the supervisor)
    navr = rows(out / "nav.csv")
    fixes = sum(r["status"] in ("FIX", "DEGRADED") for r in navr)
    assert fixes >= 30, fixes
    ev = rows(out / "events.csv")
    sf = [e for e in ev if e["event"] == "STORAGE_FAULT"]
    assert sf and sf[0]["subject"] == "0" and sf[0]["arg1"] == "2", sf  # the uplink state: not writable
    rs = [e for e in ev if e["event"] == "TC_RESYNC"]
    assert len(rs) == 1 and rs[0]["subject"] == "1" and rs[0]["severity"] == "WARNING", rs  # not stored
    assert cmd_codes(out) == [("ACCEPTED", 0), ("ACCEPTED", 0)]  # the ground keeps the epoch fresh
    hk = rows(out / "housekeeping.csv")[-1]
    assert int(hk["tc_state"]) & ST["STATE_RO"] and int(hk["n_storage_errors"]) >= 1, hk
    print(
        f"\nfile in place of the state dir: exit 0, {fixes} fixes, uplink re-synchronised, "
        f"hk tc_state {hk['tc_state']}, n_storage_errors {hk['n_storage_errors']}"
    )


def can_mount_tmpfs(d: Path) -> str | None:
    m = d / "probe"
    m.mkdir()
    r = subprocess.run(["unshare", "-m", "sh", "-c", f"mount -t tmpfs -o size=16k tmpfs '{m}'"],
                       capture_output=True, text=True, check=False)  # fmt: skip
    return None if r.returncode == 0 else (r.stderr.strip() or "unshare -m refused")


@pytest.mark.parametrize("kind", ["full", "readonly"])
def test_full_or_read_only_disk_degrades_and_the_fixlog_is_honest(bins, run, tmp_path, kind):
    d = tmp_path
    why = can_mount_tmpfs(d)
    if why is not None:
        pytest.skip(f"no private tmpfs here: {why}")
    key = d / "board.key"
    make_key(key)
    disk = d / "disk"
    disk.mkdir()
    # a 64 KiB tmpfs: the state dir and the fix log on it, then filled or made read-only,
    # in a private mount namespace (nothing outside sees it)
    if kind == "full":
        prep = (f"mount -t tmpfs -o size=64k tmpfs '{disk}' && mkdir '{disk}/state' '{disk}/fixlog' && "
                f"(dd if=/dev/zero of='{disk}/fill' bs=1k count=200 2>/dev/null; true) && "
                f"test $(df --output=avail -k '{disk}' | tail -1) -eq 0 && exec ")  # fmt: skip
    else:
        prep = (f"mount -t tmpfs -o size=64k tmpfs '{disk}' && mkdir '{disk}/state' '{disk}/fixlog' && "
                f"mount -o remount,ro '{disk}' && ! touch '{disk}/state/x' 2>/dev/null && exec ")  # fmt: skip
    wrap = ["unshare", "-m", "sh", "-c", prep + '"$0" "$@"']
    tlm, tc = d / "tlm.fifo", d / "tc.fifo"
    os.mkfifo(tlm)
    os.mkfifo(tc)
    nav_cmd = [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
               "--realtime",
               "--tty", str(tlm), "--tc-tty", str(tc), "--tc-key", str(key),
               "--state-dir", str(disk / "state"),
               "--fixlog", str(disk / "fixlog")]  # fmt: skip
    nav = subprocess.Popen([*wrap, *nav_cmd], stderr=subprocess.PIPE, text=True, cwd=d)
    out = d / "ground"
    ground = subprocess.Popen(
        [str(bins / "mfns-ground"), "--tty", str(tlm), "--out", str(out), "--no-status",
         "--max-seconds", "60",
         "--tc-tty", str(tc), "--tc-key", str(key), "--tc-state", str(d / "g.state"), "--cmd", "NOOP"],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        _, err = nav.communicate(timeout=90)
        time.sleep(0.5)
        ground.send_signal(2)
        _, g_err = ground.communicate(timeout=30)
    finally:
        for p in (nav, ground):
            if p.poll() is None:
                p.kill()
    assert nav.returncode == 0, err
    navr = rows(out / "nav.csv")
    fixes = sum(r["status"] in ("FIX", "DEGRADED") for r in navr)
    assert fixes >= 30, fixes
    m = re.search(r"fix log \S+: (\d+) fixes written, (\d+) lost to write errors", err)
    assert m is not None, err
    written, lost = int(m[1]), int(m[2])
    assert written == 0 and lost >= 1, err  # was: "118 fixes recorded" with nothing written
    hk = rows(out / "housekeeping.csv")[-1]
    assert int(hk["n_fixlog_errors"]) >= 1, hk
    assert int(hk["tc_state"]) & ST["STATE_RO"], hk
    ev = rows(out / "events.csv")
    subjects = {e["subject"] for e in ev if e["event"] == "STORAGE_FAULT"}
    assert {"0", "1"} <= subjects, subjects  # the uplink state and the fix log
    assert cmd_codes(out) == [("ACCEPTED", 0), ("ACCEPTED", 0)], cmd_codes(out)
    print(
        f"\n{kind} disk: exit 0, {fixes} fixes, fix log {written} written / {lost} lost, "
        f"hk n_fixlog_errors {hk['n_fixlog_errors']}, tc_state {hk['tc_state']}, uplink re-synchronised"
    )


def test_unsafe_configuration_refused_and_insecure_mode_reported(bins, run, tmp_path):
    d = tmp_path
    conf = d / "nav.conf"
    conf.write_text("# bench\ntc_insecure = yes\n")
    base = [str(bins / "mfns-nav"), "--config", str(conf), "--table", str(run["table"]), "--replay",
            str(run["frames"]), "--max-cycles", "3", "--tc-file", "/dev/null"]  # fmt: skip

    def nav(*extra: str) -> subprocess.CompletedProcess:
        return subprocess.run([*base, *extra], capture_output=True, text=True, timeout=60, check=False, cwd=d)

    for mode in (0o666, 0o664, 0o646, 0o620):
        conf.chmod(mode)
        r = nav()
        assert (
            r.returncode == 2 and "refused from a file with mode" in r.stderr and "tc_insecure" in r.stderr
        ), (oct(mode), r.stderr)
    conf.chmod(0o600)
    os.chown(conf, 12345, 12345)  # another user's file (the tests run as root: root may chown)
    r = nav()
    assert r.returncode == 2 and "owned by uid 12345" in r.stderr, r.stderr
    os.chown(conf, os.geteuid(), os.getegid())
    # a world-writable file without security keys is still taken (only those keys are guarded)
    other = d / "plain.conf"
    other.write_text("timeout_ms = 500\n")
    other.chmod(0o666)
    r = subprocess.run([*base[:1], "--config", str(other), *base[3:], "--tc-insecure", "-q"],
        capture_output=True,
                       text=True, timeout=60, check=False, cwd=d)  # fmt: skip
    assert r.returncode == 0, r.stderr
    # safe file: authentication off is reported on stderr, by an event and in housekeeping
    conf.chmod(0o644)
    tlm = d / "i.tlm"
    r = nav("--tlm-file", str(tlm))
    assert r.returncode == 0, r.stderr
    assert "WARNING: tc_insecure = yes in the configuration" in r.stderr, r.stderr
    out = d / "g"
    ground_read(bins, tlm, out)
    un = [e for e in rows(out / "events.csv") if e["event"] == "TC_UNPROTECTED"]
    assert len(un) == 1 and un[0]["arg0"] == "2" and un[0]["severity"] == "WARNING", un
    assert all(int(h["tc_state"]) & ST["INSECURE"] for h in rows(out / "housekeeping.csv"))


SUPERVISE_SRC = REPO / "boards" / "sitss-nav" / "image" / "mfns-supervise.c"


def build_supervise(d: Path, src: Path = SUPERVISE_SRC) -> Path:
    exe = d / "mfns-supervise"
    r = subprocess.run(
        ["cc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-Wconversion", "-Wshadow",
         "-O2", str(src), "-o", str(exe)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return exe


def supervise(
    exe: Path, d: Path, child: list[str], seconds: float, extra: list[str] | None = None, during=None
) -> tuple[str, Path]:
    """Runs the supervisor for seconds (then SIGTERM); its log (stderr, LOG_PERROR) and exit file."""
    exit_file = d / "last-exit"
    sup = subprocess.Popen(
        [str(exe), "--socket", str(d / "notify.sock"), "--exit-file", str(exit_file), "--rt-prio", "0",
         "--restart-ms", "100", "--kill-grace-ms", "200", *(extra or []), "--", *child],
        stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    try:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            if during is not None:
                during()
            time.sleep(0.1)
        sup.send_signal(15)
        _, err = sup.communicate(timeout=10)
    finally:
        if sup.poll() is None:
            os.killpg(sup.pid, 9)  # its own session: everything it started
            sup.wait()
    return err, exit_file


def marker_alive(marker: str) -> bool:
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                if marker in (p / "cmdline").read_bytes().decode(errors="replace"):
                    return True
            except OSError:
                pass
    return False


def test_supervisor_restarts_whatever_descendants_hold(tmp_path):
    d = tmp_path
    exe = build_supervise(d)
    marker = f"61.{os.getpid() % 1000}{int(time.time()) % 1000}"
    # the child leaves a grandchild holding its stdout/stderr (the log pipe), then fails
    child = ["/bin/sh", "-c", f"sleep {marker} & echo child up; exit 1"]
    err, exit_file = supervise(exe, d, child, 3.0)
    starts = err.count("started mfns-nav[")
    assert starts >= 3, err  # was 1: the supervisor blocked reading the pipe, never restarting
    assert "left processes in its group: killed" in err, err
    assert exit_file.read_text() == "exit-code exited 1\n"
    time.sleep(0.2)
    assert not marker_alive(marker), "a grandchild outlived its run"
    print(f"\nsupervisor, grandchild holding the log pipe: {starts} starts in 3 s, grandchildren killed")


def test_supervisor_takes_watchdog_pings_only_from_its_child(tmp_path):
    d = tmp_path
    exe = build_supervise(d)
    sock = d / "notify.sock"
    # the child says READY once, then hangs; another process keeps pinging for it
    child = [sys_python(), "-c",
             "import os, socket, time\n"
             "s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)\n"
             "s.sendto(b'READY=1', os.environ['NOTIFY_SOCKET'])\n"
             "time.sleep(30)\n"]  # fmt: skip
    tx = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sent = [0]

    def ping() -> None:
        try:
            tx.sendto(b"WATCHDOG=1\nREADY=1", str(sock))
            sent[0] += 1
        except OSError:
            pass

    err, exit_file = supervise(exe, d, child, 3.0, ["--watchdog-ms", "500"], during=ping)
    tx.close()
    assert sent[0] >= 10
    assert "notify datagram from pid" in err and "ignored" in err, err
    assert "watchdog: no ping" in err, err  # the hang is seen despite the foreign pings
    ends = re.findall(r"mfns-nav ended: (.*)", err)
    assert ends and ends[0].startswith("watchdog "), err  # (the last run ends by the test's SIGTERM)
    print(f"\nsupervisor, {sent[0]} foreign pings: ignored, the hung child killed by the watchdog: {ends}")


def sys_python() -> str:
    import sys

    return sys.executable


def test_reloading_the_running_table_keeps_the_track(bins, run, tmp_path):
    """Issue 45 item 6: TABLE_LOAD of the table that runs (an operator re-sending it, a ground
    script) keeps the track: the same fixes as a run without it, no false camera or beacon
    fault; nor does a compatible table (the same rig and beacons, other settings), which the
    core re-binds keeping the track."""
    d = tmp_path
    (d / "t.mfnstbl").write_bytes(run["table"].read_bytes())

    def stream(last: str) -> Path:
        src = d / "empty.bin"
        src.write_bytes(b"")
        out = d / f"{last.split()[0]}.tc"
        args = [
            str(bins / "mfns-ground"),
            "--file",
            str(src),
            "--out",
            str(d / "g-enc"),
            "-q",
            "--tc-file",
            str(out),
        ]
        for _ in range(18):  # 4 commands a cycle: the last one lands in cycle 4, mid-track
            args += ["--cmd", "NOOP"]
        args += ["--cmd", last]
        r = subprocess.run(args, capture_output=True, text=True, check=False, timeout=30)
        assert r.returncode in (0, 3), r.stderr
        return out

    def fly(name: str, tc: Path) -> tuple[list[dict], list[dict], str]:
        tlm = d / f"{name}.tlm"
        nav = subprocess.run(
            [str(bins / "mfns-nav"), "--table", str(run["table"]), "--replay", str(run["frames"]),
             "--tlm-file", str(tlm), "--tc-file", str(tc), "--tc-insecure"],
            capture_output=True, text=True, timeout=120, check=False, cwd=d,
        )  # fmt: skip
        assert nav.returncode == 0, nav.stderr
        out = d / f"{name}-g"
        ground_read(bins, tlm, out)
        return rows(out / "nav.csv"), rows(out / "events.csv"), nav.stderr

    base_nav, base_ev, _ = fly("base", stream("NOOP"))
    nav, ev, err = fly("reload", stream("TABLE_LOAD t.mfnstbl"))
    loads = [e for e in ev if e["event"] == "CMD_ACCEPTED" and int(e["subject"]) == OP["TABLE_LOAD"]]
    assert len(loads) == 1 and loads[0]["cycle"] == "4", loads
    assert "the running table" in err and "kept, the track goes on" in err
    assert [r["status"] for r in nav] == [r["status"] for r in base_nav]  # not one fix lost
    assert [r["mode"] for r in nav] == [r["mode"] for r in base_nav]
    faults = ("CAMERAS_DISAGREE", "CAMERA_INCONSISTENT", "BEACON_MISSING")
    n_base = sum(e["event"] in faults for e in base_ev)
    n = sum(e["event"] in faults for e in ev)
    assert n == n_base, (n, n_base)
    fixes = sum(r["status"] in ("FIX", "DEGRADED") for r in nav)
    print(
        f"\nreload of the running table at cycle 4: {fixes}/{len(nav)} fixes, as without it; "
        f"fault events {n} (baseline {n_base})"
    )
    # a compatible table (the same rig and beacons, another pixel sigma): the core re-binds it
    # (mfns_nav_rebind), the track goes on: the same modes as without the load, no false fault
    (d / "t2.mfnstbl").write_bytes(run["table2"].read_bytes())
    nav2, ev2, err2 = fly("compatible", stream("TABLE_LOAD t2.mfnstbl"))
    assert "re-bound, the track goes on" in err2, err2
    assert [r["mode"] for r in nav2] == [r["mode"] for r in base_nav]  # never back to ACQUIRE
    assert sum(e["event"] in faults for e in ev2) == n_base
    assert not [e for e in ev2 if e["event"] == "TABLE_REFUSED"]
