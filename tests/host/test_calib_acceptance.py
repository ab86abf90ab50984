"""Acceptance of `mfns calib` (issue 7): efficiency vs the Cramér-Rao bound, refined vs paper,
reported 1-sigma vs the spread over seeds.

Single-dataset checks run on the default `mfns sim calib` dataset (rendered images, OpenCV
corner detection). A single realisation cannot show "within 1.5x the bound" per parameter
(a Gaussian error exceeds 1.5 sigma 13 % of the time), so there the test is on the RMS of
error/CRB per group, plus a 3.5-sigma outlier check per parameter. The per-parameter checks
run over 20 seeds on corner observations simulated directly (no rendering or detection, for
speed) through the same Zhang/CPC/refinement code.
"""

import numpy as np
import pytest
from scipy.stats import chi2

from mfns.analysis.calib_results import load
from mfns.calib.covariance import nees, paper_covariance, parameter_error, refined_covariance
from mfns.calib.evaluate import run_seeds
from mfns.cli import main
from mfns.commands.calib import calibrate_dataset
from mfns.simulate.calib import truth_from_document

N_SEEDS = 20


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("calib_default") / "ds"
    assert main(["sim", "calib", str(out), "--quiet"]) == 0
    _obs, rejected, cal, cmp, _t1, _t2 = calibrate_dataset(out, out / "truth.json")
    assert not rejected
    cal.truth = truth_from_document(load(out / "truth.json", flight=False))
    return cal, cmp


@pytest.fixture(scope="module")
def seeds():
    return run_seeds(N_SEEDS, sigma_px=0.1)


def _groups(cmp):
    return {
        g: [i for i, n in enumerate(cmp.names) if cmp.group(n) == g]
        for g in ("intrinsics", "attitudes", "positions")
    }


def test_rendered_dataset_refined_errors_at_the_cramer_rao_bound(default_run):
    cal, cmp = default_run
    assert cmp.crb is not None
    print()
    from mfns.calib.report import accuracy_table

    print(accuracy_table(cmp))
    z = cmp.refined_err / cmp.crb
    for g, sel in _groups(cmp).items():
        assert np.sqrt(np.mean(z[sel] ** 2)) <= 1.5, g
    ext = [i for i, n in enumerate(cmp.names) if cmp.is_extrinsic(n)]
    assert np.max(np.abs(z[ext])) < 3.5
    # the reported 1-sigma is the covariance at the solution: close to the bound at the truth
    assert np.all(np.abs(cmp.refined_sigma / cmp.crb - 1.0) < 0.1)


def test_rendered_dataset_refined_no_worse_than_paper(default_run):
    _cal, cmp = default_run
    for g, sel in _groups(cmp).items():
        ref = np.sqrt(np.mean((cmp.refined_err[sel] / cmp.crb[sel]) ** 2))
        pap = np.sqrt(np.mean((cmp.paper_err[sel] / cmp.crb[sel]) ** 2))
        assert ref <= pap * 1.05, g  # intrinsics: Zhang is already ML per camera
    # per parameter: better than the paper, or already at the statistical limit (2 CRB)
    worse = np.abs(cmp.refined_err) > np.maximum(np.abs(cmp.paper_err), 2.0 * cmp.crb)
    assert not worse.any(), [n for n, w in zip(cmp.names, worse, strict=True) if w]
    # the paper's chained least squares is far from efficient on the attitudes
    att = _groups(cmp)["attitudes"]
    assert np.sqrt(np.mean((cmp.paper_err[att] / cmp.crb[att]) ** 2)) > 5.0


def test_multi_seed_refined_efficient_and_no_worse_than_paper(seeds):
    print()
    print(seeds.table())
    assert np.all(seeds.rms_refined <= 1.5 * seeds.crb)
    assert np.all(seeds.rms_refined <= 1.05 * seeds.rms_paper)
    # Cramér-Rao bound of the paper's geometry at 0.1 px: the 0.002-0.03 deg, 0.05-0.45 mm
    names = seeds.names
    mount_rot = [i for i, n in enumerate(names) if n[0] in "xyz" and ".rot" in n]
    mount_pos = [i for i, n in enumerate(names) if n[0] in "xyz" and ".r_b" in n]
    assert 0.001 <= seeds.crb[mount_rot].min() and seeds.crb[mount_rot].max() <= 0.03
    assert 0.02 <= seeds.crb[mount_pos].min() and seeds.crb[mount_pos].max() <= 0.45


def test_multi_seed_reported_sigma_matches_spread(seeds):
    ratio = seeds.mean_sigma / seeds.spread
    # with 20 seeds a sample standard deviation is itself uncertain by ~16 % (1 sigma), so the
    # +-30 % requirement is checked on the pooled ratio of each group; every single parameter
    # must still be within a factor 0.6-1.6
    names = seeds.names
    groups = {
        "intrinsics": [
            i
            for i, n in enumerate(names)
            if n.split(".")[1] in ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
        ],
        "attitudes": [i for i, n in enumerate(names) if ".rot" in n],
        "positions": [i for i, n in enumerate(names) if n.startswith(("r_", "x.r_", "y.r_", "z.r_"))],
    }
    assert sum(len(v) for v in groups.values()) == len(names)
    for g, sel in groups.items():
        pooled = np.sqrt(np.mean(seeds.mean_sigma[sel] ** 2 / seeds.spread[sel] ** 2))
        assert 0.7 <= pooled <= 1.3, (g, pooled)
    assert np.all((ratio > 0.6) & (ratio < 1.6)), [
        (n, r) for n, r in zip(names, ratio, strict=True) if not 0.6 < r < 1.6
    ]


# --- the covariance the results documents carry (docs/calib-results.md, issue 12) ----------------
def test_multi_seed_covariance_describes_the_errors_against_truth(seeds):
    """Refined: NEES of the truth ~ chi-square(45); paper: covered by Cov(ML) + d d^T."""
    n = seeds.n_parameters
    bound = chi2.ppf(0.99, n)
    print()
    print(seeds.coverage())
    assert len(seeds.nees_refined) == len(seeds.nees_paper) == N_SEEDS
    # the mean of 20 chi-square(45) draws is 45 +- 2.1 (1 sigma)
    assert 0.85 * n <= np.mean(seeds.nees_refined) <= 1.15 * n
    assert np.mean(seeds.nees_refined < bound) >= 0.95
    # per parameter: error / reported sigma has unit RMS, no parameter far off
    z = seeds.z_refined
    assert 0.85 <= np.sqrt(np.mean(z**2)) <= 1.15
    assert np.all(np.sqrt(np.mean(z**2, axis=0)) < 1.6)
    # the paper's estimate: the truth lies within its covariance
    assert np.mean(seeds.nees_paper < bound) >= 0.95
    assert np.mean(seeds.nees_paper) <= 1.3 * n


def test_rendered_dataset_covariance_covers_the_truth(default_run):
    """The default rendered dataset (OpenCV corners): both documents' covariances cover the truth."""
    cal, cmp = default_run
    bound = chi2.ppf(0.99, 45)
    _, cov = refined_covariance(cal.refined)
    nr = nees(parameter_error(cal.refined.rig, cal.truth), cov)
    _, cov_p = paper_covariance(cal.paper, cal.refined)
    e_p = parameter_error(cal.paper, cal.truth)
    npp, n_ml = nees(e_p, cov_p), nees(e_p, cov)
    print(
        f"\nrendered dataset NEES (45 parameters, 99 % bound {bound:.1f}): refined {nr:.1f}, "
        f"paper {npp:.1f} (under Cov(ML) alone {n_ml:.0f})"
    )
    assert nr < bound and npp < bound
    assert cmp.n_parameters == 45  # the report's line:
    assert (cmp.nees_refined, cmp.nees_paper) == pytest.approx((nr, npp), rel=1e-9)
    assert n_ml > 10 * bound  # without the rank-one term the paper's error is far outside
