"""The C pose solver through ctypes (mfns.core.flight): the statistics that are too slow for
the C unit tests under qemu: identification on 1000 random poses, and the 1000-trial
Monte Carlo of the covariance on the paper's geometry."""

from __future__ import annotations

import numpy as np
import pytest

from mfns.core.flight import Flight
from mfns.model import pose_sim
from mfns.table import mapindex
from mfns.tlm import tlm_dict


@pytest.fixture(scope="module")
def flight(core_lib):
    if not core_lib.exists():
        pytest.fail(f"{core_lib} missing: run make lib")
    return Flight(core_lib)


@pytest.fixture(scope="module")
def paper(flight):
    cams = pose_sim.paper_rig()
    beacons = pose_sim.paper_beacons()
    return cams, beacons, flight.rig(cams), flight.beacon_map(beacons, 0.3963)


@pytest.fixture(scope="module")
def paper_index(flight, paper):
    _, _, rig, bmap = paper
    return pose_sim.paper_index(flight, rig, bmap)


def _yaw_pose(yaw_deg: float):
    a = np.deg2rad(yaw_deg)
    # frame rotation R3(yaw): the turntable turned by yaw about Zt, body at the world origin
    C = np.array([[np.cos(a), np.sin(a), 0.0], [-np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    return C, np.zeros(3)


def test_identification_on_1000_random_poses(flight, paper, paper_index):
    cams, beacons, rig, bmap = paper
    rng = np.random.default_rng(7)
    cfg = flight.config(sigma_px=0.3)
    poses = pose_sim.random_visible_poses(rng, cams, beacons, 1000, min_visible=4)
    res = pose_sim.identification_sweep(flight, rig, bmap, paper_index, cams, beacons, poses, 0.3, rng, cfg)
    print(f"identification: {res.right} right, {res.wrong} wrong of {len(poses)}; no fix: {res.reasons}")
    assert res.wrong == 0  # never a wrong identification reported as a fix
    # four-blob views that another identification explains as well are refused (AMBIGUOUS)
    assert res.right >= 0.97 * len(poses)
    assert max(res.units) <= paper_index.budget_units + 64


def _monte_carlo(flight, cams, beacons, rig, bmap, C, r, sigma, trials, rng):
    cfg = flight.config(sigma_px=sigma)
    obs, ids = pose_sim.make_frame(cams, beacons, C, r, 0.0, rng)
    assoc = flight.assoc(ids)
    truth = flight.pose(C, r)
    ref = flight.refine(rig, bmap, flight.frame(obs), assoc, truth, cfg)
    assert ref.ok
    errs, pos_errs = [], []
    for _ in range(trials):
        obs, _ = pose_sim.make_frame(cams, beacons, C, r, sigma, rng)
        sol = flight.refine(rig, bmap, flight.frame(obs), assoc, truth, cfg)
        assert sol.ok
        d = sol.C_w_b @ C.T  # exp(dtheta)
        dtheta = 0.5 * np.array([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]])
        errs.append(np.concatenate([dtheta, sol.r_bw_b - r]))
        pos_errs.append(sol.r_wb_w - (-C.T @ r))
    errs = np.array(errs)
    L = np.linalg.cholesky(ref.cov)
    w = np.linalg.solve(L, errs.T).T
    S = w.T @ w / len(w)  # whitened second moment: identity if the prediction is right
    pos_var = np.mean(np.array(pos_errs) ** 2, axis=0) / ref.sigma_pos_mm**2
    return S, pos_var, ref


@pytest.mark.parametrize("sigma", [0.1, 0.3])
def test_covariance_matches_monte_carlo(flight, paper, sigma):
    cams, beacons, rig, _ = paper
    bmap = flight.beacon_map(beacons)  # pixel noise only: no survey error in the frames, none in the map
    rng = np.random.default_rng(11)
    poses = [_yaw_pose(30.0), _yaw_pose(260.0)]  # the turntable poses with four beacons in view
    poses += pose_sim.random_visible_poses(rng, cams, beacons, 2, min_visible=5)  # closer, denser
    for C, r in poses:
        S, pos_var, ref = _monte_carlo(flight, cams, beacons, rig, bmap, C, r, sigma, 1000, rng)
        print(
            f"sigma {sigma}: predicted 1-sigma {ref.sigma_pos_mm} mm {ref.sigma_euler_deg} deg; "
            f"whitened diag {np.diag(S)}"
        )
        assert np.all(np.abs(np.diag(S) - 1.0) < 0.15)
        assert np.all(np.abs(S - np.diag(np.diag(S))) < 0.15)
        assert np.all(np.abs(pos_var - 1.0) < 0.15)


def test_too_few_beacons_no_fix(flight, paper, paper_index):
    cams, beacons, rig, bmap = paper
    C, r = _yaw_pose(0.0)  # beacon 8 in X, 9 in Z
    obs, ids = pose_sim.make_frame(cams, beacons, C, r, 0.1, np.random.default_rng(1))
    assert sum(len(i) for i in ids) == 2
    sol, progress = flight.acquire(rig, bmap, paper_index, flight.frame(obs), flight.config())
    assert progress.hypotheses == 0
    assert sol.status == "NO_FIX" and sol.reason == "TOO_FEW"
    # the core's text of the reason is the dictionary's (generated: nav_codes_gen.c)
    text = flight.strerror(sol.reason)
    desc = next(d for label, d in tlm_dict.load().enums["nav_reason_t"].values() if label == "TOO_FEW")
    assert "fewer than 3 beacons" in text and desc.endswith(text)


def test_tracking_from_previous_pose(flight, paper):
    cams, beacons, rig, bmap = paper
    C, r = _yaw_pose(30.0)
    obs, ids = pose_sim.make_frame(cams, beacons, C, r, 0.1, np.random.default_rng(2))
    prev_C, prev_r = _yaw_pose(30.2)
    sol = flight.track(rig, bmap, flight.frame(obs), flight.pose(prev_C, prev_r), flight.config())
    assert sol.status in ("OK", "DEGRADED")
    assert sol.hypotheses == 0
    assert np.allclose(sol.euler_deg, [0.0, 0.0, 30.0], atol=0.05)
    assert np.linalg.norm(sol.r_wb_w) < 1.0


@pytest.fixture(scope="module")
def module_map(flight):
    """The 60-beacon module of `mfns sim nav --scenario module` with its index (a short
    map analysis: the certificate only has to be the table's kind, not its value)."""
    from mfns.simulate import nav

    cams = pose_sim.paper_rig()
    pos, nrm = nav.module_beacons(60, np.random.default_rng([2, 1]))
    rig, bmap = flight.rig(cams), flight.beacon_map(pos, 0.4)
    ws = mapindex.default_workspace(pos)
    idx, _ = mapindex.build(flight, rig, bmap, (nrm, np.full(len(pos), 90.0)), ws, 0.3, samples=40)
    return cams, pos, nrm, rig, bmap, idx, ws


def test_module_search_resumed_over_calls_equals_one_call(flight, module_map):
    """A search split into calls of 2,000 units ends exactly as one call with room for
    all of it (same hypotheses, same outcome), in the module's bands and in its 4-blob
    completions (acquire.h, "Resumable")."""
    cams, pos, nrm, rig, bmap, idx, ws = module_map
    rng = np.random.default_rng(21)
    cfg = flight.config(sigma_px=0.3)
    split = completed = 0
    for C, r in mapindex.random_poses(rng, ws[0], ws[1], 400):
        obs, ids = pose_sim.acquisition_frame(cams, pos, C, r, 0.3, rng, nrm)
        if sum(len(i) for i in ids) < 4:
            continue
        frame = flight.frame(obs)
        one, p1 = flight.acquire(rig, bmap, idx, frame, cfg, budget_units=2_000_000)
        assert not p1.budget_out
        many, p2 = flight.acquire(rig, bmap, idx, frame, cfg, budget_units=2000)
        while flight.acquire_pending():
            many, p2 = flight.acquire_resume(2000)
        split += p2.calls > 1
        completed += p1.completed
        assert (one.status, one.reason) == (many.status, many.reason)
        assert p2.hypotheses == p1.hypotheses
        assert (one.assoc == many.assoc).all()
        if one.ok:
            assert pose_sim.identification_right(one, ids)
        if split >= 12 and completed >= 2:
            break
    assert split >= 12 and completed >= 2, (split, completed)


def test_module_acquisition_over_cycles(flight, module_map):
    """A robot holding still in the module: over at most 40 cycles of the table's
    budget, the navigator's acquisition (acquire_cycle.h) identifies views a single
    cycle cannot (4-blob views certified by a completion carried over cycles, then
    confirmed on the current frame), never a wrong one, and no cycle spends more than
    its budget."""
    cams, pos, nrm, rig, bmap, idx, ws = module_map
    rng = np.random.default_rng(22)
    cfg = flight.config(sigma_px=0.3)
    poses = []
    for C, r in mapindex.random_poses(rng, ws[0], ws[1], 4000):
        obs, ids = pose_sim.acquisition_frame(cams, pos, C, r, 0.0, rng, nrm)
        if sum(len(i) for i in ids) == 4:  # the hard views: 4 beacons
            poses.append((C, r))
        if len(poses) == 12:
            break
    res = pose_sim.acquisition_cycles_sweep(flight, rig, bmap, idx, cams, pos, poses, 0.3, rng, cfg, 40, nrm)
    print(
        f"4-beacon views over cycles: {res.right} right ({res.bridged} carried), {res.wrong} wrong, "
        f"{res.no_fix} no fix {res.last_reasons}; cycles {res.cycles_to_fix}"
    )
    assert res.wrong == 0
    assert res.bridged >= 6  # most 4-blob views need more than one cycle's budget
    assert max(res.units) <= idx.budget_units + 200
