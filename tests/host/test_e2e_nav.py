"""End to end over the simulated navigation experiment: `mfns sim nav` frames ->
`mfns table build` -> the flight program `mfns-nav` (replay cameras) -> telemetry
-> `mfns-ground` -> nav.csv, compared with truth.csv.

The checks a flight user cares about: fixes are accurate, a pose marked FIX or
DEGRADED is never grossly wrong, a bad calibration table is refused with an event
on the link, and the program exits cleanly at the end of the data.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from flight_replay import fly_replay, read_csv  # tests/host

REPO = Path(__file__).resolve().parents[2]


def mfns(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True)


def run_chain(
    bins: Path, tmp: Path, sim_args: list[str], nav_args: list[str]
) -> tuple[list[dict], np.ndarray, str]:
    frames = tmp / "frames"
    res = mfns("sim", "nav", str(frames), "--quiet", *sim_args)
    assert res.returncode == 0, res.stderr
    return fly(bins, tmp, frames, nav_args)


def fly(
    bins: Path, tmp: Path, frames: Path, nav_args: list[str], table_args: tuple[str, ...] = ()
) -> tuple[list[dict], np.ndarray, str]:
    """Table from the frames' rig and map, mfns-nav on them, mfns-ground on its telemetry."""
    table = tmp / "table.mfnstbl"
    res = mfns(
        "table",
        "build",
        str(frames / "calib.json"),
        str(frames / "beacons.csv"),
        "-o",
        str(table),
        *table_args,
    )
    assert res.returncode == 0, res.stderr
    run = fly_replay(bins, table, frames, tmp, *nav_args)
    assert "stopped (data ended)" in run.nav_stderr
    assert "crc_errors=0" in run.ground_stderr
    rows = run.rows()
    truth = np.genfromtxt(frames / "truth.csv", delimiter=",", names=True)
    return rows, np.atleast_1d(truth), run.nav_stderr


def errors(rows: list[dict], truth: np.ndarray) -> tuple[list[int], np.ndarray, np.ndarray]:
    """Cycles with a fix and their position (mm) and attitude (deg) errors."""
    cyc, dp, da = [], [], []
    for r in rows:
        if r["status"] not in ("FIX", "DEGRADED"):
            continue
        k = int(r["cycle"])
        t = truth[k]
        assert abs(float(r["t_s"]) - t["t_s"]) < 1e-3  # the telemetry time is the frame time
        cyc.append(k)
        dp.append([float(r[a + "_mm"]) - t[a + "_mm"] for a in "xyz"])
        d = [float(r[a + "_deg"]) - t[a + "_deg"] for a in ("roll", "pitch", "yaw")]
        da.append([(v + 180.0) % 360.0 - 180.0 for v in d])
    return cyc, np.array(dp).reshape(-1, 3), np.array(da).reshape(-1, 3)


def test_module_tracking_from_docking_pose(bins, tmp_path):
    """Dense map, free 6-DOF motion: from a commanded start pose (a hint, as for a replay)."""
    frames_arg = ["--scenario", "module", "--frames", "40", "--seed", "3"]
    # The start pose as the ground would command it (the first truth row).
    res = mfns("sim", "nav", str(tmp_path / "probe"), "--quiet", *frames_arg)
    assert res.returncode == 0, res.stderr
    first = (tmp_path / "probe" / "truth.csv").read_text().splitlines()[1].split(",")[2:8]
    rows, truth, log = run_chain(bins, tmp_path / "run", frames_arg, ["--init-pose=" + ",".join(first)])
    assert len(rows) == 40
    cyc, dp, da = errors(rows, truth)
    assert len(cyc) >= 34, log  # >= 85 % of cycles with a fix
    assert np.sqrt(np.mean(dp**2)) < 0.5  # mm, RMS over all axes
    assert np.sqrt(np.mean(da**2)) < 0.02  # deg
    assert np.max(np.abs(dp)) < 3.0  # never a grossly wrong pose marked valid
    assert np.max(np.abs(da)) < 0.2


def test_turntable_acquisition_never_reports_a_wrong_fix(bins, tmp_path):
    """The paper's run: 1-4 beacons in view, no prior. Few fixes, all of them right. Since
    issue 23 a fix must be certified against a single faulty beacon within the alert limits
    (docs/pose.md "Integrity"): with at most four beacons none is, so none may be usable;
    whatever is usable must be right."""
    rows, truth, log = run_chain(
        bins, tmp_path, ["--scenario", "turntable", "--frames", "80", "--yaw-span", "60", "--seed", "4"], []
    )
    assert len(rows) == 80
    cyc, dp, da = errors(rows, truth)
    if len(cyc):
        assert np.max(np.abs(dp)) < 3.0, log
        assert np.max(np.abs(da)) < 0.2, log
    no_fix = [r for r in rows if r["status"] == "NO_FIX"]
    assert no_fix, "with <= 2 beacons in view most cycles must be NO_FIX"
    for r in no_fix:  # a NO_FIX row carries no pose
        assert float(r["x_mm"]) == 0.0 and float(r["yaw_deg"]) == 0.0
    # the same bench with a monitor-only table (the paper's accuracy experiment, never
    # flight): the fixes integrity cannot certify come out DEGRADED with the reason why,
    # and they are right; a detected fault would still be refused
    bench = tmp_path / "bench"
    bench.mkdir()
    settings = bench / "bench.json"
    settings.write_text('{"integrity": {"monitor_only": 1}}')
    rows_b, truth_b, log_b = fly(bins, bench, tmp_path / "frames", [], ("--settings", str(settings)))
    marked = [r for r in rows_b if r["status"] == "DEGRADED" and r["reason"] in ("3", "14", "15")]
    assert len(marked) >= 10, log_b  # MINIMAL, UNMONITORED, PL_EXCEEDS_AL
    cyc_b, dp_b, da_b = errors(rows_b, truth_b)
    assert len(cyc_b) >= len(marked)
    assert np.max(np.abs(dp_b)) < 3.0 and np.max(np.abs(da_b)) < 0.2, log_b


def test_corrupt_table_is_refused_with_an_event(bins, tmp_path, gen_dir):
    good = (gen_dir / "default.mfnstbl").read_bytes()
    bad = bytearray(good)
    bad[len(bad) // 2] ^= 0x40  # one bit in the body: the CRC must catch it
    table = tmp_path / "bad.mfnstbl"
    table.write_bytes(bytes(bad))
    tlm = tmp_path / "tlm.bin"
    empty = tmp_path / "nothing"
    empty.mkdir()
    nav = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(table), "--replay", str(empty), "--tlm-file", str(tlm)],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert nav.returncode == 2
    assert "refused" in nav.stderr and "CRC" in nav.stderr.upper()
    ground = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(tmp_path / "g"), "--no-status"],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert ground.returncode == 0
    events = (tmp_path / "g" / "events.csv").read_text()
    assert "TABLE_REFUSED" in events
    assert (
        not (tmp_path / "g" / "nav.csv").exists()
        or len((tmp_path / "g" / "nav.csv").read_text().splitlines()) <= 1
    )


@pytest.mark.parametrize(
    "args, message",
    [
        ([], "--table"),
        (["--table", "x"], "--replay"),
        (["--table", "x", "--replay", "d", "--baud", "12"], "--baud"),
        (["--table", "x", "--replay", "d", "--init-pose", "1,2,3"], "--init-pose"),
        (["--table", "x", "--replay", "d", "--tlm-file", "a", "--tlm-tty", "b"], "one telemetry output"),
    ],
)
def test_usage_errors_are_one_line(bins, args, message):
    res = subprocess.run([str(bins / "mfns-nav"), *args], check=False, capture_output=True, text=True)
    assert res.returncode == 2
    assert message in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_help_and_version(bins):
    res = subprocess.run([str(bins / "mfns-nav"), "--help"], check=False, capture_output=True, text=True)
    assert res.returncode == 0 and "--init-pose" in res.stdout
    res = subprocess.run([str(bins / "mfns-nav"), "--version"], check=False, capture_output=True, text=True)
    assert res.returncode == 0 and res.stdout.startswith("mfns-nav ")


def test_module_acquires_without_a_start_pose(bins, tmp_path):
    """Dense map (60 beacons), free 6-DOF motion, no prior: lost-in-space acquisition
    finds the pose from the map index by itself, then tracking keeps it."""
    rows, truth, log = run_chain(
        bins, tmp_path, ["--scenario", "module", "--frames", "40", "--seed", "3"], []
    )
    assert len(rows) == 40
    cyc, dp, da = errors(rows, truth)
    assert len(cyc) >= 34, log  # >= 85 % of cycles with a fix, as with a commanded start pose
    assert cyc[0] <= 3, log  # acquired within the first frames
    assert np.max(np.abs(dp)) < 3.0  # never a grossly wrong pose marked valid
    assert np.max(np.abs(da)) < 0.2


def _blackout(frames: Path, first: int, last: int) -> None:
    """Every camera dark (a flat background, no spot) for frames first..last-1."""
    import csv as _csv

    with open(frames / "frames.csv", newline="") as f:
        for row in _csv.DictReader(f):
            if first <= int(row["frame"]) < last:
                p = frames / row["file"]
                data = p.read_bytes()
                # binary PGM: magic, width height, maxval, then the pixels
                head_end = 0
                fields = 0
                while fields < 4:
                    while data[head_end : head_end + 1].isspace():
                        head_end += 1
                    while not data[head_end : head_end + 1].isspace():
                        head_end += 1
                    fields += 1
                head_end += 1
                p.write_bytes(data[:head_end] + bytes([6]) * (len(data) - head_end))


def test_module_reacquires_after_a_blackout(bins, tmp_path):
    """All cameras dark for 2 s in the middle of the module run (an astronaut in front
    of the rig): no fix during the blackout, a fix again within 2 frames of the beacons'
    return, and no wrong fix after it (automatic recovery, no ground command)."""
    frames = tmp_path / "frames"
    res = mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "110", "--seed", "5")
    assert res.returncode == 0, res.stderr
    rate = 18.6
    first, last = 30, 30 + int(round(2.0 * rate))
    _blackout(frames, first, last)
    rows, truth, log = fly(bins, tmp_path, frames, [])
    cyc, dp, da = errors(rows, truth)
    assert cyc and cyc[0] < first, log  # acquired before the blackout
    assert not [k for k in cyc if first <= k < last], "a fix was reported while every camera was dark"
    after = [k for k in cyc if k >= last]
    # re-acquired within 2 frames, then the first two multi-camera fixes after the gap are
    # held NO_FIX LAG_UNTESTED (no motion known yet to test a stale camera: docs/pose.md)
    assert after and after[0] <= last + 3, (after[:3], log)
    assert np.max(np.abs(dp)) < 3.0 and np.max(np.abs(da)) < 0.2  # no wrong fix, before or after


def test_a_robot_that_leaves_its_table_workspace(bins, tmp_path):
    """The table's workspace is the box the acquisition's certificate covers (docs/pose.md
    "The table's workspace in flight"). A table built over the box of the path's first
    40 frames only: the robot flies out of it. While tracked it keeps its usable fixes and
    WORKSPACE_LEFT is reported once, with the axes; blacked out out there, the track is
    lost, no acquisition is usable afterwards and housekeeping says LOST_OUTSIDE (the
    refusal of an acquisition in that state: test_nav_cycle.c test_leaving_the_workspace);
    never a wrong fix."""
    frames = tmp_path / "frames"
    res = mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "110", "--seed", "5")
    assert res.returncode == 0, res.stderr
    truth = np.atleast_1d(np.genfromtxt(frames / "truth.csv", delimiter=",", names=True))
    pos = np.column_stack([truth[a + "_mm"] for a in ("x", "y", "z")])
    lo, hi = pos[:40].min(axis=0) - 25.0, pos[:40].max(axis=0) + 25.0
    # the widened box (20 mm + 6 sigma, sigma well under 1 mm here) the flight tests against
    outside = np.any((pos < lo - 30.0) | (pos > hi + 30.0), axis=1)
    left = int(np.argmax(outside))
    assert outside.any() and 40 < left < 80, "the scenario no longer leaves the box: pick another"
    first = left + 10
    assert outside[first:].all(), "the robot comes back in: pick another blackout"
    _blackout(frames, first, first + 20)
    box = ",".join(f"{v:.1f}" for v in (*lo, *hi))
    rows, truth, log = fly(bins, tmp_path, frames, [], ("--workspace=" + box,))
    cyc, dp, da = errors(rows, truth)
    assert np.max(np.abs(dp)) < 3.0 and np.max(np.abs(da)) < 0.2  # never a wrong fix
    assert [k for k in cyc if left + 2 <= k < first], log  # tracked outside: still usable
    assert not [k for k in cyc if k >= first], "a fix after the track was lost outside the box"
    ground = tmp_path / "ground"
    events = [e for e in read_csv(ground / "events.csv") if e["event"].startswith("WORKSPACE_")]
    assert [e["event"] for e in events] == ["WORKSPACE_LEFT"], events
    # between leaving the box widened by the fixed 20 mm and by 30 mm (6 sigma < 10 mm here)
    beyond_20 = int(np.argmax(np.any((pos < lo - 20.0) | (pos > hi + 20.0), axis=1)))
    assert beyond_20 <= int(events[0]["cycle"]) <= left, (beyond_20, left, events)
    assert int(events[0]["subject"]) != 0 and int(events[0]["arg0"]) > 0
    hk = read_csv(ground / "housekeeping.csv")
    assert hk[-1]["workspace"] == "LOST_OUTSIDE", hk[-1]
