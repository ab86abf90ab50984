"""mfns.plan.usable: the flight's own verdict on a planned view (firmware/host/plan_fix.h via
the binding), issue 43. The verdict must be the core's: a redundant view over three cameras
is usable, fewer beacons or a view the integrity cannot monitor is not, with the core's reason;
a layout with more beacons in view but a camera left blind predicts fewer usable poses."""

from __future__ import annotations

import ctypes as ct

import numpy as np
import pytest

from mfns.core.binding import PlanFix
from mfns.core.flight import REASONS
from mfns.model.pose_sim import paper_rig
from mfns.plan import usable, workspace
from mfns.plan.core import Core
from mfns.plan.run import table_workspace
from mfns.simulate.nav import module_scenario


@pytest.fixture(scope="module")
def core(core_lib):
    if not core_lib.exists():
        pytest.skip("make lib first")
    return Core(paper_rig(), core_lib)


@pytest.fixture(scope="module")
def module_map():
    scn = module_scenario(2, 18.6, 60, 2, None, None)
    return np.asarray(scn.beacons, dtype=float)


def _ws(n=60, seed=5):
    return workspace.module(n, np.random.default_rng(seed))


def test_null_arguments_are_refused_not_a_crash(core):
    out = PlanFix()
    assert core.lib.mfns_plan_fix(None, None, None, None, None, None, None, ct.byref(out)) == -1
    assert out.usable == 0 and out.status != 0  # NO_FIX, never a usable zero


def test_verdicts_are_the_cores_and_depend_on_the_view(core, module_map):
    ws = _ws()
    lo, hi = table_workspace(ws)
    u = usable.evaluate(core, module_map, np.full(len(module_map), 0.4), ws, 0.05, lo, hi)
    assert u.usable.any() and (~u.usable).any()  # the demo module has both (docs/planning.md)
    assert set(u.reason) <= set(REASONS)
    total = u.in_view_cam.sum(axis=1)
    # a usable fix has its PLs within the default alert limits (20 mm, 1 deg) and >= 4 beacons
    assert np.all(u.pl_pos_mm[u.usable] <= 20.0) and np.all(u.pl_att_deg[u.usable] <= 1.0)
    assert np.all(total[u.usable] >= 4)
    # three or fewer beacons: never usable
    assert not np.any(u.usable[total <= 3])
    s = u.summary()
    assert s["usable_pct"] == pytest.approx(100.0 * u.usable.mean(), abs=0.01)
    assert len(s["per_camera_seen_pct"]) == 3
    assert sum(s["unusable_reasons"].values()) == int((~u.usable).sum())


def test_survey_sigma_as_the_map_states_it_changes_the_verdict(core, module_map):
    """The PL grows with the survey sigma the map states: a map surveyed to 5 mm flies less."""
    ws = _ws(40, 7)
    lo, hi = table_workspace(ws)
    good = usable.evaluate(core, module_map, np.full(len(module_map), 0.2), ws, 0.05, lo, hi)
    bad = usable.evaluate(core, module_map, np.full(len(module_map), 5.0), ws, 0.05, lo, hi)
    assert bad.usable.sum() < good.usable.sum()
    assert np.all(bad.pl_pos_mm[good.usable & bad.usable] >= good.pl_pos_mm[good.usable & bad.usable] - 1e-3)


def test_a_blind_camera_costs_usable_poses(core, module_map):
    """Issue 43's failure: beacons in view are not what flies. Every beacon one camera could
    see moved into another's view keeps the beacon count but leaves a camera blind."""
    ws = _ws(60, 9)
    lo, hi = table_workspace(ws)
    sig = np.full(len(module_map), 0.4)
    base = usable.evaluate(core, module_map, sig, ws, 0.05, lo, hi)
    # the walls seen by camera z's side of the workspace: drop every beacon with z > 0 by
    # mirroring it below (same count, camera coverage changed)
    moved = module_map.copy()
    moved[:, 2] = -np.abs(moved[:, 2])
    other = usable.evaluate(core, moved, sig, ws, 0.05, *table_workspace(ws))
    assert other.usable.sum() < base.usable.sum()


def test_polish_climbs_on_the_flights_verdict_and_keeps_the_spacing(core):
    """usable.polish: the samples the flight would use never decrease, the result is judged
    again from scratch to the count it reports, and every beacon keeps the min spacing."""
    from mfns.plan import optimize as opt
    from mfns.plan import surfaces

    surf, keep = surfaces.load("module")
    cand, _ = surfaces.candidates(surf, 200.0, keep)
    ws = _ws(60, 11)
    prob = opt.build_problem(core, cand, ws, 0.0155, 0.4)
    res = opt.optimize(prob, 16, 150.0, 100, np.random.default_rng(1), margin=1)
    lo, hi = table_workspace(ws)
    pol = usable.polish(core, prob, res.chosen, 0.4, 0.0155, 150, 150.0, np.random.default_rng(2), lo, hi)
    assert pol.usable_after >= pol.usable_before
    assert pol.moves_kept > 0
    again = usable.evaluate(core, cand[pol.chosen], np.full(16, 0.4), ws, 0.0155, lo, hi)
    assert int(again.usable.sum()) == pol.usable_after
    p = cand[pol.chosen]
    d = np.linalg.norm(p[:, None] - p[None], axis=2) + np.eye(len(p)) * 1e9
    assert d.min() >= 150.0 - 1e-6 and len(set(pol.chosen)) == 16
