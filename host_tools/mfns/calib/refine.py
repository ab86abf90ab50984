"""Joint maximum-likelihood refinement of the whole rig through the turntable kinematic chain.

Unknowns: per camera the intrinsics (fx, fy, cx, cy, k1, k2, p1, p2, k3; skew fixed at 0),
the mount attitude C_k_b = exp([d x]) C0 (d in the body frame) and r_bk_b; the rig's
C_t_w = exp([d x]) C0 (d in the world frame), r_wt_w and h of r_tb_b = (0, 0, h); per
turntable image the errors of the recorded angles (prior N(0, 8")); per prepared image the
board pose (C_w_k = exp([d x]) R0, t). Observations: every corner (N(0, sigma_px) per
coordinate), the angle priors and the caliper height (-r_wb_w[2], N(0, sigma_caliper)).
All residuals are whitened, so the Gauss-Newton covariance (J^T J)^-1 is the estimate's
covariance and, evaluated at the truth, the Cramér-Rao bound of the dataset's geometry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from ..core.errors import MfnsError
from ..model.camera import Camera
from ..model.rotations import rot_exp, rot_log
from .model import Observations, Rig
from .zhang import INTRINSIC_NAMES

N_CAM = 15  # per camera: 9 intrinsics, 3 attitude, 3 position
N_RIG = 7  # after the cameras: d_t (3), r_wt (3), h (1)


def rig0(n_cams: int) -> int:
    """Start of the rig block in the parameter vector."""
    return n_cams * N_CAM


def _rot_stack(axis: int, a: np.ndarray) -> np.ndarray:
    """Active rotations about x (axis 0) or z (axis 2) for an array of angles: (n, 3, 3)."""
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    if axis == 0:
        m = [[o, z, z], [z, c, -s], [z, s, c]]
    else:
        m = [[c, -s, z], [s, c, z], [z, z, o]]
    return np.moveaxis(np.array(m), (0, 1), (1, 2))


def _project(intr: np.ndarray, p_c: np.ndarray) -> np.ndarray:
    """Camera-frame points through intrinsics [fx, fy, cx, cy, k1, k2, p1, p2, k3] (skew 0)."""
    lens = Camera("", intr[0], intr[1], intr[2], intr[3], 0.0, intr[4:9])
    return lens.normalized_to_pixel(p_c[..., :2] / p_c[..., 2:3])


@dataclass
class Start:
    """A starting point (also the reference rotations of the parametrisation)."""

    intr: list[np.ndarray]  # per camera, INTRINSIC_NAMES order
    C_k_b: list[np.ndarray]
    r_bk_b: list[np.ndarray]
    C_t_w: np.ndarray
    r_wt_w: np.ndarray
    h: float
    prepared: list[tuple[np.ndarray, np.ndarray]]  # per prepared image (C_w_k, t)

    @classmethod
    def from_rig(cls, rig: Rig, prepared) -> Start:
        return cls(
            [np.array([c.fx, c.fy, c.cx, c.cy, *c.dist]) for c in rig.cams],
            [np.asarray(c.C_k_b, float) for c in rig.cams],
            [np.asarray(c.r_bk_b, float) for c in rig.cams],
            np.asarray(rig.C_t_w, float),
            np.asarray(rig.r_wt_w, float),
            float(rig.r_tb_b[2]),
            prepared,
        )


class Problem:
    def __init__(self, obs: Observations, start: Start, sigma_px: float):
        self.obs, self.start, self.sigma_px = obs, start, sigma_px
        self.obj = obs.board.object_points()
        self.n_cams = obs.n_cams
        self.rig0 = r0 = rig0(self.n_cams)
        self.tt = [im for im in obs.images if im.kind == "turntable"]
        self.prep = [im for im in obs.images if im.kind == "prepared"]
        if len(self.prep) != len(start.prepared):
            raise ValueError("one start pose per prepared image needed")
        self.tt_cam = np.array([im.camera for im in self.tt], dtype=int)
        self.tt_big = np.deg2rad([im.omega_big_deg for im in self.tt])
        self.tt_small = np.deg2rad([im.omega_small_deg for im in self.tt])
        # corners not seen (partial views) have weight 0 and a placeholder observation
        self.uv_tt = np.array([im.uv for im in self.tt]).reshape(len(self.tt), -1, 2)
        self.uv_prep = np.array([im.uv for im in self.prep]).reshape(len(self.prep), -1, 2)
        self.w_tt = np.isfinite(self.uv_tt).all(axis=2)[..., None].astype(float)
        self.w_prep = np.isfinite(self.uv_prep).all(axis=2)[..., None].astype(float)
        self.uv_tt = np.nan_to_num(self.uv_tt)
        self.uv_prep = np.nan_to_num(self.uv_prep)
        self.n_tt, self.n_prep = len(self.tt), len(self.prep)
        self.ang0 = r0 + N_RIG
        self.prep0 = self.ang0 + 2 * self.n_tt
        self.n = self.prep0 + 6 * self.n_prep
        self.n_corner_slots = 2 * obs.board.n * (self.n_tt + self.n_prep)  # residual rows, seen or not
        self.n_corner_res = int(2 * (self.w_tt.sum() + self.w_prep.sum()))  # observed coordinates

    def x0(self) -> np.ndarray:
        s = self.start
        r0 = self.rig0
        x = np.zeros(self.n)
        for k in range(self.n_cams):
            x[N_CAM * k : N_CAM * k + 9] = s.intr[k]
            x[N_CAM * k + 12 : N_CAM * k + 15] = s.r_bk_b[k]
        x[r0 + 3 : r0 + 6] = s.r_wt_w
        x[r0 + 6] = s.h
        for i, (_r, t) in enumerate(s.prepared):
            x[self.prep0 + 6 * i + 3 : self.prep0 + 6 * i + 6] = t
        return x

    # --- unpacking ------------------------------------------------------------------------
    def C_k_b(self, x, k):
        return rot_exp(x[N_CAM * k + 9 : N_CAM * k + 12]) @ self.start.C_k_b[k]

    def C_t_w(self, x):
        return rot_exp(x[self.rig0 : self.rig0 + 3]) @ self.start.C_t_w

    def rig(self, x) -> Rig:
        r0 = self.rig0
        cams = []
        for k in range(self.n_cams):
            fx, fy, cx, cy, *dist = x[N_CAM * k : N_CAM * k + 9]
            cams.append(
                Camera(
                    name=self.obs.camera_names[k],
                    fx=fx,
                    fy=fy,
                    cx=cx,
                    cy=cy,
                    dist=np.array(dist),
                    width=self.obs.image_size[0],
                    height=self.obs.image_size[1],
                    C_k_b=self.C_k_b(x, k),
                    r_bk_b=x[N_CAM * k + 12 : N_CAM * k + 15].copy(),
                )
            )
        return Rig(cams, self.C_t_w(x), x[r0 + 3 : r0 + 6].copy(), np.array([0.0, 0.0, x[r0 + 6]]))

    # --- residuals ---------------------------------------------------------------------------
    def residuals(self, x: np.ndarray) -> np.ndarray:
        r0 = self.rig0
        c_t_w = self.C_t_w(x)
        r_wt = x[r0 + 3 : r0 + 6]
        r_tb = np.array([0.0, 0.0, x[r0 + 6]])
        out = []
        if self.n_tt:
            d_ang = x[self.ang0 : self.prep0].reshape(-1, 2)
            a = c_t_w @ (
                _rot_stack(0, self.tt_small + d_ang[:, 1]) @ _rot_stack(2, self.tt_big + d_ang[:, 0])
            )
            c_kb = np.array([self.C_k_b(x, k) for k in range(self.n_cams)])[self.tt_cam]
            r_bk = np.array([x[N_CAM * k + 12 : N_CAM * k + 15] for k in range(self.n_cams)])[self.tt_cam]
            c_kw = a @ c_kb
            r_wk = r_wt + np.einsum("nij,nj->ni", a, r_tb + r_bk)
            p_c = np.einsum("npj,njk->npk", self.obj[None] - r_wk[:, None, :], c_kw)
            uv = np.empty_like(self.uv_tt)
            for k in range(self.n_cams):
                m = self.tt_cam == k
                uv[m] = _project(x[N_CAM * k : N_CAM * k + 9], p_c[m])
            out.append(((uv - self.uv_tt) * (self.w_tt / self.sigma_px)).ravel())
        if self.n_prep:
            uvp = np.empty_like(self.uv_prep)
            for i, im in enumerate(self.prep):
                p = x[self.prep0 + 6 * i : self.prep0 + 6 * i + 6]
                r = rot_exp(p[:3]) @ self.start.prepared[i][0]
                k = im.camera
                uvp[i] = _project(x[N_CAM * k : N_CAM * k + 9], self.obj @ r.T + p[3:])
            out.append(((uvp - self.uv_prep) * (self.w_prep / self.sigma_px)).ravel())
        out.append(x[self.ang0 : self.prep0] / self.obs.angle_sigma_rad)
        r_wb_z = r_wt[2] + (c_t_w @ r_tb)[2]
        out.append(np.array([(r_wb_z + self.obs.caliper_height_mm) / self.obs.caliper_sigma_mm]))
        return np.concatenate(out)

    def sparsity(self):
        r0 = self.rig0
        n_c = 2 * self.obs.board.n
        m = self.n_corner_slots + 2 * self.n_tt + 1
        s = lil_matrix((m, self.n), dtype=int)
        row = 0
        for j, im in enumerate(self.tt):
            k = im.camera
            s[row : row + n_c, N_CAM * k : N_CAM * (k + 1)] = 1
            s[row : row + n_c, r0 : r0 + N_RIG] = 1
            s[row : row + n_c, self.ang0 + 2 * j : self.ang0 + 2 * j + 2] = 1
            row += n_c
        for i, im in enumerate(self.prep):
            k = im.camera
            s[row : row + n_c, N_CAM * k : N_CAM * k + 9] = 1
            s[row : row + n_c, self.prep0 + 6 * i : self.prep0 + 6 * i + 6] = 1
            row += n_c
        for j in range(2 * self.n_tt):
            s[row + j, self.ang0 + j] = 1
        s[m - 1, r0 : r0 + N_RIG] = 1
        return s.tocsr()

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Dense central-difference Jacobian, columns grouped by the sparsity pattern."""
        s = self.sparsity()
        conflict = (s.T @ s).tocsr()
        groups: list[list[int]] = []
        color = -np.ones(self.n, dtype=int)
        for j in range(self.n):
            used = {
                color[i]
                for i in conflict.indices[conflict.indptr[j] : conflict.indptr[j + 1]]
                if color[i] >= 0
            }
            c = next(g for g in range(self.n + 1) if g not in used)
            color[j] = c
            if c == len(groups):
                groups.append([])
            groups[c].append(j)
        sc = s.tocsc()
        jac = np.zeros((s.shape[0], self.n))
        h = 1e-6 * np.maximum(1.0, np.abs(x))
        for g in groups:
            dx = np.zeros(self.n)
            dx[g] = h[g]
            d = (self.residuals(x + dx) - self.residuals(x - dx)) / 2.0
            for j in g:
                rows = sc.indices[sc.indptr[j] : sc.indptr[j + 1]]
                jac[rows, j] = d[rows] / h[j]
        return jac

    # --- quantities ----------------------------------------------------------------------------
    def quantity_jacobian(self, x: np.ndarray) -> tuple[list[str], np.ndarray]:
        """Map from parameter perturbations to the reported quantities (see quantities())."""
        r0 = self.rig0
        names, rows = [], []
        for k in range(self.n_cams):
            cam = self.obs.camera_names[k]
            for i, nm in enumerate(INTRINSIC_NAMES):
                names.append(f"{cam}.{nm}")
                rows.append(_unit(self.n, N_CAM * k + i))
            for i in range(3):
                names.append(f"{cam}.rot{'xyz'[i]}")
                rows.append(_unit(self.n, N_CAM * k + 9 + i) * np.rad2deg(1.0))
            for i in range(3):
                names.append(f"{cam}.r_b{cam}{'xyz'[i]}")
                rows.append(_unit(self.n, N_CAM * k + 12 + i))
        for i in range(3):
            names.append(f"C_t_w.rot{'xyz'[i]}")
            rows.append(_unit(self.n, r0 + i) * np.rad2deg(1.0))
        for i in range(3):
            names.append(f"r_wt_w.{'xyz'[i]}")
            rows.append(_unit(self.n, r0 + 3 + i))
        names.append("r_tb_b.z")
        rows.append(_unit(self.n, r0 + 6))
        c_t_w = self.C_t_w(x)
        r_tb = np.array([0.0, 0.0, x[r0 + 6]])
        v = c_t_w @ r_tb
        dv_dd = -np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])  # d(exp(d)v)/dd
        for i in range(3):
            row = np.zeros(self.n)
            row[r0 + 3 + i] = 1.0
            row[r0 + 6] = c_t_w[i, 2]
            row[r0 : r0 + 3] = dv_dd[i]
            names.append(f"r_wb_w.{'xyz'[i]}")
            rows.append(row)
        return names, np.array(rows)


def _unit(n: int, i: int) -> np.ndarray:
    e = np.zeros(n)
    e[i] = 1.0
    return e


def quantities(rig: Rig, ref: Rig) -> tuple[list[str], np.ndarray]:
    """Reported quantities of `rig`; rotations as rotation vectors (deg) relative to `ref`.

    Mount attitudes: log(C_k_b ref_C_k_b^T) (body frame); C_t_w: log(C_t_w ref^T) (world).
    With ref = truth these are the attitude errors; positions in mm, intrinsics in px / 1.
    """
    vals = []
    for c, cr in zip(rig.cams, ref.cams, strict=True):
        vals += [c.fx, c.fy, c.cx, c.cy, *c.dist]
        vals += list(np.rad2deg(rot_log(c.C_k_b @ cr.C_k_b.T)))
        vals += list(c.r_bk_b)
    vals += list(np.rad2deg(rot_log(rig.C_t_w @ ref.C_t_w.T)))
    vals += list(rig.r_wt_w)
    vals.append(rig.r_tb_b[2])
    vals += list(rig.r_wb_w)
    names = []
    for cam in (c.name for c in rig.cams):
        names += [f"{cam}.{n}" for n in INTRINSIC_NAMES]
        names += [f"{cam}.rot{a}" for a in "xyz"]
        names += [f"{cam}.r_b{cam}{a}" for a in "xyz"]
    names += [f"C_t_w.rot{a}" for a in "xyz"] + [f"r_wt_w.{a}" for a in "xyz"] + ["r_tb_b.z"]
    names += [f"r_wb_w.{a}" for a in "xyz"]
    return names, np.array(vals, dtype=float)


# Observability of the joint model (issue 28 item 2): a direction of the parameters whose
# singular value, in the Jacobian with unit-norm columns, is below UNOBSERVABLE_RCOND of the
# largest is not determined by the images (the information along it is 1e-16 of the best
# determined one: a 1-sigma 1e8 times larger, i.e. nothing). Float64 leaves ~1e-16 of noise
# on the singular values of a well-posed problem, far below; the well-posed rigs of the tests
# sit at 1e-4 and above. The parameters with a weight above UNOBSERVABLE_SHARE in such a
# direction are named in the refusal.
UNOBSERVABLE_RCOND = 1e-8
UNOBSERVABLE_SHARE = 0.3
MAX_NAMED = 8  # names in the one-line refusal (many weak directions usually mean a failed solve)


def parameter_names(prob: Problem) -> list[str]:
    """A name for every entry of the parameter vector (the refusal's words)."""
    names = []
    for k in range(prob.n_cams):
        cam = prob.obs.camera_names[k]
        names += [f"camera {cam} {n}" for n in INTRINSIC_NAMES]
        names += [f"camera {cam} mount attitude C_k_b ({a})" for a in "xyz"]
        names += [f"camera {cam} mount position r_bk_b ({a})" for a in "xyz"]
    names += [f"turntable attitude C_t_w ({a})" for a in "xyz"]
    names += [f"turntable position r_wt_w ({a})" for a in "xyz"]
    names += ["body height h above the turntable"]
    for im in prob.tt:
        names += [f"angles of {prob.obs.camera_names[im.camera]}/{im.name} ({a})" for a in ("Omega", "omega")]
    for im in prob.prep:
        names += [f"board pose of {prob.obs.camera_names[im.camera]}/{im.name}"] * 6
    return names


def _fix_hint(name: str) -> str:
    if name.startswith("camera ") and "mount" in name:
        cam = name.split()[1]
        return (
            f"turntable images in which camera {cam} sees the board at several turns (about both "
            "axes, or about one axis when another camera sees turns about both)"
        )
    if name.startswith("camera "):
        cam = name.split()[1]
        return f"more images of camera {cam} with the board filling the view at varied tilts"
    if name.startswith("turntable"):
        return (
            "turntable images turned about both axes (Omega and omega) in at least one camera, or "
            "cameras whose images turn about different axes"
        )
    if name.startswith("body height"):
        return "the caliper height (dataset caliper_height_mm)"
    return "the image named, or drop it"


def check_observable(jac: np.ndarray, prob: Problem, where: str = "the refined solution") -> None:
    """Refuse, naming the parameters, when the images do not determine them (the information
    of the joint model: rank and conditioning of the Jacobian), rather than print NaN sigmas."""
    scale = np.linalg.norm(jac, axis=0)
    dead = scale == 0
    scale[dead] = 1.0
    _u, sv, vt = np.linalg.svd(jac / scale, full_matrices=False)
    weak = vt[sv < UNOBSERVABLE_RCOND * sv[0]]
    if not dead.any() and len(weak) == 0:
        return
    names = parameter_names(prob)
    seen: dict[str, None] = {}
    hints: dict[str, None] = {}
    for i in np.flatnonzero(dead):
        seen.setdefault(names[i], None)
        hints.setdefault(_fix_hint(names[i]), None)
    for v in weak:
        mine = [names[int(i)] for i in np.flatnonzero(np.abs(v) > UNOBSERVABLE_SHARE)]
        seen.update(dict.fromkeys(mine))
        # a direction that moves the turntable is fixed by turns about another axis, whatever
        # else it moves with it (a mount, the body height along the axis)
        tt = [n for n in mine if n.startswith("turntable")]
        hints.update(dict.fromkeys(_fix_hint(n) for n in (tt[:1] or mine)))
    listed = list(seen)[:MAX_NAMED]
    more = f" and {len(seen) - len(listed)} more" if len(seen) > len(listed) else ""
    raise MfnsError(
        f"calibration: the images do not determine {'; '.join(listed)}{more} "
        f"({len(weak) + int(dead.sum())} unobservable directions of the joint model at "
        f"{where}); what would fix it: {'; '.join(list(hints)[:MAX_NAMED])}"
    )


@dataclass
class RefineResult:
    rig: Rig
    x: np.ndarray
    names: list[str]
    sigma: np.ndarray  # 1-sigma of the quantities
    cov_params: np.ndarray
    sigma_px: float
    rms_px: float
    nfev: int
    problem: Problem
    d_angles_deg: np.ndarray
    converged: bool = True  # False: least_squares stopped at max_nfev
    gn_decrease: float = 0.0  # chi2 (at sigma_px) one more Gauss-Newton step would still remove


def solve(obs: Observations, start: Start, sigma_px: float, max_nfev: int = 200, check=None) -> RefineResult:
    """Least squares from `start`; sigma_px re-estimated from the residuals (one re-weighting).

    check(rms_px), if given, runs before the covariance and may refuse the fit.
    """
    # Observability first (a rank deficiency of the model is one of the geometry, not of the
    # point): one Jacobian at the start refuses an unobservable rig before the refinement runs.
    prob = Problem(obs, start, sigma_px)
    check_observable(prob.jacobian(prob.x0()), prob, "the start")
    x: np.ndarray | None = None
    for _ in range(2):
        prob = Problem(obs, start, sigma_px)
        x0 = prob.x0() if x is None else x
        res = least_squares(
            prob.residuals,
            x0,
            jac_sparsity=prob.sparsity(),
            method="trf",
            x_scale="jac",
            xtol=1e-10,
            ftol=1e-10,
            gtol=1e-10,
            max_nfev=max_nfev,
            tr_solver="lsmr",
            tr_options={"atol": 1e-10, "btol": 1e-10, "maxiter": 2000},
        )
        x = res.x
        r = res.fun[: prob.n_corner_slots] * sigma_px
        dof = max(prob.n_corner_res - prob.n, 1)
        new_sigma = max(float(np.sqrt(np.sum(r**2) / dof)), 1e-4)
        if abs(new_sigma / sigma_px - 1.0) < 0.05:
            break
        sigma_px = new_sigma
    rms = float(np.sqrt(np.sum(r**2) / max(prob.n_corner_res, 1)))
    if check is not None:
        check(rms)
    assert x is not None  # the loop above runs at least once
    jac = prob.jacobian(x)
    check_observable(jac, prob)
    try:
        cov = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError as exc:
        raise MfnsError(
            "refinement: singular normal matrix, the images do not determine every parameter"
        ) from exc
    names, qj = prob.quantity_jacobian(x)
    sig = np.sqrt(np.einsum("ij,jk,ik->i", qj, cov, qj))
    d_ang = np.rad2deg(x[prob.ang0 : prob.prep0].reshape(-1, 2))
    grad = jac.T @ res.fun
    return RefineResult(
        prob.rig(x),
        x,
        names,
        sig,
        cov,
        sigma_px,
        rms,
        int(res.nfev),
        prob,
        d_ang,
        bool(res.status > 0),
        float(max(grad @ cov @ grad, 0.0)),
    )


def cramer_rao(obs: Observations, truth: Rig, true_prepared, true_angles_deg, sigma_px: float):
    """1-sigma CRB of the quantities at the truth for this dataset's geometry.

    true_angles_deg: (n_turntable, 2) true (Omega, omega) of the turntable images in the order
    of `obs`; the observations' recorded angles are replaced by them so the angle errors are 0.
    """
    start = Start.from_rig(truth, true_prepared)
    prob = Problem(obs, start, sigma_px)
    x = prob.x0()
    true = np.deg2rad(np.asarray(true_angles_deg, float)).reshape(-1, 2)
    x[prob.ang0 : prob.prep0] = (true - np.column_stack([prob.tt_big, prob.tt_small])).ravel()
    assert x is not None  # the loop above runs at least once
    jac = prob.jacobian(x)
    cov = np.linalg.inv(jac.T @ jac)
    names, qj = prob.quantity_jacobian(x)
    return names, np.sqrt(np.einsum("ij,jk,ik->i", qj, cov, qj))
