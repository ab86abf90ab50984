"""Error analysis of the paper's Section 3 (Figs. 4-6, Table 1) by Monte Carlo.

Set-up (Table 1, docs/system.md §4): camera Z with C_z_b = I and r_bz_b = 0, alpha_x = alpha_y =
1600 px, u0 = 640, v0 = 512, 1280 x 1024 px, no distortion; the body at the world origin
with zero attitude, so camera and world frames coincide and the depth of a beacon is Zw.

Beacon positions. Table 1 gives Xw, Zw uniform in 0..1000 mm and leaves Yw open. Taken
literally, depths near 0 give unbounded pixel errors (E[1/Zw^2] diverges), and most such
beacons fall outside the image anyway. This module therefore draws
    Xw ~ U(0, 1000), Yw ~ U(-500, 500), Zw ~ U(0, 1000) mm
and keeps a beacon only if (a) it is at least `z_min` (default 100 mm) in front of the
camera and (b) its image lies inside the 1280 x 1024 frame (an observation exists). The
Yw range is wide enough never to bind (a visible beacon has |Yw| <= 0.32 Zw <= 320 mm), so
the kept beacons are uniform over the part of the Table 1 box that camera Z sees beyond
z_min: in normalized coordinates x = Xw/Zw ~ U(0, 0.3997), y = Yw/Zw ~ U(-0.3203, 0.3197),
independent of Zw, whose density is proportional to Zw^2 on [z_min, 1000].

Error model: at error level e, every component of the error is drawn N(0, e^2), independently
per trial: the beacon position (Fig. 4, Eqs. 5-7), the camera-to-body position r_bz_b
(Fig. 5, Eq. 8), the three 2-1-3 Euler angles of C_z_b (Fig. 6, Eqs. 9-10; the paper perturbs
the angles of the world-to-camera matrix, its transpose here: same RMS). The figure of merit
is the RMS over trials of du = u' - u, through the full projection (no linearisation).

First-order prediction (projection Jacobian, u = alpha Xc/Zc + u0, at C = I):
  beacon / position:  du = alpha/Z (dX - x dZ)  ->  RMS = e alpha sqrt(E[1/Z^2] (1 + E[x^2]))
  attitude:           du = alpha (dtheta (1 + x^2) - dpsi y - dphi x y)
                      ->  RMS = e alpha sqrt(E[(1 + x^2)^2] + E[y^2] + E[x^2] E[y^2])
with the moments of the distribution above in closed form.

Extension: end-to-end pose error vs calibration error, in the module scenario of
`mfns sim nav` (60 wall beacons, the paper's rig, poses along the module trajectory with
>= 4 beacons in view): the beacons are observed through the true rig, the pose is solved
with a perturbed rig or map by a pluggable `PoseSolver`. By default the flight solver: the C
refinement of firmware/nav/pose/pose.h with known correspondences, from the shared library
`make lib` builds, through ctypes (mfns.analysis.mc_flight); `--solver reference` selects the host
reference (mfns.model.pose_ref, double-precision Gauss-Newton on the same reprojection error).
"""

from __future__ import annotations

import csv
import json
import math
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..core.errors import MfnsError
from ..core.study import SERIAL, StudyOptions, options_from_args, run_tasks
from ..model.camera import Camera, position_from_pose
from ..model.pose_ref import PoseSolver
from ..model.rotations import rot_exp, rot_log
from .mc_flight import make_solver

TABLE1 = {"fx": 1600.0, "fy": 1600.0, "cx": 640.0, "cy": 512.0, "width": 1280, "height": 1024}
X_RANGE_MM = (0.0, 1000.0)
Y_RANGE_MM = (-500.0, 500.0)
Z_RANGE_MM = (0.0, 1000.0)
DEFAULT_Z_MIN_MM = 100.0
PAPER_POSITION_MM = 1.0
PAPER_ATTITUDE_DEG = 0.17
PAPER_BEACON_MM = 0.3963  # Table 4's beacon accuracy
TARGETS_PX = (1.0, 2.0, 3.0, 5.0)


@dataclass(frozen=True)
class Group:
    key: str
    fig: str
    title: str
    unit: str
    levels: tuple[float, ...]


GROUPS = (
    Group("beacon", "fig4", "beacon position error", "mm", tuple(np.round(np.arange(0, 5.01, 0.5), 3))),
    Group(
        "position", "fig5", "camera-to-body position error", "mm", tuple(np.round(np.arange(0, 5.01, 0.5), 3))
    ),
    Group(
        "attitude",
        "fig6",
        "camera-to-body attitude error",
        "deg",
        tuple(np.round(np.arange(0, 0.501, 0.05), 3)),
    ),
)


def table1_camera() -> Camera:
    t = TABLE1
    return Camera("z", t["fx"], t["fy"], t["cx"], t["cy"], width=int(t["width"]), height=int(t["height"]))


def sample_beacons(rng: np.random.Generator, n: int, z_min: float, cam: Camera | None = None) -> np.ndarray:
    """n beacons uniform over the Table 1 box, kept if >= z_min deep and inside the image."""
    cam = cam or table1_camera()
    out: list[np.ndarray] = []
    have = 0
    for _ in range(1000):  # acceptance is ~3 %: bounded, far more than ever needed
        m = max(4 * (n - have), 1024) * 8
        p = np.column_stack(
            [rng.uniform(*X_RANGE_MM, m), rng.uniform(*Y_RANGE_MM, m), rng.uniform(*Z_RANGE_MM, m)]
        )
        p = p[p[:, 2] >= z_min]
        uv, front = cam.project_camera_points(p)
        p = p[front & cam.in_image(uv)]
        out.append(p)
        have += len(p)
        if have >= n:
            break
    else:
        raise MfnsError("could not draw visible beacons (z_min too large?)")
    return np.vstack(out)[:n]


def euler213_batch(angles: np.ndarray) -> np.ndarray:
    """(N, 3) (roll, pitch, yaw) rad -> (N, 3, 3) C = R3(yaw) R1(roll) R2(pitch)."""
    ph, th, ps = angles[:, 0], angles[:, 1], angles[:, 2]
    cf, sf, ct, st, cp, sp = np.cos(ph), np.sin(ph), np.cos(th), np.sin(th), np.cos(ps), np.sin(ps)
    c = np.empty((len(angles), 3, 3))
    c[:, 0, 0] = cp * ct + sp * st * sf
    c[:, 0, 1] = sp * cf
    c[:, 0, 2] = -cp * st + sp * ct * sf
    c[:, 1, 0] = -sp * ct + cp * st * sf
    c[:, 1, 1] = cp * cf
    c[:, 1, 2] = sp * st + cp * ct * sf
    c[:, 2, 0] = cf * st
    c[:, 2, 1] = -sf
    c[:, 2, 2] = ct * cf
    return c


def pixel_errors(
    group: str, level: float, beacons: np.ndarray, rng: np.random.Generator, cam=None
) -> np.ndarray:
    """du (N,) of one error group at one level, one trial per beacon, through the full model."""
    cam = cam or table1_camera()
    n = len(beacons)
    u_true = cam.project_camera_points(beacons)[0][:, 0]
    if group == "beacon":
        p_c = beacons + rng.normal(0.0, level, (n, 3))
    elif group == "position":
        p_c = beacons - rng.normal(0.0, level, (n, 3))  # p_c = C_z_b^T (p_b - r_bz_b), C_z_b = I
    elif group == "attitude":
        c_k_b = euler213_batch(rng.normal(0.0, math.radians(level), (n, 3)))
        p_c = np.einsum("nji,nj->ni", c_k_b, beacons)  # C_z_b^T p_b
    else:
        raise MfnsError(f"unknown error group {group!r}")
    return cam.project_camera_points(p_c)[0][:, 0] - u_true


def analytic_slope(group: str, z_min: float, cam=None) -> float:
    """First-order RMS of du per unit error level (px/mm or px/deg), closed form."""
    cam = cam or table1_camera()
    a0, a1 = max(0.0, (-0.5 - cam.cx) / cam.fx), (cam.width - 0.5 - cam.cx) / cam.fx
    b0, b1 = (-0.5 - cam.cy) / cam.fy, (cam.height - 0.5 - cam.cy) / cam.fy
    z0, z1 = z_min, Z_RANGE_MM[1]
    # The box must not cut the visible frustum, else x, y, Z are not independent.
    assert a1 * z1 <= X_RANGE_MM[1] and max(-b0, b1) * z1 <= Y_RANGE_MM[1]

    def moment(lo, hi, k):
        return (hi ** (k + 1) - lo ** (k + 1)) / ((k + 1) * (hi - lo))

    ex2, ex4, ey2 = moment(a0, a1, 2), moment(a0, a1, 4), moment(b0, b1, 2)
    e_inv_z2 = 3.0 * (z1 - z0) / (z1**3 - z0**3)  # density ~ Z^2
    if group in ("beacon", "position"):
        return cam.fx * math.sqrt(e_inv_z2 * (1.0 + ex2))
    if group == "attitude":
        return cam.fx * math.sqrt(1.0 + 2.0 * ex2 + ex4 + ey2 + ex2 * ey2) * math.pi / 180.0
    raise MfnsError(f"unknown error group {group!r}")


def slope_through_origin(levels, rms) -> float:
    x = np.asarray(levels, dtype=float)
    y = np.asarray(rms, dtype=float)
    return float(np.sum(x * y) / np.sum(x * x))


def mc_curve(group: Group, trials: int, z_min: float, rng: np.random.Generator) -> list[dict]:
    rows = []
    for level in group.levels:
        beacons = sample_beacons(rng, trials, z_min)
        du = pixel_errors(group.key, level, beacons, rng)
        rows.append(
            {
                "level": float(level),
                "rms_u_px": float(np.sqrt(np.mean(du**2))),
                "mean_abs_u_px": float(np.mean(np.abs(du))),
                "p95_abs_u_px": float(np.percentile(np.abs(du), 95)),
            }
        )
    return rows


def rms_at(group: str, level: float, trials: int, z_min: float, rng) -> float:
    return float(np.sqrt(np.mean(pixel_errors(group, level, sample_beacons(rng, trials, z_min), rng) ** 2)))


def combined_rms(pos_mm: float, att_deg: float, trials: int, z_min: float, rng) -> float:
    """RMS du with camera position and attitude errors at the same time."""
    cam = table1_camera()
    b = sample_beacons(rng, trials, z_min)
    c_k_b = euler213_batch(rng.normal(0.0, math.radians(att_deg), (trials, 3)))
    p_c = np.einsum("nji,nj->ni", c_k_b, b - rng.normal(0.0, pos_mm, (trials, 3)))
    du = cam.project_camera_points(p_c)[0][:, 0] - cam.project_camera_points(b)[0][:, 0]
    return float(np.sqrt(np.mean(du**2)))


# --------------------------------------------------------------------------- extension
POSE_GROUPS = (
    ("position", "mm", (0.0, 0.25, 0.5, 1.0, 2.0)),
    ("attitude", "deg", (0.0, 0.05, 0.1, 0.17, 0.3)),
    ("beacon", "mm", (0.0, 0.2, 0.4, 1.0, 2.0)),
)


# Poses whose position is this poorly determined (mm of 1-sigma error of r_bw_b per px of
# pixel noise, from the Jacobian at the truth) are left out: near-critical geometries (four
# beacons in one camera, nearly degenerate) whose errors would swamp the RMS; a flight
# solver flags such poses by their covariance.
MAX_POSITION_DILUTION_MM_PER_PX = 20.0


def module_pose_pool(seed: int, n_poses: int = 400):
    """(scenario, frame indices) of poses along the module trajectory usable for the extension.

    Usable: >= 4 beacons in view and a position dilution <= MAX_POSITION_DILUTION_MM_PER_PX.
    """
    from ..model.pose_ref import residuals_and_jacobian
    from ..simulate import nav

    scn = nav.module_scenario(n_poses * 2, 0.5, 60, seed)  # one pose every 2 s of the path
    keep = []
    for i in range(scn.n_frames):
        c, r = scn.pose(i)
        idx, pts, uv = [], [], []
        for k, cam in enumerate(scn.cams):
            uvk, vis, _ = nav.project_beacons(cam, c, r, scn.beacons)
            idx += [k] * int(vis.sum())
            pts.append(scn.beacons[vis])
            uv.append(uvk[vis])
        if len(idx) < 4:
            continue
        _, jac = residuals_and_jacobian(scn.cams, np.array(idx), np.vstack(pts), np.vstack(uv), c, r)
        cov = np.linalg.inv(jac.T @ jac)
        if math.sqrt(np.trace(cov[3:, 3:])) <= MAX_POSITION_DILUTION_MM_PER_PX:
            keep.append(i)
    return scn, np.array(keep, dtype=int)


def pose_errors(
    solver: PoseSolver,
    group: str,
    level: float,
    trials: int,
    rng: np.random.Generator,
    pool,
    pixel_noise_px: float = 0.0,
) -> dict:
    """Solve `trials` poses with a rig/map perturbed at `level`; RMS of the pose errors."""
    from ..simulate import nav

    scn, keep = pool
    true_cams = scn.cams
    pos_err, att_err, solved, rms_px = [], [], 0, []
    for _ in range(trials):
        i = int(keep[rng.integers(len(keep))])
        c_true, r_true = scn.pose(i)
        cam_of: list[int] = []
        pts, uv_k = [], []
        for k, cam in enumerate(true_cams):
            uvk, vis, _ = nav.project_beacons(cam, c_true, r_true, scn.beacons)
            cam_of.extend([k] * int(vis.sum()))
            pts.append(np.nonzero(vis)[0])
            uv_k.append(uvk[vis])
        idx = np.array(cam_of)
        ids = np.concatenate(pts)
        uv = np.vstack(uv_k) + rng.normal(0.0, pixel_noise_px, (len(idx), 2))
        believed_cams = [_copy_cam(c) for c in true_cams]
        believed_map = scn.beacons.copy()
        if group == "position":
            for c in believed_cams:
                c.r_bk_b = c.r_bk_b + rng.normal(0.0, level, 3)
        elif group == "attitude":
            for c in believed_cams:
                c.C_k_b = rot_exp(rng.normal(0.0, math.radians(level), 3)) @ c.C_k_b
        elif group == "beacon":
            believed_map = believed_map + rng.normal(0.0, level, believed_map.shape)
        else:
            raise MfnsError(f"unknown error group {group!r}")
        sol = solver(believed_cams, idx, believed_map[ids], uv, c_true, r_true)
        if not sol.converged:
            continue
        solved += 1
        pos_err.append(position_from_pose(sol.C_w_b, sol.r_bw_b) - position_from_pose(c_true, r_true))
        att_err.append(np.rad2deg(rot_log(sol.C_w_b @ c_true.T)))
        rms_px.append(sol.rms_px)
    pe, ae = np.array(pos_err).reshape(-1, 3), np.array(att_err).reshape(-1, 3)
    return {
        "group": group,
        "level": float(level),
        "trials": trials,
        "solved": solved,
        "pos_rms_mm": float(np.sqrt(np.mean(pe**2))) if solved else float("nan"),
        "att_rms_deg": float(np.sqrt(np.mean(ae**2))) if solved else float("nan"),
        "pos_rms_xyz_mm": np.sqrt(np.mean(pe**2, axis=0)).tolist() if solved else [float("nan")] * 3,
        "att_rms_xyz_deg": np.sqrt(np.mean(ae**2, axis=0)).tolist() if solved else [float("nan")] * 3,
        "reproj_rms_px": float(np.mean(rms_px)) if solved else float("nan"),
        # medians of the per-trial error norms: the RMS is dominated by a few poorly
        # conditioned poses (four beacons in one camera)
        "pos_median_norm_mm": float(np.median(np.linalg.norm(pe, axis=1))) if solved else float("nan"),
        "att_median_norm_deg": float(np.median(np.linalg.norm(ae, axis=1))) if solved else float("nan"),
    }


@dataclass
class PosePoint:
    """One point of the pose extension (a study task, mfns.core.study): its inputs, all data.

    Its random numbers are common to the levels of its group (np.random.default_rng([seed, 7,
    group_index])): a documented derivation from the study's seed and the group's index, so a
    point's result does not depend on where or in which order it runs."""

    solver: str | PoseSolver  # "flight" / "reference" (made where the task runs) or a callable
    group: str
    group_index: int
    level: float
    trials: int
    seed: int
    pool: tuple  # module_pose_pool(seed): computed once, shipped with the task

    def __repr__(self) -> str:  # a failure report's inputs
        return f"PosePoint({self.group} {self.level:g}, {self.trials} trials, seed {self.seed})"


_SOLVERS: dict[str, PoseSolver] = {}  # per process: the flight library loaded once


def pose_point(p: PosePoint) -> dict:
    """pose_errors of one point (a study task)."""
    if isinstance(p.solver, str):
        if p.solver not in _SOLVERS:
            _SOLVERS[p.solver] = make_solver(p.solver)[0]
        solver = _SOLVERS[p.solver]
    else:
        solver = p.solver
    crn = np.random.default_rng([p.seed, 7, p.group_index])
    return pose_errors(solver, p.group, p.level, p.trials, crn, p.pool)


def _copy_cam(c: Camera) -> Camera:
    return Camera(
        c.name,
        c.fx,
        c.fy,
        c.cx,
        c.cy,
        c.skew,
        c.dist.copy(),
        c.width,
        c.height,
        c.C_k_b.copy(),
        c.r_bk_b.copy(),
    )


# --------------------------------------------------------------------------- the run
def write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)


def plot_curve(path: Path, group: Group, rows: list[dict], slope_an: float, trials: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array([r["level"] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4.2), dpi=110)
    ax.plot(x, [r["rms_u_px"] for r in rows], "o", label=f"Monte Carlo RMS ({trials} trials/point)")
    xx = np.linspace(0, x.max(), 50)
    ax.plot(xx, slope_an * xx, "-", lw=1, label=f"first order: {slope_an:.3g} px/{group.unit}")
    ax.set_xlabel(f"{group.title} (1-sigma per component, {group.unit})")
    ax.set_ylabel("RMS pixel error of u (px)")
    ax.set_title(f"{group.fig.replace('fig', 'Fig. ')}: pixel error vs {group.title}")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_pose(path: Path, rows: list[dict], solver_name: str) -> None:
    """Pose error vs calibration error: one column per error group, position above, attitude below.

    Separate axes, not twin axes: both errors grow about linearly, so on twin axes that
    scale themselves the two curves lie on top of each other and show nothing.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # The paper's requirement on the camera mounting (Sec. 3): < 1 mm and < 0.17 deg.
    requirement = {"position": PAPER_POSITION_MM, "attitude": PAPER_ATTITUDE_DEG}
    what = {"position": "camera position r_bk_b", "attitude": "camera attitude C_k_b", "beacon": "beacon map"}
    fig, axes = plt.subplots(2, len(POSE_GROUPS), figsize=(13, 6.5), dpi=100, sharex="col")
    for k, (g, unit, _levels) in enumerate(POSE_GROUPS):
        rr = [r for r in rows if r["group"] == g]
        x = [r["level"] for r in rr]
        top, bottom = axes[0][k], axes[1][k]
        top.plot(x, [r["pos_rms_mm"] for r in rr], "o-", color="C0")
        top.set_ylabel("position error, RMS per axis (mm)")
        top.set_title(f"error of the {what.get(g, g)}", fontsize=10)
        bottom.plot(x, [r["att_rms_deg"] for r in rr], "s-", color="C3")
        bottom.set_ylabel("attitude error, RMS per axis (deg)")
        bottom.set_xlabel(f"{g} error, 1σ per component ({unit})")
        for ax in (top, bottom):
            ax.set_ylim(bottom=0)
            ax.grid(alpha=0.3)
            if g in requirement:
                ax.axvline(requirement[g], color="k", ls=":", lw=1)
        if g in requirement:
            top.annotate(
                f"paper's limit {requirement[g]:g} {unit}",
                (requirement[g], 0.02),
                xycoords=("data", "axes fraction"),
                rotation=90,
                ha="right",
                va="bottom",
                fontsize=8,
            )
    solver = solver_name.split(" (")[0]  # "flight solver (firmware/nav/pose/pose.h ...)" -> "flight solver"
    fig.suptitle(f"mfns mc: end-to-end pose error vs calibration error (module scenario, {solver})")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


MAX_TRIALS = 10_000_000  # trials are held in memory per point: bounded before allocating


def run_mc(
    out: Path,
    trials: int,
    seed: int,
    z_min: float = DEFAULT_Z_MIN_MM,
    pose_trials: int = 200,
    solver: str | PoseSolver = "flight",
    solver_name: str | None = None,
    progress: bool = True,
    options: StudyOptions = SERIAL,
) -> dict:
    """solver: "flight" (the C solver through ctypes, needs `make lib`), "reference"
    (mfns.model.pose_ref), or any PoseSolver callable (then described by solver_name).
    options: where the pose extension's points run (mfns.core.study; the same numbers serially
    and on any cluster). The curves of Figs. 4-6 draw from one random stream in turn, in this
    process: that keeps them the numbers of before."""
    from tqdm import tqdm

    if not 10 <= trials <= MAX_TRIALS:
        raise MfnsError(f"--trials must be in 10..{MAX_TRIALS}")
    if not 0 <= seed < 2**63:
        raise MfnsError("--seed must be a non-negative integer")
    if not (0 < z_min < Z_RANGE_MM[1]):
        raise MfnsError("--z-min must be in (0, 1000) mm")
    if not 0 <= pose_trials <= MAX_TRIALS:
        raise MfnsError(f"--pose-trials must be in 0..{MAX_TRIALS}")
    solver_key = solver if isinstance(solver, str) else "custom"
    pose_solver: PoseSolver | None = None
    if pose_trials:
        # Before any long work: a missing flight library is reported at once.
        if isinstance(solver, str):
            pose_solver, default_name = make_solver(solver)
            solver_name = solver_name or default_name
        else:
            pose_solver = solver
        solver_name = solver_name or getattr(pose_solver, "__name__", "custom solver")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    summary: dict = {
        "table1": {**TABLE1, "C_z_b": "I", "r_bz_b_mm": [0, 0, 0], "body": "world origin, zero attitude"},
        "beacons": {
            "x_mm": list(X_RANGE_MM),
            "y_mm": list(Y_RANGE_MM),
            "z_mm": list(Z_RANGE_MM),
            "z_min_mm": z_min,
            "kept": "only beacons at least z_min deep whose image is inside the 1280x1024 frame",
        },
        "error_model": "each error component ~ N(0, level^2), independent per trial",
        "trials_per_point": trials,
        "seed": seed,
        "groups": {},
    }
    # a step: a curve of Figs. 4-6, then a point of the pose extension (a study task)
    steps = len(GROUPS) + (sum(len(levels) for _, _, levels in POSE_GROUPS) if pose_trials else 0)
    bar = tqdm(total=steps, desc="mc", unit="step", disable=not progress)
    for g in GROUPS:
        rows = mc_curve(g, trials, z_min, rng)
        s_an = analytic_slope(g.key, z_min)
        s_mc = slope_through_origin([r["level"] for r in rows[1:]], [r["rms_u_px"] for r in rows[1:]])
        write_csv(
            out / f"{g.fig}_{g.key}.csv",
            [f"error_{g.unit}", "rms_u_px", "mean_abs_u_px", "p95_abs_u_px", "analytic_rms_u_px", "trials"],
            [
                [
                    f"{r['level']:g}",
                    f"{r['rms_u_px']:.6f}",
                    f"{r['mean_abs_u_px']:.6f}",
                    f"{r['p95_abs_u_px']:.6f}",
                ]
                + [f"{s_an * r['level']:.6f}", trials]
                for r in rows
            ],
        )
        plot_curve(out / f"{g.fig}_{g.key}.png", g, rows, s_an, trials)
        summary["groups"][g.key] = {
            "figure": g.fig,
            "unit": g.unit,
            "mc_slope_px_per_unit": s_mc,
            "analytic_slope_px_per_unit": s_an,
            "mc_over_analytic": s_mc / s_an,
            "accuracy_for_rms_px": {f"{t:g}": t / s_mc for t in TARGETS_PX},
        }
        bar.update()
    summary["paper_conclusion"] = {
        "rms_u_px_at_position_1mm": rms_at("position", PAPER_POSITION_MM, trials, z_min, rng),
        "rms_u_px_at_attitude_0.17deg": rms_at("attitude", PAPER_ATTITUDE_DEG, trials, z_min, rng),
        "rms_u_px_at_both": combined_rms(PAPER_POSITION_MM, PAPER_ATTITUDE_DEG, trials, z_min, rng),
        "rms_u_px_at_beacon_0.3963mm": rms_at("beacon", PAPER_BEACON_MM, trials, z_min, rng),
    }

    if pose_trials:
        assert pose_solver is not None and solver_name is not None  # both set above
        pool = module_pose_pool(seed)
        # Common random numbers: every level of a group sees the same poses and the same error
        # directions, scaled by the level, so the curve shows the growth with the level rather
        # than the draw-to-draw spread of a few weak poses (PosePoint).
        points = [
            PosePoint(
                solver if isinstance(solver, str) else pose_solver, pg, gi, level, pose_trials, seed, pool
            )
            for gi, (pg, _unit, levels) in enumerate(POSE_GROUPS)
            for level in levels
        ]
        if isinstance(solver, str):
            _SOLVERS.setdefault(solver, pose_solver)  # this process's, when the points run here
        done = run_tasks(
            pose_point,
            points,
            replace(options, progress=False),
            "mc-pose",
            on_result=lambda _i, _r: bar.update(),
        )
        pose_rows = done.results
        for f in done.failures:  # kept as unsolved rows; the others are written; run() exits 1
            p = points[f.index]
            pose_rows[f.index] = {
                "group": p.group,
                "level": float(p.level),
                "trials": p.trials,
                "solved": 0,
                **dict.fromkeys(("pos_rms_mm", "att_rms_deg", "reproj_rms_px"), float("nan")),
                **dict.fromkeys(("pos_median_norm_mm", "att_median_norm_deg"), float("nan")),
                "pos_rms_xyz_mm": [float("nan")] * 3,
                "att_rms_xyz_deg": [float("nan")] * 3,
                "failed": f.error,
            }
        if done.failures:
            summary["failed_tasks"] = done.failed_summary("pose points")
        write_csv(
            out / "pose_vs_calib.csv",
            ["group", "level", "unit", "trials", "solved", "pos_rms_mm", "att_rms_deg", "reproj_rms_px"]
            + ["pos_median_norm_mm", "att_median_norm_deg", "solver"],
            [
                [
                    r["group"],
                    f"{r['level']:g}",
                    dict((g, u) for g, u, _ in POSE_GROUPS)[r["group"]],
                    r["trials"],
                ]
                + [
                    r["solved"],
                    f"{r['pos_rms_mm']:.6f}",
                    f"{r['att_rms_deg']:.6f}",
                    f"{r['reproj_rms_px']:.6f}",
                ]
                + [f"{r['pos_median_norm_mm']:.6f}", f"{r['att_median_norm_deg']:.6f}", solver_key]
                for r in pose_rows
            ],
        )
        plot_pose(out / "pose_vs_calib.png", pose_rows, solver_name)
        ext = {
            "pose_pool": {
                "candidates": pool[0].n_frames,
                "usable": len(pool[1]),
                "rule": f">= 4 beacons and position dilution <= {MAX_POSITION_DILUTION_MM_PER_PX} mm/px",
            },
            "solver": solver_name,
            "solver_key": solver_key,
            "scenario": f"module, seed {seed}, 60 beacons, paper rig",
            "rows": pose_rows,
        }
        for pg, unit, _levels in POSE_GROUPS:
            rr = [r for r in pose_rows if r["group"] == pg and r["level"] > 0 and r["solved"]]
            ext[f"{pg}_slope"] = {
                f"pos_mm_per_{unit}": slope_through_origin(
                    [r["level"] for r in rr], [r["pos_rms_mm"] for r in rr]
                ),
                f"att_deg_per_{unit}": slope_through_origin(
                    [r["level"] for r in rr], [r["att_rms_deg"] for r in rr]
                ),
            }
        summary["pose_extension"] = ext
    bar.close()
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def format_summary(s: dict) -> str:
    lines = [
        f"mc: {s['trials_per_point']} trials per point, beacons >= {s['beacons']['z_min_mm']:g} mm deep "
        f"and inside the image, Yw in {s['beacons']['y_mm']} mm",
        "  curve                              slope MC      first order   MC/analytic",
    ]
    for key, g in s["groups"].items():
        lines.append(
            f"  {g['figure']} {key:9s} px/{g['unit']:3s}         {g['mc_slope_px_per_unit']:10.4f}    "
            f"{g['analytic_slope_px_per_unit']:10.4f}    {g['mc_over_analytic']:.4f}"
        )
    lines.append("  calibration accuracy (1-sigma) keeping the RMS u error at:")
    for t in TARGETS_PX:
        k = f"{t:g}"
        lines.append(
            f"    {t:g} px: beacon < {s['groups']['beacon']['accuracy_for_rms_px'][k]:.3f} mm, "
            f"camera position < {s['groups']['position']['accuracy_for_rms_px'][k]:.3f} mm, "
            f"attitude < {s['groups']['attitude']['accuracy_for_rms_px'][k]:.4f} deg"
        )
    pc = s["paper_conclusion"]
    lines.append(
        f"  paper's thresholds: position 1 mm -> {pc['rms_u_px_at_position_1mm']:.2f} px, "
        f"attitude 0.17 deg -> {pc['rms_u_px_at_attitude_0.17deg']:.2f} px, "
        f"both -> {pc['rms_u_px_at_both']:.2f} px, "
        f"beacon 0.3963 mm -> {pc['rms_u_px_at_beacon_0.3963mm']:.2f} px"
    )
    ext = s.get("pose_extension")
    if ext:
        lines.append(f"  end-to-end pose error ({ext['solver']}):")
        for r in ext["rows"]:
            lines.append(
                f"    {r['group']:9s} {r['level']:6g}: position {r['pos_rms_mm']:.3f} mm, "
                f"attitude {r['att_rms_deg']:.4f} deg RMS per axis; medians of the norms "
                f"{r['pos_median_norm_mm']:.3f} mm, {r['att_median_norm_deg']:.4f} deg "
                f"({r['solved']}/{r['trials']} solved)"
            )
    return "\n".join(lines)


def run(args) -> int:
    t0 = time.perf_counter()
    s = run_mc(
        Path(args.out),
        args.trials,
        args.seed,
        args.z_min,
        args.pose_trials,
        solver=args.solver,
        progress=not args.quiet,
        options=options_from_args(args),
    )
    print(format_summary(s))
    print(f"  wrote {args.out} in {time.perf_counter() - t0:.1f} s")
    if "failed_tasks" in s:
        print(f"mc: {s['failed_tasks']}", file=sys.stderr)
        return 1
    return 0
