"""The calibration's covariance in the calibration-results JSON (issue 12, docs/calib-results.md).

Contract: parameter names and order, symmetric PSD, sigma = sqrt(diag), files without it read
as unknown; the mapping of the refinement's covariance to the contract's parameters (checked
against a finite-difference Jacobian); the true rig of `mfns sim nav` carries none. Coverage
of the truth over simulated datasets is in test_calib_acceptance.py (the seeds it already runs).
"""

import copy
import json

import numpy as np
import pytest

from mfns.analysis import calib_results
from mfns.calib.covariance import (
    N_PARAMETERS,
    euler_sigma,
    left_jacobian,
    nees,
    paper_covariance,
    parameter_error,
    refined_covariance,
)
from mfns.calib.evaluate import _reangle
from mfns.calib.model import Board
from mfns.calib.pipeline import calibrate
from mfns.cli import main
from mfns.core.errors import MfnsError
from mfns.model.rotations import rot_exp, rot_log
from mfns.simulate.calib import PAPER_CALIB, corner_observations, default_truth, make_plan

CONTRACT = (
    "fx fy cx cy k1 k2 p1 p2 k3 theta_x theta_y theta_z r_x r_y r_z".split()
)  # docs/calib-results.md, written out here on purpose: the test holds the code to the doc


@pytest.fixture(scope="module")
def direct_cal():
    """One calibration of directly simulated corners (0.1 px), with its truth."""
    truth, board = default_truth(), Board()
    shots = make_plan(truth, board, np.random.default_rng(1), 12, 10, 8.0)
    rng = np.random.default_rng(77)
    obs = corner_observations(
        truth, board, _reangle(truth, shots, rng, 8.0), rng, 0.1, angle_sigma_arcsec=8.0
    )
    return calibrate(obs), truth


@pytest.fixture(scope="module")
def cli_outputs(calib_small_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("calibcov") / "res.json"
    assert main(["calib", str(calib_small_dataset), "-o", str(out), "--quiet"]) == 0
    return out, out.with_name("res_paper.json")


def _paper_doc():
    return json.loads(PAPER_CALIB.read_text())


def _with_covariance(doc, cov=None):
    """doc with a covariance consistent with its sigma blocks (diagonal unless cov is given)."""
    doc = copy.deepcopy(doc)
    names = [f"{c['name']}.{p}" for c in doc["cameras"] for p in CONTRACT]
    if cov is None:
        var = []
        for c in doc["cameras"]:
            # the paper's rig has extrinsic sigma only; those given must agree with the diagonal
            var += [0.25, 0.3, 0.5, 0.4, 1e-6, 1e-5, 1e-8, 1e-8, 1e-4, 1e-8, 2e-8, 3e-8]
            var += list(np.square(c["sigma"]["r_bk_b"]))
        cov = np.diag(var)
    doc["covariance"] = {"parameters": names, "matrix": np.asarray(cov).tolist()}
    return doc


# --- the contract ------------------------------------------------------------------------------
@pytest.mark.parametrize("path_kind", ["refined", "paper"])
def test_mfns_calib_writes_the_contract(cli_outputs, path_kind):
    path = cli_outputs[0] if path_kind == "refined" else cli_outputs[1]
    doc = calib_results.load(path)
    names, cov = calib_results.covariance(doc)
    assert names == [f"{c}.{p}" for c in "xyz" for p in CONTRACT]
    assert cov.shape == (45, 45)
    assert np.array_equal(cov, cov.T)
    sd = np.sqrt(np.diag(cov))
    assert np.linalg.eigvalsh(cov / np.outer(sd, sd)).min() > 0.0  # positive definite here
    # sigma = sqrt(diag) wherever both exist; the Euler sigma is the theta block propagated
    for k, cam in enumerate(doc["cameras"]):
        s, blk = cam["sigma"], sd[15 * k : 15 * k + 15]
        got = [s["fx"], s["fy"], s["cx"], s["cy"], *s["dist"], *s["r_bk_b"]]
        np.testing.assert_allclose(got, np.r_[blk[:9], blk[12:]], rtol=1e-12)
        th = cov[15 * k + 9 : 15 * k + 12, 15 * k + 9 : 15 * k + 12]
        np.testing.assert_allclose(s["euler_213_deg"], euler_sigma(np.array(cam["C_k_b"]), th), rtol=1e-9)
    # one covariance row per line: the file stays readable
    lines = path.read_text().splitlines()
    assert (
        sum(1 for ln in lines if ln.strip().startswith("[") and ln.strip().rstrip(",").count(",") == 44) == 45
    )


def test_paper_covariance_is_larger_than_the_refined_one(cli_outputs):
    _, ref = calib_results.covariance(calib_results.load(cli_outputs[0]))
    _, pap = calib_results.covariance(calib_results.load(cli_outputs[1]))
    diff = pap - ref  # the rank-one term d d^T
    w = np.linalg.eigvalsh(diff)
    assert w.min() > -1e-9 * w.max() and w[-2] < 1e-9 * w.max()  # PSD and rank one
    # the paper's attitude errors are several ML sigma: its theta variances grow
    th = [15 * k + i for k in range(3) for i in (9, 10, 11)]
    assert np.max(np.diag(pap)[th] / np.diag(ref)[th]) > 4.0


def test_files_without_covariance_are_unknown():
    doc = calib_results.validate(_paper_doc())
    assert "covariance" not in doc and calib_results.covariance(doc) is None
    doc = calib_results.validate(_with_covariance(_paper_doc()))
    names, cov = calib_results.covariance(doc)
    assert len(names) == 45 and cov.shape == (45, 45)


def test_dumps_round_trips_exactly(direct_cal):
    cal, _ = direct_cal
    from mfns.calib.report import results_document

    doc = results_document(cal, "test")
    text = calib_results.dumps(doc)
    assert json.loads(text) == json.loads(json.dumps(doc))
    calib_results.validate(json.loads(text), flight=True)


def _bad(mutate):
    doc = _with_covariance(_paper_doc())
    mutate(doc)
    return doc


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d["covariance"].pop("matrix"), "missing 'matrix'"),
        (lambda d: d["covariance"].update(extra=1), "unknown key"),
        (lambda d: d["covariance"]["parameters"].__setitem__(0, "x.f"), "parameters\\[0\\]"),
        (lambda d: d["covariance"]["parameters"].__setitem__(0, "w.fx"), "parameters\\[0\\]"),
        (lambda d: d["covariance"]["parameters"].__setitem__(1, "x.fx"), "duplicate"),
        (lambda d: d["covariance"].update(parameters=d["covariance"]["parameters"][:44]), "missing z.r_z"),
        (lambda d: d["covariance"]["matrix"].pop(), "expected a list of 45"),
        (lambda d: d["covariance"]["matrix"][0].__setitem__(1, 1e-3), "not symmetric"),
        (lambda d: d["covariance"]["matrix"][3].__setitem__(3, -1.0), "negative variance"),
        (lambda d: d["covariance"]["matrix"][2].__setitem__(2, "1"), "expected a number"),
        (lambda d: d["cameras"][1]["sigma"].update(fx=1.0), "camera y sigma fx"),
        (lambda d: d["cameras"][2]["sigma"]["r_bk_b"].__setitem__(1, 9.0), "camera z sigma r_bk_b\\[1\\]"),
    ],
)
def test_malformed_covariance_is_one_line_error(mutate, match):
    with pytest.raises(MfnsError, match=match):
        calib_results.validate(_bad(mutate))


def test_covariance_must_be_positive_semi_definite():
    doc = _with_covariance(_paper_doc())
    m = np.array(doc["covariance"]["matrix"])
    i, j = 0, 1  # |correlation| > 1
    m[i, j] = m[j, i] = 1.5 * np.sqrt(m[i, i] * m[j, j])
    doc["covariance"]["matrix"] = m.tolist()
    with pytest.raises(MfnsError, match="not positive semi-definite"):
        calib_results.validate(doc)
    # a singular (rank-deficient) PSD matrix is fine: a covariance need not be invertible
    m[i, j] = m[j, i] = np.sqrt(m[i, i] * m[j, j])  # fx and fy fully correlated
    assert np.linalg.matrix_rank(m / np.sqrt(np.outer(np.diag(m), np.diag(m)))) == 44
    calib_results.validate(_with_covariance(_paper_doc(), m))


# --- the mapping ----------------------------------------------------------------------------------
def test_left_jacobian():
    rng = np.random.default_rng(5)
    for w in (np.zeros(3), 1e-8 * rng.normal(size=3), 0.3 * rng.normal(size=3), np.array([0.0, 2.5, 0.4])):
        e = 1e-6 * rng.normal(size=3)
        theta = rot_log(rot_exp(w + e) @ rot_exp(w).T)
        np.testing.assert_allclose(theta, left_jacobian(w) @ e, rtol=1e-4, atol=1e-15)


def test_refined_covariance_is_the_refinement_covariance_mapped(direct_cal):
    """Finite-difference Jacobian of the contract's parameters w.r.t. the refinement's x."""
    cal, _ = direct_cal
    ref, prob = cal.refined, cal.refined.problem
    names, cov = refined_covariance(ref)
    x = ref.x
    base = prob.rig(x)
    a = np.zeros((len(names), len(x)))
    for j in range(len(x)):
        h = 1e-6 * max(1.0, abs(x[j]))
        dx = np.zeros(len(x))
        dx[j] = h
        a[:, j] = (parameter_error(prob.rig(x + dx), base) - parameter_error(prob.rig(x - dx), base)) / (
            2 * h
        )
    expect = a @ ref.cov_params @ a.T
    sd = np.sqrt(np.diag(expect))
    np.testing.assert_allclose(cov / np.outer(sd, sd), expect / np.outer(sd, sd), atol=1e-6)
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), sd, rtol=1e-6)
    # the diagonal of the intrinsics and positions is the refinement's own 1-sigma
    sig = dict(zip(ref.names, ref.sigma, strict=True))
    for k, cam in enumerate("xyz"):
        np.testing.assert_allclose(np.sqrt(cov[15 * k, 15 * k]), sig[f"{cam}.fx"], rtol=1e-9)
        np.testing.assert_allclose(np.sqrt(cov[15 * k + 14, 15 * k + 14]), sig[f"{cam}.r_b{cam}z"], rtol=1e-9)


def test_paper_covariance_covers_the_paper_where_ml_alone_does_not(direct_cal):
    cal, truth = direct_cal
    _, cov_ml = refined_covariance(cal.refined)
    _, cov_p = paper_covariance(cal.paper, cal.refined)
    e_p = parameter_error(cal.paper, truth)
    from scipy.stats import chi2

    bound = chi2.ppf(0.99, 3 * N_PARAMETERS)
    assert nees(e_p, cov_ml) > 10 * bound  # the paper's systematic error is far outside Cov(ML)
    assert nees(e_p, cov_p) < bound
    assert nees(parameter_error(cal.refined.rig, truth), cov_ml) < bound


# --- the true rig of mfns sim nav -----------------------------------------------------------------
def test_sim_nav_true_rig_has_no_covariance(tmp_path):
    rig = tmp_path / "rig.json"
    rig.write_text(json.dumps(_with_covariance(_paper_doc())))
    out = tmp_path / "nav"
    assert main(["sim", "nav", str(out), "--frames", "1", "--quiet", "--rig", str(rig)]) == 0
    doc = calib_results.load(out / "calib.json")
    assert "covariance" not in doc and calib_results.covariance(doc) is None
    assert doc["cameras"] == calib_results.load(rig)["cameras"]  # the rig itself unchanged
