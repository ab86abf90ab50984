"""The in-flight self-survey monitor end to end (issue 29, docs/self_survey.md section 3):
module frames rendered with the survey error, the beacon most in view moved 5 mm along its
wall in the rendering only, flown by the host-sim flight program on the table of the
surveyed (unmoved) map; mfns-ground decodes the events. The moved beacon is reported by
BEACON_BIASED (and by nothing else of the monitor) within the run, integrity's exclusion
notwithstanding; the same frames without the move raise no monitor event.
(`make bench-survey-monitor` runs the longer cases: 3, 2, 1 mm and a turned camera.)"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from flight_replay import fly_replay  # tests/host

from mfns.model.camera import load_beacons

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "bench"))

from bench_survey import along_wall, most_seen_beacon  # noqa: E402 (tests/bench, make bench-survey)

SEED, FRESH_SEED, FRAMES = 2, 7, 150  # the demo's module LEDs and fresh path


def _mfns(*args: str) -> None:
    res = subprocess.run([sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


@pytest.fixture(scope="module")
def surveyed(tmp_path_factory) -> tuple[Path, Path]:
    out = tmp_path_factory.mktemp("monitor")
    _mfns(
        "sim",
        "nav",
        str(out / "map"),
        "--scenario",
        "module",
        "--frames",
        "1",
        "--seed",
        str(SEED),
        "--quiet",
    )
    _mfns(
        "table",
        "build",
        str(out / "map" / "calib.json"),
        str(out / "map" / "beacons.csv"),
        "-o",
        str(out / "t.mfnstbl"),
    )
    return out / "map", out / "t.mfnstbl"


def _fly(bins: Path, tmp: Path, table: Path, beacon_map: Path) -> list[dict]:
    frames = tmp / "frames"
    _mfns(
        "sim",
        "nav",
        str(frames),
        "--scenario",
        "module",
        "--frames",
        str(FRAMES),
        "--seed",
        str(FRESH_SEED),
        "--beacon-map",
        str(beacon_map),
        "--survey-error",
        "--survey-seed",
        str(SEED),
        "--quiet",
    )
    return fly_replay(bins, table, frames, tmp, "--quiet", ground_name="g").rows("events.csv")


def test_moved_beacon_reported_by_the_monitor_and_clean_quiet(bins, surveyed, tmp_path):
    base, table = surveyed
    ids, p, sig = load_beacons(base / "beacons.csv")
    b = most_seen_beacon(FRESH_SEED, FRAMES, ids, p)
    q = p.copy()
    q[b] += 5.0 * along_wall(p[b])
    moved = tmp_path / "moved.csv"
    with open(moved, "w") as f:
        f.write("id,x_mm,y_mm,z_mm,sigma_mm\n")
        for i, x, s in zip(ids, q, sig, strict=True):
            f.write(f"{int(i)},{x[0]:.4f},{x[1]:.4f},{x[2]:.4f},{s:.4f}\n")
    ev = _fly(bins, tmp_path / "moved", table, moved)
    biased = [e for e in ev if e["event"] == "BEACON_BIASED"]
    assert [int(e["arg1"]) for e in biased] == [int(ids[b])], ev
    assert int(biased[0]["arg0"]) > 1842  # chi-square x100 over the level 18.42
    assert not [e for e in ev if e["event"] == "CAMERA_BIASED"]
    clean = _fly(bins, tmp_path / "clean", table, base / "beacons.csv")
    assert not [e for e in clean if e["event"] in ("BEACON_BIASED", "CAMERA_BIASED")], clean
