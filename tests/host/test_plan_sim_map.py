"""`mfns sim nav --beacon-map`: the simulator renders a given beacons.csv (the planner's output)."""

from __future__ import annotations

import csv
import subprocess
import sys

import numpy as np
import pytest

from mfns.simulate import nav


def _write_map(path, pos, sigma=0.5):
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(nav.BEACONS_HEADER)
        for i, p in enumerate(pos):
            w.writerow([i, *(f"{v:.4f}" for v in p), sigma])


def test_turntable_takes_the_given_map(tmp_path):
    pos = np.array([[600.0, 0.0, 80.0], [0.0, 600.0, 80.0], [0.0, 0.0, 560.0], [-600.0, 0.0, 80.0]])
    _write_map(tmp_path / "b.csv", pos)
    scn = nav.turntable_scenario(8, 18.6, 0.0, 360.0, beacon_map=tmp_path / "b.csv")
    assert np.allclose(scn.beacons, pos)
    assert np.allclose(scn.beacon_sigma, 0.5)
    # aimed at the turntable centre, as the paper's LEDs
    assert np.allclose(scn.beacon_normals, -pos / np.linalg.norm(pos, axis=1, keepdims=True))
    base = nav.turntable_scenario(8, 18.6, 0.0, 360.0)
    assert np.allclose(scn.euler_deg, base.euler_deg)  # same sweep


def test_module_keeps_its_trajectory_and_aims_leds_off_the_walls(tmp_path):
    pos = np.array([[2000.0, 100.0, 0.0], [0.0, -1000.0, 300.0], [500.0, 0.0, 1000.0]])
    _write_map(tmp_path / "b.csv", pos)
    scn = nav.module_scenario(5, 1.0, 60, 3, beacon_map=tmp_path / "b.csv")
    base = nav.module_scenario(5, 1.0, 60, 3)
    assert np.allclose(scn.r_wb_w, base.r_wb_w) and np.allclose(scn.euler_deg, base.euler_deg)
    assert np.allclose(scn.beacon_normals, [[-1, 0, 0], [0, 1, 0], [0, 0, -1]])


@pytest.mark.parametrize(
    "rows, message",
    [
        ("id,x_mm,y_mm,z_mm,sigma_mm\n0,1,2,3,-1\n", "sigma_mm must be positive"),
        ("id,x\n0,1\n", "missing columns x_mm, y_mm, z_mm, sigma_mm"),
    ],
)
def test_bad_map_is_one_line_error(tmp_path, rows, message):
    (tmp_path / "b.csv").write_text(rows)
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "mfns",
            "sim",
            "nav",
            str(tmp_path / "out"),
            "--beacon-map",
            str(tmp_path / "b.csv"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 2
    assert message in res.stderr and "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_module_refuses_a_beacon_outside(tmp_path):
    _write_map(tmp_path / "b.csv", [[2500.0, 0.0, 0.0]])
    with pytest.raises(nav.MfnsError, match="outside the module"):
        nav.module_scenario(2, 1.0, 60, 0, beacon_map=tmp_path / "b.csv")
