"""`mfns map refine`: the self-survey (docs/self_survey.md). A bundle adjustment over the
fixes of a fix log: every fix's pose, every beacon's position with the survey as its prior,
and optionally each camera's mount (rotation and offset in the body), by scipy's
least_squares with a robust (Huber) loss on a sparse analytic Jacobian.

Projection goes through the one numpy lens model (mfns.model.camera.Camera: `project_jacobian`,
held to the C model by tests/host/test_camera_model.py); nothing here restates it.

Model of one association j (fix f, camera k, beacon b), all in double:

    C_w_b(f) = C0_w_b(f) exp(-[phi_f]x)      pose: rotation about the body axes, and r_wb_w(f)
    p_b      = C_w_b(f) (p_w(b) - r_wb_w(f))
    C_k_b(k) = exp([psi_k]x) C0_k_b(k),  r_bk_b(k) = r0_bk_b(k) + t_k      (mounts, optional)
    p_c      = C_k_b(k)^T (p_b - r_bk_b(k)),  uv = lens(p_c)

residual W_j (uv - uv_measured), W_j^T W_j = R_j^-1, R_j = the centroider's covariance plus
pixel_floor^2 I. Priors: (p_w(b) - p_survey(b)) / sigma_survey(b) per coordinate, and, with
mounts, psi_k / sigma_rot and t_k / sigma_mm.

Gauge. Poses and beacons alone are defined up to a similarity (3 translations, 3
rotations, a scale): the survey prior on every beacon fixes it, so the refined map keeps the
survey's datum: its weighted mean position, orientation and scale are the survey's within
sigma/sqrt(N) (no beacon is held fixed, none is privileged). With mounts, a rotation or an
offset common to all three cameras is the same as a change of body pose and cannot be seen:
the mount priors hold that common mode at the calibration; flagged and written mounts are
then re-centred on the median camera (the body frame is the one in which the median camera did
not move), so one shifted camera shows as itself and not as a third of it on every camera.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.optimize import least_squares
from scipy.stats import chi2, norm

from ..analysis.calib_results import CAMERA_NAMES
from ..analysis.mc import PAPER_ATTITUDE_DEG, PAPER_POSITION_MM
from ..core.csv_formats import BEACON_COLUMNS
from ..core.errors import MfnsError
from ..model.camera import Camera
from ..model.rotations import matrix_to_euler213_deg, rot_exp, skew
from .fixlog import Fix

# Stated test levels (docs/self_survey.md): a beacon's refined place against its survey, and
# a camera's mount rotation or offset, each a chi-square with 3 degrees of freedom at this
# false-alarm probability (per beacon, per camera and part). 1e-4 keeps the family of 60
# beacons below 1 % false alarms per refinement.
P_FALSE_ALARM = 1e-4
CHI2_3 = float(chi2.isf(P_FALSE_ALARM, 3))  # 21.1
# Huber threshold on whitened residuals: quadratic within 3 sigma, linear beyond.
HUBER_SIGMA = 3.0
# The variance of a unit normal truncated to |r| <= HUBER_SIGMA (0.973): the unit weight
# is estimated from the residuals within it only (unit_weight).
HUBER_TRUNC_VAR = float(1.0 - 2.0 * HUBER_SIGMA * norm.pdf(HUBER_SIGMA) / (2.0 * norm.cdf(HUBER_SIGMA) - 1.0))
# Mount priors when the calibration gives none: the paper's requirement on the rig
# (docs/system.md section 4: 1 mm and 0.17 deg), far wider than a calibration's 1 sigma.
MOUNT_SIGMA_DEG = PAPER_ATTITUDE_DEG
MOUNT_SIGMA_MM = PAPER_POSITION_MM
PIXEL_FLOOR_PX = 0.005  # the table's default floor order (grid residual); the centroider's covariance adds


@dataclass
class Problem:
    cams: list[Camera]
    ids: np.ndarray  # (B,) survey ids
    p_survey: np.ndarray  # (B, 3) mm
    sigma_survey: np.ndarray  # (B,) mm
    C0: np.ndarray  # (F, 3, 3) initial C_w_b of each fix
    r0: np.ndarray  # (F, 3) initial r_wb_w
    fix: np.ndarray  # (M,) fix index of each association
    cam: np.ndarray  # (M,) camera
    bea: np.ndarray  # (M,) beacon index (into ids)
    uv: np.ndarray  # (M, 2)
    W: np.ndarray  # (M, 2, 2) whitening
    mounts: bool = False
    mount_sigma: tuple[float, float] = (np.deg2rad(MOUNT_SIGMA_DEG), MOUNT_SIGMA_MM)

    @property
    def n_fix(self) -> int:
        return len(self.C0)

    @property
    def n_beacon(self) -> int:
        return len(self.ids)

    @property
    def n_par(self) -> int:
        return 6 * self.n_fix + 3 * self.n_beacon + (18 if self.mounts else 0)

    def split(self, x):
        f6 = x[: 6 * self.n_fix].reshape(-1, 6)
        b3 = x[6 * self.n_fix : 6 * self.n_fix + 3 * self.n_beacon].reshape(-1, 3)
        m6 = x[6 * self.n_fix + 3 * self.n_beacon :].reshape(-1, 6) if self.mounts else np.zeros((3, 6))
        return f6, b3, m6


@dataclass
class Result:
    ids: np.ndarray
    p_survey: np.ndarray
    sigma_survey: np.ndarray
    p: np.ndarray  # (B, 3) refined
    cov: np.ndarray  # (B, 3, 3)
    sigma: np.ndarray  # (B,) written sigma_mm: sqrt of the largest eigenvalue of cov
    chi2_moved: np.ndarray  # (B,)
    moved: np.ndarray  # (B,) bool
    n_obs: np.ndarray  # (B,)
    mount_rot_deg: np.ndarray  # (3, 3) per camera, median-recentred
    mount_off_mm: np.ndarray  # (3, 3)
    mount_chi2: np.ndarray  # (3, 2): rotation, offset
    mount_moved: np.ndarray  # (3,) bool
    C_w_b: np.ndarray  # (F, 3, 3) refined poses
    r_wb_w: np.ndarray  # (F, 3)
    sigma0: float  # a posteriori unit weight (1 = the noise model holds)
    n_fixes: int = 0
    n_assoc: int = 0
    n_downweighted: int = 0
    mounts: bool = False
    info: dict = field(default_factory=dict)
    # The map's covariance split into a rigid datum part and the rest (datum_split):
    # (B,) sqrt(trace / 3) of each beacon's relative covariance (times the
    # scale that makes the table's fix covariance explain the map's, _sigma_scale), and
    # the datum's 6x6 covariance (shift mm, turn rad about datum_centre): map_datum.json.
    sigma_relative: np.ndarray | None = None
    datum_cov: np.ndarray | None = None
    datum_centre: np.ndarray | None = None


def rigid_jacobian(p: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(3B, 6): how a rigid motion of the map (a shift dt, a small turn dth about c) moves
    each beacon of p (B, 3): dp_i = dt - [p_i - c]x dth."""
    A = np.zeros((3 * len(p), 6))
    for i, pi in enumerate(p):
        A[3 * i : 3 * i + 3, :3] = np.eye(3)
        A[3 * i : 3 * i + 3, 3:] = -skew(pi - c)
    return A


def datum_split(p: np.ndarray, cov_bb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The map's covariance (3B x 3B, beacon order, refined positions p (B, 3)) split into a
    rigid motion of the whole map -- the datum: a shift dt and a turn dth about the centroid
    c, dp_i = dt - [p_i - c]x dth -- and what no rigid motion explains (the beacons relative
    to each other) -> (datum covariance (6, 6) over (dt mm, dth rad), per-beacon relative
    sigma (B,) = sqrt(trace / 3) of its 3x3 block, centroid (3,)).

    The relative sigma is the isotropic one of the same total variance, not the largest
    axis: the relative blocks are elongated (median axis ratios 1 : 0.2 : 0.1 on the
    module's 24-minute logs, the long axis along the survey flight's lines of sight, which
    a view along them does not see), and the largest axis written as isotropic made every
    fix's covariance conservative (16 fresh paths: mean NEES 4.0; per coordinate the
    relative errors were 0.31 of the variance it stated, 0.4-0.9 with trace / 3).

    The datum part is the covariance of the least-squares rigid fit of the error field
    (A^+ C A^+^T), the relative part (I - A A^+) C (I - A A^+)^T. Why it matters
    (docs/self_survey.md "Which part of the 1-sigma is the map's"): a pose moves rigidly
    with the map, so the datum enters a fix once, where the same error written into each
    beacon as independent is multiplied by a weak geometry."""
    p = np.asarray(p, dtype=float)
    n = len(p)
    c = p.mean(axis=0)
    A = rigid_jacobian(p, c)
    Ap = np.linalg.pinv(A)  # (A^T A)^-1 A^T; pinv also holds a degenerate (collinear) map
    cov_d = Ap @ cov_bb @ Ap.T
    P = np.eye(3 * n) - A @ Ap
    rel = P @ cov_bb @ P.T
    blocks = [rel[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] for i in range(n)]
    sig = np.sqrt(np.maximum([np.trace(b) / 3.0 for b in blocks], 0.0))
    return 0.5 * (cov_d + cov_d.T), sig, c


def whitening(cov_uv: np.ndarray, floor_px: float) -> np.ndarray:
    """(M, 2, 2) covariances + floor^2 I -> W with W^T W = R^-1 (inverse Cholesky factor)."""
    r = cov_uv + floor_px**2 * np.eye(2)
    L = np.linalg.cholesky(r)
    return np.linalg.inv(L)


def build_problem(
    fixes: list[Fix],
    cams: list[Camera],
    ids,
    p_survey,
    sigma_survey,
    mounts: bool = False,
    pixel_floor_px: float = PIXEL_FLOOR_PX,
    mount_sigma: tuple[float, float] | None = None,
) -> Problem:
    """The adjustment's data from fixes (fixlog.Fix) and the survey; associations to a
    beacon the survey does not list are refused (a fix log of another map)."""
    if not fixes:
        raise MfnsError("no fixes to refine from (a fix log of usable fixes is needed)")
    ids = np.asarray(ids, dtype=int)
    index = {int(i): n for n, i in enumerate(ids)}
    fx, cm, be, uv, cv_list = [], [], [], [], []
    for f_i, f in enumerate(fixes):
        for c, b, u, r in zip(f.camera, f.beacon_id, f.uv, f.cov_uv, strict=True):
            if int(b) not in index:
                raise MfnsError(
                    f"fix of cycle {f.cycle}: beacon id {int(b)} is not in the survey's beacons.csv"
                )
            fx.append(f_i)
            cm.append(int(c))
            be.append(index[int(b)])
            uv.append(u)
            cv_list.append(r)
    cv = np.asarray(cv_list, dtype=float).reshape(-1, 2, 2)
    if not np.all(np.isfinite(cv)):
        raise MfnsError("a centroid covariance of the fix log is not finite")
    return Problem(
        cams=cams,
        ids=ids,
        p_survey=np.asarray(p_survey, dtype=float),
        sigma_survey=np.asarray(sigma_survey, dtype=float),
        C0=np.array([f.C_w_b for f in fixes]),
        r0=np.array([f.r_wb_w for f in fixes]),
        fix=np.array(fx),
        cam=np.array(cm),
        bea=np.array(be),
        uv=np.asarray(uv, dtype=float).reshape(-1, 2),
        W=whitening(cv, pixel_floor_px),
        mounts=mounts,
        mount_sigma=mount_sigma or (np.deg2rad(MOUNT_SIGMA_DEG), MOUNT_SIGMA_MM),
    )


def _rot_batch(w: np.ndarray) -> np.ndarray:
    return np.array([rot_exp(v) for v in w]).reshape(-1, 3, 3)


def _model(pb: Problem, x: np.ndarray, jac: bool):
    """Whitened residuals (and the sparse Jacobian) at x."""
    f6, b3, m6 = pb.split(x)
    Cwb = pb.C0 @ np.transpose(_rot_batch(f6[:, :3]), (0, 2, 1))  # C0 exp(-[phi])
    r = pb.r0 + f6[:, 3:]
    p_w = pb.p_survey + b3
    Ckb = np.array([rot_exp(m6[k, :3]) @ c.C_k_b for k, c in enumerate(pb.cams)])
    rbk = np.array([c.r_bk_b + m6[k, 3:] for k, c in enumerate(pb.cams)])
    M = len(pb.fix)
    d = p_w[pb.bea] - r[pb.fix]  # (M, 3)
    A = Cwb[pb.fix]  # (M, 3, 3)
    p_b = np.einsum("mij,mj->mi", A, d)
    q = p_b - rbk[pb.cam]
    Mk = np.transpose(Ckb, (0, 2, 1))[pb.cam]  # C_k_b^T
    p_c = np.einsum("mij,mj->mi", Mk, q)
    uv = np.zeros((M, 2))
    D = np.zeros((M, 2, 3))
    for k, c in enumerate(pb.cams):
        s = pb.cam == k
        if np.any(s):
            uv[s], D[s] = c.project_jacobian(p_c[s])
    res_obs = np.einsum("mij,mj->mi", pb.W, uv - pb.uv).ravel()
    prior_b = (b3 / pb.sigma_survey[:, None]).ravel()
    parts = [res_obs, prior_b]
    if pb.mounts:
        parts.append((m6 / np.array([pb.mount_sigma[0]] * 3 + [pb.mount_sigma[1]] * 3)).ravel())
    res = np.concatenate(parts)
    if not jac:
        return res, None
    WD = np.einsum("mij,mjk->mik", pb.W, D)  # (M, 2, 3) d(res)/d(p_c)
    G = np.einsum("mij,mjk->mik", WD, Mk)  # d(res)/d(p_b)
    J_pw = np.einsum("mij,mjk->mik", G, A)  # d/d p_w
    J_phi = np.einsum("mij,mjk->mik", J_pw, np.array([skew(v) for v in d]))  # A [d]x
    blocks = [(J_phi, 6 * pb.fix[:, None] + np.arange(3)), (-J_pw, 6 * pb.fix[:, None] + 3 + np.arange(3))]
    off_b = 6 * pb.n_fix
    blocks.append((J_pw, off_b + 3 * pb.bea[:, None] + np.arange(3)))
    if pb.mounts:
        off_m = off_b + 3 * pb.n_beacon
        J_psi = np.einsum("mij,mjk->mik", WD, np.einsum("mij,mjk->mik", Mk, np.array([skew(v) for v in q])))
        blocks.append((J_psi, off_m + 6 * pb.cam[:, None] + np.arange(3)))
        blocks.append((-np.einsum("mij,mjk->mik", WD, Mk), off_m + 6 * pb.cam[:, None] + 3 + np.arange(3)))
    rows, cols, vals = [], [], []
    row_idx = (2 * np.arange(M))[:, None] + np.arange(2)  # (M, 2)
    for val, col in blocks:
        rows.append(np.broadcast_to(row_idx[:, :, None], val.shape).ravel())
        cols.append(np.broadcast_to(col[:, None, :], val.shape).ravel())
        vals.append(val.ravel())
    n_obs_rows = 2 * M
    nb = 3 * pb.n_beacon
    rows.append(n_obs_rows + np.arange(nb))
    cols.append(off_b + np.arange(nb))
    vals.append(np.repeat(1.0 / pb.sigma_survey, 3))
    if pb.mounts:
        rows.append(n_obs_rows + nb + np.arange(18))
        cols.append(6 * pb.n_fix + nb + np.arange(18))
        vals.append(np.tile(1.0 / np.array([pb.mount_sigma[0]] * 3 + [pb.mount_sigma[1]] * 3), 3))
    J = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(len(res), pb.n_par)
    )
    return res, J


def _huber_weights(res: np.ndarray) -> np.ndarray:
    a = np.abs(res)
    return np.where(a <= HUBER_SIGMA, 1.0, HUBER_SIGMA / np.maximum(a, 1e-12))


def _huber_cost(res: np.ndarray) -> float:
    a = np.abs(res)
    return float(np.sum(np.where(a <= HUBER_SIGMA, 0.5 * a * a, HUBER_SIGMA * (a - 0.5 * HUBER_SIGMA))))


def _schur_parts(H: sp.csc_matrix, pb: Problem):
    """H partitioned as poses (block diagonal 6x6) and the rest: (inverse pose blocks, H_pm, H_mm)."""
    n_p = 6 * pb.n_fix
    Hpp = H[:n_p, :n_p].toarray().reshape(pb.n_fix, 6, pb.n_fix, 6)
    blocks = np.array([np.linalg.inv(Hpp[i, :, i, :]) for i in range(pb.n_fix)])
    return sp.block_diag(blocks, format="csc"), H[:n_p, n_p:], H[n_p:, n_p:].toarray()


def _solve(H: sp.csc_matrix, g: np.ndarray, pb: Problem) -> np.ndarray:
    """H dx = -g by the Schur complement on the pose blocks (exact, sparse)."""
    n_p = 6 * pb.n_fix
    Hpp_inv, Hpm, Hmm = _schur_parts(H, pb)
    gp, gm = g[:n_p], g[n_p:]
    S = Hmm - (Hpm.T @ Hpp_inv @ Hpm).toarray()
    dm = np.linalg.solve(S, -(gm - Hpm.T @ (Hpp_inv @ gp)))
    dp = -(Hpp_inv @ (gp + Hpm @ dm))
    return np.concatenate([dp, dm])


def _marginal_cov(J: sp.csr_matrix, w: np.ndarray, pb: Problem) -> np.ndarray:
    """Covariance of the non-pose parameters (beacons, mounts) from J^T diag(w) J, the poses
    eliminated by their 6x6 blocks (Schur complement)."""
    H = (J.T @ sp.diags(w) @ J).tocsc()
    Hpp_inv, Hpm, Hmm = _schur_parts(H, pb)
    return np.linalg.inv(Hmm - (Hpm.T @ Hpp_inv @ Hpm).toarray())


def _irls(pb: Problem, x: np.ndarray, max_iter: int) -> tuple[np.ndarray, dict]:
    """Levenberg-Marquardt on the Huber cost by iteratively reweighted normal equations,
    solved exactly through the pose blocks' Schur complement. Stops when the cost changes
    by less than 1e-9 of itself (or after max_iter)."""
    res, J = _model(pb, x, True)
    cost = _huber_cost(res)
    lam, iterations = 1e-4, 0
    for it in range(1, max_iter + 1):
        iterations = it
        w = _huber_weights(res)
        JW = J.T @ sp.diags(w)
        H = (JW @ J).tocsc()
        g = JW @ res
        H = H + sp.diags(lam * H.diagonal() + 1e-12)
        dx = _solve(H.tocsc(), g, pb)
        res_n, J_n = _model(pb, x + dx, True)
        cost_n = _huber_cost(res_n)
        if cost_n <= cost:
            done = cost - cost_n < 1e-9 * cost
            x, res, J, cost = x + dx, res_n, J_n, cost_n
            lam = max(lam / 10.0, 1e-9)
            if done:
                break
        else:
            lam *= 10.0
            if lam > 1e6:
                break
    return x, {"iterations": iterations, "cost": cost, "damping": lam}


def _sigma_scale(
    pb: Problem,
    J: sp.csr_matrix,
    cov_bb: np.ndarray,
    lam: np.ndarray,
    n_fix: int = 100,
    datum: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> float:
    """The scale s >= 1 of the written sigmas (s * sqrt(lam), independent per beacon) with
    which a fix's covariance explains the map's correlated error on average over (up to
    n_fix of) the logged fixes: mean tr(P_tab(s)^-1 P_map) / 6 = 1, by bisection.

    datum (covariance (6, 6), centre (3,), map (B, 3); datum_split's): the table also
    carries the map's rigid part, which moves a fix rigidly: P_tab(s) then adds its
    term G A Sigma_d A^T G^T (A: the beacons' rigid-motion Jacobian), as the flight solver
    adds it (mfns_pose_add_datum_term), and lam are the relative parts."""
    off_b = 6 * pb.n_fix
    picks = np.unique(np.linspace(0, pb.n_fix - 1, min(n_fix, pb.n_fix)).astype(int))
    Jc = J.tocsc()
    per_fix = []
    for f in picks:
        obs = np.nonzero(pb.fix == f)[0]
        rows = np.ravel(np.column_stack([2 * obs, 2 * obs + 1]))
        Jf = Jc[rows, :]
        Jp = Jf[:, 6 * f : 6 * f + 6].toarray()
        bs = np.unique(pb.bea[obs])
        cols = np.ravel(off_b + 3 * bs[:, None] + np.arange(3))
        Jb = Jf[:, cols].toarray()
        cidx = np.ravel(3 * bs[:, None] + np.arange(3))
        A = Jp.T @ Jp
        Ai = np.linalg.inv(A)
        G = Ai @ Jp.T @ Jb
        P_map = Ai + G @ cov_bb[np.ix_(cidx, cidx)] @ G.T
        D = np.zeros((6, 6))
        if datum is not None:
            cov_d, c, pmap = datum
            GA = G @ rigid_jacobian(pmap[bs], c)
            D = GA @ cov_d @ GA.T
        # each observation's 2x2 map term under the table's model: J_b,i s^2 lam_b J_b,i^T
        lam_o = lam[pb.bea[obs]]
        Jbo = np.array(
            [
                Jb[2 * i : 2 * i + 2, 3 * int(np.searchsorted(bs, pb.bea[o])) :][:, :3]
                for i, o in enumerate(obs)
            ]
        )
        per_fix.append((Jp, P_map, lam_o, Jbo, D))

    def ratio(s: float) -> float:
        r = []
        for Jp, P_map, lam_o, Jbo, D in per_fix:
            info = np.zeros((6, 6))
            for i in range(len(lam_o)):
                R = np.eye(2) + s * s * lam_o[i] * Jbo[i] @ Jbo[i].T
                Ji = Jp[2 * i : 2 * i + 2]
                info += Ji.T @ np.linalg.solve(R, Ji)
            P_tab = np.linalg.inv(info) + D
            r.append(np.trace(np.linalg.solve(P_tab, P_map)) / 6.0)
        return float(np.mean(r))

    lo, hi = 1.0, 10.0
    if ratio(lo) <= 1.0:
        return lo
    for _ in range(40):  # bisection on a decreasing function: 40 halvings of [1, 10]
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ratio(mid) > 1.0 else (lo, mid)
    return hi


# unit_weight: the clipping's bound of iterations (it converges in a few: the clip moves
# only with the scale) and its relative tolerance.
UNIT_WEIGHT_MAX_ITER = 50
UNIT_WEIGHT_RTOL = 1e-9


def unit_weight(r: np.ndarray, n_par: int) -> float:
    """The a posteriori unit weight of whitened residuals r (n_par parameters fitted):
    the RMS of the residuals within HUBER_SIGMA of its own scale, the truncation's variance
    divided out, found as the fixed point s = rms(r[|r| <= HUBER_SIGMA s]) / sqrt(0.973)
    from the median absolute residual.

    Why clipped: gross outliers (a blob re-associated with a far beacon, thousands of
    sigma) would set a plain RMS: measured on seed 2's 24-minute survey flight, 13 of
    7,734 residuals made it 1.81 where the 7,721 others give 0.92, every beacon's
    covariance was inflated 3.3 times and the refined map flew NEES 1.83.
    Why the clip follows the scale: a clip fixed at HUBER_SIGMA (in the noise model's
    sigma) would cut a noise model wrong by a factor k into its own centre and return
    about 1.6 for k = 3, leaving the map's sigma overconfident; at the fixed point the
    clip is 3 of the data's own sigma whatever k is.
    Misses: outliers within 3 sigma (they count as noise: a slightly larger unit weight,
    the safe side) and a share of gross outliers above about half the residuals (the
    median start is theirs)."""
    a = np.abs(np.asarray(r, dtype=float))
    s = float(np.median(a)) / float(norm.ppf(0.75))
    if not s > 0.0:
        return 0.0
    for _ in range(UNIT_WEIGHT_MAX_ITER):
        keep = a <= HUBER_SIGMA * s
        dof = max(1, int(np.count_nonzero(keep)) - n_par)
        s_new = float(np.sqrt(np.sum(a[keep] ** 2) / dof / HUBER_TRUNC_VAR))
        if abs(s_new - s) <= UNIT_WEIGHT_RTOL * s:
            return s_new
        s = s_new
    return s


def refine(pb: Problem, max_iter: int = 30, polish_nfev: int = 3) -> Result:
    x, info = _irls(pb, np.zeros(pb.n_par), max_iter)
    if polish_nfev > 0:
        # scipy's least_squares (Huber loss, the sparse Jacobian) from that start: its
        # first-order test confirms the optimum (alone, from the fixes' poses, its LSMR
        # trust region needs hundreds of evaluations: docs/self_survey.md)
        sol = least_squares(
            lambda v: _model(pb, v, False)[0],
            x,
            jac=lambda v: _model(pb, v, True)[1],
            method="trf",
            loss="huber",
            f_scale=HUBER_SIGMA,
            tr_solver="lsmr",
            x_scale="jac",
            max_nfev=polish_nfev,
        )
        if _huber_cost(_model(pb, sol.x, False)[0]) <= info["cost"]:
            x = sol.x
        info["least_squares"] = {"nfev": int(sol.nfev), "optimality": float(sol.optimality)}
    res, J = _model(pb, x, True)
    w = _huber_weights(res)
    n_obs_res = 2 * len(pb.fix)
    sigma0 = unit_weight(res[:n_obs_res], 6 * pb.n_fix)
    cov = _marginal_cov(J, w, pb) * max(1.0, sigma0**2)  # never claim better than the data show
    f6, b3, m6 = pb.split(x)
    nb = pb.n_beacon
    cov_b = np.array([cov[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] for i in range(nb)])
    # the move test: d = refined - survey; under "not moved" its covariance is the
    # survey's minus the refined estimate's (the estimate used the survey as its prior)
    chi = np.zeros(nb)
    for i in range(nb):
        cd = pb.sigma_survey[i] ** 2 * np.eye(3) - cov_b[i]
        ev, vec = np.linalg.eigh(cd)
        ev = np.maximum(ev, 0.05 * pb.sigma_survey[i] ** 2)  # a beacon the data barely see
        chi[i] = float(b3[i] @ (vec @ np.diag(1.0 / ev) @ vec.T) @ b3[i])
    # The written sigma: the table weighs beacons as independent, but the refined map's
    # errors are correlated (the datum: a shift common to every beacon, which every fix
    # sees whole). The written sigma is sqrt(lambda_max) of each beacon's covariance times
    # one scale s >= 1, chosen so that on the logged fixes' own geometry the fix covariance
    # the table will give, P_tab(s), explains the one the full map covariance implies,
    # P_map: mean over fixes of tr(P_tab^-1 P_map) / 6 = 1 (the expected NEES / 6).
    lam = np.array([np.linalg.eigvalsh(c).max() for c in cov_b])
    s_scale = _sigma_scale(pb, J, cov[: 3 * nb, : 3 * nb], lam)
    sig = s_scale * np.sqrt(lam)
    cbb = cov[: 3 * nb, : 3 * nb].reshape(nb, 3, nb, 3)
    info["sigma_datum_mm"] = float(np.sqrt(np.linalg.eigvalsh(cbb.sum(axis=(0, 2)) / nb**2).max()))
    info["sigma_scale"] = float(s_scale)
    p_ref = pb.p_survey + b3  # the refined map
    cov_d, sig_rel, centroid = datum_split(p_ref, cov[: 3 * nb, : 3 * nb])
    # the relative sigmas the table carries beside the datum, scaled as the written ones
    # are (their correlations left out), now with the datum's term in the fix covariance
    s_rel = _sigma_scale(pb, J, cov[: 3 * nb, : 3 * nb], sig_rel**2, datum=(cov_d, centroid, p_ref))
    info["sigma_relative_scale"] = float(s_rel)
    sig_rel = s_rel * sig_rel
    info["datum"] = {
        "centroid_mm": [round(float(v), 3) for v in centroid],
        "sigma_shift_mm": [round(float(v), 4) for v in np.sqrt(np.diag(cov_d)[:3])],
        "sigma_turn_deg": [round(float(v), 5) for v in np.degrees(np.sqrt(np.diag(cov_d)[3:]))],
        "relative_sigma_median_mm": round(float(np.median(sig_rel)), 4),
    }
    n_obs = np.bincount(pb.bea, minlength=nb)
    rot = np.zeros((3, 3))
    off = np.zeros((3, 3))
    mchi = np.zeros((3, 2))
    mmoved = np.zeros(3, bool)
    if pb.mounts:
        med = np.median(m6, axis=0)
        rel = m6 - med
        o = 3 * nb
        for k in range(3):
            # a mount is seen only against the others (their common mode is a body pose):
            # test k against each other camera j, psi_k - psi_j with its covariance (the
            # common mode cancels); k moved when it differs from both (min of the two)
            best = np.full(2, np.inf)
            for j in range(3):
                if j == k:
                    continue
                dk = m6[k] - m6[j]
                ck = cov[o + 6 * k : o + 6 * k + 6, o + 6 * k : o + 6 * k + 6]
                cj = cov[o + 6 * j : o + 6 * j + 6, o + 6 * j : o + 6 * j + 6]
                ckj = cov[o + 6 * k : o + 6 * k + 6, o + 6 * j : o + 6 * j + 6]
                cd = ck + cj - ckj - ckj.T
                best[0] = min(best[0], float(dk[:3] @ np.linalg.solve(cd[:3, :3], dk[:3])))
                best[1] = min(best[1], float(dk[3:] @ np.linalg.solve(cd[3:, 3:], dk[3:])))
            mchi[k] = best
        mmoved = np.asarray((mchi > CHI2_3).any(axis=1))
        rot = np.rad2deg(rel[:, :3])
        off = rel[:, 3:]
    Cwb = pb.C0 @ np.transpose(_rot_batch(f6[:, :3]), (0, 2, 1))
    return Result(
        ids=pb.ids,
        p_survey=pb.p_survey,
        sigma_survey=pb.sigma_survey,
        p=p_ref,
        cov=cov_b,
        sigma=sig,
        chi2_moved=chi,
        moved=chi > CHI2_3,
        n_obs=n_obs,
        mount_rot_deg=rot,
        mount_off_mm=off,
        mount_chi2=mchi,
        mount_moved=mmoved,
        C_w_b=Cwb,
        r_wb_w=pb.r0 + f6[:, 3:],
        sigma0=sigma0,
        n_fixes=pb.n_fix,
        n_assoc=len(pb.fix),
        n_downweighted=int(np.sum(w[:n_obs_res] < 1.0)),
        mounts=pb.mounts,
        info=info,
        sigma_relative=sig_rel,
        datum_cov=cov_d,
        datum_centre=centroid,
    )


def refined_rig_doc(doc: dict, res: Result) -> dict:
    """The calibration document with each camera's mount corrected by the refinement
    (median-recentred), for `mfns table build`."""
    out = json.loads(json.dumps(doc))
    for k, e in enumerate(out["cameras"]):
        c = rot_exp(np.deg2rad(res.mount_rot_deg[k])) @ np.asarray(e["C_k_b"], dtype=float)
        c, _ = np.linalg.qr(c)  # orthonormal to rounding (the loader checks it)
        c = c * np.sign(np.diag(c))[None, :]
        e["C_k_b"] = c.tolist()
        e["euler_213_deg"] = matrix_to_euler213_deg(c).tolist()
        e["r_bk_b"] = (np.asarray(e["r_bk_b"], dtype=float) + res.mount_off_mm[k]).tolist()
    out["source"] = f"{doc.get('source', '')} + mfns map refine (mounts)".strip()
    return out


def write_beacons(path: Path, res: Result) -> None:
    """beacons.csv of the refined map: id, position, sigma_mm (the refinement's)."""
    with open(path, "w") as f:
        f.write(",".join(BEACON_COLUMNS) + "\n")
        for i, p, s in zip(res.ids, res.p, res.sigma, strict=True):
            f.write(f"{int(i)},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},{max(s, 1e-4):.4f}\n")


def report(res: Result) -> dict:
    """The refinement's findings as a JSON-able dict (refine.json)."""
    shift = res.p - res.p_survey
    return {
        "fixes": res.n_fixes,
        "associations": res.n_assoc,
        "downweighted_residuals": res.n_downweighted,
        "sigma0": round(res.sigma0, 4),
        "chi2_3_level": round(CHI2_3, 3),
        "p_false_alarm": P_FALSE_ALARM,
        "solver": res.info,
        "beacons": [
            {
                "id": int(i),
                "shift_mm": [round(float(v), 4) for v in d],
                "sigma_mm": round(float(s), 4),
                "sigma_relative_mm": None
                if res.sigma_relative is None
                else round(float(res.sigma_relative[k]), 4),
                "chi2": round(float(c), 2),
                "moved": bool(m),
                "observations": int(n),
            }
            for k, (i, d, s, c, m, n) in enumerate(
                zip(res.ids, shift, res.sigma, res.chi2_moved, res.moved, res.n_obs, strict=True)
            )
        ],
        "moved_beacons": [int(i) for i in res.ids[res.moved]],
        "mounts": None
        if not res.mounts
        else [
            {
                "camera": CAMERA_NAMES[k],
                "rotation_deg": [round(float(v), 5) for v in res.mount_rot_deg[k]],
                "offset_mm": [round(float(v), 4) for v in res.mount_off_mm[k]],
                "chi2_rotation": round(float(res.mount_chi2[k, 0]), 2),
                "chi2_offset": round(float(res.mount_chi2[k, 1]), 2),
                "moved": bool(res.mount_moved[k]),
            }
            for k in range(3)
        ],
    }
