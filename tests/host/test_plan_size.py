"""`mfns plan size` (issue 43): the curve LED count -> usable and one-call rates by the flight's
verdict, the smallest count reaching the targets, and what each count cannot reach."""

from __future__ import annotations

import json

import pytest

from mfns.cli import main

SMALL = [
    "--workspace",
    "module",
    "--samples",
    "40",
    "--iterations",
    "50",
    "--pixel-sigma",
    "0.0155",
    "--polish",
    "20",
]


def test_size_curve_and_the_targets_a_count_cannot_reach(tmp_path, capsys, core_lib):
    if not core_lib.exists():
        pytest.skip("make lib first")
    out = tmp_path / "size"
    argv = ["plan", "size", str(out), *SMALL, "--no-calib-sigma", "--counts", "8,40"]
    assert main([*argv, "--target-usable", "99.9", "--target-one-call", "99.9"]) == 0
    text = capsys.readouterr().out
    doc = json.loads((out / "size.json").read_text())
    rows = {r["count"]: r for r in doc["curve"]}
    assert sorted(rows) == [8, 40]
    # eight LEDs leave most poses without a usable fix; forty give more
    assert rows[8]["usable_pct"] < rows[40]["usable_pct"]
    assert rows[8]["one_call_pct"] <= rows[8]["usable_pct"]
    # 99.9 % is out of reach of both counts on 40 samples of this module: each says which target
    for n in (8, 40):
        assert any(m.startswith("usable") for m in rows[n]["misses"]), rows[n]
        assert f"{n:4d} LEDs:" in text and "cannot reach: usable" in text
    assert doc["answer"] is None and "no count tried reaches" in text
    assert (out / "size.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "beacons_40.csv").read_text().startswith("id,x_mm,y_mm,z_mm,sigma_mm")
    # a reachable target is answered with the smallest count reaching it
    low = rows[40]["usable_pct"] - 0.01
    assert main([*argv, "--target-usable", f"{low:.2f}", "-q"]) == 0
    assert json.loads((out / "size.json").read_text())["answer"] in (8, 40)


@pytest.mark.parametrize(
    "bad", [["--counts", "3,8"], ["--counts", "x"], ["--target-usable", "120"], ["--counts", "300"]]
)
def test_size_refuses_bad_arguments(tmp_path, capsys, bad):
    assert main(["plan", "size", str(tmp_path / "o"), *SMALL, *bad]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_optimize_refuses_bad_fly_arguments(tmp_path, capsys):
    for bad in (["--fly-frames", "-1"], ["--fly-paths", "0"]):
        assert main(["plan", "optimize", str(tmp_path / "o"), "--count", "6", *bad]) == 2
        assert "--fly-frames" in capsys.readouterr().err


def test_a_module_plan_is_flown_before_it_is_reported(tmp_path, capsys, core_lib):
    """Issue 43: the planned layout is flown on a fresh module path (mfns sim nav, its table,
    the flight program, the ground station) and plan.json gives flown against predicted."""
    from mfns.programs import program_path

    if not core_lib.exists() or program_path("mfns-nav") is None:
        pytest.skip("make lib flight first")
    out = tmp_path / "p"
    argv = ["plan", "optimize", str(out), "--surfaces", "module", "--count", "30", "--grid", "200"]
    argv += [*SMALL, "--no-calib-sigma", "--restarts", "1", "--polish", "30", "--ident-samples", "0"]
    assert main([*argv, "--fly-frames", "8", "--fly-paths", "1"]) == 0
    text = capsys.readouterr().out
    plan = json.loads((out / "plan.json").read_text())
    f = plan["fly"]["planned"]
    assert f["paths"] == 1 and f["frames_per_path"] == 8
    assert 0.0 <= f["flown_usable_pct"] <= 100.0 and 0.0 <= f["predicted_usable_pct"] <= 100.0
    assert "flown (planned, 1 fresh paths x 8 frames)" in text
    assert "polish on the flight's verdict" in text
    assert (out / "fly" / "planned-0" / "ground" / "nav.csv").is_file()
