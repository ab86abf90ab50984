"""Calibration: the simulator's geometry and images, the paper's CPC on exact data."""

import cv2
import numpy as np
import pytest

from mfns.calib.cpc import run_cpc, solve_a10
from mfns.calib.dataset import detect_corners
from mfns.calib.model import Board, world_to_pixels
from mfns.calib.pipeline import calibrate, paper_quantities
from mfns.calib.refine import quantities
from mfns.calib.zhang import ZhangResult
from mfns.simulate.calib import Renderer, corner_observations, default_truth, make_plan

BOARD = Board()


@pytest.fixture(scope="module")
def truth():
    return default_truth()


@pytest.fixture(scope="module")
def exact_plan(truth):
    """Geometry with exact turntable angles (no 8" noise)."""
    return make_plan(truth, BOARD, np.random.default_rng(11), 10, 5, angle_sigma_arcsec=0.0)


def test_simulator_projection_matches_opencv(truth, exact_plan):
    obj = BOARD.object_points()
    for s in exact_plan[::4]:
        cam = truth.cams[s.camera]
        uv, vis = world_to_pixels(cam, s.C_k_w, s.r_wk_w, obj)
        assert vis.all()
        rvec, _ = cv2.Rodrigues(s.C_k_w.T)
        tvec = -s.C_k_w.T @ s.r_wk_w
        ref, _ = cv2.projectPoints(obj, rvec, tvec, cam.K, cam.dist)
        assert np.max(np.abs(uv - ref.reshape(-1, 2))) < 1e-9


def test_every_camera_sees_the_whole_board_with_varied_angles(exact_plan):
    for k in range(3):
        tt = [s for s in exact_plan if s.camera == k and s.kind == "turntable"]
        assert len(tt) >= 10
        big = np.array([s.omega_big_deg for s in tt])
        small = np.array([s.omega_small_deg for s in tt])
        assert np.ptp(big) >= 10.0 and np.ptp(small) >= 5.0
    z = [s for s in exact_plan if s.camera == 2 and s.kind == "turntable"]
    assert sum(s.omega_small_deg == 0.0 for s in z) >= 4  # pure-Omega views for Eq. A16
    assert sum(s.omega_big_deg == 0.0 and s.omega_small_deg != 0.0 for s in z) >= 3


def test_rendered_image_gives_subpixel_corners(truth, exact_plan):
    """Corners found by OpenCV on a rendered image sit on the true projections, in order."""
    shots = [s for s in exact_plan if s.camera == 2][:2]
    rend = Renderer(truth.cams[2], BOARD)
    rng = np.random.default_rng(5)
    for s in shots:
        img = rend.render(s.C_k_w, s.r_wk_w, rng)
        assert img.dtype == np.uint8 and img.shape == (1024, 1280)
        assert 0 < img.min() < 40 and 150 < img.max() < 255  # black and white squares, no clipping
        uv = detect_corners(img, BOARD)
        assert uv is not None
        ref, _ = world_to_pixels(truth.cams[2], s.C_k_w, s.r_wk_w, BOARD.object_points())
        err = uv - ref
        assert np.sqrt(np.mean(err**2)) < 0.1
        assert np.max(np.abs(err.mean(axis=0))) < 0.03  # no systematic shift


def _exact_zhang(truth, obs, shots):
    """Zhang results holding the true intrinsics and per-image poses."""
    out = []
    for k in range(3):
        cam = truth.cams[k]
        mine = [s for s in shots if s.camera == k]
        assert [s.name for s in mine] == [im.name for im in obs.of_camera(k)]
        out.append(
            ZhangResult(
                k,
                cam.K,
                cam.dist,
                np.zeros(9),
                0.0,
                [s.name for s in mine],
                [s.C_k_w.T for s in mine],
                [-s.C_k_w.T @ s.r_wk_w for s in mine],
            )
        )
    return out


def test_cpc_recovers_truth_exactly_on_exact_poses(truth, exact_plan):
    obs = corner_observations(
        truth,
        BOARD,
        exact_plan,
        np.random.default_rng(0),
        0.0,
        caliper_height_mm=-truth.r_wb_w[2],
        angle_sigma_arcsec=0.0,
    )
    res = run_cpc(obs, _exact_zhang(truth, obs, exact_plan))
    assert np.max(np.abs(res.C_t_w - truth.C_t_w)) < 1e-10
    for k in range(3):
        assert np.max(np.abs(res.C_k_b[k] - truth.cams[k].C_k_b)) < 1e-10
        assert np.max(np.abs(res.r_bk_b[k] - truth.cams[k].r_bk_b)) < 1e-8
    assert np.max(np.abs(res.r_wt_w - truth.r_wt_w)) < 1e-8
    assert np.max(np.abs(res.r_tb_b - truth.r_tb_b)) < 1e-8
    assert np.max(np.abs(res.r_wb_w - truth.r_wb_w)) < 1e-8


def test_a10_single_pass_is_the_papers_first_order_solution(truth, exact_plan):
    """One pass of Eq. A10 has a second-order error (~0.01 deg here); iterating removes it."""
    obs = corner_observations(
        truth,
        BOARD,
        exact_plan,
        np.random.default_rng(0),
        0.0,
        caliper_height_mm=-truth.r_wb_w[2],
        angle_sigma_arcsec=0.0,
    )
    zh = _exact_zhang(truth, obs, exact_plan)[2]
    poses = []
    for i, im in enumerate(obs.of_camera(2)):
        if im.kind == "turntable":
            c, r = zh.camera_in_world(i)
            poses.append((np.deg2rad(im.omega_big_deg), np.deg2rad(im.omega_small_deg), c, r))
    t1, z1, n1 = solve_a10(poses, iterations=1)
    t9, z9, n9 = solve_a10(poses, iterations=10)
    err1 = np.rad2deg(np.max(np.abs(z1 - truth.cams[2].C_k_b)))
    assert n1 == 1 and 1e-4 < err1 < 0.05
    assert n9 > 1 and np.max(np.abs(z9 - truth.cams[2].C_k_b)) < 1e-10


def test_pipeline_on_noise_free_corners_recovers_truth(truth, exact_plan):
    """Zhang + CPC + refinement from noise-free corners: both solutions are the truth."""
    obs = corner_observations(
        truth,
        BOARD,
        exact_plan,
        np.random.default_rng(0),
        0.0,
        caliper_height_mm=-truth.r_wb_w[2],
        angle_sigma_arcsec=0.0,
    )
    obs.angle_sigma_rad = 1e-9  # exact angles: keep the prior from dominating the tiny residuals
    cal = calibrate(obs)
    names, q_true = quantities(truth, truth)
    _, q_pap = paper_quantities(cal, truth)
    _, q_ref = quantities(cal.refined.rig, truth)
    tol = np.array([1e-3 if n.split(".")[1] in ("fx", "fy", "cx", "cy") else 1e-4 for n in names])
    assert np.all(np.abs(q_pap - q_true) < 10 * tol), [
        n for n, a, b in zip(names, q_pap, q_true, strict=True) if abs(a - b) >= 1e-2
    ]
    assert np.all(np.abs(q_ref - q_true) < tol)
