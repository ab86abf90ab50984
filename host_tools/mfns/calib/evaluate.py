"""Multi-seed check of the estimators on corner observations simulated directly.

One fixed geometry (turntable angles and prepared poses of `mfns sim calib`); per seed new
corner noise, new turntable angle errors (8") and a new caliper error. Image rendering and
corner detection are skipped for speed; Zhang, CPC and the refinement are the same code
`mfns calib` runs. Reports per quantity: RMS error of the paper's method and of the
refinement, the Cramér-Rao bound, the refinement's mean reported 1-sigma and the spread of
its estimates over the seeds, and the NEES of the truth under the covariances the results
documents carry (refined and paper method, docs/calib-results.md).

Run by tests/bench/bench_calib_seeds.py (`make bench-calib-seeds`) and the acceptance test
tests/host/test_calib_acceptance.py.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from tqdm import tqdm

from ..simulate.calib import Shot, corner_observations, default_truth, make_plan
from .covariance import N_PARAMETERS, nees, paper_covariance, parameter_error, refined_covariance
from .model import Board, Rig
from .pipeline import calibrate, paper_quantities
from .refine import cramer_rao, quantities


@dataclass
class SeedStats:
    names: list[str]
    truth: np.ndarray
    paper: np.ndarray  # (n_seeds, n_q) estimates
    refined: np.ndarray
    sigma: np.ndarray  # (n_seeds, n_q) reported 1-sigma
    crb: np.ndarray
    # the documents' covariance (covariance.py) against the truth, per seed
    nees_refined: np.ndarray  # (n_seeds,) e^T Cov^-1 e of the refined estimate
    nees_paper: np.ndarray  # (n_seeds,) of the paper's estimate under Cov(ML) + d d^T
    z_refined: np.ndarray  # (n_seeds, n_p) per-parameter error / sqrt(diag)
    n_parameters: int

    @property
    def rms_paper(self):
        return np.sqrt(np.mean((self.paper - self.truth) ** 2, axis=0))

    @property
    def rms_refined(self):
        return np.sqrt(np.mean((self.refined - self.truth) ** 2, axis=0))

    @property
    def spread(self):
        return np.std(self.refined, axis=0, ddof=1)

    @property
    def mean_sigma(self):
        return np.mean(self.sigma, axis=0)

    def table(self) -> str:
        lines = [
            f"{len(self.paper)} seeds; {self.coverage()}",
            f"{len(self.paper)} seeds; per quantity: RMS error (paper, refined), CRB, mean reported "
            "1-sigma, spread of the refined estimates",
            f"  {'quantity':14s} {'paper RMS':>10s} {'refined RMS':>11s} {'CRB':>9s} {'ref/CRB':>7s}"
            f" {'ref/paper':>9s} {'1-sigma':>9s} {'spread':>9s} {'sig/spread':>10s}",
        ]
        for i, n in enumerate(self.names):
            lines.append(
                f"  {n:14s} {self.rms_paper[i]:10.5f} {self.rms_refined[i]:11.5f} {self.crb[i]:9.5f}"
                f" {self.rms_refined[i] / self.crb[i]:7.2f} {self.rms_refined[i] / self.rms_paper[i]:9.2f}"
                f" {self.mean_sigma[i]:9.5f} {self.spread[i]:9.5f}"
                f" {self.mean_sigma[i] / self.spread[i]:10.2f}"
            )
        return "\n".join(lines)

    def coverage(self) -> str:
        """NEES of the truth under the documents' covariances against chi-square(n_parameters)."""
        from scipy.stats import chi2

        b99 = chi2.ppf(0.99, self.n_parameters)
        return (
            f"NEES of the truth ({self.n_parameters} parameters, expected {self.n_parameters}, 99 % bound "
            f"{b99:.1f}): refined mean {np.mean(self.nees_refined):.1f} max {np.max(self.nees_refined):.1f}; "
            f"paper (Cov(ML) + d d^T) mean {np.mean(self.nees_paper):.1f} max {np.max(self.nees_paper):.1f}; "
            f"refined per-parameter RMS error/sigma {np.sqrt(np.mean(self.z_refined**2)):.2f}"
        )


def _reangle(truth: Rig, shots: list[Shot], rng, angle_sigma_arcsec: float) -> list[Shot]:
    out = []
    for s in shots:
        if s.kind != "turntable":
            out.append(s)
            continue
        a = s.omega_big_deg + rng.normal(0.0, angle_sigma_arcsec) / 3600.0
        b = s.omega_small_deg + rng.normal(0.0, angle_sigma_arcsec) / 3600.0
        c, r = truth.camera_pose(s.camera, np.deg2rad(a), np.deg2rad(b))
        out.append(replace(s, true_omega_big_deg=a, true_omega_small_deg=b, C_k_w=c, r_wk_w=r))
    return out


def run_seeds(
    n_seeds: int,
    sigma_px: float = 0.1,
    n_turntable: int = 12,
    n_prepared: int = 10,
    plan_seed: int = 1,
    angle_sigma_arcsec: float = 8.0,
    progress: bool = False,
    seed_base: int = 1000,
) -> SeedStats:
    truth, board = default_truth(), Board()
    shots = make_plan(
        truth, board, np.random.default_rng(plan_seed), n_turntable, n_prepared, angle_sigma_arcsec
    )
    names, q_true = quantities(truth, truth)
    paper, refined, sigma = [], [], []
    nees_ref, nees_pap, z_ref = [], [], []
    obs = None
    for seed in tqdm(range(n_seeds), desc="seeds", disable=not progress):
        rng = np.random.default_rng(seed_base + seed)
        seed_shots = _reangle(truth, shots, rng, angle_sigma_arcsec)
        obs = corner_observations(
            truth, board, seed_shots, rng, sigma_px, angle_sigma_arcsec=angle_sigma_arcsec
        )
        cal = calibrate(obs)
        paper.append(paper_quantities(cal, truth)[1])
        refined.append(quantities(cal.refined.rig, truth)[1])
        sigma.append(cal.refined.sigma * sigma_px / cal.refined.sigma_px)  # at the known noise level
        # the covariances as the documents carry them (estimated noise), against the truth
        _, cov = refined_covariance(cal.refined)
        err = parameter_error(cal.refined.rig, truth)
        nees_ref.append(nees(err, cov))
        z_ref.append(err / np.sqrt(np.diag(cov)))
        if cal.paper is not None:
            _, cov_p = paper_covariance(cal.paper, cal.refined)
            nees_pap.append(nees(parameter_error(cal.paper, truth), cov_p))
    prep = [(s.C_k_w.T, -s.C_k_w.T @ s.r_wk_w) for s in shots if s.kind == "prepared"]
    ang = np.array([(s.omega_big_deg, s.omega_small_deg) for s in shots if s.kind == "turntable"])
    assert obs is not None
    _, crb = cramer_rao(obs, truth, prep, ang, sigma_px)
    return SeedStats(
        names,
        q_true,
        np.array(paper),
        np.array(refined),
        np.array(sigma),
        crb,
        np.array(nees_ref),
        np.array(nees_pap),
        np.array(z_ref),
        N_PARAMETERS * len(truth.cams),
    )
