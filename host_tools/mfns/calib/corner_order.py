"""Corner order of the cameras a half-turn-symmetric board leaves open, decided by the joint fit.

A camera whose turntable images turn about one axis only cannot tell, alone, which corner of
a half-turn-symmetric chessboard is the first (halfturn.py puts its images in one orientation,
not the camera as a whole). The other cameras can: they fix the turntable in the world (C_t_w,
r_wt_w), and the camera's images turned as a whole are the same turns about an axis moved to
Rz(pi) (r_wt - c) (c: the board's far corner) and tilted the other way, which the shared
turntable does not fit unless its axis pierces the board at its centre along the normal.

So every open camera's order is decided by refining the whole rig (pipeline._fit, the same
start and refinement as any calibration) once per combination of orders (2^m fits for m open
cameras, at most MAX_OPEN_CAMERAS) and comparing the chi-squares of the fits:
chi2_h = sum(corner residual^2) / sigma^2 + the whitened angle and caliper terms, with one
sigma for all (the corner noise the best fit estimates, its sum over its degrees of freedom).

The margin. Whitened residuals: the true order T fits the noise-free corners exactly, the
other W leaves a residual vector b there (delta^2 = |b|^2, the geometry's evidence). To first
order chi2_W - chi2_T = delta^2 + 2 b^T e with b^T e ~ N(0, delta^2) (e: the corner noise),
i.e. D ~ N(delta^2, 4 delta^2). Had the order with the larger chi2 been the true one, a lead
of D or more for the other is observed with probability Phi(-(D + delta^2) / (2 delta)), at
most Phi(-sqrt(D)) (at delta = sqrt(D)) whatever the geometry. Deciding only when
D >= MARGIN_CHI2 = 25 bounds the probability of a false decision by Phi(-5) = 2.9e-7. The
term neglected is the difference of the noise's projections on the two fits' parameter
spaces (mean 0); it is small where the orders are hard to tell (the fits are then nearly
reparametrisations of each other) and irrelevant where they are easy. Where the margin cannot
tell, the calibration is refused, with both chi-squares, RMS and the margin in the message.

A fit of the other order may stop at the refinement's evaluation limit (a badly fitting order
crawls: on the 9 x 7 test rig the wrong order stops at RMS ~34 px, the same from two
different starts); its chi2 is then taken less what one more Gauss-Newton step would remove
(g^T (J^T J)^-1 g at the stop), the first-order estimate of its minimum.

Misses: a wrong order whose minimum lies far below that first-order estimate (a second valley
the refinement does not reach) would look worse than it is; when every camera is
open, one of them is put in order by the world-frame convention (halfturn.py: the turntable's
zero along the board's axes), the others relative to it by the residuals.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import norm

from ..core.errors import MfnsError
from ..model.rotations import rot_log, rz
from .halfturn import HalfTurns, apply_half_turns
from .model import Observations
from .zhang import ZhangResult, calibrate_camera

if TYPE_CHECKING:
    from .pipeline import Calibration

MARGIN_Z = 5.0  # false-decision probability at most Phi(-MARGIN_Z)
MARGIN_CHI2 = MARGIN_Z**2
MAX_OPEN_CAMERAS = 3  # 2^3 = 8 refinements


@dataclass
class _Hypothesis:
    turned: tuple[bool, ...]  # per open camera: all its turntable images reversed
    flips: list[int]
    cal: Calibration | None
    error: str = ""
    sum_px2: float = float("nan")  # sum of squared corner residuals, px^2
    prior_chi2: float = float("nan")  # whitened angle and caliper residuals
    n_res: int = 0
    n_par: int = 0
    gn_px2: float = 0.0  # sum of squares one more Gauss-Newton step would still remove, px^2
    converged: bool = True

    @property
    def rms_px(self) -> float:
        return float(np.sqrt(self.sum_px2 / max(self.n_res, 1)))

    def chi2(self, sigma_px: float) -> float:
        return self.sum_px2 / sigma_px**2 + self.prior_chi2 if self.cal is not None else float("inf")

    def chi2_low(self, sigma_px: float) -> float:
        """chi2 less what one more Gauss-Newton step would remove: the first-order estimate of
        its minimum when the refinement stopped at its evaluation limit (converged: ~chi2)."""
        return self.chi2(sigma_px) - self.gn_px2 / sigma_px**2


@dataclass
class CornerOrder:
    """The decision for one open camera (in the report and the results JSON)."""

    camera: str
    reference_image: str  # its first turntable image: the order is named by this image's corner 0
    turned: bool  # chosen: the reference image's corners reversed (True) or as detected
    chi2_chosen: float
    chi2_other: float  # the best fit with this camera's order the other way
    rms_px_chosen: float
    rms_px_other: float
    sigma_px: float  # the corner noise both chi-squares use
    chi2_other_low: float  # chi2_other less what one more Gauss-Newton step would remove
    margin_chi2: float = MARGIN_CHI2

    @property
    def difference(self) -> float:
        """The lead the decision uses (the other order's chi2 taken at its first-order minimum)."""
        return self.chi2_other_low - self.chi2_chosen

    @property
    def false_decision_bound(self) -> float:
        """Phi(-sqrt(D)): the most a wrong order leads by D (see the module header)."""
        return float(norm.sf(np.sqrt(max(self.difference, 0.0))))

    def words(self, turned: bool) -> str:
        return f"{self.reference_image} {'turned' if turned else 'as detected'}"

    def line(self) -> str:
        return (
            f"camera {self.camera}: corner order decided by the joint fit: {self.words(self.turned)} "
            f"chi-square {self.chi2_chosen:.1f} (RMS {self.rms_px_chosen:.4f} px), "
            f"{self.words(not self.turned)} {self.chi2_other:.1f}{self._low()} "
            f"(RMS {self.rms_px_other:.4f} px) at "
            f"sigma {self.sigma_px:.4f} px; difference {self.difference:.1f} >= margin {self.margin_chi2:g} "
            f"(false decision <= {self.false_decision_bound:.1e})"
        )

    def _low(self) -> str:
        if self.chi2_other - self.chi2_other_low <= 1e-6 * max(abs(self.chi2_other), 1.0):
            return ""
        return f" (first-order minimum {self.chi2_other_low:.1f})"

    def to_dict(self) -> dict:
        return {
            "camera": self.camera,
            "reference_image": self.reference_image,
            "reference_turned": self.turned,
            "chi2_chosen": float(self.chi2_chosen),
            "chi2_other": float(self.chi2_other),
            "rms_px_chosen": float(self.rms_px_chosen),
            "rms_px_other": float(self.rms_px_other),
            "sigma_px": float(self.sigma_px),
            "chi2_other_first_order_minimum": float(self.chi2_other_low),
            "margin_chi2": float(self.margin_chi2),
            "false_decision_bound": self.false_decision_bound,
        }


def _angle(r: np.ndarray) -> float:
    return float(np.linalg.norm(rot_log(r)))


def _evaluate(
    obs: Observations,
    zhang: list[ZhangResult],
    turns: HalfTurns,
    turned: tuple[bool, ...],
    fit: Callable[[list[ZhangResult]], Calibration],
) -> _Hypothesis:
    """Refine the rig with the open cameras' orders `turned`; obs is left as it was."""
    flips = [i for k, t in zip(turns.open, turned, strict=True) if t for i in turns.turntable[k]]
    again = {k for k, t in zip(turns.open, turned, strict=True) if t}
    apply_half_turns(obs, flips)
    try:
        z = [calibrate_camera(obs, k) if k in again else zk for k, zk in enumerate(zhang)]
        hyp = _Hypothesis(turned, flips, fit(z))
    except MfnsError as exc:
        hyp = _Hypothesis(turned, flips, None, str(exc))
    finally:
        apply_half_turns(obs, flips)  # reversing twice restores the order
    if hyp.cal is not None:
        ref = hyp.cal.refined
        prob = ref.problem
        r = prob.residuals(ref.x)
        px = r[: prob.n_corner_slots] * prob.sigma_px
        hyp.sum_px2 = float(px @ px)
        hyp.prior_chi2 = float(r[prob.n_corner_slots :] @ r[prob.n_corner_slots :])
        hyp.n_res, hyp.n_par = prob.n_corner_res, prob.n
        hyp.gn_px2 = ref.gn_decrease * prob.sigma_px**2
        hyp.converged = ref.converged
    return hyp


def _refusal(obs: Observations, k: int, why: str) -> MfnsError:
    b = obs.board
    return MfnsError(
        f"camera {obs.camera_names[k]}: on a half-turn-symmetric board (inner_corners {b.cols} x {b.rows}) "
        f"its turntable images turn about one axis only, and the joint fit through the shared turntable "
        f"cannot tell which corner is the first: {why}; use a board with one odd and one even square "
        "count, or turn this camera about both axes"
    )


def decide_corner_order(
    obs: Observations,
    zhang: list[ZhangResult],
    turns: HalfTurns,
    fit: Callable[[list[ZhangResult]], Calibration],
) -> tuple[Calibration, list[int], list[CornerOrder]]:
    """(the chosen order's fit, the images it reverses, one decision per open camera).

    `obs` must hold the per-camera orientation already (turns.flips applied); the chosen
    flips are not applied here. Raises MfnsError where the margin cannot tell.
    """
    m = len(turns.open)
    if m > MAX_OPEN_CAMERAS:
        names = [obs.camera_names[k] for k in turns.open]
        raise _refusal(
            obs,
            turns.open[0],
            f"{m} cameras ({', '.join(names)}) turn about one axis only, the joint decision "
            f"takes at most {MAX_OPEN_CAMERAS} ({2**MAX_OPEN_CAMERAS} refinements)",
        )
    anchored = m == obs.n_cams  # no camera fixes the world frame: the first open one does
    combos = [c for c in itertools.product((False, True), repeat=m) if not (anchored and c[0])]
    hyps = [_evaluate(obs, zhang, turns, c, fit) for c in combos]
    fitted = [h for h in hyps if h.cal is not None]
    if not fitted:
        raise MfnsError(hyps[0].error)
    # the corner noise from the fit with the smallest corner residuals (the best one whenever
    # the decision is clear), then the best by chi-square at that sigma
    sigma = min(float(np.sqrt(h.sum_px2 / max(h.n_res - h.n_par, 1))) for h in fitted)
    best = min(fitted, key=lambda h: h.chi2(sigma))
    decisions: list[CornerOrder] = []
    for j, k in enumerate(turns.open):
        if anchored and j == 0:
            continue
        ref_name = obs.images[turns.turntable[k][0]].name
        rivals = [h for h in hyps if h.turned[j] != best.turned[j]]
        failed = [h for h in rivals if h.cal is None]
        if failed:
            side = "turned" if not best.turned[j] else "as detected"
            raise _refusal(
                obs, k, f"the fit with {ref_name} {side} failed ({failed[0].error}): nothing to compare with"
            )
        other = min(rivals, key=lambda h: h.chi2_low(sigma))
        d = CornerOrder(
            obs.camera_names[k],
            ref_name,
            best.turned[j],
            best.chi2(sigma),
            other.chi2(sigma),
            best.rms_px,
            other.rms_px,
            sigma,
            other.chi2_low(sigma),
        )
        if d.difference < MARGIN_CHI2:
            raise _refusal(
                obs,
                k,
                f"chi-square {d.chi2_chosen:.1f} (corner RMS {d.rms_px_chosen:.4f} px) with "
                f"{d.words(d.turned)}, {d.chi2_other:.1f}{d._low()} (RMS {d.rms_px_other:.4f} px) with "
                f"{d.words(not d.turned)} at sigma {sigma:.4f} px; the difference {d.difference:.1f} is "
                f"below the margin {MARGIN_CHI2:g} (a false decision could be as likely as "
                f"{d.false_decision_bound:.1e})",
            )
        decisions.append(d)
    chosen = best
    assert chosen.cal is not None
    if anchored and _angle(rz(np.pi) @ chosen.cal.refined.rig.C_t_w) < _angle(chosen.cal.refined.rig.C_t_w):
        # the same fit in the other world frame: the turntable's zero along the board names it
        chosen = _evaluate(obs, zhang, turns, tuple(not t for t in best.turned), fit)
        if chosen.cal is None:
            raise MfnsError(f"corner order: the fit in the turntable's world frame failed: {chosen.error}")
        decisions = [replace(d, turned=not d.turned) for d in decisions]
    assert chosen.cal is not None
    return chosen.cal, chosen.flips, decisions
