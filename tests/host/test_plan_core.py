"""mfns.plan against the C core: visibility is the C decision, the numpy pieces the
optimiser uses agree with the C functions, and the pixel-noise bound is the flight
solver's own covariance."""

from __future__ import annotations

import ctypes as ct
import json

import numpy as np
import pytest

from mfns.analysis import calib_results
from mfns.core.flight import V3, Flight
from mfns.model.pose_sim import make_frame, paper_beacons, paper_rig, random_visible_poses
from mfns.plan import analyze as A
from mfns.plan import surfaces, workspace
from mfns.plan.core import Core, prefilter
from mfns.plan.crlb import CalibrationError, output_jacobian, sigma_batch
from mfns.simulate.nav import PAPER_CALIB


@pytest.fixture(scope="module")
def core(core_lib):
    if not core_lib.exists():
        pytest.skip("make lib first")
    return Core(paper_rig(), core_lib)


def _c_in_view(core, k, C, r, pts):
    """The flight rule on every point, no prefilter: mfns_cam_project OK and in the image."""
    cam = ct.byref(core.rig.cam[k])
    pose = Flight.pose(C, r)
    uv = (ct.c_float * 2)()
    out = np.zeros(len(pts), dtype=bool)
    for i, p in enumerate(pts):
        if core.lib.mfns_cam_project(cam, ct.byref(pose), V3(*map(float, p)), ct.byref(uv), None) == 0:
            out[i] = core.lib.mfns_cam_in_image(ct.byref(core.rig.cam[k].k), uv[0], uv[1])
    return out


def test_visibility_is_the_c_decision_and_the_prefilter_never_drops_a_visible_point(core):
    cand, _ = surfaces.candidates(*surfaces.builtin("module")[:1], 250.0, [])
    pts = np.vstack([cand, paper_beacons()])
    ws = workspace.box(40, [-900, -400, -400], [900, 400, 400], np.random.default_rng(3))
    seen = 0
    for i in range(ws.n):
        C, r = ws.C_w_b[i], ws.r_bw_b(i)
        for k in range(3):
            truth = _c_in_view(core, k, C, r, pts)
            _, vis, _ = core.project(k, C, r, pts)
            assert np.array_equal(vis, truth)
            assert not np.any(truth & ~prefilter(core.cams[k], C, r, pts))
            seen += int(truth.sum())
    assert seen > 100  # the check saw plenty of visible points


def test_numpy_output_sigma_matches_mfns_pose_covariance(core):
    rng = np.random.default_rng(5)
    poses = random_visible_poses(rng, core.cams, paper_beacons(), 12, min_visible=3)
    infos, jos, want = [], [], []
    for C, r in poses:
        obs, _ = A.observe(core, paper_beacons(), C, r)
        J = np.concatenate([o.J for o in obs])
        info = J.T @ J / 0.1**2
        infos.append(info)
        jos.append(output_jacobian(C, r))
        pos, eul = core.output_sigma(info, C, r)
        want.append(np.concatenate([pos, eul]))
    got = sigma_batch(np.array(infos), np.array(jos))
    np.testing.assert_allclose(got, np.array(want), rtol=2e-3)


def test_pixel_noise_bound_is_the_flight_solvers_covariance(core):
    """Refining exact observations from the truth, the C solver reports sigma^2 (J^T J)^-1
    mapped to the outputs: the planner's bound with pixel noise only must be the same."""
    rng = np.random.default_rng(8)
    beacons = paper_beacons()
    fl = core.flight
    bmap = fl.beacon_map(beacons)
    for C, r in random_visible_poses(rng, core.cams, beacons, 6, min_visible=4):
        obs, ids = make_frame(core.cams, beacons, C, r, 0.0, rng)
        cfg = fl.config(sigma_px=0.25)
        sol = fl.refine(core.rig, bmap, fl.frame(obs), fl.assoc(ids), fl.pose(C, r), cfg)
        assert sol.ok
        o, _ = A.observe(core, beacons, C, r)
        plan = A.pose_sigma(core, o, C, r, 0.25, np.zeros(len(beacons)), None, beacons)
        np.testing.assert_allclose(plan[:3], sol.sigma_pos_mm, rtol=1e-2)
        np.testing.assert_allclose(plan[3:], sol.sigma_euler_deg, rtol=1e-2)


def test_survey_and_calibration_errors_add_to_the_bound(core):
    beacons = paper_beacons()
    doc = calib_results.load(PAPER_CALIB)
    (C, r), *_ = random_visible_poses(np.random.default_rng(2), core.cams, beacons, 1, min_visible=4)
    o, _ = A.observe(core, beacons, C, r)
    zero = np.zeros(len(beacons))
    pix = A.pose_sigma(core, o, C, r, 0.1, zero, None, beacons)
    sur = A.pose_sigma(core, o, C, r, 0.1, zero + 0.4, None, beacons)
    cal = A.pose_sigma(core, o, C, r, 0.1, zero + 0.4, CalibrationError(core, doc), beacons)
    assert np.all(sur > pix) and np.all(cal > sur)
    # a document without sigma entries adds nothing
    bare = json.loads(json.dumps(doc))
    for cam in bare["cameras"]:
        cam.pop("sigma", None)
    assert not CalibrationError(core, bare)


def test_flight_sequence_rule():
    seq = np.array([3, 4, 3, 3, 2, 3, 4, 5, 2])
    assert A.flight_sequence_fix(seq).tolist() == [False, True, True, True, False, False, True, True, False]


def test_workspace_samples_are_deterministic():
    a = workspace.module(50, np.random.default_rng([4, 0]))
    b = workspace.module(50, np.random.default_rng([4, 0]))
    assert np.array_equal(a.r_wb_w, b.r_wb_w) and np.array_equal(a.C_w_b, b.C_w_b)
    assert np.all(np.abs(a.euler_deg[:, 0]) <= 20.0 + 1e-9)
