"""The fly check's measured one-call rate (mfns.plan.fly, step 5): the flight program started
lost at frames of a flown path, one cycle each; a start counts when its first cycle
certifies a fix (usable, or held only for its untested lag)."""

from __future__ import annotations

import csv
import json

import pytest

from mfns.core.errors import MfnsError
from mfns.plan import fly


def test_start_frames_spread_over_the_path():
    f = fly.start_frames(120, 20)
    assert len(f) == 20 and f[0] == 0 and f[-1] == 119 and f == sorted(set(f))
    assert max(b - a for a, b in zip(f, f[1:], strict=False)) <= 7
    assert fly.start_frames(5, 20) == [0, 1, 2, 3, 4]  # never more starts than frames
    assert fly.start_frames(120, 0) == [] and fly.start_frames(0, 5) == []


@pytest.mark.parametrize(
    ("status", "reason", "certified"),
    [
        ("FIX", "NONE", True),
        ("DEGRADED", "EXCLUDED", True),
        ("NO_FIX", "LAG_UNTESTED", True),  # a certified fix held only for its lag test
        ("NO_FIX", "BELOW_CERTIFICATE", False),
        ("NO_FIX", "NOT_IDENTIFIED", False),
        ("NO_FIX", "PL_EXCEEDS_AL", False),
        ("NO_FIX", "TOO_FEW", False),
    ],
)
def test_what_counts_as_certified_in_the_first_cycle(status, reason, certified):
    assert fly.first_cycle_certified(status, reason) is certified


def test_one_call_summary_counts_starts_and_puts_the_prediction_beside():
    outcomes = [
        ("NO_FIX", "LAG_UNTESTED"),
        ("FIX", "NONE"),
        ("NO_FIX", "BELOW_CERTIFICATE"),
        ("NO_FIX", "LAG_UNTESTED"),
        ("NO_FIX", "PL_EXCEEDS_AL"),
        ("NO_FIX", "BELOW_CERTIFICATE"),
        ("NO_FIX", "LAG_UNTESTED"),
        ("NO_FIX", "TOO_FEW"),
    ]
    predicted = [True, True, True, True, False, False, True, False]
    s = fly.one_call_summary(outcomes, predicted)
    assert s["starts"] == 8 and s["certified_first_cycle"] == 4
    assert s["measured_pct"] == 50.0 and s["predicted_pct"] == 62.5
    assert s["not_certified_reasons"] == {"BELOW_CERTIFICATE": 2, "PL_EXCEEDS_AL": 1, "TOO_FEW": 1}
    assert list(s["not_certified_reasons"])[0] == "BELOW_CERTIFICATE"  # most common first
    empty = fly.one_call_summary([], [])
    assert empty["starts"] == 0 and empty["measured_pct"] is None
    with pytest.raises(ValueError):
        fly.one_call_summary(outcomes, predicted[:-1])


def _folder(tmp_path):
    fr = tmp_path / "frames"
    rows = [["frame", "t_s", "camera", "file", "exposure_us", "gain_db"]]
    for k in range(3):
        for c in "xyz":
            (fr / f"cam_{c}").mkdir(parents=True, exist_ok=True)
            (fr / f"cam_{c}" / f"{k:06d}.pgm").write_text(f"{c}{k}")
            rows.append([str(k), f"{k / 18.6:.6f}", c, f"cam_{c}/{k:06d}.pgm", "1000", "0.0"])
    with open(fr / "frames.csv", "w", newline="") as f:
        csv.writer(f, lineterminator="\n").writerows(rows)
    (fr / "scenario.json").write_text(json.dumps({"scenario": "module"}))
    return fr


def test_a_start_folder_holds_that_frame_alone(tmp_path):
    fr = _folder(tmp_path)
    d = fly.start_folder(fr, 1, tmp_path / "s1")
    rows = list(csv.DictReader(open(d / "frames.csv")))
    assert [r["frame"] for r in rows] == ["1", "1", "1"] and [r["camera"] for r in rows] == ["x", "y", "z"]
    assert (d / "cam_y" / "000001.pgm").read_text() == "y1"  # the images are the path's own
    assert (d / "scenario.json").read_bytes() == (fr / "scenario.json").read_bytes()
    with pytest.raises(MfnsError, match="frame 7"):
        fly.start_folder(fr, 7, tmp_path / "s7")


def test_lost_starts_fly_the_flight_program(tmp_path, bins, capsys):
    """A real path (the demo module, 3 frames, in-process sim and table): the start at
    frame 0 is the full replay's first cycle (both a fresh program on the same frame), and
    every start gives one outcome the core names."""
    from mfns import cli
    from mfns.core.flight import REASONS

    fr, table = tmp_path / "frames", tmp_path / "t.mfnstbl"
    assert (
        cli.main(["sim", "nav", str(fr), "--scenario", "module", "--frames", "3", "--seed", "2", "--quiet"])
        == 0
    )
    build = ["table", "build", str(fr / "calib.json"), str(fr / "beacons.csv"), "-o", str(table)]
    build += ["--certify-samples", "20"]  # a small map analysis: both runs fly the same table
    assert cli.main([*build, "--workspace", str(fr / "scenario.json"), "--quiet"]) == 0
    nav, ground = bins / "mfns-nav", bins / "mfns-ground"
    out = fly.lost_starts(nav, ground, table, fr, tmp_path / "starts", [0, 1, 2])
    assert len(out) == 3 and all(reason in REASONS for _, reason in out)
    full = tmp_path / "full"
    fly._run([str(nav), "--table", str(table), "--replay", str(fr), "--tlm-file", str(tmp_path / "t.bin")],
             tmp_path / "nav.log", "mfns-nav")  # fmt: skip
    fly._run(
        [str(ground), "--file", str(tmp_path / "t.bin"), "--out", str(full), "-q"],
        tmp_path / "g.log",
        "ground",
    )
    rows = list(csv.DictReader(open(full / "nav.csv")))
    assert len(rows) == 3
    assert out[0] == (rows[0]["status"], fly._reason(rows[0]["reason"], REASONS))
    capsys.readouterr()
