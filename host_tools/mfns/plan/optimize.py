"""Beacon-layout optimiser: availability first, then the worst-case Cramer-Rao 1-sigma.

Algorithm (docs/planning.md): the candidates are grid points on the allowed surfaces
(surfaces.py). For every candidate and pose sample the C core decides, once, whether the
candidate is in view of each camera and gives its Jacobians (core.py); a candidate in
view contributes an information matrix (crlb.information: pixel noise and survey error,
exact per beacon). A layout's per-pose information is then the sum of its beacons'
contributions, so a move costs only the poses the moved beacon touches.

1. Greedy construction: add, one at a time, the feasible candidate (min spacing, not
   in a keep-out) that makes most poses reach a fix, then most (pose, missing beacon)
   deficits filled; ties are broken by the full objective below over a seeded sample.
2. Simulated annealing: for ``iterations`` rounds, take the layout's beacons in a
   seeded order and propose moving one to a random feasible candidate or to one within
   ``near_mm``, and accept it by the Metropolis rule on the energy worst + mean score +
   a penalty per pose without a fix and per missing beacon, with a geometric
   temperature schedule. score = max(max position 1-sigma / POS_SCALE_MM,
   max attitude 1-sigma / ATT_SCALE_DEG) of a pose with a fix; worst and mean over them.
   The best layout seen, by the lexicographic objective (poses with a fix, poses whose
   view the acquisition can certify in one call, -missing beacons below the fix
   threshold, -worst score, -mean score), is returned.

Certifiable acquisition (issue 27): a view of exactly four beacons is below every
certificate (firmware/nav/acquire/acquire.h: at least MFNS_BIDX_MIN_CERT = 5 inliers); the
acquisition certifies it only by an exhaustive completion of ~N^3/5 gP3P solves, tens of
cycles' budget, and 5.7 % of the module's four-blob views stay ambiguous
(docs/pose.md). So the objective counts, right after the poses with a fix, the poses
with at least CERT_MIN_IN_VIEW (+ margin; or --cert-in-view) beacons in view, and the annealing energy
charges for each pose below it. The identification margin of the acquisition's map
analysis (ident.py: the C core through the binding, ~50 ms a pose) is too slow for the
inner loop: run.py computes it for each restart's layout on a sample of poses and
prefers the layout with the fewest ambiguous views (margin <= 0) among those of equal
objective.

Deterministic for a seed (no wall-clock budget); run time is reported.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .analyze import CERT_MIN_IN_VIEW, FIX_MIN_IN_VIEW
from .core import Core
from .crlb import Observation, information, output_jacobian, sigma_batch
from .workspace import Workspace

# Score weights of the two kinds of 1-sigma: 1 mm of position counts as much as 0.1 deg
# of attitude (the ratio of the paper's Table 5 results, 1.6 mm to 0.15 deg).
POS_SCALE_MM = 1.0
ATT_SCALE_DEG = 0.1
TIE_SAMPLE = 24  # greedy: tied candidates scored with the full objective
NEAR_PROB = 0.5  # annealing: share of moves to a nearby candidate
# Annealing temperature, relative to the greedy layout's energy (worst + mean score):
# geometric from ANNEAL_T0 to ANNEAL_T_END over the iterations.
ANNEAL_T0 = 0.05
ANNEAL_T_END = 1e-4
# Energy cost of a pose losing its fix, relative to the greedy layout's worst + mean score.
ANNEAL_FIX_WEIGHT = 0.5
# Energy cost of a pose below CERT_MIN_IN_VIEW, relative to a pose losing its fix: a
# four-beacon view still gets a fix, over cycles (the carried search).
ANNEAL_CERT_WEIGHT = 0.5


@dataclass
class Problem:
    cand: np.ndarray  # (M, 3) mm
    ws: Workspace
    pair_c: np.ndarray  # (K,) candidate of each (candidate, pose) pair in view
    pair_p: np.ndarray  # (K,) pose
    pair_info: np.ndarray  # (K, 6, 6)
    start: np.ndarray  # (M + 1,) pairs of candidate c are start[c]:start[c + 1]
    jo: np.ndarray  # (P, 6, 6) output Jacobians
    build_s: float = 0.0


def build_problem(
    core: Core, cand: np.ndarray, ws: Workspace, sigma_px: float, beacon_sigma_mm: float, progress=False
) -> Problem:
    from tqdm import tqdm

    t0 = time.perf_counter()
    pc, pp, pi = [], [], []
    for p in tqdm(range(ws.n), desc="plan: candidates in view", unit="pose", disable=not progress):
        C, r = ws.C_w_b[p], ws.r_bw_b(p)
        per_cand: dict[int, list[Observation]] = {}
        for k in range(3):
            uv, vis, jac = core.project(k, C, r, cand)
            for cv in np.nonzero(vis)[0]:
                per_cand.setdefault(int(cv), []).append(
                    Observation(k, 0, uv[cv], jac[cv], jac[cv][:, 3:] @ C)
                )
        for c, obs in per_cand.items():
            pc.append(c)
            pp.append(p)
            pi.append(information(obs, sigma_px, [beacon_sigma_mm]))
    pair_c = np.array(pc, dtype=int)
    order = np.argsort(pair_c, kind="stable")
    pair_c = pair_c[order]
    pair_p = np.array(pp, dtype=int)[order]
    pair_info = np.array(pi).reshape(-1, 6, 6)[order]
    start = np.searchsorted(pair_c, np.arange(len(cand) + 1))
    jo = np.array([output_jacobian(ws.C_w_b[p], ws.r_bw_b(p)) for p in range(ws.n)])
    return Problem(cand, ws, pair_c, pair_p, pair_info, start, jo, time.perf_counter() - t0)


@dataclass
class State:
    prob: Problem
    chosen: list[int] = field(default_factory=list)
    target: int = FIX_MIN_IN_VIEW  # beacons in view that count as a fix for the objective
    cert: int = CERT_MIN_IN_VIEW  # beacons in view the acquisition certifies in one call

    def __post_init__(self):
        P = self.prob.ws.n
        self.count = np.zeros(P, dtype=int)
        self.H = np.zeros((P, 6, 6))
        self.score = np.full(P, np.inf)

    def _apply(self, c: int, sign: int) -> np.ndarray:
        s, e = self.prob.start[c], self.prob.start[c + 1]
        p = self.prob.pair_p[s:e]
        self.count[p] += sign
        self.H[p] += sign * self.prob.pair_info[s:e]
        return p

    def _rescore(self, p: np.ndarray) -> None:
        if len(p):
            sd = sigma_batch(self.H[p], self.prob.jo[p])
            self.score[p] = np.maximum(
                sd[:, :3].max(axis=1) / POS_SCALE_MM, sd[:, 3:].max(axis=1) / ATT_SCALE_DEG
            )

    def move(self, i: int | None, new: int | None) -> np.ndarray:
        """Replace chosen[i] by new (i None: append; new None: remove); returns touched poses."""
        touched = []
        if i is not None:
            touched.append(self._apply(self.chosen[i], -1))
        if new is not None:
            touched.append(self._apply(new, +1))
        if i is None:
            if new is None:
                raise ValueError("move(None, None): neither a beacon to replace nor one to add")
            self.chosen.append(new)
        elif new is None:
            self.chosen.pop(i)
        else:
            self.chosen[i] = new
        p = np.unique(np.concatenate(touched)) if touched else np.zeros(0, dtype=int)
        self._rescore(p)
        return p

    def objective(self) -> tuple:
        fix = self.count >= self.target
        cert = self.count >= max(self.cert, self.target)
        deficit = int(np.clip(self.target - self.count, 0, None).sum())
        worst = float(self.score[fix].max()) if fix.any() else np.inf
        mean = float(self.score[fix].mean()) if fix.any() else np.inf
        return (int(fix.sum()), int(cert.sum()), -deficit, -worst, -mean)

    def snapshot(self, p: np.ndarray):
        return list(self.chosen), self.count[p].copy(), self.H[p].copy(), self.score[p].copy()

    def restore(self, p: np.ndarray, snap) -> None:
        self.chosen, self.count[p], self.H[p], self.score[p] = snap[0], snap[1], snap[2], snap[3]


def better(a: tuple, b: tuple) -> bool:
    """Lexicographic a > b, float terms with a relative tolerance (no churn on rounding)."""
    for x, y in zip(a, b, strict=True):
        if isinstance(x, int):
            if x != y:
                return x > y
            continue
        if np.isinf(x) or np.isinf(y):
            if x != y:
                return x > y
            continue
        if abs(x - y) > 1e-9 * max(abs(x), abs(y)):
            return x > y
    return False


def _energy(obj: tuple, n_poses: int, scale: float) -> float:
    """Annealing energy: worst + mean score, plus `scale` per pose without a fix and per
    missing beacon below the fix threshold, and ANNEAL_CERT_WEIGHT * `scale` per pose
    the acquisition cannot certify in one call (so the search may cross a layout that
    loses a fix for a moment; the best layout kept is judged lexicographically)."""
    sig = (-obj[3] - obj[4]) if np.isfinite(obj[3]) else 0.0
    return sig + scale * ((n_poses - obj[0]) + ANNEAL_CERT_WEIGHT * (n_poses - obj[1]) + (-obj[2]))


def _accept(d: float, temp: float, rng: np.random.Generator) -> bool:
    """Metropolis rule on an energy change d."""
    return d <= 0 or (temp > 0 and rng.random() < np.exp(-d / temp))


class _Spacing:
    """Which candidates are closer than min_spacing, or within near_mm, of which: the
    same distances as computing them per move, once (M x M booleans)."""

    def __init__(self, cand: np.ndarray, min_spacing: float, near_mm: float):
        self.close = np.zeros((len(cand), len(cand)), dtype=bool)
        self.near = np.zeros((len(cand), len(cand)), dtype=bool)
        for c in range(len(cand)):
            d = np.linalg.norm(cand - cand[c], axis=1)
            self.close[c] = d < min_spacing if min_spacing > 0 else False
            self.near[c] = d <= near_mm

    def feasible(self, chosen: list[int], skip: int | None = None) -> np.ndarray:
        """Candidates not chosen and at least min_spacing from every chosen one but skip."""
        others = [c for j, c in enumerate(chosen) if j != skip]
        ok = (
            np.asarray(~self.close[others].any(axis=0))
            if others
            else np.ones(self.close.shape[0], dtype=bool)
        )
        ok[chosen] = False
        return ok


@dataclass
class Result:
    chosen: list[int]
    objective: tuple
    greedy_objective: tuple
    greedy_s: float
    search_s: float
    moves_tried: int
    moves_kept: int


def optimize(
    prob: Problem,
    n_beacons: int,
    min_spacing_mm: float,
    iterations: int,
    rng: np.random.Generator,
    near_mm: float = 200.0,
    progress: bool = False,
    margin: int = 0,
    certify: bool = True,
    cert_in_view: int | None = None,
) -> Result:
    """margin: the objective counts a pose as fixed only with FIX_MIN_IN_VIEW + margin
    beacons in view, and certifiable with CERT_MIN_IN_VIEW + margin -- a reserve against
    poses between the samples. cert_in_view: the beacons in view that count as
    certifiable in one call instead (default CERT_MIN_IN_VIEW + margin). certify False:
    no certifiable term (the objective before issue 27: every pose with a fix counts as
    certifiable)."""
    from tqdm import tqdm

    from ..core.errors import MfnsError

    st = State(prob, target=FIX_MIN_IN_VIEW + margin, cert=_cert_target(certify, margin, cert_in_view))
    t0 = time.perf_counter()
    spacing = _Spacing(prob.cand, min_spacing_mm, near_mm)
    for _ in tqdm(range(n_beacons), desc="plan: greedy", unit="beacon", disable=not progress):
        ok = spacing.feasible(st.chosen)
        if not ok.any():
            raise MfnsError(
                f"only {len(st.chosen)} of {n_beacons} beacons fit with --min-spacing {min_spacing_mm:g} mm"
            )
        need = st.count[prob.pair_p]
        gain_fix = np.bincount(prob.pair_c, weights=need == st.target - 1, minlength=len(prob.cand))
        gain_def = np.bincount(prob.pair_c, weights=need < st.target, minlength=len(prob.cand))
        primary = np.where(ok, gain_fix * (prob.ws.n + 1) + gain_def, -1.0)
        tied = np.nonzero(primary == primary.max())[0]
        if len(tied) > TIE_SAMPLE:
            tied = rng.choice(tied, TIE_SAMPLE, replace=False)
        pick: int | None = None
        pick_obj: tuple | None = None
        for c in tied:
            p = st.move(None, int(c))
            obj = st.objective()
            if pick_obj is None or better(obj, pick_obj):
                pick, pick_obj = int(c), obj
            st.move(len(st.chosen) - 1, None)
            del p
        st.move(None, pick)
    greedy_obj = st.objective()
    t1 = time.perf_counter()
    tried = kept = 0
    cur = best_obj = greedy_obj
    best = list(st.chosen)
    f0 = -cur[3] - cur[4] if np.isfinite(cur[3]) else 1.0
    scale = ANNEAL_FIX_WEIGHT * f0
    e_cur = _energy(cur, prob.ws.n, scale)
    order = rng.permutation(n_beacons)
    bar = tqdm(range(iterations), desc="plan: annealing", unit="move", disable=not progress)
    for it in bar:
        i = int(order[it % n_beacons])
        ok = spacing.feasible(st.chosen, skip=i)
        if rng.random() < NEAR_PROB:
            ok &= spacing.near[st.chosen[i]]
        idx = np.nonzero(ok)[0]
        if len(idx) == 0:
            continue
        new = int(rng.choice(idx))
        tried += 1
        old = st.chosen[i]
        s, e = prob.start[old], prob.start[old + 1]
        s2, e2 = prob.start[new], prob.start[new + 1]
        touched = np.unique(np.concatenate([prob.pair_p[s:e], prob.pair_p[s2:e2]]))
        snap = st.snapshot(touched)
        st.move(i, new)
        obj = st.objective()
        temp = ANNEAL_T0 * f0 * (ANNEAL_T_END / ANNEAL_T0) ** (it / max(iterations - 1, 1))
        e_new = _energy(obj, prob.ws.n, scale)
        if _accept(e_new - e_cur, temp, rng):
            cur, e_cur = obj, e_new
            kept += 1
            if better(obj, best_obj):
                best_obj, best = obj, list(st.chosen)
        else:
            st.restore(touched, snap)
    return Result(best, best_obj, greedy_obj, t1 - t0, time.perf_counter() - t1, tried, kept)


def _cert_target(certify: bool, margin: int, cert_in_view: int | None) -> int:
    """Beacons in view a pose needs to count as certifiable in one call (0: every pose)."""
    if not certify:
        return margin
    return CERT_MIN_IN_VIEW + margin if cert_in_view is None else int(cert_in_view)


def evaluate(
    prob: Problem, chosen: list[int], margin: int = 0, certify: bool = True, cert_in_view: int | None = None
) -> tuple:
    """The objective of a given layout (candidate indices)."""
    st = State(prob, target=FIX_MIN_IN_VIEW + margin, cert=_cert_target(certify, margin, cert_in_view))
    for c in chosen:
        st.move(None, c)
    return st.objective()
