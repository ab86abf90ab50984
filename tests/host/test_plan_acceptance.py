"""Acceptance of `mfns plan` (issue 15).

1. The Cramer-Rao bound of the planner agrees with the Monte Carlo spread of the flight
   solver (through ctypes) within 15 % on sampled poses: with pixel noise only the
   flight solver is efficient and reaches the bound; with survey and calibration errors
   (which the flight solver does not model) its spread is the planner's flight 1-sigma
   (same Jacobians, equal weights) within 15 %, and never below the bound.
2. The planner's availability agrees with simulated runs within 2 points.
3. The optimiser improves the paper's turntable layout as the issue states: the run
   `mfns sim nav` with its map, then `mfns-nav`, gives a fix in >= 95 % of cycles
   (the paper's layout: 17.5 %) with 1-sigma no worse.
"""

from __future__ import annotations

import copy
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mfns.analysis import calib_results
from mfns.model.pose_sim import make_frame, paper_beacons, paper_rig
from mfns.model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg
from mfns.plan import analyze as A
from mfns.plan import workspace
from mfns.plan.core import Core
from mfns.plan.crlb import CalibrationError
from mfns.simulate import nav

REPO = Path(__file__).resolve().parents[2]
BIN = REPO / "build" / "host-sim" / "bin"
TRIALS = 250
TOL = 0.15


@pytest.fixture(scope="module")
def core(core_lib):
    if not core_lib.exists():
        pytest.skip("make lib first")
    return Core(paper_rig(), core_lib)


def _module_poses(core, beacons, n, min_beacons=5):
    ws = workspace.module(80, np.random.default_rng(3))
    out = []
    for i in range(ws.n):
        obs, _ = A.observe(core, beacons, ws.C_w_b[i], ws.r_bw_b(i))
        if len({o.beacon for o in obs}) >= min_beacons:
            out.append((ws.C_w_b[i], ws.r_bw_b(i), ws.r_wb_w[i]))
        if len(out) == n:
            return out
    raise AssertionError("not enough module poses with beacons in view")


def _monte_carlo(core, beacons, C, r, r_wb_w, sigma_px, survey_mm, doc, rng):
    """Spread (6,) of the flight solver's fixes: x, y, z mm, roll, pitch, yaw deg."""
    fl = core.flight
    # an operational budget: gates never fire; iterations enough to converge on every trial
    cfg = fl.config(sigma_px=max(1.0, sigma_px), max_iterations=100)
    errs = []
    for _ in range(TRIALS):
        cams = core.cams
        if doc is not None:  # the true rig differs from the calibration by its 1-sigma
            cams = [copy.deepcopy(c) for c in core.cams]
            for k, c in enumerate(cams):
                s = doc["cameras"][k]["sigma"]
                e = np.asarray(doc["cameras"][k]["euler_213_deg"]) + rng.normal(size=3) * s["euler_213_deg"]
                c.C_k_b = euler213_deg_to_matrix(e)
                c.r_bk_b = c.r_bk_b + rng.normal(size=3) * np.asarray(s["r_bk_b"])
        obs, ids = make_frame(cams, beacons, C, r, sigma_px, rng)
        bmap = fl.beacon_map(beacons + rng.normal(0.0, survey_mm, beacons.shape))  # the surveyed map
        sol = fl.refine(core.rig, bmap, fl.frame(obs), fl.assoc(ids), fl.pose(C, r), cfg)
        assert sol.ok, sol.reason
        de = (sol.euler_deg - matrix_to_euler213_deg(C) + 180.0) % 360.0 - 180.0
        errs.append(np.concatenate([sol.r_wb_w - r_wb_w, de]))
    return np.std(np.array(errs), axis=0)


def test_crlb_is_the_flight_solvers_spread_with_pixel_noise(core):
    beacons, _ = nav.module_beacons(60, np.random.default_rng([2, 1]))
    rng = np.random.default_rng(21)
    for C, r, p in _module_poses(core, beacons, 3):
        obs, _ = A.observe(core, beacons, C, r)
        bound = A.pose_sigma(core, obs, C, r, 0.1, np.zeros(60), None, beacons)
        mc = _monte_carlo(core, beacons, C, r, p, 0.1, 0.0, None, rng)
        assert np.all(np.abs(mc / bound - 1.0) < TOL), mc / bound


def test_flight_sigma_matches_the_spread_with_survey_and_calibration_errors(core):
    beacons, _ = nav.module_beacons(60, np.random.default_rng([2, 1]))
    doc = calib_results.load(nav.PAPER_CALIB)
    calib = CalibrationError(core, doc)
    rng = np.random.default_rng(22)
    for C, r, p in _module_poses(core, beacons, 3):
        obs, _ = A.observe(core, beacons, C, r)
        bound, flight = A.pose_sigmas(core, obs, C, r, 0.1, np.full(60, 0.4), calib, beacons)
        mc = _monte_carlo(core, beacons, C, r, p, 0.1, 0.4, doc, rng)
        assert np.all(np.abs(mc / flight - 1.0) < TOL), mc / flight
        assert np.all(mc > bound * (1.0 - TOL)), mc / bound  # a bound: no solver does better
        assert np.all(flight >= bound * (1.0 - 1e-6))


def test_availability_agrees_with_the_simulator():
    """The planner (C decision) against `mfns sim nav`'s own visibility: the turntable
    sweep and the module trajectory, paper's and module maps."""
    core = Core(paper_rig())
    tt = nav.turntable_scenario(200, 18.6, 0.0, 120.0)
    mod = nav.module_scenario(300, 5.0, 60, 4)
    for scn in (tt, mod):
        sim = nav.visibility_stats(nav.visibility_counts(scn))
        ws = workspace.Workspace(
            "truth",
            scn.r_wb_w,
            np.array([scn.pose(i)[0] for i in range(scn.n_frames)]),
            scn.euler_deg,
            scn.name,
            ordered=True,
        )
        a = A.analyze(core, scn.beacons, scn.beacon_sigma, ws, 0.1)
        assert abs(100 * a.fix.mean() - 100 * sim["frac_ge_4"]) <= 2.0
        assert abs(100 * a.track.mean() - 100 * sim["frac_ge_3"]) <= 2.0


# --------------------------------------------------------------------------- end to end
def _mfns(*args):
    res = subprocess.run([sys.executable, "-m", "mfns", *args], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    return res.stdout


def _run(tmp: Path, beacon_map: Path | None):
    """`mfns sim nav` (the demo's turntable run) -> table -> mfns-nav -> mfns-ground:
    (fix per cycle, std of the fix errors per axis x, y, z, roll, pitch, yaw)."""
    frames = tmp / "frames"
    extra = ["--beacon-map", str(beacon_map)] if beacon_map else []
    _mfns(
        "sim",
        "nav",
        str(frames),
        "--scenario",
        "turntable",
        "--frames",
        "200",
        "--yaw-span",
        "120",
        "--seed",
        "1",
        "--quiet",
        *extra,
    )
    # the turntable is an accuracy bench of at most a few beacons, which no single-fault test
    # can certify (docs/pose.md "Integrity"): its table is monitor-only, as in make demo, so
    # the fix rate measured is the layout's, not the integrity gate's
    bench = tmp / "bench.json"
    bench.write_text('{"integrity": {"monitor_only": 1}}')
    _mfns(
        "table", "build", str(frames / "calib.json"), str(frames / "beacons.csv"), "-o", str(tmp / "t.tbl"),
        "--settings", str(bench),
    )  # fmt: skip
    for cmd in (
        [BIN / "mfns-nav", "--table", tmp / "t.tbl", "--replay", frames, "--tlm-file", tmp / "tlm.bin"],
        [BIN / "mfns-ground", "--file", tmp / "tlm.bin", "--out", tmp / "ground", "--no-status"],
    ):
        res = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, check=False, timeout=300)
        assert res.returncode == 0, res.stderr
    rows = list(csv.DictReader(open(tmp / "ground" / "nav.csv")))
    truth = list(csv.DictReader(open(frames / "truth.csv")))
    assert len(rows) == len(truth) == 200
    fix = np.array([r["status"] != "NO_FIX" for r in rows])
    cols = ("x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg")
    est = np.array([[float(r[c]) for c in cols] for r in rows])[fix]
    tru = np.array([[float(r[c]) for c in cols] for r in truth])[fix]
    err = est - tru
    err[:, 3:] = (err[:, 3:] + 180.0) % 360.0 - 180.0
    return fix, err.std(axis=0), frames


@pytest.fixture(scope="module")
def flight_bins():
    res = subprocess.run(
        ["make", "--no-print-directory", "-j2", "flight"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 0, res.stdout + res.stderr


def test_optimised_turntable_layout_end_to_end(tmp_path, flight_bins):
    out = tmp_path / "plan"
    # the simulated world: an exact map and the scenario's ~0.016 px centroid noise
    _mfns(
        "plan",
        "optimize",
        str(out),
        "--surfaces",
        "paper-frame",
        "--count",
        "10",
        "--samples",
        "240",
        "--pixel-sigma",
        "0.0155",
        "--beacon-sigma",
        "0",
        "--no-calib-sigma",
        "--no-certify",  # 1-4 of 10 in view: never certifiable, as the demo plans it
        "--polish",  # no climb on the integrity verdict: the turntable flies monitor-only
        "0",  # tables, as the demo plans it (mk/demo.sh: it cost 1.28x of the 1 sigma)
        "--restarts",
        "1",
        "--seed",
        "1",
        "--quiet",
    )
    plan = json.loads((out / "plan.json").read_text())
    assert plan["check"]["availability_pct"] >= 99.0
    fix_paper, sd_paper, _ = _run(tmp_path / "paper", None)
    fix_opt, sd_opt, frames = _run(tmp_path / "opt", out / "beacons.csv")
    assert fix_paper.mean() < 0.25  # today: 35 of 200 cycles
    assert fix_opt.mean() >= 0.95
    # 1-sigma no worse: on average over the axes, and no axis beyond the sampling noise
    # of a 35-fix standard deviation (about 12 %)
    ratio = sd_opt / sd_paper
    assert ratio.mean() <= 1.0 and np.all(ratio <= 1.2), ratio
    # availability of the plan against the run, within 2 points (the nav-cycle rule for
    # the paper's map, >= 4 in view for the planned one, where both are the same)
    core = Core(paper_rig())
    ws = workspace.from_truth(frames / "truth.csv")
    for fix, bmap in ((fix_paper, None), (fix_opt, out / "beacons.csv")):
        _, pos, sig = nav.load_beacon_map(bmap) if bmap else (None, paper_beacons(), np.full(10, 0.4))
        a = A.analyze(core, pos, sig, ws, 0.0155)
        assert abs(100 * a.fix_flight.mean() - 100 * fix.mean()) <= 2.0
