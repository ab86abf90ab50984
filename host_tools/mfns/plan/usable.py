"""The usable rate a layout is planned for: the flight's own verdict per pose (issue 43).

Beacons in view are not what flies: a view of four or more beacons whose protection level
exceeds the alert limit, or whose fault hypotheses cannot be monitored, gives NO_FIX. So
for each pose sample the frame the rig sees (mfns_certify_frame: the flight camera model,
its emission cone, at most MFNS_MAX_OBS_PER_CAMERA per camera) goes through the C core's
own snapshot chain, firmware/host/plan_fix.h: the solver from the true pose with the true
association, then integrity (test, exclusion, protection level against the alert limits,
the table's default settings), with the survey 1-sigma the map states for each beacon
(beacons.csv sigma_mm, as the flight table carries it) and the rig's pixel noise. The
verdict (usable or not, the reason, the PLs) is the core's; nothing here decides.

What the prediction leaves out (and the fly check of `mfns plan optimize` measures): the
acquisition (a pose is counted usable as if identified; `one_call_pct` is the share usable
*and* with at least CERT_MIN_IN_VIEW beacons in view, the views the acquisition can certify
in one call), measurement noise and ghost spots, memory across cycles and camera health.
"""

from __future__ import annotations

import ctypes as ct
from dataclasses import dataclass

import numpy as np

from ..core.binding import PlanFix
from .analyze import CERT_MIN_IN_VIEW
from .core import Core
from .workspace import Workspace


@dataclass
class Usable:
    usable: np.ndarray  # (n,) bool: the flight would use the fix
    reason: np.ndarray  # (n,) str: the core's reason (OK, PL_EXCEEDS_AL, UNMONITORED, ...)
    pl_pos_mm: np.ndarray  # (n,) inf where not evaluated
    pl_att_deg: np.ndarray
    in_view_cam: np.ndarray  # (n, 3) observations per camera in the flight's frame

    def summary(self) -> dict:
        n = len(self.usable)
        seen = self.in_view_cam > 0
        total = self.in_view_cam.sum(axis=1)
        pl = self.pl_pos_mm[self.usable]
        reasons, counts = np.unique(self.reason[~self.usable], return_counts=True)
        return {
            "usable_pct": round(100.0 * float(self.usable.mean()), 2) if n else None,
            "one_call_pct": round(100.0 * float(np.mean(self.usable & (total >= CERT_MIN_IN_VIEW))), 2)
            if n
            else None,
            "unusable_reasons": {str(r): int(c) for r, c in zip(reasons, counts, strict=True)},
            "pl_pos_mm_p50_usable": round(float(np.median(pl)), 3) if len(pl) else None,
            "per_camera_seen_pct": [round(100.0 * float(v), 1) for v in seen.mean(axis=0)] if n else [],
            "per_camera_usable_seen_pct": [
                round(100.0 * float(v), 1) for v in (seen & self.usable[:, None]).mean(axis=0)
            ]
            if n
            else [],
        }


class UsableModel:
    """One layout's map (with its survey sigma), rig and map index, judged pose by pose."""

    def __init__(self, core: Core, beacons_w, sigma_mm, lo, hi, sigma_px: float):
        fl = core.flight
        self.core = core
        self.fl = fl
        self.bmap = fl.beacon_map(beacons_w, np.asarray(sigma_mm, dtype=float))
        self.idx = fl.build_index(core.rig, self.bmap, lo, hi)
        self.cfg = fl.config(sigma_px=sigma_px)

    def judge(self, C_w_b, r_bw_b) -> tuple[PlanFix, np.ndarray]:
        pose = self.fl.pose(C_w_b, r_bw_b)
        frame, assoc = self.fl.view(self.core.rig, self.bmap, self.idx, pose)
        out = PlanFix()
        self.fl.lib.mfns_plan_fix(
            ct.byref(self.core.rig),
            ct.byref(self.bmap),
            ct.byref(frame),
            ct.byref(assoc),
            ct.byref(pose),
            ct.byref(self.cfg),
            None,
            ct.byref(out),
        )
        return out, np.array(list(frame.count), dtype=int)


def evaluate(core: Core, beacons_w, sigma_mm, ws: Workspace, sigma_px: float, lo, hi) -> Usable:
    """The flight's verdict at every pose of ws (module docstring)."""
    from ..core.flight import REASONS

    m = UsableModel(core, beacons_w, sigma_mm, lo, hi, sigma_px)
    n = ws.n
    usable = np.zeros(n, dtype=bool)
    reason = np.empty(n, dtype=object)
    pl_p, pl_a = np.full(n, np.inf), np.full(n, np.inf)
    cams = np.zeros((n, 3), dtype=int)
    for i in range(n):
        f, counts = m.judge(ws.C_w_b[i], ws.r_bw_b(i))
        usable[i] = bool(f.usable)
        reason[i] = REASONS[f.reason] if 0 <= f.reason < len(REASONS) else f"?{f.reason}"
        pl_p[i], pl_a[i] = f.pl_pos_mm, f.pl_att_deg
        cams[i] = counts
    return Usable(usable, reason, pl_p, pl_a, cams)


@dataclass
class PolishResult:
    chosen: list[int]
    usable_before: int  # poses of the samples the flight would use, before and after
    usable_after: int
    one_call_before: int
    one_call_after: int
    moves_tried: int
    moves_kept: int
    seconds: float


# polish: share of moves to a candidate within near_mm of the moved beacon (else anywhere)
POLISH_NEAR_PROB = 0.5
POLISH_NEAR_MM = 300.0


def polish(core: Core, prob, chosen: list[int], sigma_mm: float, sigma_px: float, moves: int,
           min_spacing_mm: float, rng: np.random.Generator, lo, hi) -> PolishResult:  # fmt: skip
    """Hill-climb the layout on the flight's own verdict (issue 43): move one beacon at a time
    to a feasible candidate (min spacing kept; half the moves nearby) and keep the move when
    the samples the flight would use -- then those usable in one call -- increase, or stay
    and the optimiser's accuracy term (the worst, then the mean Cramer-Rao score of the poses
    with a fix, optimize.State) is no worse: a move that changes no verdict never trades
    accuracy away (a random walk over neutral moves made the planned turntable's 1 sigma
    5.4 times the original's).

    The optimiser's objective (optimize.py) counts beacons in view and the Cramer-Rao score,
    which a numpy sum makes fast; it cannot see a protection level over the alert limit or a
    camera left blind, which is what the flight refuses. Only the poses that see the old or
    the new candidate (prob.pair_p, the C core's visibility) are judged again per move, by
    the C core (mfns_plan_fix). The map index the frames are made with is built once: the
    planner's beacons have no emission cone (every beacon emits toward every pose), so the
    index's per-beacon geometry does not depend on where the beacon is."""
    import time

    from .optimize import State, _Spacing, better

    t0 = time.perf_counter()
    chosen = list(chosen)
    cand, ws = prob.cand, prob.ws
    model = UsableModel(core, cand[chosen], np.full(len(chosen), sigma_mm), lo, hi, sigma_px)
    use = np.zeros(ws.n, dtype=bool)
    one = np.zeros(ws.n, dtype=bool)

    def judge(poses) -> tuple[np.ndarray, np.ndarray]:
        u, o = np.zeros(len(poses), dtype=bool), np.zeros(len(poses), dtype=bool)
        for i, p in enumerate(poses):
            f, counts = model.judge(ws.C_w_b[p], ws.r_bw_b(p))
            u[i] = bool(f.usable)
            o[i] = u[i] and int(counts.sum()) >= CERT_MIN_IN_VIEW
        return u, o

    acc = State(prob)  # the accuracy term of the optimiser's objective, kept in step
    for c in chosen:
        acc.move(None, c)
    use[:], one[:] = judge(np.arange(ws.n))
    before = (int(use.sum()), int(one.sum()))
    spacing = _Spacing(cand, min_spacing_mm, POLISH_NEAR_MM)
    kept = 0
    for _ in range(moves):
        j = int(rng.integers(len(chosen)))
        old = chosen[j]
        ok = spacing.feasible(chosen, skip=j)
        if rng.random() < POLISH_NEAR_PROB and (ok & spacing.near[old]).any():
            ok &= spacing.near[old]
        if not ok.any():
            continue
        new = int(rng.choice(np.flatnonzero(ok)))
        poses = np.union1d(
            prob.pair_p[prob.start[old] : prob.start[old + 1]],
            prob.pair_p[prob.start[new] : prob.start[new + 1]],
        )
        model.bmap.beacon[j].p_w.x, model.bmap.beacon[j].p_w.y, model.bmap.beacon[j].p_w.z = map(
            float, cand[new]
        )
        u, o = judge(poses)
        d_use = int(u.sum()) - int(use[poses].sum())
        d_one = int(o.sum()) - int(one[poses].sum())
        acc_before = acc.objective()[3:]
        snap = acc.snapshot(poses)
        acc.move(j, new)
        neutral_ok = d_use == 0 and d_one == 0 and not better(acc_before, acc.objective()[3:])
        if d_use > 0 or (d_use == 0 and d_one > 0) or neutral_ok:
            chosen[j] = new
            use[poses], one[poses] = u, o
            kept += 1
        else:
            acc.restore(poses, snap)
            p = cand[old]
            model.bmap.beacon[j].p_w.x, model.bmap.beacon[j].p_w.y, model.bmap.beacon[j].p_w.z = map(float, p)
    return PolishResult(
        chosen, before[0], int(use.sum()), before[1], int(one.sum()), moves, kept, time.perf_counter() - t0
    )
