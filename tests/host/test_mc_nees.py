"""The flight pose covariance on the module scenario (mfns.analysis.mc_nees): mean NEES 6 with each
error source modelled, far above 6 with its term switched off."""

from __future__ import annotations

import pytest

from mfns.analysis import mc_nees


@pytest.fixture(scope="module")
def nees(core_lib):
    if not core_lib.exists():
        pytest.fail(f"{core_lib} missing: run make lib")
    return mc_nees.run(trials=400, seed=5, lib=core_lib)


@pytest.mark.parametrize("case", ["pixel", "survey", "calibration"])
def test_nees_six_with_the_term(nees, case):
    mean, inside95, fixes = nees[case]
    print(f"{case}: mean NEES {mean:.2f}, {100 * inside95:.1f} % inside the 95 % bound, {fixes} fixes")
    assert fixes >= 360
    assert 6.0 * 0.85 < mean < 6.0 * 1.15  # standard error of the mean ~0.12 at 400 fixes
    assert 0.92 < inside95 < 0.98


@pytest.mark.parametrize("case", ["survey, no survey term", "calibration, no calibration term"])
def test_nees_far_above_six_without_it(nees, case):
    mean, inside95, _ = nees[case]
    assert mean > 30.0 and inside95 < 0.5


def test_mfns_nees_is_a_command(core_lib, monkeypatch, capsys):
    """`mfns nees` runs the same analysis and prints one row per case; bad --trials is exit 2."""
    from mfns import cli

    monkeypatch.setenv("MFNS_CORE_LIB", str(core_lib))
    assert cli.main(["nees", "--trials", "0"]) == 2
    assert "--trials must be in" in capsys.readouterr().err
    assert cli.main(["nees", "--trials", "20", "--seed", "1"]) == 0
    out = capsys.readouterr().out
    assert "module scenario, 20 poses" in out
    assert all(case in out for case in ("pixel", "survey", "calibration", "no calibration term"))
