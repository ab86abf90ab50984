"""mfns map refine (host_tools/mfns/map/refine.py, docs/self_survey.md) against truth, on
synthetic fixes made with the one numpy lens model: the module's walls and trajectory, the
survey error rendered, centroid noise, the fixes' poses as the flight gives them (truth plus
their own error). The refinement must beat the survey, keep its covariance honest, flag a
beacon moved 5 mm (and only it) and a camera mount turned 0.1 deg (and only it)."""

from __future__ import annotations

import numpy as np
import pytest

from mfns.analysis import calib_results
from mfns.map import refine
from mfns.map.fixlog import Fix
from mfns.model.camera import pose_from_position, rig_from_doc
from mfns.model.rotations import euler213_deg_to_matrix, rot_exp, skew
from mfns.simulate.nav import PAPER_CALIB, module_beacons, module_trajectory, project_beacons

PIXEL_SIGMA = 0.02  # px, the order of the module's centroids
SURVEY_SIGMA = 0.4  # mm, beacons.csv


def scene(seed=2, n_fix=200, moved=None, cam_rot_deg=None, noise_scale=1.0):
    """(fixes, cams, ids, survey map, sigma, true map). moved: (beacon index, mm vector);
    cam_rot_deg: (camera, rotation vector deg) applied to the true rig only; noise_scale:
    the centroid noise drawn, in units of the PIXEL_SIGMA the fixes state."""
    rng = np.random.default_rng([seed, 1])
    p_survey, _ = module_beacons(60, rng)
    t = np.arange(n_fix) * 1.5  # one fix every 1.5 s: 5 minutes
    r_wb, att = module_trajectory(t, rng)
    noise = np.random.default_rng([seed, 9])
    p_true = p_survey + noise.normal(0.0, SURVEY_SIGMA, p_survey.shape)
    if moved is not None:
        p_true[moved[0]] += moved[1]
    cams = rig_from_doc(calib_results.load(PAPER_CALIB))
    true_cams = rig_from_doc(calib_results.load(PAPER_CALIB))
    if cam_rot_deg is not None:
        k, w = cam_rot_deg
        true_cams[k].C_k_b = rot_exp(np.deg2rad(w)) @ true_cams[k].C_k_b
    fixes = []
    for i in range(n_fix):
        C = euler213_deg_to_matrix(att[i])
        r_bw = pose_from_position(C, r_wb[i])
        cam_i, bid, uv = [], [], []
        for k, c in enumerate(true_cams):
            u, vis, _ = project_beacons(c, C, r_bw, p_true)
            for b in np.nonzero(vis)[0]:
                cam_i.append(k)
                bid.append(b)
                uv.append(u[b] + noise.normal(0.0, noise_scale * PIXEL_SIGMA, 2))
        if len(bid) < 5:
            continue
        # the flight's fix: truth off by about its own sigma (0.3 mm, 0.01 deg)
        C_fix = C @ rot_exp(noise.normal(0.0, np.deg2rad(0.01), 3))
        fixes.append(
            Fix(
                cycle=i,
                t_s=float(t[i]),
                status="FIX",
                C_w_b=C_fix,
                r_wb_w=r_wb[i] + noise.normal(0.0, 0.3, 3),
                cov=np.eye(6),
                camera=np.array(cam_i),
                beacon_id=np.array(bid),
                uv=np.array(uv),
                cov_uv=np.tile(PIXEL_SIGMA**2 * np.eye(2), (len(bid), 1, 1)),
            )
        )
    return fixes, cams, np.arange(60), p_survey, np.full(60, SURVEY_SIGMA), p_true


def run(fixes, cams, ids, p, s, mounts=False):
    pb = refine.build_problem(fixes, cams, ids, p, s, mounts=mounts, pixel_floor_px=0.005)
    return refine.refine(pb)


def test_refinement_beats_the_survey_and_its_sigma_is_honest():
    fixes, cams, ids, p, s, truth = scene()
    assert len(fixes) > 150
    res = run(fixes, cams, ids, p, s)
    before = np.sqrt(np.mean((p - truth) ** 2))
    after = np.sqrt(np.mean((res.p - truth) ** 2))
    assert before > 0.3
    assert after < 0.15 < before / 2, (before, after)
    assert 0.7 < res.sigma0 < 1.3  # the noise model holds
    # the written sigma covers the error (it carries the datum's common part: conservative)
    z = np.abs(res.p - truth) / res.sigma[:, None]
    assert np.mean(z**2) < 1.5
    assert not res.moved.any()  # nothing flagged on a map within its survey


def test_gross_outliers_do_not_inflate_the_map_sigma():
    """A few associations thousands of sigma off (a blob re-associated with a far beacon)
    sit in the Huber loss's linear tail: they must not set the unit weight, which scales
    every beacon's covariance (measured on a 24-minute module flight: 13 of 7,734
    residuals made it 1.81 and the refined map flew NEES 1.83)."""
    fixes, cams, ids, p, s, truth = scene()
    clean = run(fixes, cams, ids, p, s)
    rng = np.random.default_rng(5)
    for f in rng.choice(len(fixes), 12, replace=False):
        fixes[f].uv[0] = fixes[f].uv[0] + rng.uniform(20.0, 60.0, 2)  # 1,000-3,000 sigma
    dirty = run(fixes, cams, ids, p, s)
    assert 0.7 < dirty.sigma0 < 1.3, dirty.sigma0
    assert abs(np.median(dirty.sigma) / np.median(clean.sigma) - 1.0) < 0.1
    assert np.sqrt(np.mean((dirty.p - truth) ** 2)) < 0.15


def test_a_wrong_noise_model_sets_the_unit_weight():
    """Centroids 3 times noisier than the fixes state: the unit weight must say so (about
    3, not the 1.6 a clip fixed at 3 model sigma gives) and the written sigma must grow
    with it, gross outliers still left out."""
    fixes, cams, ids, p, s, truth = scene()
    clean = run(fixes, cams, ids, p, s)
    fixes, cams, ids, p, s, truth = scene(noise_scale=3.0)
    rng = np.random.default_rng(5)
    for f in rng.choice(len(fixes), 12, replace=False):
        fixes[f].uv[0] = fixes[f].uv[0] + rng.uniform(20.0, 60.0, 2)
    noisy = run(fixes, cams, ids, p, s)
    assert 2.6 < noisy.sigma0 < 3.4, noisy.sigma0
    assert np.median(noisy.sigma) > 2.0 * np.median(clean.sigma)
    z = np.abs(noisy.p - truth) / noisy.sigma[:, None]
    assert np.mean(z**2) < 1.5  # honest again


def test_unit_weight_is_the_clipped_fixed_point():
    """unit_weight on drawn residuals: the scale of the bulk, whatever it is, with a
    few percent of gross outliers left out; 0 for no residual spread."""
    rng = np.random.default_rng(3)
    for k in (0.5, 1.0, 3.0):
        r = rng.normal(0.0, k, 20000)
        r[:300] = rng.uniform(1e3, 3e3, 300) * rng.choice([-1, 1], 300)
        assert abs(refine.unit_weight(r, 0) / k - 1.0) < 0.03, k
    assert refine.unit_weight(np.zeros(10), 0) == 0.0


def test_moved_beacon_is_flagged_alone():
    fixes, cams, ids, p, s, truth = scene(moved=(17, np.array([0.0, 3.0, 4.0])))  # 5 mm
    res = run(fixes, cams, ids, p, s)
    assert list(ids[res.moved]) == [17], res.chi2_moved[res.moved]
    assert res.chi2_moved[17] > 4 * refine.CHI2_3
    assert np.linalg.norm(res.p[17] - truth[17]) < 0.5  # the refined place follows the LED


@pytest.mark.parametrize("cam", [1])
def test_turned_camera_mount_is_flagged_alone(cam):
    fixes, cams, ids, p, s, truth = scene(cam_rot_deg=(cam, [0.1, 0.0, 0.0]))
    res = run(fixes, cams, ids, p, s, mounts=True)
    assert list(np.nonzero(res.mount_moved)[0]) == [cam], res.mount_chi2
    assert abs(res.mount_rot_deg[cam, 0] - 0.1) < 0.02
    assert not res.moved.any()  # the mount, not the beacons, took the shift


def test_refuses_a_log_of_another_map():
    fixes, cams, ids, p, s, _ = scene(n_fix=20)
    from mfns.core.errors import MfnsError

    with pytest.raises(MfnsError, match="not in the survey"):
        refine.build_problem(fixes, cams, ids[:30], p[:30], s[:30])
    with pytest.raises(MfnsError, match="no fixes"):
        refine.build_problem([], cams, ids, p, s)


@pytest.mark.parametrize("seed", [2, 3])
def test_per_beacon_target_in_the_survey_datum(seed):
    """Issue 29's target (per-beacon position error RMS <= 0.1 mm), read per beacon in 3-D,
    the stricter reading: met in the survey's datum (the truth moved rigidly onto the survey,
    the frame the refinement keeps) for every beacon the fixes saw in >= MIN_SEEN_FIXES; against
    the true positions what is left beyond that is the survey's own datum error (a rotation and
    shift common to all beacons, 3-D RMS ~ 0.4 sqrt(6/60) = 0.13 mm expected), which no
    self-survey can see; a beacon never seen keeps its survey place and sigma."""
    from mfns.map.refine_demo import MIN_SEEN_FIXES, rigid_to

    fixes, cams, ids, p, s, truth = scene(seed=seed)
    res = run(fixes, cams, ids, p, s)
    seen = np.zeros(len(ids), int)
    for f in fixes:
        np.add.at(seen, f.beacon_id, 1)
    ok = seen >= MIN_SEEN_FIXES
    assert ok.sum() >= 50

    def rms3(d):
        return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))

    in_datum = rigid_to(truth, p)
    assert rms3((res.p - in_datum)[ok]) < 0.1
    datum = rms3(in_datum - truth)
    assert rms3((res.p - truth)[ok]) < np.hypot(datum, 0.1)
    unseen = seen == 0
    if unseen.any():
        np.testing.assert_allclose(res.p[unseen], p[unseen], atol=0.05)
        assert np.all(res.sigma[unseen] >= SURVEY_SIGMA)


def test_rigid_to_removes_a_rigid_motion_only():
    rng = np.random.default_rng(4)
    a = rng.uniform(-1000.0, 1000.0, (30, 3))
    r = rot_exp(np.deg2rad([0.3, -0.2, 0.5]))
    b = a @ r.T + [1.0, -2.0, 0.5]
    from mfns.map.refine_demo import rigid_to

    np.testing.assert_allclose(rigid_to(a, b), b, atol=1e-9)
    c = b * 1.001  # a scale is not removed
    assert np.abs(rigid_to(a, c) - c).max() > 0.1


def test_a_fresh_path_without_a_fix_is_a_result_not_a_crash(tmp_path):
    """A fresh path on which no fix is usable (seed 15's surveyed map, 3 December 2026) made
    `mfns report` exit with "nothing to report" and ended the whole multi-seed bench; it is
    now a row of 0 fixes, and any other failure still ends the run."""
    import sys

    from mfns.map import refine_demo

    log = tmp_path / "report.log"
    say = "import sys; print('mfns report: error: nothing to report: no solutions'); sys.exit(2)"
    assert refine_demo._run([sys.executable, "-c", say], log, allow="nothing to report") is False
    with pytest.raises(SystemExit, match="failed"):
        refine_demo._run([sys.executable, "-c", "import sys; sys.exit(2)"], log, allow="nothing to report")
    with pytest.raises(SystemExit, match="failed"):
        refine_demo._run([sys.executable, "-c", say], log)  # not allowed: a failure
    assert refine_demo._run([sys.executable, "-c", "pass"], log) is True
    row = refine_demo._row("surveyed", refine_demo._no_fix_summary())
    assert row.startswith("| surveyed | 0 | nan |") and row.endswith("| nan |")
    # one usable fix: `mfns report` writes its 1-sigma as null (seed 28's surveyed map,
    # 3 December 2026, ended the bench with a TypeError deep in numpy)
    one = {
        "n_used": 1,
        "axes": [{"axis": a, "mean": 0.25, "sigma": None} for a in ("x", "y", "z", "roll", "pitch", "yaw")],
        "nees": {"mean": 3.5},
    }
    assert refine_demo._row("surveyed", one) == "| surveyed | 1 | nan | nan | nan | nan | nan | nan | 3.50 |"


def test_datum_split_separates_a_rigid_motion_from_the_rest():
    """datum_split: a covariance that is a rigid motion of the map alone comes back as that
    datum covariance with no relative part; independent errors give the datum s^2 (A^T A)^-1
    (a shift s^2 / N per axis) and a relative sigma just below s; the two parts add back."""
    rng = np.random.default_rng(3)
    p = rng.uniform(-2000.0, 2000.0, (40, 3))
    n = len(p)
    c = p.mean(axis=0)
    A = np.zeros((3 * n, 6))
    for i in range(n):
        A[3 * i : 3 * i + 3, :3] = np.eye(3)
        A[3 * i : 3 * i + 3, 3:] = -skew(p[i] - c)
    L = rng.normal(size=(6, 6))
    M = L @ L.T + 6.0 * np.eye(6)
    R = M / np.sqrt(np.outer(np.diag(M), np.diag(M)))  # a correlation matrix
    d = np.sqrt([0.01, 0.02, 0.03, 1e-8, 2e-8, 3e-8])  # mm^2 shift, rad^2 turn
    S = R * np.outer(d, d)
    cov_d, sig_rel, cen = refine.datum_split(p, A @ S @ A.T)
    np.testing.assert_allclose(cov_d, S, rtol=1e-6, atol=1e-15)
    assert sig_rel.max() < 1e-6
    np.testing.assert_allclose(cen, c)
    s = 0.4
    cov_d, sig_rel, _ = refine.datum_split(p, s * s * np.eye(3 * n))
    np.testing.assert_allclose(cov_d, s * s * np.linalg.inv(A.T @ A), rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(np.sqrt(np.diag(cov_d)[:3]), s / np.sqrt(n), rtol=1e-9)
    assert np.all((sig_rel < s) & (sig_rel > 0.9 * s))


def test_relative_sigma_and_datum_explain_the_refined_error():
    """What `mfns map refine` hands the table (map_datum.json): the refined map's error
    against truth is a rigid motion the datum covariance explains, plus per-beacon errors the
    relative sigma explains; the relative sigma is a fraction of the written (marginal) one,
    which carries the datum's common part into every beacon."""
    from scipy.stats import chi2

    fixes, cams, ids, p, s, truth = scene()
    res = run(fixes, cams, ids, p, s)
    e = res.p - truth
    n = len(ids)
    A = refine.rigid_jacobian(res.p, res.datum_centre)
    d, *_ = np.linalg.lstsq(A, e.ravel(), rcond=None)  # the error's rigid part
    assert float(d @ np.linalg.solve(res.datum_cov, d)) < chi2.isf(1e-3, 6)
    rest = (e.ravel() - A @ d).reshape(n, 3)
    z2 = np.mean((rest / res.sigma_relative[:, None]) ** 2)
    assert 0.2 < z2 < 1.5, z2
    assert np.median(res.sigma_relative) < 0.6 * np.median(res.sigma)
    assert res.info["sigma_relative_scale"] >= 1.0
