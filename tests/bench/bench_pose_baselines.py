"""Our flight pose solver (C, through ctypes) against PoseLib and pycolmap on the same
observations (make bench-pose). Paper rig (docs/system.md §7), synthetic beacons, 4 to 10 in
view over the three cameras, Gaussian pixel noise.

Columns: time per call (us, measured in Python around the call, so every solver pays
its binding overhead) and the RMS position / attitude error against the truth.
- ours refine    mfns_pose_refine, warm start (previous pose 0.2 deg / 1 mm off)
- paper mode     the paper's Newton on Eq. 3 (same warm start)
- poselib refine refine_generalized_absolute_pose (same warm start, correspondences)
- poselib est.   estimate_generalized_absolute_pose (RANSAC + refine, correspondences given)
- colmap est.    pycolmap.estimate_and_refine_generalized_absolute_pose (same)
- ours cold      mfns_acquire: no correspondences, no initial pose (identify too)
The C-native times (no Python) are printed by bench_pose.
"""

from __future__ import annotations

import ctypes as ct
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))

import poselib  # noqa: E402
import pycolmap  # noqa: E402

from mfns.core.flight import MODE_PAPER, Flight, SolutionC  # noqa: E402
from mfns.model import pose_sim  # noqa: E402
from mfns.model.rotations import random_rotations  # noqa: E402

SIGMA = 0.3
FRAMES = 100


def make_scene(rng, cams, n):
    """A random body pose and n beacons in view (spread over the cameras) plus out-of-view
    ones up to 10: (C_w_b, r_bw_b, beacons (10, 3))."""
    C = random_rotations(rng, 1)[0]
    pos = rng.uniform(-200, 200, 3)
    r = -C @ pos
    per = [(n + 2) // 3, (n + 1) // 3, n // 3]
    pts_b = []
    for cam, k in zip(cams, per, strict=True):
        uv = np.column_stack([rng.uniform(40, cam.width - 40, k), rng.uniform(40, cam.height - 40, k)])
        xy = cam.undistort_pixels(uv)
        z = rng.uniform(500, 1500, k)
        p_c = np.column_stack([xy * z[:, None], z])
        pts_b.append(p_c @ cam.C_k_b.T + cam.r_bk_b)
    for i in range(10 - n):  # behind all three cameras
        pts_b.append(np.array([[-600.0 - 50 * i, -500.0 - 30 * i, -700.0 + 20 * i]]))
    p_b = np.vstack(pts_b)
    return C, r, (p_b - r) @ C  # p_w = C^T (p_b - r)


def rot_err_deg(a, b):
    """Angle of a^T b, from its skew part and trace (arccos of the trace alone loses
    ~0.02 deg on a float rotation matrix)."""
    d = a.T @ b
    s = 0.5 * np.linalg.norm([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]])
    return np.degrees(np.arctan2(s, 0.5 * (np.trace(d) - 1)))


def small_rotation(rng, deg):
    w = rng.normal(size=3)
    w *= np.radians(deg) / np.linalg.norm(w)
    k = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    th = np.linalg.norm(w)
    return np.eye(3) + np.sin(th) / th * k + (1 - np.cos(th)) / th**2 * k @ k


def timed(fn, reps=5):
    t0 = time.perf_counter()
    for _ in range(reps):
        out = fn()
    return out, (time.perf_counter() - t0) / reps * 1e6


def main() -> int:
    rng = np.random.default_rng(5)
    fl = Flight()
    cams = pose_sim.paper_rig()
    rig = fl.rig(cams)
    pl_cams = [
        {
            "model": "OPENCV",
            "width": c.width,
            "height": c.height,
            "params": [c.fx, c.fy, c.cx, c.cy, *c.dist[:4]],
        }
        for c in cams
    ]
    pl_ext = []
    for c in cams:
        e = poselib.CameraPose()
        e.R = c.C_k_b.T
        e.t = -c.C_k_b.T @ c.r_bk_b
        pl_ext.append(e)
    col_cams = [
        pycolmap.Camera(model="OPENCV", width=c.width, height=c.height, params=list(d["params"]))
        for c, d in zip(cams, pl_cams, strict=True)
    ]
    col_ext = [pycolmap.Rigid3d(np.hstack([c.C_k_b.T, (-c.C_k_b.T @ c.r_bk_b)[:, None]])) for c in cams]
    names = ["ours refine", "paper mode", "poselib refine", "poselib est.", "colmap est.", "ours cold"]
    print(
        f"bench_pose_baselines: paper rig, sigma {SIGMA} px, {FRAMES} frames per row; time us / RMS pos mm / RMS att deg"
    )
    print(f"{'n':>3} " + " ".join(f"{h:>24}" for h in names))
    ratio_rows = []
    for n in range(4, 11):
        t = {k: [] for k in names}
        e_pos = {k: [] for k in names}
        e_att = {k: [] for k in names}
        for _ in range(FRAMES):
            C, r, beacons = make_scene(rng, cams, n)
            bmap = fl.beacon_map(beacons)
            obs, ids = pose_sim.make_frame(cams, beacons, C, r, SIGMA, rng)
            assert sum(len(i) for i in ids) == n
            frame, assoc = fl.frame(obs), fl.assoc(ids)
            C0 = small_rotation(rng, 0.2) @ C
            r0 = r + rng.uniform(-1, 1, 3)
            init = fl.pose(C0, r0)
            cfg = fl.config(sigma_px=SIGMA)
            cfg_p = fl.config(sigma_px=SIGMA, mode=MODE_PAPER)
            pos_true = -C.T @ r
            # the scene's map index over a workspace around the pose (built offline in flight)
            idx = fl.build_index(rig, bmap, pos_true - 300.0, pos_true + 300.0)
            results = {}
            # time the bare ctypes call (prebuilt structs), as the pybind11 calls below
            raw = SolutionC()
            args = [ct.byref(x) for x in (rig, bmap, frame, assoc, init, cfg, raw)]
            _, dt = timed(lambda: fl.lib.mfns_pose_refine(*args))
            sol = fl._solution(raw)
            results["ours refine"] = (sol.C_w_b, sol.r_wb_w, dt)
            args_p = [ct.byref(x) for x in (rig, bmap, frame, assoc, init, cfg_p, raw)]
            _, dt = timed(lambda: fl.lib.mfns_pose_refine(*args_p))
            sol = fl._solution(raw)
            results["paper mode"] = (sol.C_w_b, sol.r_wb_w, dt)
            used = [k for k in range(3) if len(ids[k])]
            p2 = [obs[k][:, :2].astype(float) for k in used]
            p3 = [beacons[ids[k]] for k in used]
            ext = [pl_ext[k] for k in used]
            cd = [pl_cams[k] for k in used]
            ip = poselib.CameraPose()
            ip.R = C0
            ip.t = r0
            (pose, _info), dt = timed(
                lambda: poselib.refine_generalized_absolute_pose(p2, p3, ip, ext, cd, {})
            )
            results["poselib refine"] = (pose.R, -pose.R.T @ pose.t, dt)
            (pose, _info), dt = timed(
                lambda: poselib.estimate_generalized_absolute_pose(
                    p2, p3, ext, cd, {"max_reproj_error": 2.0}, {}
                )
            )
            results["poselib est."] = (pose.R, -pose.R.T @ pose.t, dt)
            allp2 = np.vstack(p2)
            allp3 = np.vstack(p3)
            idxs = [k for k in used for _ in range(len(ids[k]))]
            opts = pycolmap.RANSACOptions()
            opts.max_error = 2.0
            res, dt = timed(
                lambda: pycolmap.estimate_and_refine_generalized_absolute_pose(
                    allp2, allp3, idxs, col_ext, col_cams, opts
                )
            )
            if res is not None:
                rw = res["rig_from_world"]
                Rm = rw.rotation.matrix()
                results["colmap est."] = (Rm, -Rm.T @ np.asarray(rw.translation), dt)
            (sol, _progress), dt = timed(lambda: fl.acquire(rig, bmap, idx, frame, cfg), reps=1)
            if sol.ok:
                results["ours cold"] = (sol.C_w_b, sol.r_wb_w, dt)
            for k, (Rk, pk, dt) in results.items():
                t[k].append(dt)
                e_pos[k].append(np.linalg.norm(pk - pos_true))
                e_att[k].append(rot_err_deg(Rk, C))
        row = []
        for k in names:
            if t[k]:
                row.append(
                    f"{np.mean(t[k]):8.1f}/{np.sqrt(np.mean(np.square(e_pos[k]))):6.3f}/{np.sqrt(np.mean(np.square(e_att[k]))):7.4f}"
                )
            else:
                row.append(f"{'-':>24}")
        print(f"{n:>3} " + " ".join(f"{c:>24}" for c in row))
        ratio_rows.append(np.mean(t["poselib refine"]) / np.mean(t["ours refine"]))
    print(
        "refinement speed ratio PoseLib / ours (bare binding calls, same observations): "
        + " ".join(f"{x:.1f}x" for x in ratio_rows)
    )
    print(
        "target: refinement >= 2x faster than PoseLib at equal error; cold start <= 1000 us (C-native: bench_pose)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
