"""Camera data health in the flight program (issue 23, item 1; firmware/frames/frame_health.h).

A small module folder (`mfns sim nav`, 40 frames) is flown by the built `mfns-nav`
on replay cameras with one camera's data broken the way a stuck sensor or a
stepping clock breaks it: the fault is reported (event and camera state), the
camera's frames are left out until it is healthy again, and every nav packet is
stamped with the capture time of the frames it came from.
"""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("MFNS_BIN", REPO / "build" / "host-sim" / "bin"))
FRAMES = 40
HEALTH_EVENTS = {"CAMERA_FROZEN", "CAMERA_CLOCK_JUMP", "CAMERA_LATE", "CAMERA_SEQ_MISMATCH", "CAMERA_HEALTHY"}
HEALTH_STATES = {"PROBATION", "FROZEN", "CLOCK_FAULT", "LATE", "OUT_OF_STEP"}


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> dict:
    d = tmp_path_factory.mktemp("health")
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
    build = [sys.executable, "-m", "mfns", "table", "build", str(frames / "calib.json")]
    build += [str(frames / "beacons.csv"), "-o", str(table), "-q"]
    res = subprocess.run(build, check=False, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    with open(frames / "truth.csv", newline="") as f:
        times = [float(r["t_s"]) for r in csv.DictReader(f)]
    return {"frames": frames, "table": table, "times": times}


def fly(bins: Path, base: dict, folder: Path, tmp: Path) -> tuple[dict[str, list[dict]], str]:
    tlm = tmp / "t.bin"
    args = [str(bins / "mfns-nav"), "--table", str(base["table"]), "--replay", str(folder)]
    args += ["--tlm-file", str(tlm)]
    nav = subprocess.run(args, check=False, capture_output=True, text=True, timeout=120)
    assert nav.returncode == 0, nav.stderr
    out = tmp / "g"
    res = subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(tlm), "--out", str(out), "--no-status"],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    tables = {}
    for name in ("nav", "camera", "events"):
        with open(out / f"{name}.csv", newline="") as f:
            tables[name] = list(csv.DictReader(f))
    return tables, nav.stderr


def shift_clock(folder: Path, cam: str, first: int, step_s: float) -> None:
    lines = (folder / "frames.csv").read_text().splitlines()
    out = [lines[0]]
    for ln in lines[1:]:
        p = ln.split(",")
        if p[2] == cam and int(p[0]) >= first:
            p[1] = f"{float(p[1]) + step_s:.6f}"
        out.append(",".join(p))
    (folder / "frames.csv").write_text("\n".join(out) + "\n")


def usable_stamped_at_their_frames(tables: dict, times: list[float]) -> None:
    """Every usable fix carries its cycle's frame time (cycle k fuses frame k here)."""
    for r in tables["nav"]:
        if r["status"] in ("FIX", "DEGRADED"):
            assert abs(float(r["t_s"]) - times[int(r["cycle"])]) < 1e-3, r


def test_clean_run_has_no_health_event(bins, base, tmp_path):
    folder = shutil.copytree(base["frames"], tmp_path / "f")
    tables, err = fly(bins, base, folder, tmp_path)
    assert not [e for e in tables["events"] if e["event"] in HEALTH_EVENTS], tables["events"]
    assert not [r for r in tables["camera"] if r["state"] in HEALTH_STATES]
    assert "health" not in err
    usable_stamped_at_their_frames(tables, base["times"])


def test_frozen_camera_is_left_out(bins, base, tmp_path):
    """Camera y's files from frame 10 on are copies of frame 10 (a stuck sensor)."""
    folder = shutil.copytree(base["frames"], tmp_path / "f")
    for i in range(11, FRAMES):
        shutil.copy(folder / "cam_y" / "000010.pgm", folder / "cam_y" / f"{i:06d}.pgm")
    tables, err = fly(bins, base, folder, tmp_path)
    health = [e for e in tables["events"] if e["event"] in HEALTH_EVENTS]
    ev = [(e["event"], int(e["cycle"]), e["subject"]) for e in health]
    assert ev == [("CAMERA_FROZEN", 11, "1")], ev  # the first repeated frame, once
    assert "camera y: cycle 11: frame 11 has the previous frame's content: frozen, left out" in err
    states = {int(r["cycle"]): r["state"] for r in tables["camera"] if r["camera"] == "y"}
    assert all(states[c] == "FROZEN" for c in range(11, FRAMES)), states
    usable_stamped_at_their_frames(tables, base["times"])


def test_clock_step_ahead_is_left_out_then_realigned(bins, base, tmp_path):
    """Camera y's stamps jump +5 s at frame 15: reported, left out, re-aligned after probation."""
    folder = shutil.copytree(base["frames"], tmp_path / "f")
    shift_clock(folder, "y", 15, 5.0)
    tables, err = fly(bins, base, folder, tmp_path)
    ev = [
        (e["event"], int(e["cycle"]), e["subject"], int(e["arg0"]), int(e["arg1"]))
        for e in tables["events"]
        if e["event"] in HEALTH_EVENTS
    ]
    jump = [e for e in ev if e[0] == "CAMERA_CLOCK_JUMP"]
    assert len(jump) == 1 and jump[0][1:3] == (15, "1") and abs(jump[0][3] - 5_000_000) < 1000, ev
    back = [e for e in ev if e[0] == "CAMERA_HEALTHY"]
    assert len(back) == 1 and back[0][1:3] == (25, "1") and abs(back[0][4] + 5_000_000) < 1000, ev
    y = [r for r in tables["camera"] if r["camera"] == "y"]
    states = {int(r["cycle"]): (r["state"], int(r["frame_seq"])) for r in y}
    assert states[15][0] == "CLOCK_FAULT" and all(states[c][0] == "PROBATION" for c in range(16, 25)), states
    # back with its stamps corrected: its frame k in cycle k; integrity first holds it
    # (LAG_VERIFY) until its time-offset test has passed 4 fixes, then fuses it
    assert all(states[c][1] == c and states[c][0] in ("OK", "LAG_VERIFY") for c in range(25, FRAMES)), states
    # (in this short run its lag is never verified: it stays held to the end, availability
    # lost, never integrity; issue 23's open item)
    # no nav packet stamped 5 s ahead, and every fix at its frames' capture time
    assert max(float(r["t_s"]) for r in tables["nav"]) < base["times"][-1] + 0.01
    usable_stamped_at_their_frames(tables, base["times"])
    assert "clock stepped by 5000" in err
