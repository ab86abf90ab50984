"""One knocked beacon (issue 23): the acquisition of views in which one visible beacon has
moved off its surveyed place while the table's map still has it there, C through ctypes,
on the maps of bench_ident.py (same index, certificate, survey error 0.4 mm, sigma 0.3 px).

Random poses of each map's workspace with enough beacons in view (bench_ident's); for each
move d (0, 5, 20, 50 mm) one beacon the frame holds is moved d mm in a random direction
before the frame is rendered. One call of mfns_acquire within one cycle's budget. Printed
per map and move: right fixes (every inlier its own beacon; the moved one may be an inlier
or left out), wrong fixes (must be 0), no fix by reason. A moved beacon's blob is then
unexplained and the beacon missing (docs/pose.md Acquisition, "One knocked beacon"); the
moved beacon is FDE's to exclude once tracking.

    python tests/bench/bench_moved_beacon.py [--maps paper module large] [--poses N] [--seed S]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_ident import SIGMA_PX, SURVEY_SIGMA_MM, setup, visible_poses  # noqa: E402

from mfns.model import pose_sim  # noqa: E402

MOVES_MM = (0.0, 5.0, 20.0, 50.0)


def run(name: str, n: int, seed: int) -> bool:
    m = setup(name)
    fl, cams, rig, pos, nrm, ws, bmap, idx = m.fl, m.cams, m.rig, m.pos, m.nrm, m.ws, m.bmap, m.idx
    rng = np.random.default_rng([seed, len(pos), 23])
    poses = visible_poses(fl, rig, bmap, idx, rng, ws[0], ws[1], n)
    cfg = m.cfg
    print(f"== {name}: {len(pos)} beacons, {n} views, one visible beacon moved (budget {idx.budget_units})")
    wrong_total = 0
    for d in MOVES_MM:
        counts: dict = {}
        for C, r in poses:
            truth = pos if name == "paper" else pos + rng.normal(0.0, SURVEY_SIGMA_MM, pos.shape)
            if d > 0.0:
                _, ids = pose_sim.acquisition_frame(cams, truth, C, r, SIGMA_PX, rng, nrm, 0.0)
                seen = np.unique(np.concatenate([i[i >= 0] for i in ids]))
                v = rng.normal(size=3)
                truth = truth.copy()
                truth[int(rng.choice(seen))] += d * v / np.linalg.norm(v)
            obs, ids = pose_sim.acquisition_frame(cams, truth, C, r, SIGMA_PX, rng, nrm, 0.0)
            sol, _ = fl.acquire(rig, bmap, idx, fl.frame(obs), cfg)
            if not sol.ok:
                key = sol.reason
            elif pose_sim.identification_right(sol, ids):
                key = "right"
            else:
                key = "WRONG"
            counts[key] = counts.get(key, 0) + 1
        wrong_total += counts.get("WRONG", 0)
        others = {k: v for k, v in counts.items() if k not in ("right", "WRONG")}
        print(
            f"{name} moved {d:4.0f} mm: right {counts.get('right', 0)} "
            f"({100.0 * counts.get('right', 0) / n:.1f} %), wrong {counts.get('WRONG', 0)}, none {others}",
            flush=True,
        )
    return wrong_total == 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", nargs="+", default=["paper", "module"], choices=["paper", "module", "large"])
    ap.add_argument("--poses", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    ok = True
    for name in a.maps:
        ok &= run(name, a.poses, a.seed)
    print("target: 0 wrong on every map and move")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
