"""`mfns mc`: the Section 3 Monte Carlo against its first-order prediction; the pose solver."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mfns.analysis import mc
from mfns.cli import main
from mfns.model import pose_ref
from mfns.model.rotations import euler213_to_matrix, rot_exp
from mfns.simulate import nav


def test_euler_batch_matches_rotations():
    rng = np.random.default_rng(0)
    a = rng.uniform(-3, 3, (20, 3))
    c = mc.euler213_batch(a)
    for ai, ci in zip(a, c, strict=True):
        assert np.allclose(ci, euler213_to_matrix(*ai), atol=1e-14)


def test_beacons_are_in_the_table1_box_deep_enough_and_visible():
    rng = np.random.default_rng(1)
    b = mc.sample_beacons(rng, 5000, 100.0)
    assert b.shape == (5000, 3)
    assert np.all((b[:, 0] >= 0) & (b[:, 0] <= 1000) & (b[:, 2] >= 100) & (b[:, 2] <= 1000))
    assert np.all(np.abs(b[:, 1]) <= 500)
    uv, front = mc.table1_camera().project_camera_points(b)
    assert front.all() and mc.table1_camera().in_image(uv).all()
    # depth density ~ Z^2 on [100, 1000]: mean = 3/4 (z1^4 - z0^4) / (z1^3 - z0^3)
    assert abs(b[:, 2].mean() - 0.75 * (1e12 - 1e8) / (1e9 - 1e6)) < 8.0


def test_zero_error_gives_zero_pixel_error():
    rng = np.random.default_rng(2)
    b = mc.sample_beacons(rng, 100, 100.0)
    for g in mc.GROUPS:
        assert np.max(np.abs(mc.pixel_errors(g.key, 0.0, b, rng))) < 1e-9


def test_closed_form_matches_the_jacobian_averaged_over_beacons():
    """The analytic slope's moments vs the numerical Jacobian of the full model, averaged."""
    rng = np.random.default_rng(3)
    b = mc.sample_beacons(rng, 100000, 100.0)
    cam = mc.table1_camera()
    h = 1e-4
    # beacon / camera position: du/dP
    grad2 = 0.0
    for j in range(3):
        d = np.zeros(3)
        d[j] = h
        du = (cam.project_camera_points(b + d)[0][:, 0] - cam.project_camera_points(b - d)[0][:, 0]) / (2 * h)
        grad2 = grad2 + du**2
    assert abs(np.sqrt(grad2.mean()) / mc.analytic_slope("position", 100.0) - 1) < 0.01
    # attitude: du/d(euler) in rad, converted to px/deg
    grad2 = 0.0
    for j in range(3):
        d = np.zeros((len(b), 3))
        d[:, j] = h
        up = cam.project_camera_points(np.einsum("nji,nj->ni", mc.euler213_batch(d), b))[0][:, 0]
        um = cam.project_camera_points(np.einsum("nji,nj->ni", mc.euler213_batch(-d), b))[0][:, 0]
        grad2 = grad2 + ((up - um) / (2 * h)) ** 2
    assert abs(np.sqrt(grad2.mean()) * np.pi / 180 / mc.analytic_slope("attitude", 100.0) - 1) < 0.01


@pytest.mark.parametrize("group", mc.GROUPS, ids=lambda g: g.key)
def test_monte_carlo_slopes_within_10_percent_of_first_order(group):
    rng = np.random.default_rng(4)
    rows = mc.mc_curve(group, 4000, 100.0, rng)
    s_mc = mc.slope_through_origin([r["level"] for r in rows[1:]], [r["rms_u_px"] for r in rows[1:]])
    s_an = mc.analytic_slope(group.key, 100.0)
    assert abs(s_mc / s_an - 1) < 0.10
    # and each point, not only the fit: linear growth
    for r in rows[1:]:
        assert abs(r["rms_u_px"] / (s_an * r["level"]) - 1) < 0.2


def test_the_paper_thresholds_give_a_few_pixels():
    """Section 3: < 1 mm and < 0.17 deg keep the observation error at several pixels."""
    rng = np.random.default_rng(5)
    pos = mc.rms_at("position", mc.PAPER_POSITION_MM, 10000, 100.0, rng)
    att = mc.rms_at("attitude", mc.PAPER_ATTITUDE_DEG, 10000, 100.0, rng)
    assert 1.5 < pos < 4.0
    assert 4.0 < att < 6.5
    both = mc.combined_rms(mc.PAPER_POSITION_MM, mc.PAPER_ATTITUDE_DEG, 10000, 100.0, rng)
    assert abs(both - np.hypot(pos, att)) < 0.4


# --------------------------------------------------------------------------- pose solver
def observations(scn, i):
    c, r = scn.pose(i)
    idx, pts, uv = [], [], []
    for k, cam in enumerate(scn.cams):
        uvk, vis, _ = nav.project_beacons(cam, c, r, scn.beacons)
        idx += [k] * int(vis.sum())
        pts.append(scn.beacons[vis])
        uv.append(uvk[vis])
    return c, r, np.array(idx), np.vstack(pts), np.vstack(uv)


def test_reference_solver_jacobian_and_exact_recovery():
    scn = nav.module_scenario(30, 1.0, 60, seed=2)
    good = np.nonzero(nav.visibility_counts(scn).sum(axis=1) >= 4)[0]
    assert len(good) >= 20
    for i in good[::8]:
        c, r, idx, pts, uv = observations(scn, i)
        c0, r0 = rot_exp([0.04, -0.03, 0.05]) @ c, r + [40.0, -25.0, 30.0]
        res, jac = pose_ref.residuals_and_jacobian(scn.cams, idx, pts, uv, c0, r0)
        num = np.zeros_like(jac)
        h = 1e-6
        for j in range(6):
            d = np.zeros(6)
            d[j] = h
            rp = pose_ref.residuals_and_jacobian(scn.cams, idx, pts, uv, rot_exp(-d[:3]) @ c0, r0 + d[3:])[0]
            rm = pose_ref.residuals_and_jacobian(scn.cams, idx, pts, uv, rot_exp(d[:3]) @ c0, r0 - d[3:])[0]
            num[:, j] = (rp - rm) / (2 * h)
        assert np.max(np.abs(jac - num)) < 1e-5 * np.max(np.abs(jac))
        sol = pose_ref.solve_pose_gn(scn.cams, idx, pts, uv, c0, r0)
        assert sol.converged and sol.rms_px < 1e-8
        assert np.max(np.abs(sol.C_w_b - c)) < 1e-10 and np.max(np.abs(sol.r_bw_b - r)) < 1e-7


def test_reference_solver_refuses_too_few_observations():
    scn = nav.module_scenario(2, 1.0, 60, seed=2)
    c, r, idx, pts, uv = observations(scn, 0)
    sol = pose_ref.solve_pose_gn(scn.cams, idx[:2], pts[:2], uv[:2], c, r)
    assert not sol.converged


def test_pose_extension_uses_the_plugged_solver_and_grows_with_the_error():
    pool = mc.module_pose_pool(0, n_poses=60)
    calls = []

    def solver(*args):
        calls.append(len(args[1]))
        return pose_ref.solve_pose_gn(*args)

    rng = np.random.default_rng(6)
    zero = mc.pose_errors(solver, "attitude", 0.0, 10, rng, pool)
    assert len(calls) == 10 and min(calls) >= 4
    assert zero["solved"] == 10 and zero["pos_rms_mm"] < 1e-6 and zero["att_rms_deg"] < 1e-8
    small = mc.pose_errors(solver, "position", 0.5, 40, rng, pool)
    large = mc.pose_errors(solver, "position", 2.0, 40, rng, pool)
    assert 0.1 < small["pos_median_norm_mm"] < large["pos_median_norm_mm"]


# --------------------------------------------------------------------------- CLI
def test_cli_mc_smoke(tmp_path, capsys):
    out = tmp_path / "mc"
    assert main(["mc", str(out), "--trials", "500", "--pose-trials", "4", "--solver", "reference"]) == 0
    text = capsys.readouterr().out
    assert "first order" in text and "end-to-end" in text
    for g in mc.GROUPS:
        lines = (out / f"{g.fig}_{g.key}.csv").read_text().splitlines()
        assert lines[0] == f"error_{g.unit},rms_u_px,mean_abs_u_px,p95_abs_u_px,analytic_rms_u_px,trials"
        assert len(lines) == 1 + len(g.levels)
        assert (out / f"{g.fig}_{g.key}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    s = json.loads((out / "summary.json").read_text())
    assert set(s["groups"]) == {"beacon", "position", "attitude"}
    assert s["trials_per_point"] == 500 and "host reference" in s["pose_extension"]["solver"]
    assert s["pose_extension"]["solver_key"] == "reference"
    pose = (out / "pose_vs_calib.csv").read_text().splitlines()
    assert pose[0].startswith("group,level,unit,trials,solved,pos_rms_mm,att_rms_deg")
    assert len(pose) == 1 + sum(len(levels) for _, _, levels in mc.POSE_GROUPS)
    assert pose[0].endswith(",solver") and all(line.endswith(",reference") for line in pose[1:])
    assert (out / "pose_vs_calib.png").exists()


def test_cli_mc_errors(tmp_path, capsys):
    assert main(["mc", str(tmp_path / "a"), "--trials", "5", "--quiet"]) == 2
    assert main(["mc", str(tmp_path / "b"), "--z-min", "0", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(e.startswith("mfns mc: error:") for e in err)
    with pytest.raises(SystemExit) as exc:
        main(["mc", "--help"])
    assert exc.value.code == 0
