"""`mfns plan` on the command line: outputs, determinism, one-line errors."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest

from mfns.plan.report import SAMPLES_HEADER


def mfns(*args):
    return subprocess.run(
        [sys.executable, "-m", "mfns", "plan", *args], capture_output=True, text=True, check=False
    )


def test_help():
    for action in ([], ["analyze"], ["optimize"]):
        res = mfns(*action, "--help")
        assert res.returncode == 0 and "usage: mfns plan" in res.stdout


def test_analyze_writes_csv_summary_and_plots_deterministically(tmp_path):
    args = [
        "--workspace",
        "box",
        "--box=-300,-200,-200,300,200,200",
        "--samples",
        "30",
        "--seed",
        "4",
    ]
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        res = mfns("analyze", str(out), *args)
        assert res.returncode == 0, res.stderr
        assert "availability" in res.stdout  # --quiet would print nothing
    assert (a / "samples.csv").read_bytes() == (b / "samples.csv").read_bytes()
    rows = list(csv.DictReader(open(a / "samples.csv")))
    assert list(rows[0]) == SAMPLES_HEADER and len(rows) == 30
    assert all(r["ident_margin"] == "" for r in rows)  # issue 11's analysis is not plugged in
    assert all(r["fix_flight"] == "" for r in rows)  # an unordered workspace
    s = json.loads((a / "summary.json").read_text())
    assert 0.0 <= s["availability_pct"] <= 100.0
    assert s["availability_pct"] == pytest.approx(100.0 * sum(r["fix"] == "1" for r in rows) / 30, abs=0.01)
    # the one-call ceiling: views at or above the certificate's floor, and views of exactly four
    from mfns.plan.analyze import CERT_MIN_IN_VIEW
    from mfns.table.generated.layout_gen import CONSTANTS

    assert CERT_MIN_IN_VIEW == CONSTANTS["MFNS_BIDX_MIN_CERT"] == 5
    n_in = [int(r["in_view"]) for r in rows]
    assert s["one_call_views_pct"] == pytest.approx(100.0 * sum(n >= 5 for n in n_in) / 30, abs=0.01)
    assert s["four_in_view_pct"] == pytest.approx(100.0 * sum(n == 4 for n in n_in) / 30, abs=0.01)
    assert s["one_call_views_pct"] + s["four_in_view_pct"] == pytest.approx(s["availability_pct"], abs=0.02)
    assert "one-call views" in (a / "summary.md").read_text()
    for name in ("in_view_hist.png", "availability.png", "sigma.png", "summary.md"):
        assert (a / name).stat().st_size > 1000


def test_optimize_writes_a_map_the_simulator_and_table_builder_read(tmp_path):
    out = tmp_path / "o"
    res = mfns(
        "optimize",
        str(out),
        "--count",
        "6",
        "--samples",
        "24",
        "--grid",
        "120",
        "--iterations",
        "50",
        "--restarts",
        "1",
        "--keep-out=-500,-800,400,700,500,600",
        "--quiet",
    )
    assert res.returncode == 0, res.stderr
    rows = list(csv.DictReader(open(out / "beacons.csv")))
    assert len(rows) == 6 and list(rows[0]) == ["id", "x_mm", "y_mm", "z_mm", "sigma_mm"]
    assert all(float(r["z_mm"]) < 400 for r in rows)  # the keep-out took the top face
    plan = json.loads((out / "plan.json").read_text())
    assert plan["algorithm"].startswith("greedy") and plan["run_time_s"]["total"] > 0
    chk = plan["check"]
    assert set(chk) == {
        "availability_pct",
        "one_call_views_pct",
        "four_in_view_pct",
        "samples",
        "flight_verdict",
    }
    # issue 43: the flight's own verdict on the check samples, per camera (mfns.plan.usable)
    v = chk["flight_verdict"]
    assert 0.0 <= v["one_call_pct"] <= v["usable_pct"] <= chk["availability_pct"]
    assert len(v["per_camera_seen_pct"]) == 3
    assert len(plan["restart_usable_pct"]) == 1
    assert "fly" not in plan  # a turntable workspace is not flown (module paths only)
    assert chk["one_call_views_pct"] + chk["four_in_view_pct"] == pytest.approx(
        chk["availability_pct"], abs=0.02
    )
    # the box planned for (the turntable's poses: one body position, every yaw), padded
    lo, hi = plan["table_workspace_mm"][:3], plan["table_workspace_mm"][3:]
    assert all(a < 0.0 < b for a, b in zip(lo, hi, strict=True)) and max(hi) < 5.0
    tbl = subprocess.run(
        [
            sys.executable,
            "-m",
            "mfns",
            "table",
            "build",
            "host_tools/mfns/data/paper_calib.json",
            str(out / "beacons.csv"),
            "-o",
            str(tmp_path / "t.tbl"),
            "--workspace",
            str(out / "plan.json"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert tbl.returncode == 0, tbl.stderr
    # the table's map index is built over the planned box, not the map's default one
    assert f"workspace [{lo[0]:.0f}, {hi[0]:.0f}] x [{lo[1]:.0f}, {hi[1]:.0f}]" in tbl.stdout, tbl.stdout
    assert "the workspace is the default" not in tbl.stdout


def test_a_workspace_beyond_the_beacons_is_named():
    import numpy as np

    from mfns.table.mapindex import workspace_outside

    pos = np.array([[-2000.0, -1000.0, -1000.0], [2000.0, 1000.0, 1000.0], [0.0, 0.0, 0.0]])
    assert workspace_outside(pos, np.array([-800, -300, -300]), np.array([800, 300, 300])) is None
    line = workspace_outside(pos, np.array([-800, -300, -300]), np.array([800, 300, 3000]))
    assert "along z by 2000 mm" in line and "units (mm)" in line
    line = workspace_outside(pos, np.array([-8000, -300, -300]), np.array([800, 1500, 300]))
    assert "x by 6000 mm, y by 500 mm" in line


def test_table_workspace_from_a_plan_or_numbers(tmp_path):
    from mfns.core.errors import MfnsError
    from mfns.table.mapindex import workspace_arg

    lo, hi = workspace_arg("-800,-300,-300,800,300,300")
    assert lo.tolist() == [-800, -300, -300] and hi.tolist() == [800, 300, 300]
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"table_workspace_mm": [-1.5, -2, -3, 4, 5, 6.25]}))
    lo, hi = workspace_arg(str(plan))
    assert lo.tolist() == [-1.5, -2, -3] and hi.tolist() == [4, 5, 6.25]
    for text, message in (
        ('{"optimised_on": "module"}', "table_workspace_mm"),
        ('{"table_workspace_mm": [1, 2, 3]}', "table_workspace_mm"),
        ('{"table_workspace_mm": [1, 2, 3, 0, 5, 6]}', "below its maximum"),
        ("[1, 2", "not a readable JSON"),
        ('{"table_workspace_mm": [true, 2, 3, 4, 5, 6]}', "table_workspace_mm"),
        ('{"table_workspace_mm": [1, 2, 3, 4, 5, "6"]}', "table_workspace_mm"),
        ('{"table_workspace_mm": [1, 2, 3, 4, 5, 1' + "0" * 400 + "]}", "six numbers"),
    ):
        plan.write_text(text)
        with pytest.raises(MfnsError, match=message):
            workspace_arg(str(plan))
    with pytest.raises(MfnsError, match="no such file"):
        workspace_arg(str(tmp_path / "plan_typo.json"))
    plan.write_bytes(b" " * ((1 << 20) + 1))
    with pytest.raises(MfnsError, match="larger than"):
        workspace_arg(str(plan))


@pytest.mark.parametrize(
    "args, message",
    [
        (["analyze", "OUT", "--workspace", "box"], "needs --box"),
        (["analyze", "OUT", "--workspace", "box", "--box", "1,2,3"], "expected 6"),
        (["analyze", "OUT", "--workspace", "truth"], "needs --truth"),
        (["analyze", "OUT", "--samples", "0"], "expected 1..100000 pose samples"),
        (["analyze", "OUT", "--beacons", "/nonexistent.csv"], "nonexistent"),
        (["analyze", "OUT", "--pixel-sigma", "-1"], "positive"),
        (["optimize", "OUT", "--surfaces", "/nonexistent.json"], "no such surface file"),
        (["optimize", "OUT", "--count", "3"], "at least 4"),
        (["optimize", "OUT", "--count", "257"], "at most 256"),
        (["optimize", "OUT", "--keep-out", "a,b"], "six numbers"),
        (["optimize", "OUT", "--count", "10", "--min-spacing", "5000", "--iterations", "0"], "fit"),
    ],
)
def test_bad_input_is_one_line(tmp_path, args, message):
    args = [str(tmp_path / "out") if a == "OUT" else a for a in args]
    res = mfns(*args, "--quiet")
    assert res.returncode == 2, res.stdout
    assert message in res.stderr and "Traceback" not in res.stderr, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
