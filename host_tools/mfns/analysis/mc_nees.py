"""Does the flight pose covariance mean what it says? NEES of the C solver on the module scenario.

The normalized estimation error squared e^T P^-1 e of each fix (e: the ROS-order pose error,
r_wb_w mm then phi_w rad, C_b_w(est) = exp(phi_w) C_b_w(true); P: the solution's cov_ros) has
mean 6 when P is right. Poses along the module trajectory of `mfns sim nav` (60 wall beacons,
the paper's rig, >= 4 beacons in view, mc.module_pose_pool), known correspondences, the C
refinement (firmware/nav/pose/pose.h mfns_pose_refine through mfns.core.flight) from the true pose, the
flight defaults otherwise. Three error sources, each alone:

  pixel        centroid noise sigma_px on every blob, known to the solver (cov_px2 = s^2 I)
  survey       + every beacon displaced by N(0, sigma_b^2 I) per trial (the map keeps the
               nominal positions and says sigma_b)
  calibration  + the rig the images come from drawn from a calibration covariance Sigma_c
               (truth = estimate - error, nav_settings.h conventions); the solver has the
               nominal rig and Sigma_c (its calibration term)

and for each the same solve with the matching term switched off (survey: sigma_mm 0 in the map;
calibration: no calibration covariance), which shows the term is what makes NEES 6.

Rerun: `mfns nees [--trials N] [--seed S]` (after `make lib`).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import MfnsError
from ..model.camera import Camera, position_from_pose
from ..model.rotations import rot_exp, rot_log

# A calibration covariance of the size the paper's method leaves (px, unitless, rad, mm per
# parameter of format.CALIB_PARAM_NAMES), correlated across parameters and cameras.
CALIB_SD = (0.5, 0.5, 0.5, 0.5, 3e-4, 3e-4, 3e-5, 3e-5, 3e-4, 1.5e-4, 1.5e-4, 1.5e-4, 0.2, 0.2, 0.2)


def example_calib_cov(rng: np.random.Generator) -> np.ndarray:
    sd = np.tile(CALIB_SD, 3)
    b = rng.uniform(-0.6, 0.6, (len(sd), 3)) * sd[:, None]
    return b @ b.T + np.diag(0.6 * sd**2)


def perturbed_rig(cams: list[Camera], err: np.ndarray) -> list[Camera]:
    """The true rig for a calibration error err (45,): truth = estimate - error."""
    from .mc import _copy_cam

    out = []
    for k, c in enumerate(cams):
        e = err[15 * k : 15 * (k + 1)]
        t = _copy_cam(c)
        t.fx, t.fy, t.cx, t.cy = c.fx - e[0], c.fy - e[1], c.cx - e[2], c.cy - e[3]
        t.dist = c.dist - e[4:9]
        t.C_k_b = rot_exp(-e[9:12]) @ c.C_k_b  # C_k_b(est) = exp([theta]) C_k_b(true)
        t.r_bk_b = c.r_bk_b - e[12:15]
        out.append(t)
    return out


def run(trials: int = 2000, seed: int = 0, sigma_px: float = 0.1, sigma_b_mm: float = 0.4, lib=None) -> dict:
    """{case: (mean NEES, fraction inside the chi-square(6) 95 % bound, fixes)}."""
    from ..core import flight as fl
    from ..simulate import nav
    from .mc import module_pose_pool

    f = fl.Flight(lib)
    rng = np.random.default_rng(seed)
    scn, keep = module_pose_pool(seed)
    cams = scn.cams
    rig = f.rig(cams)
    sigma_c = example_calib_cov(rng)
    floor = 0.01  # the table's unmodelled floor (px): the grid's worst case
    cfg = f.config(sigma_px=floor)
    cfg_c = f.config(sigma_px=floor, calib_cov=sigma_c)
    lc = np.linalg.cholesky(sigma_c)
    chi2_95 = 12.5916  # chi-square, 6 degrees of freedom
    cases: dict[str, list[float]] = {
        k: []
        for k in (
            "pixel",
            "survey",
            "survey, no survey term",
            "calibration",
            "calibration, no calibration term",
        )
    }
    map_sig = f.beacon_map(scn.beacons, sigma_b_mm)
    map_zero = f.beacon_map(scn.beacons, 0.0)
    for _ in range(trials):
        i = int(keep[rng.integers(len(keep))])
        c_true, r_true = scn.pose(i)
        truth = f.pose(c_true, r_true)
        disp = scn.beacons + rng.normal(0.0, sigma_b_mm, scn.beacons.shape)
        true_cams = perturbed_rig(cams, lc @ rng.normal(size=lc.shape[0]))
        for kind, world, eye in (
            ("pixel", scn.beacons, cams),
            ("survey", disp, cams),
            ("calibration", scn.beacons, true_cams),
        ):
            obs, ids = [], []
            for k in range(3):
                uv, vis, _ = nav.project_beacons(eye[k], c_true, r_true, world)
                uv = uv[vis] + rng.normal(0.0, sigma_px, (int(vis.sum()), 2))
                xy = cams[k].undistort_pixels(uv) if len(uv) else np.zeros((0, 2))
                cov = np.tile([sigma_px**2, 0.0, sigma_px**2], (len(uv), 1))
                obs.append(np.hstack([uv, xy, cov]))
                ids.append(np.nonzero(vis)[0])
            frame, assoc = f.frame(obs), f.assoc(ids)
            runs = {
                "pixel": [("pixel", map_zero, cfg)],
                "survey": [("survey", map_sig, cfg), ("survey, no survey term", map_zero, cfg)],
                "calibration": [
                    ("calibration", map_zero, cfg_c),
                    ("calibration, no calibration term", map_zero, cfg),
                ],
            }[kind]
            for name, bmap, c in runs:
                sol = f.refine(rig, bmap, frame, assoc, truth, c)
                if not sol.ok:
                    continue
                e = np.concatenate(
                    [
                        sol.r_wb_w - position_from_pose(c_true, r_true),
                        rot_log(sol.C_w_b.T @ c_true),  # C_b_w(est) C_b_w(true)^T
                    ]
                )
                cases[name].append(float(e @ np.linalg.solve(sol.cov_ros, e)))
    return {
        k: (float(np.mean(v)), float(np.mean(np.array(v) <= chi2_95)), len(v))
        if v
        else (math.nan, math.nan, 0)
        for k, v in cases.items()
    }


MAX_TRIALS = 1_000_000  # a bound on the run, as mfns mc's


def report(args) -> int:
    """`mfns nees` (commands/nees.py): run() printed as the table of docs/error-analysis.md."""
    if not 1 <= args.trials <= MAX_TRIALS:
        raise MfnsError(f"--trials must be in 1..{MAX_TRIALS}")
    res = run(args.trials, args.seed)
    print(
        f"module scenario, {args.trials} poses, pixel 0.1 px, survey 0.4 mm, "
        "calibration Sigma_c (mc_nees.CALIB_SD)"
    )
    print(f"{'case':36s} {'mean NEES':>10s} {'in 95 %':>8s} {'fixes':>6s}   (6 and 95 % when right)")
    for k, (m, frac, n) in res.items():
        print(f"{k:36s} {m:10.2f} {100 * frac:7.1f}% {n:6d}")
    return 0
