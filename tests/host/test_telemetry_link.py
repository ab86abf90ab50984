"""End to end telemetry link: encoder -> pseudo-terminal -> mfns-ground -> CSV.

The C encoder (mfns-tlm-gen, the synthetic stream of ground/tlm_synth.h)
writes through the fd transport into a pty this test creates; mfns-ground
reads the other side and writes CSV. The expected navigation rows are
computed here, independently, from the generator's documented integer
formulas, so the comparison checks encoder, framing, pty raw mode, decoder
and CSV formatting together. Faults are injected into the byte stream and
the ground's counters are checked against them.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import threading
import tty
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = REPO / "build" / "host-sim" / "bin"
U32 = 0xFFFFFFFF


@pytest.fixture(scope="module")
def bins() -> dict[str, Path]:
    ground, gen = BIN / "mfns-ground", BIN / "mfns-tlm-gen"
    # make is incremental: cheap when up to date, builds them when missing.
    res = subprocess.run(
        ["make", "--no-print-directory", "-j2", "BOARD=host-sim", "flight"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    assert ground.exists() and gen.exists()
    return {"ground": ground, "gen": gen}


def fixed(v: int, d: int) -> str:
    p = 10**d
    return f"{'-' if v < 0 else ''}{abs(v) // p}.{abs(v) % p:0{d}d}"


def cuc_time_str(i: int) -> str:
    t_us = i * 53763
    coarse, fine = t_us // 1_000_000, ((t_us % 1_000_000) << 16) // 1_000_000
    us = coarse * 1_000_000 + ((fine * 1_000_000 + 32768) >> 16)
    return f"{us // 1_000_000}.{us % 1_000_000:06d}"


def expected_nav_row(i: int, seq: int) -> str:
    """ground_gen_nav(i) as mfns-ground prints it (docs/telemetry.md columns)."""
    no_fix = i % 10 == 9
    pos = [
        ((i * 7919) & U32) % 20001 - 10000,
        15000 - ((i * 104729) & U32) % 30001,
        500000 + i % 1000,
    ]
    att = [
        ((i * 37) & U32) % 301 * 1000 - 150000,
        150000 - ((i * 53) & U32) % 301 * 1000,
        ((i * 1000000) & U32) % 360000000 - 180000000,
    ]
    sp = [1600 + (i + k * 7) % 100 for k in range(3)]
    sa = [150000 + (i + k * 11) % 1000 for k in range(3)]
    # quaternion (Q1.30) and covariance (binary32) of ground_gen_nav, in float32 as the C code
    f32 = np.float32
    a = f32(0.001) * f32(i % 1000)
    q = (
        [0, 0, 0, 0]
        if no_fix
        else [q30(f32(0.8)), q30(f32(0.6) * (f32(1) - a)), q30(f32(-0.6) * a), q30(f32(0))]
    )
    cov = []
    for k in range(21):
        mag = f32(2.5e-3) if k in (0, 6, 11) else f32(1.0e-7) * f32(k + 1)
        v = (-mag if (i + k) % 3 == 0 else mag) * (f32(1) + f32(0.01) * f32(i % 97))
        cov.append("0" if no_fix else f"{float(v):.9g}")
    cols = [
        cuc_time_str(i),
        str(seq),
        str(i),
        "NO_FIX" if no_fix else "FIX",
        "3" if no_fix else "0",
        "ACQUIRE" if i == 0 else "TRACK",
        str(3 + i % 4),
        str(1 + i % 7),
        str(2 + i % 5),
        *[fixed(v, 3) for v in pos],
        *[fixed(v, 6) for v in att],
        *[fixed(v, 3) for v in sp],
        *[fixed(v, 6) for v in sa],
        fixed(100 + (i * 37) % 900, 3),
        *[f"{v / 2**30:.10f}" for v in q],
        *cov,
        fixed(0, 3),  # pl_pos_mm: ground_gen_nav leaves the protection levels 0
        fixed(0, 6),  # pl_att_deg
    ]
    return ",".join(cols)


def q30(v: np.float32) -> int:
    """tlm_scale_i32(v, TLM_Q30_SCALE): product in float32, rounded half away from zero."""
    r = np.float32(v) * np.float32(2**30)
    return int(r + np.float32(0.5)) if r >= 0 else -int(-r + np.float32(0.5))


UTC = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{6}Z")


def rows(path: Path) -> list[str]:
    """The data rows of a ground CSV without their utc, time_source and ground_utc
    columns (checked here: the synthetic stream carries no time correlation, so
    its UTC is the ground's at receipt)."""
    out = []
    for line in path.read_text().splitlines()[1:]:
        body, utc, source, received = line.rsplit(",", 3)
        assert UTC.fullmatch(utc) and UTC.fullmatch(received), line
        assert source in ("GROUND_RECEIPT", "FLIGHT_SYSTEM", "FLIGHT_SYNCED"), line
        out.append(body)
    return out


AX = ("x", "y", "z", "rx", "ry", "rz")
NAV_HEADER = (
    "t_s,seq,cycle,status,reason,mode,beacons_used,cams_used,iterations,x_mm,y_mm,z_mm,"
    "roll_deg,pitch_deg,yaw_deg,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_roll_deg,sigma_pitch_deg,"
    "sigma_yaw_deg,residual_rms_px,q_w,q_x,q_y,q_z,"
    + ",".join(f"cov_{a}_{b}" for i, a in enumerate(AX) for b in AX[i:])
    + ",pl_pos_mm,pl_att_deg,utc,time_source,ground_utc"
)


def frames_per_cycle(i: int) -> int:
    return 4 + (1 if i <= 1 else 0) + (1 if i % 19 == 18 else 0)


def total_frames(cycles: int) -> int:
    return sum(frames_per_cycle(i) for i in range(cycles))


def open_pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)  # before any byte arrives: no echo, no CR/LF mapping
    return master, slave, os.ttyname(slave)


def run_ground(bins, args: list[str], **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [str(bins["ground"]), "--no-status", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def test_pty_link_csv_equals_what_was_sent(bins, tmp_path):
    cycles = 200
    n_frames = total_frames(cycles)
    master, slave, slave_path = open_pty()
    out = tmp_path / "out"
    try:
        ground = run_ground(
            bins,
            ["--tty", slave_path, "--out", str(out), "--max-frames", str(n_frames), "--max-seconds", "30"],
        )
        gen = subprocess.run(
            [str(bins["gen"]), "--cycles", str(cycles), "--fd", str(master)],
            pass_fds=(master,),
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert gen.returncode == 0, gen.stderr
        _, err = ground.communicate(timeout=60)
    finally:
        os.close(master)
        os.close(slave)
    assert ground.returncode == 0, err
    nav = (out / "nav.csv").read_text().splitlines()
    assert nav[0] == NAV_HEADER
    assert rows(out / "nav.csv") == [expected_nav_row(i, i) for i in range(cycles)]
    stats = json.loads((out / "stats.json").read_text())
    assert stats["frames_ok"] == n_frames
    for key in ("crc_errors", "truncated", "oversize", "bad_packets", "resyncs", "seq_gaps"):
        assert stats[key] == 0, key
    cam = (out / "camera.csv").read_text().splitlines()
    assert len(cam) == 1 + 3 * cycles
    assert cam[1].split(",")[3:6] == ["x", "OK", "0"]
    assert len((out / "housekeeping.csv").read_text().splitlines()) == 1 + sum(
        1 for i in range(cycles) if i % 19 == 18
    )
    events = (out / "events.csv").read_text().splitlines()
    assert [e.split(",")[3] for e in events[1:]] == ["BOOT", "TABLE_LOADED"]
    # JSON Lines carry the same rows
    jl = [json.loads(line) for line in (out / "nav.jsonl").read_text().splitlines()]
    assert len(jl) == cycles
    assert jl[7]["yaw_deg"] == pytest.approx(-173.0)
    assert jl[7]["cycle"] == 7 and jl[9]["status"] == "NO_FIX"
    assert f"frames_ok={n_frames} crc_errors=0" in err


def split_frames(stream: bytes) -> list[bytes]:
    parts = stream.split(b"\x00")
    assert parts[-1] == b""
    return [p + b"\x00" for p in parts[:-1]]


def test_pty_link_with_injected_faults(bins, tmp_path):
    cycles = 120
    raw = subprocess.run(
        [str(bins["gen"]), "--cycles", str(cycles)], capture_output=True, check=True, timeout=30
    ).stdout
    frames = split_frames(raw)
    assert len(frames) == total_frames(cycles)
    # frame index -> cycle of each nav frame
    nav_frame_of_cycle, k = {}, 0
    for i in range(cycles):
        k += 1 if i <= 1 else 0
        nav_frame_of_cycle[i] = k
        k += frames_per_cycle(i) - (1 if i <= 1 else 0)
    hit_cycles = {10: "garbage", 25: "bitflip", 40: "truncate", 55: "oversize", 70: "bitflip"}
    hit_frames = {nav_frame_of_cycle[c]: how for c, how in hit_cycles.items()}
    # the receiver starts mid-"frame": this garbage is glued onto frame 0 (BOOT) and costs it
    out_stream = bytearray(b"\x13\x11garbage before the first frame")
    for idx, f in enumerate(frames):
        how = hit_frames.get(idx)
        if how == "garbage":
            out_stream += bytes(range(1, 40))  # glued onto this frame
            out_stream += f
        elif how == "bitflip":
            g = bytearray(f)
            g[len(g) // 2] ^= 0x10
            if g[len(g) // 2] == 0:
                g[len(g) // 2] = 0x77
            out_stream += g
        elif how == "truncate":
            out_stream += f[: len(f) // 2] + b"\x00"
        elif how == "oversize":
            out_stream += b"\x55" * 500 + f
        else:
            out_stream += f
    expected_good = len(frames) - len(hit_frames) - 1
    master, slave, slave_path = open_pty()
    out = tmp_path / "out"
    try:
        ground = run_ground(
            bins,
            [
                "--tty",
                slave_path,
                "--out",
                str(out),
                "--max-frames",
                str(expected_good),
                "--max-seconds",
                "30",
            ],
        )
        writer = threading.Thread(target=os.write, args=(master, bytes(out_stream)))
        writer.start()
        _, err = ground.communicate(timeout=60)
        writer.join(timeout=30)
    finally:
        os.close(master)
        os.close(slave)
    assert ground.returncode == 0, err
    stats = json.loads((out / "stats.json").read_text())
    assert stats["frames_ok"] == expected_good
    # the leading garbage + each of the 5 faults: one dropped frame each, then a resync
    dropped = stats["crc_errors"] + stats["truncated"] + stats["oversize"] + stats["bad_packets"]
    assert dropped == len(hit_frames) + 1
    assert stats["oversize"] >= 1
    assert stats["truncated"] + stats["crc_errors"] >= 3
    assert stats["resyncs"] == len(hit_frames) + 1
    assert stats["packets"]["nav"]["gaps"] == len(hit_cycles)
    assert stats["packets"]["nav"]["lost"] == len(hit_cycles)
    nav = rows(out / "nav.csv")
    assert nav == [expected_nav_row(i, i) for i in range(cycles) if i not in hit_cycles]
    events = (out / "events.csv").read_text().splitlines()[1:]
    assert [e.split(",")[3] for e in events] == ["TABLE_LOADED"]


def test_file_replay_record_and_stdin(bins, tmp_path):
    stream = tmp_path / "tlm.bin"
    subprocess.run([str(bins["gen"]), "--cycles", "30", "--out", str(stream)], check=True, timeout=30)
    rec = tmp_path / "rec.bin"
    res = subprocess.run(
        [str(bins["ground"]), "--file", str(stream), "--out", str(tmp_path / "a"), "--record", str(rec)],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert res.returncode == 0, res.stderr
    assert rec.read_bytes() == stream.read_bytes()
    a = rows(tmp_path / "a" / "nav.csv")
    assert a == [expected_nav_row(i, i) for i in range(30)]
    with stream.open("rb") as f:
        res = subprocess.run(
            [str(bins["ground"]), "--file", "-", "--out", str(tmp_path / "b")],
            stdin=f,
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
    assert res.returncode == 0, res.stderr
    assert rows(tmp_path / "b" / "nav.csv") == a


def test_cli_errors_and_help(bins, tmp_path):
    def run(*args):
        return subprocess.run(
            [str(bins["ground"]), *args], capture_output=True, text=True, timeout=30, check=False
        )

    h = run("--help")
    assert h.returncode == 0 and "--max-frames" in h.stdout and "--port" in h.stdout
    assert run().returncode == 2
    assert run("--file", "x", "--tty", "y").returncode == 2
    assert run("--file", "x", "--max-frames", "abc").returncode == 2
    assert run("--bogus", "1").returncode == 2
    missing = run("--file", str(tmp_path / "nope.bin"), "--out", str(tmp_path / "o"))
    assert missing.returncode == 1 and "nope.bin" in missing.stderr
    # libserialport refuses a pty (docs/telemetry.md, transports): a clear error, not a hang
    master, slave, slave_path = open_pty()
    try:
        serial = run("--port", slave_path, "--out", str(tmp_path / "s"), "--max-seconds", "2")
    finally:
        os.close(master)
        os.close(slave)
    assert serial.returncode == 1 and "cannot open" in serial.stderr


def test_fifo_transport_and_live_status(bins, tmp_path):
    """mfns-tlm-gen writes through the transport into a FIFO by path; mfns-ground
    reads it and shows its status line. Whichever opens the FIFO first, the
    writer's open is retried at the transport's cadence until the reader is there."""
    fifo = tmp_path / "tlm.fifo"
    os.mkfifo(fifo)
    cycles = 40
    n_frames = total_frames(cycles)
    out = tmp_path / "out"
    ground = subprocess.Popen(
        [
            str(bins["ground"]),
            "--tty",
            str(fifo),
            "--out",
            str(out),
            "--max-frames",
            str(n_frames),
            "--max-seconds",
            "30",
            "--status",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,  # bytes: text mode would turn the status line's \r into \n
    )
    gen = subprocess.run(
        [str(bins["gen"]), "--cycles", str(cycles), "--tty", str(fifo), "--rate", "400"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    _, err_bytes = ground.communicate(timeout=60)
    err = err_bytes.decode()
    assert gen.returncode == 0, gen.stderr
    assert ground.returncode == 0, err
    assert rows(out / "nav.csv") == [expected_nav_row(i, i) for i in range(cycles)]
    assert "\r" in err and "link ok" in err and f"frames {n_frames}" in err


def test_file_source_ends_quiet_is_quiet_and_backward_counts_are_not_losses(bins, tmp_path):
    """Issue 26's mfns-ground faults: --file ends on any input (/dev/null
    never ended), a missing recording names itself (it said "uart: cannot open
    the port"), -q prints nothing on a good stream, and a shuffled recording's
    backward counts are counted as such, not as ~16,000 lost each."""

    def run(*args, **kw):
        return subprocess.run(
            [str(bins["ground"]), *args], capture_output=True, text=True, timeout=30, check=False, **kw
        )

    empty = run("--file", "/dev/null", "--out", str(tmp_path / "n"), "--no-status")
    assert empty.returncode == 3 and "no valid frame" in empty.stderr
    missing = run("--file", str(tmp_path / "nope.bin"), "--out", str(tmp_path / "m"))
    assert missing.returncode == 1
    assert "cannot open the recording: No such file or directory" in missing.stderr
    assert "uart" not in missing.stderr
    stream = tmp_path / "tlm.bin"
    subprocess.run([str(bins["gen"]), "--cycles", "60", "--out", str(stream)], check=True, timeout=30)
    quiet = run("--file", str(stream), "--out", str(tmp_path / "q"), "-q")
    assert quiet.returncode == 0 and quiet.stderr == "" and quiet.stdout == ""
    frames = split_frames(stream.read_bytes())
    rng = np.random.default_rng(4)
    shuffled = tmp_path / "shuffled.bin"
    shuffled.write_bytes(b"".join(frames[i] for i in rng.permutation(len(frames))))
    res = run("--file", str(shuffled), "--out", str(tmp_path / "s"), "--no-status")
    assert res.returncode == 0, res.stderr
    st = json.loads((tmp_path / "s" / "stats.json").read_text())
    assert st["frames_ok"] == len(frames)
    # every packet arrived, so none reads as lost (issue 45: 23,044 "lost" of a shuffled
    # recording before): each count a forward jump skipped came later and is counted late
    assert st["seq_lost"] == 0, st
    assert st["seq_late"] > st["seq_gaps"] // 4
    assert sum(t["late"] for t in st["packets"].values()) == st["seq_late"]
    assert sum(t["back"] for t in st["packets"].values()) == st["seq_back"]
    # a real loss still reads as loss, reordered or not: every third frame left out, the rest
    # with each pair of neighbours swapped (a reordering link); a type's last frames left out
    # have no later count to show them (at most one per type)
    kept = [f for i, f in enumerate(frames) if i % 3 != 1]
    for i in range(0, len(kept) - 1, 2):
        kept[i], kept[i + 1] = kept[i + 1], kept[i]
    holes = tmp_path / "holes.bin"
    holes.write_bytes(b"".join(kept))
    res = run("--file", str(holes), "--out", str(tmp_path / "h"), "--no-status")
    assert res.returncode == 0, res.stderr
    st = json.loads((tmp_path / "h" / "stats.json").read_text())
    assert st["frames_ok"] == len(kept)
    dropped = len(frames) - len(kept)
    assert dropped - len(st["packets"]) <= st["seq_lost"] <= dropped, st
    assert st["seq_late"] > 0, st


def test_file_replay_paced_by_flight_time(bins, tmp_path):
    """--pace X replays a recording at X times its flight-time pace (issue 26:
    a full-speed replay overflowed the UDP receiver), and only with --file."""
    import time

    stream = tmp_path / "tlm.bin"
    subprocess.run([str(bins["gen"]), "--cycles", "40", "--out", str(stream)], check=True, timeout=30)
    fast = subprocess.run(
        [str(bins["ground"]), "--file", str(stream), "--out", str(tmp_path / "f"), "-q"],
        check=True,
        timeout=30,
    )
    assert fast.returncode == 0
    t = [float(r.split(",")[0]) for r in rows(tmp_path / "f" / "nav.csv")]
    span = max(t) - min(t)
    assert span > 0.5
    t0 = time.monotonic()
    subprocess.run(
        [str(bins["ground"]), "--file", str(stream), "--out", str(tmp_path / "p"), "-q", "--pace", "4"],
        check=True,
        timeout=60,
    )
    took = time.monotonic() - t0
    assert took >= 0.9 * span / 4, (took, span)
    assert rows(tmp_path / "p" / "nav.csv") == rows(tmp_path / "f" / "nav.csv")
    bad = subprocess.run(
        [str(bins["ground"]), "--tty", "/dev/null", "--pace", "2"], capture_output=True, text=True, timeout=30
    )
    assert bad.returncode == 2 and "--pace" in bad.stderr
