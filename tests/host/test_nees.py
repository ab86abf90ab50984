"""`mfns report`'s covariance check (mfns.analysis.nees): NEES of errors drawn from a known covariance,
a covariance too small or too large detected, the attitude-error convention (phi_w about the
world axes, C_b_w(est) = exp(phi_w) C_b_w(true)), the quaternion held to the C core's, and
malformed or missing covariance columns.

The synthetic nav.csv files here are written independently of mfns.analysis.nees: the estimated
quaternion is built with scipy's Rotation (scalar-last) and the Hamilton product, the
covariance columns from their documented names (docs/telemetry.md).
"""

from __future__ import annotations

import csv
import ctypes as ct
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from mfns.analysis import compare
from mfns.analysis import nees as N
from mfns.analysis import report as rpt
from mfns.cli import main
from mfns.core.errors import MfnsError
from mfns.model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg

BASE_HEADER = [
    "t_s",
    "seq",
    "cycle",
    "status",
    "reason",
    "mode",
    "x_mm",
    "y_mm",
    "z_mm",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
]
SIGMAS = [
    "sigma_x_mm",
    "sigma_y_mm",
    "sigma_z_mm",
    "sigma_roll_deg",
    "sigma_pitch_deg",
    "sigma_yaw_deg",
]
AX = ("x", "y", "z", "rx", "ry", "rz")
COVS = [f"cov_{AX[i]}_{AX[j]}" for i in range(6) for j in range(i, 6)]  # the documented order
QUATS = ["q_w", "q_x", "q_y", "q_z"]


def known_cov(rng: np.random.Generator) -> np.ndarray:
    """A correlated 6x6 covariance in mm^2 / mm deg / deg^2 (position ~0.3 mm, attitude ~0.01 deg)."""
    scale = np.array([0.3, 0.5, 0.2, 0.01, 0.02, 0.015])
    a = rng.normal(size=(6, 6))
    corr = a @ a.T + 3 * np.eye(6)
    d = np.sqrt(np.diag(corr))
    corr = corr / np.outer(d, d)
    return corr * np.outer(scale, scale)


def hamilton(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product of (w, x, y, z) quaternions."""
    pw, pv = p[0], p[1:]
    qw, qv = q[0], q[1:]
    return np.concatenate([[pw * qw - pv @ qv], pw * qv + qw * pv + np.cross(pv, qv)])


def quat_of(c_b_w: np.ndarray) -> np.ndarray:
    x, y, z, w = Rotation.from_matrix(c_b_w).as_quat()
    return np.array([w, x, y, z])


def write_case(
    tmp: Path,
    n: int = 1500,
    seed: int = 7,
    cov_scale: float = 1.0,
    columns: str = "full",  # full | no-quat | diagonal
    true_cov: np.ndarray | None = None,
):
    """Truth poses over the whole rotation group and estimates with errors drawn from a known
    covariance P; the nav.csv carries cov_scale * P. Returns (nav, truth, P, errors)."""
    rng = np.random.default_rng(seed)
    p = known_cov(rng) if true_cov is None else true_cov
    e = rng.multivariate_normal(np.zeros(6), p, size=n)
    t = np.arange(n) / 18.6
    truth_rows, nav_rows = [], []
    header = BASE_HEADER + (SIGMAS if columns == "diagonal" else []) + (COVS if columns != "diagonal" else [])
    header += QUATS if columns == "full" else []
    for k in range(n):
        eul_t = matrix_to_euler213_deg(Rotation.random(random_state=rng).as_matrix())
        pos_t = rng.uniform(-1500, 1500, 3)
        truth_rows.append([k, f"{t[k]:.6f}", *(f"{v:.9f}" for v in pos_t), *(f"{v:.9f}" for v in eul_t)])
        c_b_w_t = euler213_deg_to_matrix(eul_t).T
        if columns == "diagonal":
            # the old telemetry: the errors are Euler-angle errors, the sigmas per angle
            eul_e = eul_t + e[k, 3:]
            q_e = None
        else:
            phi = np.radians(e[k, 3:])
            ang = np.linalg.norm(phi)
            q_phi = np.concatenate([[np.cos(ang / 2)], np.sin(ang / 2) * phi / ang])
            q_e = hamilton(q_phi, quat_of(c_b_w_t))
            c_b_w_e = Rotation.from_quat([*q_e[1:], q_e[0]]).as_matrix()
            eul_e = matrix_to_euler213_deg(c_b_w_e.T)
        row = {
            "t_s": f"{t[k]:.6f}",
            "seq": k,
            "cycle": k,
            "status": "FIX",
            "reason": 0,
            "mode": "TRACK",
            **{c: f"{v:.9f}" for c, v in zip(("x_mm", "y_mm", "z_mm"), pos_t + e[k, :3], strict=True)},
            **{c: f"{v:.9f}" for c, v in zip(("roll_deg", "pitch_deg", "yaw_deg"), eul_e, strict=True)},
        }
        if columns == "diagonal":
            row.update({c: f"{np.sqrt(cov_scale * p[i, i]):.9g}" for i, c in enumerate(SIGMAS)})
        else:
            row.update({c: f"{cov_scale * p[i, j]:.9g}" for c, (i, j) in zip(COVS, N.COV_PAIRS, strict=True)})
        if q_e is not None and columns == "full":
            row.update({c: f"{v:.12f}" for c, v in zip(QUATS, q_e, strict=True)})
        nav_rows.append([row[h] for h in header])
    nav, truth = tmp / "nav.csv", tmp / "truth.csv"
    for path, hdr, rows in ((nav, header, nav_rows), (truth, rpt.TRUTH_HEADER, truth_rows)):
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(hdr)
            w.writerows(rows)
    return nav, truth, p, e


def report_of(nav: Path, truth: Path) -> rpt.Report:
    return rpt.build_report(rpt.load_nav(nav), rpt.load_truth(truth), tolerance_s=0.01)


def test_column_names_are_the_documented_ones():
    assert N.COV_COLUMNS == tuple(COVS)
    assert N.COV_COLUMNS[:7] == (
        "cov_x_x",
        "cov_x_y",
        "cov_x_z",
        "cov_x_rx",
        "cov_x_ry",
        "cov_x_rz",
        "cov_y_y",
    )
    assert N.COV_COLUMNS[-1] == "cov_rz_rz" and len(N.COV_COLUMNS) == 21
    p = known_cov(np.random.default_rng(1))[None]
    assert np.array_equal(N.cov_from_columns(N.cov_to_columns(p)), p)
    assert N.BOUND_95 == pytest.approx(12.592, abs=1e-3) and N.BOUND_99 == pytest.approx(16.812, abs=1e-3)


def test_errors_from_the_reported_covariance_give_mean_nees_6(tmp_path):
    nav, truth, _, _ = write_case(tmp_path)
    res = report_of(nav, truth).nees
    assert res is not None and res.kind == N.FULL
    assert res.n == 1500 and res.n_not_pd == 0 and res.n_bad_quat == 0
    # the mean of 1500 chi-square(6) values: inside its 99.9 % interval (5.77-6.24)
    lo, hi = res.mean_interval(0.999)
    assert lo < res.mean < hi, res.mean
    assert res.verdict() == "consistent"
    # the fractions inside the bounds: binomial, n = 1500 (3.5 sigma)
    assert abs(res.frac_95 - 0.95) < 3.5 * np.sqrt(0.95 * 0.05 / 1500)
    assert abs(res.frac_99 - 0.99) < 3.5 * np.sqrt(0.99 * 0.01 / 1500)
    rms = np.sqrt(np.mean(res.z**2, axis=0))
    assert np.all(np.abs(rms - 1) < 0.1), rms
    # the NEES of each fix is e^T P^-1 e of the errors drawn (CSV rounding aside)


def test_nees_matches_the_drawn_errors_fix_by_fix(tmp_path):
    nav, truth, p, e = write_case(tmp_path, n=200, seed=3)
    res = report_of(nav, truth).nees
    expected = np.einsum("ni,ij,nj->n", e, np.linalg.inv(p), e)
    assert res.nees == pytest.approx(expected, rel=1e-4, abs=1e-6)


@pytest.mark.parametrize("scale, verdict", [(0.25, "too small"), (4.0, "too large")])
def test_a_covariance_four_times_off_is_detected(tmp_path, scale, verdict):
    nav, truth, _, _ = write_case(tmp_path, n=300, cov_scale=scale)
    res = report_of(nav, truth).nees
    lo, hi = res.mean_interval()
    assert res.mean == pytest.approx(6 / scale, rel=0.15)
    assert not lo <= res.mean <= hi
    assert verdict in res.verdict()
    if scale < 1:
        assert res.frac_99 < 0.9  # a fusion filter's gate would reject many good fixes
    else:
        assert res.frac_99 == 1.0


def test_without_quaternion_the_attitude_error_comes_from_the_euler_angles(tmp_path):
    nav, truth, _, _ = write_case(tmp_path, n=300, seed=5)
    full = report_of(nav, truth).nees
    (tmp_path / "nq").mkdir()
    nav2, truth2, _, _ = write_case(tmp_path / "nq", n=300, seed=5, columns="no-quat")
    noq = report_of(nav2, truth2).nees
    assert any("quaternion q_w" in n for n in full.notes)
    assert any("from the Euler angles" in n for n in noq.notes)
    assert noq.nees == pytest.approx(full.nees, rel=1e-4, abs=1e-6)


def test_diagonal_nees_of_an_old_nav_csv_is_labelled(tmp_path):
    """The telemetry before the full covariance: six 1-sigma columns, Euler-angle errors."""
    p = np.diag([0.3, 0.5, 0.2, 0.01, 0.02, 0.015]) ** 2
    nav, truth, _, _ = write_case(tmp_path, n=800, true_cov=p, columns="diagonal")
    rep = report_of(nav, truth)
    res = rep.nees
    assert res.kind == N.DIAGONAL and res.axes == ("x", "y", "z", "roll", "pitch", "yaw")
    lo, hi = res.mean_interval(0.999)
    assert lo < res.mean < hi
    md = rpt.summary_markdown(rep)
    assert "diagonal NEES" in md and "**Diagonal only**" in md
    assert rpt.summary_json(rep)["nees"]["kind"] == "diagonal"


def test_attitude_error_convention_about_world_axes():
    """A known small rotation about a world axis applied to the true orientation gives
    phi_w along that axis with its sign and size, whatever the true attitude."""
    c_w_b_true = euler213_deg_to_matrix([10.0, -20.0, 30.0])
    c_b_w_true = c_w_b_true.T
    q_true = quat_of(c_b_w_true)
    for axis in range(3):
        for ang_deg in (0.5, -0.2):
            half = np.radians(ang_deg) / 2
            q_rot = np.zeros(4)
            q_rot[0], q_rot[1 + axis] = np.cos(half), np.sin(half)
            q_est = hamilton(q_rot, q_true)  # rotate the body by ang about world axis `axis`
            c_b_w_est = N.quat_to_matrix(q_est[None])[0]
            phi = N.attitude_error_deg(c_b_w_est[None], c_b_w_true[None])[0]
            want = np.zeros(3)
            want[axis] = ang_deg
            assert phi == pytest.approx(want, abs=1e-9)
            # the same through the Euler angles of C_w_b, as an old nav.csv carries them
            eul = matrix_to_euler213_deg(c_b_w_est.T)
            c_from_euler = N.euler_to_c_w_b(eul[None])[0].T
            assert N.attitude_error_deg(c_from_euler[None], c_b_w_true[None])[0] == pytest.approx(
                want, abs=1e-9
            )
    # the quaternion rotates body vectors into the world as C_b_w does: body x -> C_b_w[:, 0]
    assert N.quat_to_matrix(q_true[None])[0] == pytest.approx(c_b_w_true, abs=1e-12)


def test_sign_of_the_normalised_error_end_to_end(tmp_path):
    """A fix turned by +0.5 deg about world z with sigma_rz 0.25 deg: z_rz = +2, NEES 4."""
    nav, truth, _, _ = write_case(tmp_path, n=3, true_cov=np.diag([1, 1, 1, 0.01, 0.01, 0.0625]))
    rows = list(csv.DictReader(nav.open()))
    truths = list(csv.DictReader(truth.open()))
    for r, t in zip(rows, truths, strict=True):
        c_b_w_t = euler213_deg_to_matrix([float(t[a]) for a in ("roll_deg", "pitch_deg", "yaw_deg")]).T
        q = hamilton(np.array([np.cos(np.radians(0.25)), 0, 0, np.sin(np.radians(0.25))]), quat_of(c_b_w_t))
        r.update({c: f"{v:.12f}" for c, v in zip(QUATS, q, strict=True)})
        r.update({a: t[a] for a in ("x_mm", "y_mm", "z_mm")})
    with nav.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    res = report_of(nav, truth).nees
    assert res.nees == pytest.approx([4.0] * 3, rel=1e-6)
    assert res.z[:, 5] == pytest.approx([2.0] * 3, rel=1e-6)
    assert np.abs(res.z[:, :5]).max() < 1e-6


def test_quaternion_matches_the_flight_cores(core_lib):
    """The quaternion of the wire (mfns_m3_to_quat, math/rotation.c) read back by quat_to_matrix
    is the matrix it came from."""
    if not core_lib.exists():
        pytest.skip("make lib first")
    from mfns.core.binding import M3, load

    lib = load(core_lib)
    rots = Rotation.random(500, random_state=11).as_matrix()
    rots[:3] = [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])]
    for r in rots:
        m = M3()
        for i in range(3):
            for j in range(3):
                m.m[i][j] = r[i, j]
        q = (ct.c_float * 4)()
        lib.mfns_m3_to_quat(m, q)
        assert N.quat_to_matrix(np.array(q[:])[None])[0] == pytest.approx(r, abs=2e-6)


def test_malformed_covariance_columns(tmp_path, capsys):
    nav, truth, _, _ = write_case(tmp_path, n=40)
    text = nav.read_text()
    lines = text.splitlines()
    # part of the covariance columns: a malformed file, refused with what is missing
    header = lines[0].split(",")
    drop = header.index("cov_y_rz")
    cut = "\n".join(",".join(v for k, v in enumerate(line.split(",")) if k != drop) for line in lines) + "\n"
    nav.write_text(cut)
    with pytest.raises(MfnsError, match="20 of the 21 covariance columns.*missing cov_y_rz"):
        rpt.load_nav(nav)
    assert main(["report", str(nav), "--truth", str(truth), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "covariance columns" in err[0]
    # three of the four quaternion columns
    qi = header.index("q_z")
    nav.write_text(
        "\n".join(",".join(v for k, v in enumerate(line.split(",")) if k != qi) for line in lines) + "\n"
    )
    with pytest.raises(MfnsError, match="3 of the 4 quaternion columns"):
        rpt.load_nav(nav)
    # text where a number belongs
    ci = header.index("cov_x_y")
    bad = lines[:]
    f = bad[5].split(",")
    f[ci] = "abc"
    bad[5] = ",".join(f)
    nav.write_text("\n".join(bad) + "\n")
    with pytest.raises(MfnsError, match="line 6 cov_x_y: 'abc' is not a number"):
        rpt.load_nav(nav)


def test_rows_without_a_usable_covariance_are_counted_not_fatal(tmp_path):
    nav, truth, _, _ = write_case(tmp_path, n=60)
    rows = list(csv.DictReader(nav.open()))
    rows[3]["cov_x_x"] = "-0.5"  # negative variance
    rows[4].update({c: "0" for c in COVS})  # all zero (e.g. a solver that gave none)
    rows[5]["cov_y_rz"] = ""  # empty field: unknown
    rows[9]["cov_z_z"] = "inf"  # not finite
    rows[6]["cov_x_y"] = "100"  # |corr| > 1: not positive definite
    rows[7]["q_w"] = "2.0"  # not a unit quaternion
    rows[8]["status"] = "NO_FIX"  # no fix: empty covariance is fine and not counted
    rows[8].update({c: "" for c in COVS})
    with nav.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    rep = report_of(nav, truth)
    res = rep.nees
    assert res.n_fixes == 59 and res.n_not_pd == 5 and res.n_bad_quat == 1 and res.n == 53
    md = rpt.summary_markdown(rep)
    assert "5 with a covariance that is not positive definite" in md
    assert "1 with a quaternion that is not a unit one" in md
    js = rpt.summary_json(rep)["nees"]
    assert js["n_not_positive_definite"] == 5 and js["n_used"] == 53
    # no usable covariance at all: said so, the numbers empty, no figure, no crash
    for r in rows:
        r.update({c: "0" for c in COVS})
    with nav.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    rep = report_of(nav, truth)
    assert rep.nees.n == 0 and rep.nees.n_not_pd == 59
    assert "no fix with a usable covariance" in rpt.summary_markdown(rep)
    js = rpt.summary_json(rep)["nees"]
    assert js["mean"] is None and js["n_not_positive_definite"] == 59
    assert json.loads(json.dumps(js)) == js
    assert [p.name for p in rpt.write_plots(rep, tmp_path)] == [
        "nav_errors_vs_time.png",
        "nav_errors_vs_yaw.png",
    ]


def test_no_covariance_at_all_and_no_truth(tmp_path):
    nav, truth, _, _ = write_case(tmp_path, n=20)
    rows = list(csv.DictReader(nav.open()))
    keep = [h for h in rows[0] if h not in COVS and h not in QUATS]
    with nav.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keep, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    rep = report_of(nav, truth)
    assert rep.nees is None
    assert "No covariance check" in rpt.summary_markdown(rep)
    assert rpt.build_report(rpt.load_nav(nav), None).nees is None


def test_cli_writes_nees_to_summary_and_plot(tmp_path, capsys):
    nav, truth, _, _ = write_case(tmp_path, n=300)
    out = tmp_path / "rep"
    assert main(["report", str(nav), "--truth", str(truth), "--out", str(out), "--title", "t"]) == 0
    printed = capsys.readouterr().out
    assert "## Covariance consistency: NEES" in printed and "| mean NEES |" in printed
    doc = json.loads((out / "summary.json").read_text())
    assert doc["title"] == "t" and doc["n_used"] == 300
    nees = doc["nees"]
    assert nees["kind"] == "full" and nees["n_used"] == 300 and nees["dof"] == 6
    lo, hi = chi2.ppf([0.0005, 0.9995], 6 * 300) / 300
    assert lo < nees["mean"] < hi
    assert set(nees["normalised_error"]) == set(AX)
    png = (out / "nees.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10000


def test_compare_has_a_nees_row_per_run(tmp_path):
    """mfns compare's Table 5 gains the NEES of each run (full or labelled diagonal)."""
    demo = tmp_path / "demo"
    frames = demo / "module" / "frames"
    frames.mkdir(parents=True)
    nav, truth, _, _ = write_case(frames, n=200)
    (frames / "nav.csv").rename(tmp_path / "full.csv")
    (demo / "module" / "true-rig" / "ground").mkdir(parents=True)
    (tmp_path / "full.csv").rename(demo / "module" / "true-rig" / "ground" / "nav.csv")
    # the same fixes with only the diagonal of the 1-sigma columns (an old nav.csv)
    rows = list(csv.DictReader((demo / "module" / "true-rig" / "ground" / "nav.csv").open()))
    old = [h for h in rows[0] if h not in COVS and h not in QUATS] + SIGMAS
    for r in rows:
        r.update({s: f"{np.sqrt(float(r[f'cov_{a}_{a}'])):.9g}" for s, a in zip(SIGMAS, AX, strict=True)})
    (demo / "module" / "paper-calibration" / "ground").mkdir(parents=True)
    with (demo / "module" / "paper-calibration" / "ground" / "nav.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=old, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    text = compare.build(demo)
    full = report_of(demo / "module" / "true-rig" / "ground" / "nav.csv", truth).nees
    line = next(ln for ln in text.splitlines() if ln.startswith("| mean NEES (6 expected) |"))
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[3].startswith(f"{full.mean:.2f} [") and "diagonal" not in cells[3]
    assert cells[4].endswith("(diagonal)")
    assert any(ln.startswith("| fixes inside the χ²(6) 95 % / 99 % bounds") for ln in text.splitlines())


CELLS = st.sampled_from(["", "nan", "0", "-1", "1", "1e-30", "1e308", "-0.0", "0.5", "abc", "inf", " 2 "])


@settings(
    max_examples=120,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_hostile_covariance_and_quaternion_cells(tmp_path_factory, data):
    """Any cell in the covariance and quaternion columns: a clear one-line refusal or a report
    whose counts add up, never a crash."""
    work = tmp_path_factory.mktemp("hostile")
    nav, truth, _, _ = write_case(work, n=6, seed=2)
    rows = list(csv.DictReader(nav.open()))
    for r in rows:
        for c in data.draw(st.lists(st.sampled_from(COVS + QUATS), max_size=8)):
            r[c] = data.draw(CELLS)
        if data.draw(st.booleans()):
            r.update({c: data.draw(CELLS | st.floats(allow_nan=True).map(repr)) for c in COVS})
    with nav.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    try:
        rep = report_of(nav, truth)
    except MfnsError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg and "is not a number" in msg, msg
        return
    res = rep.nees
    assert res.n + res.n_not_pd + res.n_bad_quat == res.n_fixes == 6
    assert np.all(np.isfinite(res.nees)) and np.all(res.nees >= 0)
    json.dumps(rpt.summary_json(rep), allow_nan=False)
    rpt.summary_markdown(rep)


def test_an_overflowing_covariance_is_not_a_nan_nees():
    """Found by test_hostile_covariance_and_quaternion_cells (CI, 3 December 2026): a
    covariance cell of 1e308 passes the finiteness test, and its factor or NEES overflows to
    inf / nan, which entered the statistics as a NaN. Such a row counts as not positive
    definite, like a covariance whose Cholesky fails."""
    e = np.ones((4, 6))
    p = np.stack([np.eye(6)] * 4)
    p[1][0, 2] = p[1][2, 0] = 1e308  # overflows
    p[2][0, 0] = 1e308  # PD, but its z and NEES stay finite: kept
    p[3][4, 4] = 0.0  # singular: Cholesky refuses it
    ok, nees, z = N.nees_values(e, p)
    assert ok.tolist() == [True, False, True, False]
    assert len(nees) == len(z) == 2 and np.all(np.isfinite(nees)) and np.all(np.isfinite(z))
    assert nees[0] == pytest.approx(6.0) and nees[1] == pytest.approx(5.0)
