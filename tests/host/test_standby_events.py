"""Issue 46: a commanded STANDBY raises no event per cycle.

Before: in STANDBY the navigator does not run and its output was zeroed, so the "none" indices
(-1) of the integrity and watch reports read as beacon 0 / camera 0, and every cycle raised 5
WARNINGs (CAMERA_LAG, BEACON_MISSING, BEACON_REJECTED, CAMERA_INCONSISTENT, CAMERAS_DISAGREE)
and 2 INFOs (BEACON_READMITTED, CAMERA_READMITTED): 240 WARNINGs in 8 s. Now the flight
program reports no navigation findings when no navigation ran."""

from __future__ import annotations

import subprocess
import sys
from collections import Counter

from flight_replay import read_csv


def mfns(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True)


def test_commanded_standby_raises_no_event_per_cycle(bins, tmp_path):
    frames = tmp_path / "frames"
    res = mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "20", "--seed", "3")
    assert res.returncode == 0, res.stderr
    table = tmp_path / "table.mfnstbl"
    res = mfns(
        "table", "build", str(frames / "calib.json"), str(frames / "beacons.csv"), "-o", str(table), "-q"
    )
    assert res.returncode == 0, res.stderr
    empty, tc = tmp_path / "empty.bin", tmp_path / "tc.bin"
    empty.write_bytes(b"")
    g = [str(bins / "mfns-ground"), "--file", str(empty), "--out", str(tmp_path / "enc"), "--no-status"]
    res = subprocess.run(
        [*g, "--tc-file", str(tc), "--cmd", "SET_MODE standby"], capture_output=True, text=True
    )
    assert "uplink: 1 commands sent, 0 errors" in res.stderr, res.stderr
    tlm = tmp_path / "tlm.bin"
    nav = subprocess.run(
        [str(bins / "mfns-nav"), "--table", str(table), "--replay", str(frames), "--tlm-file", str(tlm),
         "--tc-file", str(tc), "--tc-insecure"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert nav.returncode == 0, nav.stderr
    out = tmp_path / "ground"
    res = subprocess.run([str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"])
    assert res.returncode == 0
    navr = read_csv(out / "nav.csv")
    assert len(navr) == 20 and all(r["mode"] == "STANDBY" and r["status"] == "NO_FIX" for r in navr)
    ev = read_csv(out / "events.csv")
    per_cycle = Counter(e["event"] for e in ev if int(e["cycle"]) >= 1)
    assert per_cycle == Counter(), per_cycle  # nothing after the command's own cycle
    assert [e["event"] for e in ev if e["severity"] == "WARNING"] == [
        "TC_AUTH",
        "TC_UNPROTECTED",
    ]  # --tc-insecure's own two
    assert {"MODE_CHANGE", "CMD_ACCEPTED"} <= {e["event"] for e in ev}
