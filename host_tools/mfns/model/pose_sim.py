"""Synthetic beacon observations for the pose solver's tests and benchmarks.

The paper's rig (docs/system.md §7 Tables 2-3, mfns/data/paper_calib.json) and beacon map
(Table 4, paper_beacons.csv); random poses with a required number of beacons in view
(vectorised rejection sampling: with these mounts only one to four of the ten beacons
are in view at a time); frames of (u, v) pixels with Gaussian noise and the matching
undistorted normalized (x, y), as the flight solver takes them.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from importlib import resources

import numpy as np

from .camera import Camera, load_beacons, rig_from_doc
from .rotations import random_rotations


def paper_rig() -> list[Camera]:
    doc = json.loads(resources.files("mfns.data").joinpath("paper_calib.json").read_text())
    return rig_from_doc(doc)


def paper_beacons() -> np.ndarray:
    with resources.as_file(resources.files("mfns.data").joinpath("paper_beacons.csv")) as p:
        return load_beacons(p)[1]


def visible_counts(cams: list[Camera], beacons: np.ndarray, C: np.ndarray, r_bw_b: np.ndarray) -> np.ndarray:
    """Beacons in view (in front, inside the image) for poses C (n,3,3), r_bw_b (n,3)."""
    p_b = np.einsum("nij,bj->nbi", C, beacons) + r_bw_b[:, None, :]
    total = np.zeros(len(C), dtype=int)
    for cam in cams:
        uv, front = cam.project_camera_points((p_b - cam.r_bk_b) @ cam.C_k_b)
        total += np.sum(front & cam.in_image(uv), axis=1)
    return total


def random_visible_poses(
    rng: np.random.Generator,
    cams,
    beacons,
    n: int,
    min_visible: int = 4,
    pos_range: float = 150.0,
    batch: int = 200_000,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """n poses (C_w_b, r_bw_b) with uniform attitude, body position within +-pos_range mm,
    and at least min_visible beacons in view."""
    out: list[tuple[np.ndarray, np.ndarray]] = []
    for _ in range(1000):
        C = random_rotations(rng, batch)
        pos = rng.uniform(-pos_range, pos_range, size=(batch, 3))
        r = -np.einsum("nij,nj->ni", C, pos)
        ok = np.nonzero(visible_counts(cams, beacons, C, r) >= min_visible)[0]
        out.extend((C[i], r[i]) for i in ok[: n - len(out)])
        if len(out) >= n:
            return out
    raise RuntimeError("could not find enough poses")


def make_frame(cams, beacons, C_w_b, r_bw_b, sigma: float, rng: np.random.Generator):
    """Observations of every visible beacon: ([(N_k, 4) u v x y per camera], [beacon ids per camera])."""
    obs, ids = [], []
    for cam in cams:
        uv, vis = cam.project(C_w_b, r_bw_b, beacons)
        idx = np.nonzero(vis)[0]
        uv = uv[idx] + sigma * rng.normal(size=(len(idx), 2))
        xy = cam.undistort_pixels(uv) if len(idx) else np.zeros((0, 2))
        obs.append(np.hstack([uv, xy]))
        ids.append(idx)
    return obs, ids


def paper_index(flight, rig, bmap, pos_range: float = 150.0):
    """The map index of the paper's beacons over the poses random_visible_poses draws
    (body within +-pos_range mm of the origin), with its certificate from the map
    analysis (mfns.table.mapindex, as `mfns table build` makes it)."""
    from ..table import mapindex

    lo, hi = np.full(3, -pos_range), np.full(3, pos_range)
    idx, _ = mapindex.build(flight, rig, bmap, None, (lo, hi), sigma_px=0.3, samples=40)
    return idx


@dataclass
class SweepResult:
    right: int = 0
    wrong: int = 0
    reasons: dict = field(default_factory=dict)
    seconds: list = field(default_factory=list)  # per acquisition call (C, through ctypes)
    units: list = field(default_factory=list)  # work units per call
    wrong_cases: list = field(default_factory=list)
    partial: int = 0  # right fixes that left a beacon in view unused

    @property
    def total(self) -> int:
        return self.right + self.wrong + sum(self.reasons.values())


def acquisition_frame(cams, beacons, C, r, sigma, rng, normals=None, spurious_rate=0.0):
    """One frame of the acquisition sweeps: every visible beacon with pixel noise sigma,
    without those whose LED faces away (normals, (N, 3), optional), and with a reflection
    (a blob of no beacon, id -1) in spurious_rate of the frames; at most 32 per camera."""
    obs, ids = make_frame(cams, beacons, C, r, sigma, rng)
    if normals is not None:
        p_w = -C.T @ r
        for k, cam in enumerate(cams):
            ck = p_w + C.T @ cam.r_bk_b
            keep = np.einsum("ij,ij->i", ck - beacons[ids[k]], normals[ids[k]]) > 0
            obs[k], ids[k] = obs[k][keep], ids[k][keep]
    if spurious_rate > 0 and rng.uniform() < spurious_rate:
        k = int(rng.integers(len(cams)))
        cam = cams[k]
        uv = rng.uniform([0.0, 0.0], [cam.width - 1.0, cam.height - 1.0])
        obs[k] = np.vstack([obs[k], np.concatenate([uv, cam.undistort_pixels(uv[None])[0]])])
        ids[k] = np.concatenate([ids[k], [-1]])
    for k in range(len(cams)):
        obs[k], ids[k] = obs[k][:32], ids[k][:32]
    return obs, ids


def identification_right(sol, ids) -> bool:
    """Every inlier of the fix carries its own beacon (a reflection taken for one is wrong)."""
    return all(
        (not sol.inlier[c][i]) or sol.assoc[c][i] == ids[c][i]
        for c in range(len(ids))
        for i in range(len(ids[c]))
    )


def identification_sweep(
    flight,
    rig,
    bmap,
    idx,
    cams,
    beacons,
    poses,
    sigma: float,
    rng: np.random.Generator,
    cfg,
    normals=None,
    spurious_rate: float = 0.0,
) -> SweepResult:
    """Cold acquisition (flight.acquire, no prior) on one frame of each pose, one call.
    beacons are the positions the frames are made from (they may differ from the map's by
    a survey error); normals and spurious_rate as in acquisition_frame. A fix is wrong
    when an inlier carries another beacon than its own (or a reflection is taken for a
    beacon): a wrong identification. A right fix may leave a blob unused (`partial`)."""
    import time

    res = SweepResult()
    for C, r in poses:
        obs, ids = acquisition_frame(cams, beacons, C, r, sigma, rng, normals, spurious_rate)
        t0 = time.perf_counter()
        sol, pr = flight.acquire(rig, bmap, idx, flight.frame(obs), cfg)
        res.seconds.append(time.perf_counter() - t0)
        res.units.append(pr.units)
        if not sol.ok:
            res.reasons[sol.reason] = res.reasons.get(sol.reason, 0) + 1
            continue
        correct = identification_right(sol, ids)
        res.partial += int(correct and sol.beacons_used != sum(int(np.sum(i >= 0)) for i in ids))
        res.right += int(correct)
        res.wrong += int(not correct)
        if not correct:
            res.wrong_cases.append((C, r, sol.r_wb_w, sol.beacons_used))
    return res


@dataclass
class CycleSweepResult:
    right: int = 0
    wrong: int = 0
    no_fix: int = 0
    bridged: int = 0  # fixes from a carried search, verified on a later frame
    cycles_to_fix: list = field(default_factory=list)  # per right fix: 1 = the first cycle
    seconds: list = field(default_factory=list)  # per cycle (C, through ctypes)
    units: list = field(default_factory=list)  # work units per cycle
    last_reasons: dict = field(default_factory=dict)  # the last cycle's reason, per pose without a fix
    wrong_cases: list = field(default_factory=list)


def acquisition_cycles_sweep(
    flight,
    rig,
    bmap,
    idx,
    cams,
    beacons,
    poses,
    sigma: float,
    rng: np.random.Generator,
    cfg,
    max_cycles: int,
    normals=None,
    spurious_rate: float = 0.0,
) -> CycleSweepResult:
    """Acquisition over navigation cycles (flight.acq_cycle: acquire_cycle.h) of a robot
    holding still at each pose: every cycle a new frame (new pixel noise, a reflection in
    spurious_rate of them), at most max_cycles cycles, stopping at the first fix. Counts
    right and wrong fixes as identification_sweep does, the cycles each right fix took,
    and every cycle's time and work."""
    import time

    from ..core.flight import ACQ_SOURCES

    if max_cycles < 1:
        raise ValueError(f"max_cycles must be at least 1, not {max_cycles}")
    carried = ACQ_SOURCES.index("CARRIED")
    res = CycleSweepResult()
    for C, r in poses:
        flight.acq_cycle_reset()
        cycles = 0
        for _ in range(max_cycles):
            cycles += 1
            obs, ids = acquisition_frame(cams, beacons, C, r, sigma, rng, normals, spurious_rate)
            t0 = time.perf_counter()
            sol, rep = flight.acq_cycle(rig, bmap, idx, flight.frame(obs), cfg)
            res.seconds.append(time.perf_counter() - t0)
            res.units.append(rep.progress.units)
            if sol.ok:
                break
        if not sol.ok:
            res.no_fix += 1
            res.last_reasons[sol.reason] = res.last_reasons.get(sol.reason, 0) + 1
            continue
        if identification_right(sol, ids):
            res.right += 1
            res.cycles_to_fix.append(cycles)
            res.bridged += int(rep.source == carried)
        else:
            res.wrong += 1
            res.wrong_cases.append((C, r, sol.r_wb_w, sol.beacons_used))
    return res
