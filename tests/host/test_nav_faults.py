"""Fault injection into the flight program `mfns-nav` (issue 17, items 1, 3, 4, 5, 8).

One small module folder (`mfns sim nav`, 20 frames) and its table are made once;
each test copies the folder, breaks one thing the way a hostile input or a
failing device would, runs the built `mfns-nav` (replay cameras) and reads what
it reported: its stderr and the telemetry decoded by `mfns-ground`.

What must hold, whatever the fault: the cameras stay in step (every frame a
cycle fuses carries that cycle's frame index), every fault is reported (an
event on the link and a line on stderr), and the program ends cleanly.
"""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("MFNS_BIN", REPO / "build" / "host-sim" / "bin"))
FRAMES = 20


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> dict:
    d = tmp_path_factory.mktemp("faults")
    frames = d / "frames"
    sim = [sys.executable, "-m", "mfns", "sim", "nav", str(frames), "--quiet"]
    res = subprocess.run(
        [*sim, "--scenario", "module", "--frames", str(FRAMES), "--seed", "3"],
        check=False,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr
    table = d / "table.mfnstbl"
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "mfns",
            "table",
            "build",
            str(frames / "calib.json"),
            str(frames / "beacons.csv"),
        ]
        + ["-o", str(table)],
        check=False,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr
    first = (frames / "truth.csv").read_text().splitlines()[1].split(",")[2:8]
    return {"frames": frames, "table": table, "init": "--init-pose=" + ",".join(first)}


def copy_folder(base: dict, dst: Path) -> Path:
    shutil.copytree(base["frames"], dst)
    return dst


def run_nav(bins: Path, base: dict, folder: Path, tlm: Path | str, *extra: str, timeout: float = 120):
    args = [str(bins / "mfns-nav"), "--table", str(base["table"]), "--replay", str(folder)]
    args += ["--tlm-file", str(tlm), base["init"], *extra]
    return subprocess.run(args, check=False, capture_output=True, text=True, timeout=timeout)


def decode(bins: Path, tlm: Path, out: Path) -> tuple[dict[str, list[dict]], str]:
    res = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    tables = {}
    for name in ("nav", "camera", "events", "housekeeping"):
        with open(out / f"{name}.csv", newline="") as f:
            tables[name] = list(csv.DictReader(f))
    return tables, res.stderr


def rewrite_rows(folder: Path, edit) -> None:
    lines = (folder / "frames.csv").read_bytes().split(b"\n")
    (folder / "frames.csv").write_bytes(b"\n".join(edit(lines)))


def row_index(lines: list[bytes], frame: int, cam: str) -> int:
    key = f"{frame},".encode()
    for i, ln in enumerate(lines):
        parts = ln.split(b",")
        if ln.startswith(key) and len(parts) > 2 and parts[2] == cam.encode():
            return i
    raise AssertionError(f"no row for frame {frame} camera {cam}")


def replace_row(frame: int, cam: str, fn):
    def edit(lines):
        i = row_index(lines, frame, cam)
        new = fn(lines[i])
        return lines[:i] + new + lines[i + 1 :]

    return edit


HOSTILE_ROWS = {
    "5 fields": lambda r: [r.rsplit(b",", 1)[0]],
    "7 fields": lambda r: [r + b",7"],
    "NUL byte": lambda r: [r.replace(b"cam_y", b"cam\0y")],
    "dot-dot path": lambda r: [r.replace(b"cam_y/", b"../cam_y/")],
    "negative exposure": lambda r: [b",".join(r.split(b",")[:4] + [b"-5"] + r.split(b",")[5:])],
    "camera w": lambda r: [r.replace(b",y,", b",w,")],
    "duplicate": lambda r: [r, r],
}


@pytest.mark.parametrize("fault", sorted(HOSTILE_ROWS))
def test_one_bad_row_costs_one_frame_of_one_camera(bins, base, tmp_path, fault):
    """Item 1: a bad row of camera y at frame 3 never desynchronises the cameras."""
    folder = copy_folder(base, tmp_path / "f")
    rewrite_rows(folder, replace_row(3, "y", HOSTILE_ROWS[fault]))
    nav = run_nav(bins, base, folder, tmp_path / "t.bin")
    assert nav.returncode == 0, nav.stderr
    assert "stopped (data ended) after 20 cycles" in nav.stderr
    tables, _ = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    ok = [r for r in tables["camera"] if r["state"] == "OK"]
    # every fused frame belongs to its cycle: frame index == cycle index
    assert all(int(r["frame_seq"]) == int(r["cycle"]) for r in ok), [
        (r["cycle"], r["camera"], r["frame_seq"]) for r in ok if r["frame_seq"] != r["cycle"]
    ]
    missed = [(r["cycle"], r["camera"]) for r in tables["camera"] if r["state"] != "OK"]
    assert len(missed) <= 1 and all(c == "y" for _, c in missed), missed
    assert len(ok) >= 3 * FRAMES - 1
    # a fault that cost a frame is reported on stderr and on the link
    if missed:
        assert "camera y" in nav.stderr
        assert any(
            e["event"] in ("FRAME_REJECTED", "CAMERA_OUT_OF_STEP", "CAMERA_STALE") for e in tables["events"]
        )


def test_camera_frames_missing_goes_lost_and_recovers(bins, base, tmp_path):
    """Item 3: camera y has no frames 5..16: LOST (event, state, one line), then RECOVERED."""
    folder = copy_folder(base, tmp_path / "f")
    for i in range(5, 17):
        (folder / "cam_y" / f"{i:06d}.pgm").unlink()
    nav = run_nav(bins, base, folder, tmp_path / "t.bin")
    assert nav.returncode == 0, nav.stderr
    assert nav.stderr.count("camera y lost") == 1, nav.stderr
    assert nav.stderr.count("camera y recovered") == 1, nav.stderr
    tables, _ = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    ev = [(e["event"], int(e["cycle"]), e["subject"]) for e in tables["events"]]
    lost = [c for name, c, s in ev if name == "CAMERA_LOST" and s == "1"]
    rec = [c for name, c, s in ev if name == "CAMERA_RECOVERED" and s == "1"]
    assert lost == [14] and rec == [17], ev  # 10 cycles without a frame (5..14), back at 17
    states = {int(r["cycle"]): r["state"] for r in tables["camera"] if r["camera"] == "y"}
    # back at 17: its frames flow again, and integrity holds it out (LAG_VERIFY) until its
    # time-offset test has passed, or fuses it (OK) at once when no other camera worked
    assert all(states[c] == "LOST" for c in range(14, 17)) and states[17] in ("OK", "LAG_VERIFY"), states
    assert all(states[c] == "SKIPPED" for c in range(5, 14)), [(c, states[c]) for c in range(3, 20)]
    hk = tables["housekeeping"][-1]
    assert int(hk["n_cam_errors"]) >= 12


def test_camera_rows_that_end_early_are_reported(bins, base, tmp_path):
    """Item 3: camera y's rows of frames.csv end at frame 10: counted and reported."""
    folder = copy_folder(base, tmp_path / "f")
    lines = (folder / "frames.csv").read_text().splitlines()
    keep = [
        ln
        for ln in lines
        if not (ln.split(",")[2] == "y" and ln.split(",")[0].isdigit() and int(ln.split(",")[0]) > 10)
    ]
    (folder / "frames.csv").write_text("\n".join(keep) + "\n")
    nav = run_nav(bins, base, folder, tmp_path / "t.bin")
    assert nav.returncode == 0, nav.stderr
    assert "camera y: recorded frames ended" in nav.stderr
    assert "stopped (data ended) after 20 cycles" in nav.stderr
    tables, _ = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    assert [int(e["cycle"]) for e in tables["events"] if e["event"] == "CAMERA_ENDED"] == [11]
    states = {int(r["cycle"]): r["state"] for r in tables["camera"] if r["camera"] == "y"}
    assert all(states[c] == "ENDED" for c in range(11, FRAMES))
    assert int(tables["housekeeping"][-1]["n_cam_errors"]) >= 1


def test_telemetry_fifo_without_reader_at_start_is_retried(bins, base, tmp_path):
    """Item 4: no reader on the FIFO yet is not fatal; the reader gets the stream once it opens."""
    fifo = tmp_path / "tlm.fifo"
    os.mkfifo(fifo)
    args = [str(bins / "mfns-nav"), "--table", str(base["table"]), "--replay", str(base["frames"])]
    err_path = tmp_path / "nav.err"
    with err_path.open("w") as err_f:
        nav = subprocess.Popen(
            [*args, "--tlm-tty", str(fifo), "--realtime", base["init"]],
            stdout=subprocess.DEVNULL,
            stderr=err_f,
            text=True,
        )
    # the program is running without a reader: wait until it says so (not a fixed time,
    # which a loaded machine can overrun; bounded at 30 s)
    deadline = time.monotonic() + 30
    while "not available yet" not in err_path.read_text() and nav.poll() is None:
        assert time.monotonic() < deadline, err_path.read_text()
        time.sleep(0.02)
    # non-blocking, so a program that already gave up cannot hang the test
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    data = b""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            chunk = os.read(fd, 65536)
        except BlockingIOError:
            chunk = None
        if chunk:
            data += chunk
        elif nav.poll() is not None:
            break
        else:
            time.sleep(0.02)
    os.close(fd)
    nav.wait(timeout=60)
    err = err_path.read_text()
    assert nav.returncode == 0, err
    assert "not available yet" in err and "retrying" in err
    (tmp_path / "t.bin").write_bytes(data)
    tables, gerr = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    assert "crc_errors=0" in gerr
    assert len(tables["nav"]) == FRAMES  # 20 cycles of ~4 kB fit the queue: nothing lost
    assert "0 telemetry frames dropped" in err


def test_telemetry_write_errors_are_counted_exactly(bins, base, tmp_path):
    """Item 4: --tlm-file /dev/full: non-zero exit, every frame produced counted as lost."""
    good = run_nav(bins, base, base["frames"], tmp_path / "t.bin")
    assert good.returncode == 0, good.stderr
    tables, gerr = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    frames_ok = int(gerr.split("frames_ok=")[1].split()[0])
    bad = run_nav(bins, base, base["frames"], "/dev/full")
    assert bad.returncode == 3, bad.stderr
    assert "No space left on device" in bad.stderr
    line = next(ln for ln in bad.stderr.splitlines() if "frames produced" in ln)
    produced, sent, lost = (int(line.split(w)[0].split()[-1]) for w in (" frames produced", " sent", " lost"))
    # the same packets as the good run, plus the one TLM_WRITE_ERROR event, plus a
    # TLM_DROPPED event at each housekeeping report after the transmit queue (nothing
    # leaves it) overflowed; none arrived, and every one is counted as lost
    n_hk = len(tables["housekeeping"])
    assert sent == 0 and lost == produced, (line, frames_ok)
    assert frames_ok + 1 <= produced <= frames_ok + 1 + n_hk, (line, frames_ok, n_hk)
    assert f"{lost} telemetry frames dropped" in bad.stderr


def test_blocking_frame_file_obeys_timeout(bins, base, tmp_path):
    """Item 5: a frame file that is a FIFO whose writer never writes costs one timeout."""
    folder = copy_folder(base, tmp_path / "f")
    pgm = folder / "cam_y" / "000005.pgm"
    pgm.unlink()
    os.mkfifo(pgm)
    fd = os.open(pgm, os.O_RDWR)  # a writer that holds it open and never writes
    try:
        t0 = time.monotonic()
        nav = run_nav(bins, base, folder, tmp_path / "t.bin", "--timeout-ms", "100", timeout=30)
        took = time.monotonic() - t0
    finally:
        os.close(fd)
    assert nav.returncode == 0, nav.stderr
    assert "1 timeouts" in nav.stderr
    assert took < 20
    tables, _ = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    states = {int(r["cycle"]): r["state"] for r in tables["camera"] if r["camera"] == "y"}
    assert states[5] == "SKIPPED" and states[6] == "OK"


def scenario_variant(base: dict, tmp: Path, text: str) -> Path:
    folder = copy_folder(base, tmp)
    (folder / "scenario.json").write_text(text)
    return folder


@pytest.mark.parametrize(
    ("text", "accepted", "needle"),
    [
        ('{"format": "mfns-nav-frames", "version": 1.5}', False, "not a whole number"),
        ('{"format": "mfns-nav-frames", "meta": {"version": 1}, "version": 2}', False, "version 2 is newer"),
        ('{"format": "mfns-nav-frames", "meta": {"version": 1}}', False, "missing"),
        ('{"format": "mfns-nav-frames", "version": 1, "version": 1}', False, "duplicated"),
        ('{"format": "mfns-nav-frames", "version": 1,}', False, "expected a key"),
        # keys after the first 16 KiB (the old reader looked no further)
        ('{"pad": "' + "x" * 40000 + '", "format": "mfns-nav-frames", "version": 1}', True, ""),
    ],
)
def test_scenario_json_version_and_size(bins, base, tmp_path, text, accepted, needle):
    """Item 8: version 1.5 refused, nested keys never shadow, a 40 kB file accepted."""
    folder = scenario_variant(base, tmp_path / "f", text)
    nav = run_nav(bins, base, folder, tmp_path / "t.bin", "--max-cycles", "2")
    if accepted:
        assert nav.returncode == 0, nav.stderr
    else:
        assert nav.returncode == 2, nav.stderr
        assert needle in nav.stderr, nav.stderr
        assert len(nav.stderr.strip().splitlines()) == 1


def test_ground_counts_a_frame_cut_by_end_of_file(bins, base, tmp_path):
    """Item 8: mfns-ground counts the last frame of a recording cut mid-frame."""
    nav = run_nav(bins, base, base["frames"], tmp_path / "t.bin", "--max-cycles", "3")
    assert nav.returncode == 0, nav.stderr
    data = (tmp_path / "t.bin").read_bytes()
    (tmp_path / "cut.bin").write_bytes(data[:-10])
    _, err = decode(bins, tmp_path / "cut.bin", tmp_path / "g")
    assert "truncated=1" in err, err


# --------------------------------------------------------------------------- issue 13
def test_flight_stream_decodes_through_the_xtce_to_the_ground_csv(bins, base, tmp_path, xtce_decode):
    """Issue 13 item 2: a recorded flight stream (mfns-ground --record, COBS-unframed here)
    decoded by space-packet-parser with the XTCE gives mfns-ground's CSV values, field by
    field, every packet: nav with quaternion and covariance, camera, housekeeping, events."""
    from conftest import assert_packets_match_csv

    nav = run_nav(bins, base, base["frames"], tmp_path / "t.bin")
    assert nav.returncode == 0, nav.stderr
    res = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tmp_path / "t.bin"), "--out", str(tmp_path / "g")]
        + ["--record", str(tmp_path / "rec.bin"), "--no-status"],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    rec = (tmp_path / "rec.bin").read_bytes()
    assert rec == (tmp_path / "t.bin").read_bytes()
    decoded = xtce_decode(rec)
    counts = assert_packets_match_csv(decoded, tmp_path / "g")
    assert counts["nav"] == FRAMES and counts["camera"] == 3 * FRAMES and counts["housekeeping"] >= 2
    fixes = [p for n, p in decoded if n == "nav" and str(p["nav_status"]) != "NO_FIX"]
    assert fixes
    for p in fixes:  # a usable pose carries a unit quaternion (w >= 0) and a covariance
        q = [float(p[f"nav_q_{c}"]) for c in "wxyz"]
        assert abs(sum(v * v for v in q) - 1.0) < 1e-6 and q[0] >= 0.0
        assert float(p["nav_cov_x_x"]) > 0 and float(p["nav_cov_rz_rz"]) > 0


def _summary(stderr: str) -> dict[str, int]:
    import re

    m = re.search(r"after (\d+) cycles: (\d+) fix, (\d+) degraded, (\d+) no fix", stderr)
    assert m, stderr
    return dict(zip(("cycles", "fix", "degraded", "no_fix"), map(int, m.groups()), strict=True))


def test_counts_and_clock_agree_between_log_housekeeping_and_nav_csv(bins, base, tmp_path):
    """Issue 13 item 6: the last housekeeping packet is on the flight clock (time never runs
    backwards: it was the wall clock since start, 0.04 s after a 1 s run) and counts the cycles
    that ran (was one more); FIX and DEGRADED are counted apart, the same in mfns-nav's last
    line, housekeeping and nav.csv (mfns-nav said '20 fix' of 20 DEGRADED rows)."""
    nav = run_nav(bins, base, base["frames"], tmp_path / "t.bin")
    assert nav.returncode == 0, nav.stderr
    tables, _ = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    log = _summary(nav.stderr)
    rows = tables["nav"]
    status = [r["status"] for r in rows]
    assert log["cycles"] == len(rows) == FRAMES
    assert (log["fix"], log["degraded"], log["no_fix"]) == (
        status.count("FIX"),
        status.count("DEGRADED"),
        status.count("NO_FIX"),
    )
    hk = tables["housekeeping"]
    last = hk[-1]
    assert int(last["n_cycles"]) == log["cycles"]
    assert int(last["cycle"]) == int(rows[-1]["cycle"])
    assert (int(last["n_fix"]), int(last["n_degraded"]), int(last["n_no_fix"])) == (
        log["fix"],
        log["degraded"],
        log["no_fix"],
    )
    t_hk = [float(r["t_s"]) for r in hk]
    assert t_hk == sorted(t_hk), t_hk
    assert t_hk[-1] >= max(float(r["t_s"]) for r in rows)
    assert int(last["cams_enabled"]) == 0x7 and int(last["n_cmd_accepted"]) == 0


def test_table_crc_is_printed_the_same_in_events_and_housekeeping(bins, base, tmp_path):
    """Issue 13 item 6: TABLE_LOADED's CRC was signed decimal in events.csv, hex in
    housekeeping.csv."""
    nav = run_nav(bins, base, base["frames"], tmp_path / "t.bin")
    assert nav.returncode == 0, nav.stderr
    tables, _ = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    loaded = [e for e in tables["events"] if e["event"] == "TABLE_LOADED"]
    assert len(loaded) == 1
    crcs = {r["table_crc32"] for r in tables["housekeeping"]}
    assert crcs == {loaded[0]["arg1"]}
    import re

    assert re.fullmatch(r"0x[0-9a-f]{8}", loaded[0]["arg1"])


def test_every_row_carries_the_ground_receive_time(bins, base, tmp_path):
    """Issue 13 item 6: ground_utc, ISO 8601 UTC with microseconds, within the run."""
    import datetime as dt
    import re

    nav = run_nav(bins, base, base["frames"], tmp_path / "t.bin")
    assert nav.returncode == 0, nav.stderr
    t0 = dt.datetime.now(dt.UTC)
    tables, _ = decode(bins, tmp_path / "t.bin", tmp_path / "g")
    t1 = dt.datetime.now(dt.UTC)
    for name, rows in tables.items():
        assert rows, name
        for r in rows:
            s = r["ground_utc"]
            assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{6}Z", s), (name, s)
            t = dt.datetime.fromisoformat(s.replace("Z", "+00:00"))
            assert t0 - dt.timedelta(seconds=1) <= t <= t1 + dt.timedelta(seconds=1), (name, s)
    jl = (tmp_path / "g" / "nav.jsonl").read_text().splitlines()
    import json

    assert json.loads(jl[0])["ground_utc"] == tables["nav"][0]["ground_utc"]


@pytest.mark.parametrize("content", [b"", b"\x05\x11\x22\x33\x00\x42\x42\x42\x00"], ids=["empty", "garbage"])
def test_ground_exits_nonzero_when_no_frame_was_valid(bins, tmp_path, content):
    """Issue 13 item 6: mfns-ground exited 0 on a stream without one valid frame."""
    (tmp_path / "s.bin").write_bytes(content)
    res = subprocess.run(
        [
            str(bins / "mfns-ground"),
            "--file",
            str(tmp_path / "s.bin"),
            "--out",
            str(tmp_path / "g"),
            "--no-status",
        ],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 3, res.stderr
    assert "no valid frame" in res.stderr
