"""Consistency of the reported pose covariance: the normalised estimation error squared (NEES).

For every fix matched to truth, the 6-DOF error e = (r_wb_w(est) - r_wb_w(true) in mm,
phi_w in deg) and the covariance P the flight code reported with it give

    NEES = e^T P^-1 e,

which is chi-square distributed with 6 degrees of freedom when P is the covariance of e
(mean 6; 95 % of the fixes below 12.59, 99 % below 16.81). A mean well above 6 means the
reported covariance is too small (optimistic: a fusion filter would trust the fix too
much), well below 6 too large (pessimistic).

Conventions (docs/telemetry.md, nav.csv; docs/conventions.md):
- `q_w,q_x,q_y,q_z`: unit quaternion (Hamilton) of C_b_w = C_w_b^T, the body's orientation
  in the world;
- `cov_<a>_<b>` for a <= b over (x, y, z, rx, ry, rz): the upper triangle, row-major, of the
  covariance in ROS PoseWithCovariance order, position r_wb_w in mm, rotation phi_w in deg
  about the world's fixed axes with C_b_w(est) = exp(phi_w) C_b_w(true); errors estimate
  minus truth; units mm^2, mm deg, deg^2.

A nav.csv without the covariance columns (the telemetry before the full covariance) has only
the 1-sigma columns sigma_{x,y,z}_mm and sigma_{roll,pitch,yaw}_deg: then the NEES is the
*diagonal* one, sum of (error / sigma)^2 over the position and the 2-1-3 Euler-angle errors,
which ignores every correlation and is labelled as such.

Consecutive fixes are not independent (the same beacons, a slowly moving pose, a calibration
bias common to all): the interval given for the mean assumes independence and is the
tightest one could ask for, not a test level.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.csv_formats import COV_AXES as POSE_AXES
from ..core.csv_formats import COV_COLUMNS, COV_PAIRS, SIGMA_COLUMNS
from ..core.errors import MfnsError

POSE_UNITS = ("mm", "mm", "mm", "deg", "deg", "deg")
QUAT_COLUMNS = ("q_w", "q_x", "q_y", "q_z")
DIAG_AXES = ("x", "y", "z", "roll", "pitch", "yaw")
DOF = 6
# A quaternion whose norm is this far from 1 is not a rotation (the wire carries a unit one).
QUAT_NORM_TOLERANCE = 1e-3

FULL = "full"
DIAGONAL = "diagonal"


def chi2_bound(p: float, dof: int = DOF) -> float:
    from scipy.stats import chi2

    return float(chi2.ppf(p, dof))


BOUND_95 = chi2_bound(0.95)  # 12.59
BOUND_99 = chi2_bound(0.99)  # 16.81


def cov_from_columns(upper: np.ndarray) -> np.ndarray:
    """(N, 21) upper triangles in COV_COLUMNS order -> (N, 6, 6) symmetric matrices."""
    upper = np.asarray(upper, dtype=float)
    if upper.ndim != 2 or upper.shape[1] != len(COV_PAIRS):
        raise MfnsError(f"covariance: expected (N, {len(COV_PAIRS)}) upper triangles, got {upper.shape}")
    p = np.zeros((len(upper), 6, 6))
    for k, (i, j) in enumerate(COV_PAIRS):
        p[:, i, j] = upper[:, k]
        p[:, j, i] = upper[:, k]
    return p


def cov_to_columns(p: np.ndarray) -> np.ndarray:
    """(N, 6, 6) -> (N, 21) upper triangles in COV_COLUMNS order."""
    p = np.asarray(p, dtype=float)
    return np.stack([p[:, i, j] for i, j in COV_PAIRS], axis=1)


def quat_to_matrix(q_wxyz: np.ndarray) -> np.ndarray:
    """(N, 4) Hamilton unit quaternions (w, x, y, z) -> (N, 3, 3) rotation matrices R, R v = q v q*.

    For the nav.csv quaternion R is C_b_w. The input is normalised; check the norm first.
    """
    q = np.asarray(q_wxyz, dtype=float).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    r = np.empty((len(q), 3, 3))
    r[:, 0, 0] = 1 - 2 * (y * y + z * z)
    r[:, 0, 1] = 2 * (x * y - w * z)
    r[:, 0, 2] = 2 * (x * z + w * y)
    r[:, 1, 0] = 2 * (x * y + w * z)
    r[:, 1, 1] = 1 - 2 * (x * x + z * z)
    r[:, 1, 2] = 2 * (y * z - w * x)
    r[:, 2, 0] = 2 * (x * z - w * y)
    r[:, 2, 1] = 2 * (y * z + w * x)
    r[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def euler_to_c_w_b(euler_deg: np.ndarray) -> np.ndarray:
    """(N, 3) 2-1-3 Euler angles (roll, pitch, yaw) of C_w_b in deg -> (N, 3, 3) C_w_b."""
    from ..model.rotations import euler213_deg_to_matrix

    e = np.asarray(euler_deg, dtype=float).reshape(-1, 3)
    return np.array([euler213_deg_to_matrix(a) for a in e]).reshape(-1, 3, 3)


def attitude_error_deg(c_b_w_est: np.ndarray, c_b_w_true: np.ndarray) -> np.ndarray:
    """phi_w (deg) with C_b_w(est) = exp(phi_w) C_b_w(true): the rotation vector of
    C_b_w(est) C_b_w(true)^T, about the world's fixed axes. (N, 3, 3) each -> (N, 3)."""
    from scipy.spatial.transform import Rotation

    d = np.einsum("nij,nkj->nik", np.asarray(c_b_w_est, float), np.asarray(c_b_w_true, float))
    if len(d) == 0:
        return np.zeros((0, 3))
    return np.degrees(Rotation.from_matrix(d).as_rotvec())


@dataclass
class Nees:
    """NEES of the fixes of one run (docs/error-analysis.md, "Covariance consistency")."""

    kind: str  # FULL (the 6x6 covariance) or DIAGONAL (the six 1-sigma columns only)
    t_s: np.ndarray  # time of each fix with a usable covariance
    nees: np.ndarray  # e^T P^-1 e of each such fix
    z: np.ndarray  # (M, 6) normalised errors e_i / sqrt(P_ii)
    axes: tuple[str, ...]  # names of the six components (POSE_AXES or DIAG_AXES)
    n_fixes: int  # fixes matched to truth
    n_not_pd: int  # of which the covariance is not positive definite (or not finite)
    n_bad_quat: int = 0  # of which the quaternion is not a unit one
    notes: list[str] = field(default_factory=list)

    @property
    def n(self) -> int:
        return len(self.nees)

    @property
    def mean(self) -> float:
        return float(np.mean(self.nees)) if self.n else float("nan")

    @property
    def median(self) -> float:
        return float(np.median(self.nees)) if self.n else float("nan")

    def mean_interval(self, p: float = 0.95) -> tuple[float, float]:
        """Central interval of the mean of n independent chi-square(6) values:
        n * mean ~ chi-square(6 n)."""
        if not self.n:
            return float("nan"), float("nan")
        from scipy.stats import chi2

        lo, hi = chi2.ppf([(1 - p) / 2, (1 + p) / 2], DOF * self.n)
        return float(lo / self.n), float(hi / self.n)

    @property
    def frac_95(self) -> float:
        return float(np.mean(self.nees <= BOUND_95)) if self.n else float("nan")

    @property
    def frac_99(self) -> float:
        return float(np.mean(self.nees <= BOUND_99)) if self.n else float("nan")

    def verdict(self) -> str:
        if not self.n:
            return "no fix with a usable covariance"
        lo, hi = self.mean_interval()
        if self.mean < lo:
            return "covariance too large (pessimistic)"
        if self.mean > hi:
            return "covariance too small (optimistic)"
        return "consistent"

    @property
    def label(self) -> str:
        return "NEES" if self.kind == FULL else "diagonal NEES (1-sigma columns only, no correlations)"

    def to_json(self) -> dict:
        lo, hi = self.mean_interval()
        return {
            "kind": self.kind,
            "dof": DOF,
            "expected_mean": float(DOF),
            "n_fixes": self.n_fixes,
            "n_used": self.n,
            "n_not_positive_definite": self.n_not_pd,
            "n_bad_quaternion": self.n_bad_quat,
            "mean": _num(self.mean),
            "median": _num(self.median),
            "mean_interval_95": [_num(lo), _num(hi)],
            "bound_95": BOUND_95,
            "bound_99": BOUND_99,
            "frac_inside_95": _num(self.frac_95),
            "frac_inside_99": _num(self.frac_99),
            "verdict": self.verdict(),
            "normalised_error": {
                a: {"mean": _num(np.mean(self.z[:, k])), "rms": _num(np.sqrt(np.mean(self.z[:, k] ** 2)))}
                if self.n
                else {"mean": None, "rms": None}
                for k, a in enumerate(self.axes)
            },
            "notes": self.notes,
        }


def _num(x) -> float | None:
    x = float(x)
    return x if np.isfinite(x) else None


def nees_values(e: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """NEES of errors e (N, 6) under covariances p (N, 6, 6).

    Returns (ok, nees, z): ok marks the rows whose P is finite and positive definite
    (Cholesky succeeds); nees and z (e_i / sqrt(P_ii)) are given for those rows only.
    """
    e = np.asarray(e, dtype=float).reshape(-1, 6)
    p = np.asarray(p, dtype=float).reshape(-1, 6, 6)
    ok = np.all(np.isfinite(p), axis=(1, 2)) & np.all(np.isfinite(e), axis=1)
    idx = np.flatnonzero(ok)
    try:  # every row at once; the rare failure is then found row by row
        chol = np.linalg.cholesky(p[idx])
    except np.linalg.LinAlgError:
        chol = np.zeros((len(idx), 6, 6))
        for n, k in enumerate(idx):
            try:
                chol[n] = np.linalg.cholesky(p[k])
            except np.linalg.LinAlgError:
                ok[k] = False
        chol = chol[ok[idx]]
    rows = np.flatnonzero(ok)  # the rows chol holds, in order
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # NEES = |L^-1 e|^2, row by row where the batch meets a singular factor
        y = np.zeros((len(rows), 6))
        if len(rows):
            try:
                y = np.linalg.solve(chol, e[rows][:, :, None])[:, :, 0]
            except np.linalg.LinAlgError:
                for n, k in enumerate(rows):
                    try:
                        y[n] = np.linalg.solve(chol[n], e[k])
                    except np.linalg.LinAlgError:
                        y[n] = np.nan
        nees = np.sum(y * y, axis=1)
        d = np.sqrt(np.einsum("nii->ni", p[rows]))
        z = e[rows] / d
    # A covariance whose factor or NEES overflowed (entries near 1e308 pass the finiteness
    # test and Cholesky, then give inf or nan) is no usable covariance either: counted with
    # the ones that are not positive definite, never a NaN in the statistics.
    finite = np.isfinite(nees) & np.all(np.isfinite(z), axis=1) & np.all(np.isfinite(chol), axis=(1, 2))
    ok[rows[~finite]] = False
    return ok, nees[finite], z[finite]


def compute(
    t_s: np.ndarray,
    pos_err_mm: np.ndarray,
    euler_err_deg: np.ndarray,
    cols: dict[str, np.ndarray],
    euler_est_deg: np.ndarray,
    euler_true_deg: np.ndarray,
) -> Nees | None:
    """NEES of matched fixes.

    t_s (N,), pos_err_mm (N, 3) estimate - truth, euler_err_deg (N, 3) the wrapped 2-1-3 angle
    errors, euler_est_deg / euler_true_deg (N, 3) the angles of C_w_b; cols the optional
    nav.csv columns of these rows (COV_COLUMNS, QUAT_COLUMNS, SIGMA_COLUMNS; NaN where a
    field was empty). None when the file has neither a covariance nor the 1-sigma columns.
    """
    n = len(t_s)
    pos_err_mm = np.asarray(pos_err_mm, dtype=float).reshape(n, 3)
    if all(c in cols for c in COV_COLUMNS):
        p = cov_from_columns(np.column_stack([cols[c] for c in COV_COLUMNS]).reshape(n, len(COV_COLUMNS)))
        c_b_w_true = np.transpose(euler_to_c_w_b(euler_true_deg), (0, 2, 1))
        notes = []
        bad_q = np.zeros(n, dtype=bool)
        if all(c in cols for c in QUAT_COLUMNS):
            q = np.column_stack([cols[c] for c in QUAT_COLUMNS]).reshape(n, 4)
            norm = np.linalg.norm(q, axis=1)
            bad_q = ~np.isfinite(norm) | (np.abs(norm - 1.0) > QUAT_NORM_TOLERANCE)
            q = np.where(bad_q[:, None], [1.0, 0.0, 0.0, 0.0], q)
            c_b_w_est = quat_to_matrix(q)
            notes.append("attitude error from the quaternion q_w..q_z")
        else:
            c_b_w_est = np.transpose(euler_to_c_w_b(euler_est_deg), (0, 2, 1))
            notes.append("no quaternion columns: attitude error from the Euler angles")
        phi = attitude_error_deg(c_b_w_est, c_b_w_true)
        e = np.column_stack([pos_err_mm, phi])
        ok, nees, z = nees_values(e, p)
        ok_use = ok & ~bad_q
        keep = ok_use[ok]
        return Nees(
            kind=FULL,
            t_s=np.asarray(t_s)[ok_use],
            nees=nees[keep],
            z=z[keep],
            axes=POSE_AXES,
            n_fixes=n,
            n_not_pd=int(np.count_nonzero(~ok)),
            n_bad_quat=int(np.count_nonzero(bad_q & ok)),
            notes=notes,
        )
    if all(c in cols for c in SIGMA_COLUMNS):
        s = np.column_stack([cols[c] for c in SIGMA_COLUMNS]).reshape(n, 6)
        e = np.column_stack([pos_err_mm, np.asarray(euler_err_deg, dtype=float).reshape(n, 3)])
        p = np.zeros((n, 6, 6))
        idx = np.arange(6)
        p[:, idx, idx] = s * s
        # a zero or negative sigma is no covariance (s * s would hide the sign)
        p[np.any(~(s > 0), axis=1)] = np.nan
        ok, nees, z = nees_values(e, p)
        return Nees(
            kind=DIAGONAL,
            t_s=np.asarray(t_s)[ok],
            nees=nees,
            z=z,
            axes=DIAG_AXES,
            n_fixes=n,
            n_not_pd=int(np.count_nonzero(~ok)),
            notes=[
                "no covariance columns (cov_*): the diagonal NEES of the 1-sigma columns over the "
                "position and 2-1-3 Euler-angle errors; correlations ignored"
            ],
        )
    return None


def check_columns(header: list[str], what: str) -> None:
    """Refuse a nav.csv with part of a column group: a malformed file, not an old one."""
    for group, name in ((COV_COLUMNS, "covariance"), (QUAT_COLUMNS, "quaternion")):
        have = [c for c in group if c in header]
        if have and len(have) != len(group):
            missing = [c for c in group if c not in header]
            raise MfnsError(
                f"{what}: has {len(have)} of the {len(group)} {name} columns "
                f"(missing {', '.join(missing)}); expected all of {group[0]}..{group[-1]} or none"
            )


def markdown(res: Nees) -> list[str]:
    """Lines of the NEES section of summary.md."""
    lo, hi = res.mean_interval()
    head = "## Covariance consistency: " + res.label
    lines = [head, ""]
    if res.kind == DIAGONAL:
        lines += [
            "**Diagonal only**: this nav.csv has no covariance columns, so the NEES uses the six "
            "1-sigma columns and ignores every correlation (the figure before the full covariance).",
            "",
        ]
    lines += [
        "| quantity | value | expected (chi-square, 6 DOF) |",
        "|---|---|---|",
        f"| mean NEES | {res.mean:.3f} | 6 (95 % interval of the mean of {res.n} fixes: {lo:.2f}-{hi:.2f}) |",
        f"| median NEES | {res.median:.3f} | 5.35 |",
        f"| fixes inside the 95 % bound ({BOUND_95:.2f}) | {100 * res.frac_95:.1f} % | 95 % |",
        f"| fixes inside the 99 % bound ({BOUND_99:.2f}) | {100 * res.frac_99:.1f} % | 99 % |",
        "",
        "| normalised error | " + " | ".join(res.axes) + " |",
        "|---|" + "---|" * len(res.axes),
    ]
    if res.n:
        lines.append("| mean | " + " | ".join(f"{np.mean(res.z[:, k]):+.3f}" for k in range(6)) + " |")
        lines.append(
            "| RMS (1 expected) | "
            + " | ".join(f"{np.sqrt(np.mean(res.z[:, k] ** 2)):.3f}" for k in range(6))
            + " |"
        )
    lines += [
        "",
        f"Verdict: {res.verdict()}. {res.n} of {res.n_fixes} fixes with truth used"
        + (f"; {res.n_not_pd} with a covariance that is not positive definite" if res.n_not_pd else "")
        + (f"; {res.n_bad_quat} with a quaternion that is not a unit one" if res.n_bad_quat else "")
        + ".",
        "",
        *(f"- {n[0].upper()}{n[1:]}." for n in res.notes),
        "",
    ]
    return lines


# The histogram's axis: to the 99th percentile of the data (plus a tenth), never past
# HIST_TOP_MAX (the fixes beyond go to the last bin, counted in the label) nor below
# HIST_TOP_MIN (a run of near-zero NEES still shows the density's rise).
HIST_TOP_MAX = 20 * BOUND_99
HIST_TOP_MIN = 1.0


def hist_top(v: np.ndarray) -> float:
    """Right end of the NEES histogram's axis, scaled to the data v."""
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    if not len(v):
        return 3 * BOUND_99
    return float(min(max(1.1 * np.quantile(v, 0.99), HIST_TOP_MIN), HIST_TOP_MAX))


def plot(res: Nees, path, title: str | None = None) -> None:
    """NEES per fix over time with the chi-square(6) bounds, and its histogram against the
    chi-square(6) density."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.stats import chi2

    fig, (ax_t, ax_h) = plt.subplots(1, 2, figsize=(13, 4.8))
    v = res.nees
    if res.n:
        ax_t.semilogy(res.t_s, np.maximum(v, 1e-3), ".", ms=4, label=res.label.split(" (")[0])
    for y, lab, st in (
        (DOF, "expected mean 6", "-"),
        (BOUND_95, f"95 % bound {BOUND_95:.2f}", "--"),
        (BOUND_99, f"99 % bound {BOUND_99:.2f}", ":"),
    ):
        ax_t.axhline(y, color="k", ls=st, lw=0.9, label=lab)
    ax_t.set_xlabel("time (s)")
    ax_t.set_ylabel("NEES (log scale)")
    ax_t.grid(True, alpha=0.3, which="both")
    ax_t.legend(fontsize=8)
    lo, hi = res.mean_interval()
    ax_t.set_title(
        f"mean {res.mean:.2f} (6 expected, 95 % interval {lo:.2f}-{hi:.2f}); inside 95 %: "
        f"{100 * res.frac_95:.0f} %, 99 %: {100 * res.frac_99:.0f} %",
        fontsize=9,
    )
    top = hist_top(v)
    over = int(np.count_nonzero(v > top))
    ax_h.hist(np.minimum(v, top), bins=40, range=(0, top), density=True, alpha=0.6, label="fixes")
    x = np.linspace(0, top, 400)
    ax_h.plot(x, chi2.pdf(x, DOF), "k-", lw=1.2, label="chi-square(6) density")
    for b, st in ((BOUND_95, "--"), (BOUND_99, ":")):
        if b <= top:  # a bound beyond the data would stretch the axis again
            ax_h.axvline(b, color="k", ls=st, lw=0.9)
    ax_h.set_xlim(0, top)
    ax_h.set_xlabel("NEES" + (f" ({over} fixes above {top:.0f} counted in the last bin)" if over else ""))
    ax_h.set_ylabel("density")
    ax_h.legend(fontsize=8)
    ax_h.grid(True, alpha=0.3)
    ax_h.set_title(
        f"{res.n} fixes" + (f", {res.n_not_pd} not positive definite" if res.n_not_pd else ""), fontsize=9
    )
    run = f"{title}: " if title else ""
    fig.suptitle(f"{run}{res.label}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
