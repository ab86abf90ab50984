"""Minimum detectable displacement of one beacon (issue 23): the smallest move of a beacon, in
a given direction, that the flight's fault test (integrity.h: solution separation for the
beacon's hypothesis, per output axis, at the table's P_fa) detects with probability 1 - P_md,
computed from the geometry of the fixes it would have to be detected in.

For a fix with whitened Jacobian J (pose: world position mm, world attitude rad; 2 rows per
observation), the beacon's rows F (its observations in every camera), the separation of its
hypothesis is s = P0 J_F^T e_F (to first order; dx_k - dx_0), covariance S = P_k - P0. A move
d u of the beacon (u unit, mm) shifts its whitened observations by d L^-1 J_p u (J_p the
pixel's Jacobian in the beacon's position), so E[s] = d a, a = P0 J_F^T L^-1 J_p u, and the
test on axis j detects it with probability 1 - P_md when |d a_j| >= (K_fa + K_md) sqrt(S_jj).
The minimum detectable displacement of the fix is min_j (K_fa + K_md) sqrt(S_jj) / |a_j|;
K_fa = Q^-1(P_fa / (2 * 6 * N_hyp)) (N_hyp: beacons + cameras of the fix), K_md = Q^-1(P_md).

The observations of a fix are the rendered spots of its frame (spots.csv; the simulator's, so
the fix's inliers up to the solver's gate), their noise the median residual RMS of the clean
run's usable fixes (the centroid noise the solver met, inflated by sqrt(2n / (2n - 6)) for the
six pose parameters; a moved beacon inflates its own run's residuals) plus the survey term
sigma_mm^2 J_p J_p^T the flight adds. The fixes: the run's usable fixes; when none holds the
beacon, every third frame that sees it (the geometry alone). A numpy model of the
flight's test, not the flight code (its results are checked against the runs in the campaign
table: a move above the MDB that is not reported is "not reported", never "below MDB").
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from statistics import NormalDist

import numpy as np

from mfns.model.camera import Camera

from . import score

P_FA = 1e-5  # the table defaults (caltable_layout.toml integrity.p_fa, p_md)
P_MD = 1e-3
H_MM = 1e-3  # finite-difference steps: position (mm), attitude (rad)
H_RAD = 1e-6


def q_inv(p: float) -> float:
    """Upper-tail Gaussian quantile."""
    return -NormalDist().inv_cdf(p)


def _pixels(cam: Camera, c_w_b: np.ndarray, r_wb_w: np.ndarray, p_w: np.ndarray) -> np.ndarray:
    r_bw_b = -c_w_b @ r_wb_w
    uv, _ = cam.project_camera_points(cam.world_to_camera(c_w_b, r_bw_b, p_w))
    return np.asarray(uv).reshape(-1, 2)


def _jacobians(cam: Camera, c_w_b: np.ndarray, r_wb_w: np.ndarray, p_w: np.ndarray):
    """d uv / d (phi_w, r_wb_w) (2 x 6) and d uv / d p_w (2 x 3) by central differences;
    phi_w perturbs the attitude about the world axes: C_b_w' = exp(phi) C_b_w."""
    j = np.zeros((2, 6))
    jp = np.zeros((2, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = H_RAD
        plus = _pixels(cam, c_w_b @ score.rot_exp(-e), r_wb_w, p_w)
        minus = _pixels(cam, c_w_b @ score.rot_exp(e), r_wb_w, p_w)
        j[:, i] = ((plus - minus) / (2 * H_RAD))[0]
        e[i] = H_MM
        j[:, 3 + i] = (
            (_pixels(cam, c_w_b, r_wb_w + e, p_w) - _pixels(cam, c_w_b, r_wb_w - e, p_w)) / (2 * H_MM)
        )[0]
        jp[:, i] = (
            (_pixels(cam, c_w_b, r_wb_w, p_w + e) - _pixels(cam, c_w_b, r_wb_w, p_w - e)) / (2 * H_MM)
        )[0]
    return j, jp


def fix_mdb(
    cams: dict[str, Camera],
    beacons: dict[int, tuple[np.ndarray, float]],
    spots: list[tuple[str, int]],
    c_w_b: np.ndarray,
    r_wb_w: np.ndarray,
    beacon: int,
    u: np.ndarray,
    sigma_px: float,
) -> float | None:
    """MDB (mm) of beacon along unit u in one fix from spots [(camera, beacon id)]; None when
    the beacon is not in the fix or its hypothesis is not monitorable (no redundancy)."""
    rows_j, rows_a, is_f = [], [], []
    for cam_name, b in spots:
        p_w, sigma_mm = beacons[b]
        j, jp = _jacobians(cams[cam_name], c_w_b, r_wb_w, p_w)
        r = sigma_px**2 * np.eye(2) + sigma_mm**2 * (jp @ jp.T)
        w = np.linalg.inv(np.linalg.cholesky(r))  # L^-1
        rows_j.append(w @ j)
        rows_a.append(w @ jp @ u if b == beacon else np.zeros(2))
        is_f += [b == beacon] * 2
    if not any(is_f):
        return None
    jw = np.vstack(rows_j)
    fault = np.concatenate(rows_a)
    f = np.array(is_f)
    i0 = jw.T @ jw
    ik = jw[~f].T @ jw[~f]
    for m in (i0, ik):  # conditioning on the scaled information (rad and mm columns)
        d = np.sqrt(np.maximum(np.diag(m), 1e-300))
        if np.linalg.cond(m / np.outer(d, d)) > 1e8:
            return None
    p0, pk = np.linalg.inv(i0), np.linalg.inv(ik)
    a = p0 @ (jw[f].T @ fault[f])  # separation per mm of move (the subset does not see it)
    s = np.diag(pk - p0)
    n_hyp = len({b for _, b in spots}) + len({c for c, _ in spots})
    k = q_inv(P_FA / (2 * 6 * n_hyp)) + q_inv(P_MD)
    with np.errstate(divide="ignore"):
        per_axis = k * np.sqrt(np.maximum(s, 0.0)) / np.abs(a)
    best = float(np.min(per_axis))
    return best if math.isfinite(best) else None


def run_mdb(
    frames: Path,
    nav_rows: list[dict],
    beacon: int,
    move_mm: np.ndarray,
    usable_only: bool = True,
    sigma_px: float | None = None,
) -> dict:
    """The MDB of beacon moved along move_mm over the fixes of a run (nav.csv rows: the usable
    ones, or every cycle with a pose when usable_only is False), at their true poses:
    {"min_mm", "median_mm", "fixes"} (None values when no fix has the beacon)."""
    doc = json.loads((frames / "calib.json").read_text())
    cams = {e["name"]: Camera.from_entry(e) for e in doc["cameras"]}
    beacons = {}
    with open(frames / "beacons.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            beacons[int(r["id"])] = (
                np.array([float(r[a]) for a in ("x_mm", "y_mm", "z_mm")]),
                float(r["sigma_mm"]),
            )
    spots: dict[int, list[tuple[str, int]]] = {}
    with open(frames / "spots.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            b = int(r["beacon_id"])
            if b >= 0:
                spots.setdefault(int(r["frame"]), []).append((r["camera"], b))
    truth_rows = score.read_csv(frames / "truth.csv")
    t_frame = [(float(r["t_s"]), int(r["frame"])) for r in truth_rows]
    truth = score.Truth(truth_rows)
    rows = [r for r in nav_rows if (r["status"] in score.USABLE) or not usable_only]
    if sigma_px is None:  # the centroid noise the solver met in the run's usable fixes
        rms = [float(r["residual_rms_px"]) for r in rows if r.get("residual_rms_px") not in (None, "", "nan")]
        rms = [x for x in rms if x > 0]
        sigma_px = float(np.median(rms)) if rms else float(doc.get("pixel_noise_px", 0.1))
    u = np.asarray(move_mm, dtype=float)
    u = u / np.linalg.norm(u)

    def over(frames_t: list[tuple[int, float]]) -> list[float]:
        out = []
        for frame, t in frames_t:
            obs = spots.get(frame, [])
            n = 2 * len(obs)
            if n <= 6:
                continue
            pos, c_w_b, _ = truth.at(t)
            m = fix_mdb(cams, beacons, obs, c_w_b, pos, beacon, u, sigma_px * math.sqrt(n / (n - 6)))
            if m is not None:
                out.append(m)
        return out

    usable = []
    for r in rows:
        t = float(r["t_s"])
        usable.append((min(t_frame, key=lambda x: abs(x[0] - t))[1], t))
    out, where = over(usable), "usable fixes"
    if not out:  # no usable fix holds the beacon: the geometry of every frame that sees it
        out, where = (
            over([(f, t) for t, f in t_frame if any(b == beacon for _, b in spots.get(f, []))]),
            "frames",
        )
    return {
        "min_mm": min(out) if out else None,
        "median_mm": float(np.median(out)) if out else None,
        "fixes": len(out),
        "over": where,
        "sigma_px": sigma_px,
    }
