"""Four beacons plus one reflection (issue 27): the acquisition of a view of exactly four
beacons and one blob of no beacon, C through ctypes, on the maps of bench_ident.py (same
index, certificate, survey error 0.4 mm, sigma 0.3 px).

Random poses of each map's workspace whose frame holds exactly four beacons (LEDs facing
away not seen); one reflection is added at a random pixel of a random camera and stays
there while the robot holds still. Two sweeps:

- one call: mfns_acquire on the first frame, within one cycle's budget and, to show what
  the five-blob completion decides when it may finish, without a budget (10^9 units);
- cycles: the navigator's acquisition over cycles (acquire_cycle.h) of the robot holding
  still, a new frame (new pixel noise, the same reflection) every cycle, at most 40.

Printed per map: right fixes (every inlier its own beacon, the reflection none), wrong
fixes (must be 0), no fix by reason (SPURIOUS_AMBIGUOUS: a second identification explains
four of the five blobs, so the frame cannot tell which blob is the reflection), and the
work a five-blob completion took.

    python tests/bench/bench_pose_reflection.py [--maps paper module large] [--poses N]
                                                [--seed S] [--cycles K] [--map-workspace]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_ident import SIGMA_PX, SURVEY_SIGMA_MM, setup  # noqa: E402

from mfns.model import pose_sim  # noqa: E402
from mfns.simulate import nav  # noqa: E402
from mfns.table import mapindex  # noqa: E402

UNBOUNDED = 10**9


def frame_with(cams, beacons, C, r, rng, normals, refl):
    """A frame of the pose with the reflection refl = (camera, u, v) appended."""
    obs, ids = pose_sim.acquisition_frame(cams, beacons, C, r, SIGMA_PX, rng, normals, 0.0)
    k, uv = refl
    obs[k] = np.vstack([obs[k], np.concatenate([uv, cams[k].undistort_pixels(uv[None])[0]])])
    ids[k] = np.concatenate([ids[k], [-1]])
    return obs, ids


def four_beacon_poses(fl, rig, bmap, idx, cams, truth, normals, rng, lo, hi, n):
    """n poses whose frame holds exactly four beacons, each with its reflection."""
    out = []
    while len(out) < n:
        for C, r in mapindex.random_poses(rng, lo, hi, 4096):
            f, _ = fl.view(rig, bmap, idx, fl.pose(C, r))
            if sum(f.count) < 4 or sum(f.count) > 6:
                continue
            obs, ids = pose_sim.acquisition_frame(cams, truth, C, r, SIGMA_PX, rng, normals, 0.0)
            if sum(len(i) for i in ids) != 4:
                continue
            k = int(rng.integers(len(cams)))
            uv = rng.uniform([0.0, 0.0], [cams[k].width - 1.0, cams[k].height - 1.0])
            out.append((C, r, (k, uv)))
            if len(out) == n:
                break
    return out


def tally(counts: dict, sol, ids) -> None:
    if not sol.ok:
        counts[sol.reason] = counts.get(sol.reason, 0) + 1
    elif pose_sim.identification_right(sol, ids):
        counts["right"] = counts.get("right", 0) + 1
    else:
        counts["WRONG"] = counts.get("WRONG", 0) + 1


def pct(counts: dict, key: str, n: int) -> str:
    return f"{100.0 * counts.get(key, 0) / n:.1f} %"


def run(name: str, n: int, seed: int, cycles: int, robot_ws: bool = True) -> bool:
    # the module maps: index and poses in the box the module scenario's paths stay in, as
    # the robot's table is built (`mfns table build --workspace scenario.json`);
    # --map-workspace: the map's default box
    m = setup(name, nav.module_workspace() if robot_ws and name != "paper" else None)
    fl, cams, rig, pos, nrm, ws, bmap, idx = m.fl, m.cams, m.rig, m.pos, m.nrm, m.ws, m.bmap, m.idx
    rng = np.random.default_rng([seed, len(pos), 27])
    truth = pos if name == "paper" else pos + rng.normal(0.0, SURVEY_SIGMA_MM, pos.shape)
    cfg = m.cfg
    poses = four_beacon_poses(fl, rig, bmap, idx, cams, truth, nrm, rng, ws[0], ws[1], n)
    one, free, cyc = {}, {}, {}
    free_units = []
    for C, r, refl in poses:
        obs, ids = frame_with(cams, truth, C, r, rng, nrm, refl)
        sol, _ = fl.acquire(rig, bmap, idx, fl.frame(obs), cfg)
        tally(one, sol, ids)
        sol, pr = fl.acquire(rig, bmap, idx, fl.frame(obs), cfg, UNBOUNDED)
        tally(free, sol, ids)
        free_units.append(pr.units)
        if cycles > 0:
            fl.acq_cycle_reset()
            for _ in range(cycles):
                obs, ids = frame_with(cams, truth, C, r, rng, nrm, refl)
                sol, _ = fl.acq_cycle(rig, bmap, idx, fl.frame(obs), cfg)
                if sol.ok:
                    break
            tally(cyc, sol, ids)
    u = np.array(free_units)
    print(
        f"== {name}: {len(pos)} beacons, {n} views of four beacons + one reflection "
        f"(budget {idx.budget_units}; workspace {np.round(ws[0]).tolist()}..{np.round(ws[1]).tolist()} mm)"
    )
    rows = [("one call", one), ("one call, no budget", free)]
    if cycles > 0:
        rows.append((f"within {cycles} cycles, still", cyc))
    for label, c in rows:
        others = {k: v for k, v in c.items() if k not in ("right", "WRONG")}
        print(
            f"{name} {label}: right {c.get('right', 0)} ({pct(c, 'right', n)}), wrong {c.get('WRONG', 0)}, "
            f"none {n - c.get('right', 0) - c.get('WRONG', 0)} ({others})"
        )
    print(
        f"{name} five-blob search without a budget: work units median {np.median(u):.0f}, "
        f"p90 {np.percentile(u, 90):.0f}, max {u.max()}"
    )
    return one.get("WRONG", 0) == 0 and free.get("WRONG", 0) == 0 and cyc.get("WRONG", 0) == 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", nargs="+", default=["paper", "module"], choices=["paper", "module", "large"])
    ap.add_argument("--poses", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cycles", type=int, default=40, help="cycles of the still robot (0: none)")
    ap.add_argument(
        "--map-workspace",
        action="store_true",
        help="module maps: index and poses in the map's default box, not the box the module paths stay in",
    )
    a = ap.parse_args()
    ok = True
    for name in a.maps:
        ok &= run(name, a.poses, a.seed, a.cycles, not a.map_workspace)
    print("target: 0 wrong on every map")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
