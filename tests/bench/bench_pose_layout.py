"""One-call acquisition on a planned beacon layout against the original (issue 27): the
flight acquisition (mfns_acquire, C through ctypes, one call of one cycle's budget) from
random poses, on each layout with its own table-built index and certificate (as `mfns
table build` makes them: mapindex.build), sigma 0.3 px, beacons displaced by the survey
sigma their beacons.csv states, LEDs aimed along the nearest wall's normal (as `mfns sim
nav --beacon-map` renders them), a reflection in 10 % of the frames.

Poses: the module scenario's reachable poses (mfns.plan.workspace.module: the space the
planner optimises over) with >= 4 beacons in view, on an independent stream, and the index
built over that workspace's box (as the robot's table is: `mfns table build --workspace`, the
plan.json's box); with --map-workspace over the table's default box instead (the beacons'
box shrunk by 10 %: larger, and on a layout with no beacon low on the walls not holding the
lowest poses). With --box, bench_ident.py's uniform attitude in the map's default box.

    python tests/bench/bench_pose_layout.py PLANNED.csv ORIGINAL.csv [--poses N] [--seed S]
        [--box] [--map-workspace] [--breakdown]

Prints per layout: right / wrong / no fix (reasons), the share of poses with >= 4 and
>= 5 beacons in view, and the call's time. Target (issue 27), the module's 60 LEDs:
>= 99.9 % right, 0 wrong on the planned layout.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_ident import SIGMA_PX, SPURIOUS_RATE, visible_poses  # noqa: E402

from mfns.core.flight import Flight  # noqa: E402
from mfns.model import pose_sim  # noqa: E402
from mfns.plan import workspace  # noqa: E402
from mfns.simulate import nav  # noqa: E402
from mfns.table import mapindex  # noqa: E402
from mfns.table.builder import load_beacon_csv  # noqa: E402

UNBOUNDED_UNITS = 10**8


def module_poses(fl, rig, bmap, idx, rng, n):
    """n poses of the module workspace with >= 4 beacons in view (the C core's visibility)."""
    out = []
    while len(out) < n:
        ws = workspace.module(2048, rng)
        for i in range(ws.n):
            C, r = ws.C_w_b[i], ws.r_bw_b(i)
            f, _ = fl.view(rig, bmap, idx, fl.pose(C, r))
            if sum(f.count) >= 4:
                out.append((C, r))
                if len(out) == n:
                    break
    return out


def run(csv: str, n: int, seed: int, box: bool, breakdown: bool = False, map_ws: bool = False) -> bool:
    fl = Flight()
    cams = pose_sim.paper_rig()
    rig = fl.rig(cams)
    _, pos, sig = load_beacon_csv(csv)
    nrm = nav.wall_normals(pos)
    bmap = fl.beacon_map(pos, sig)
    # the table's workspace: the box the poses are drawn from, as the flight table of this
    # robot is built (`mfns table build --workspace`, the plan's table_workspace_mm), or the
    # table's default, the map's box shrunk by 10 % (--box poses are drawn in it; --map-workspace)
    ws = mapindex.default_workspace(pos) if box or map_ws else nav.module_workspace()
    t0 = time.perf_counter()
    idx, report = mapindex.build(fl, rig, bmap, (nrm, np.full(len(pos), 90.0)), ws, SIGMA_PX)
    t_index = time.perf_counter() - t0
    rng = np.random.default_rng([seed, 2727])
    if box:
        poses = visible_poses(fl, rig, bmap, idx, rng, ws[0], ws[1], n)
    else:
        poses = module_poses(fl, rig, bmap, idx, rng, n)
    truth = pos + rng.normal(0.0, 1.0, pos.shape) * sig[:, None]
    in_view = np.array([sum(fl.view(rig, bmap, idx, fl.pose(C, r))[0].count) for C, r in poses])
    cfg = fl.config(sigma_px=SIGMA_PX)
    t0 = time.perf_counter()
    res = pose_sim.identification_sweep(
        fl, rig, bmap, idx, cams, truth, poses, SIGMA_PX, rng, cfg, nrm, SPURIOUS_RATE
    )
    ms = np.array(res.seconds) * 1e3
    print(
        f"== {csv}: {len(pos)} beacons, survey sigma {np.median(sig):g} mm; "
        f"index {t_index:.0f} s ({report.lines()[2]}); workspace "
        f"{np.round(ws[0]).tolist()}..{np.round(ws[1]).tolist()} mm{' (the map default)' if box or map_ws else ''}"
    )
    print(
        f"   one call: {res.right} right ({100.0 * res.right / n:.2f} %), {res.wrong} wrong of {n}; "
        f"no fix {res.reasons}; blobs in view >= 5: {100.0 * np.mean(in_view >= 5):.1f} %, "
        f"exactly 4: {100.0 * np.mean(in_view == 4):.1f} %; ms median {np.median(ms):.2f}, "
        f"p99 {np.percentile(ms, 99):.2f} ({time.perf_counter() - t0:.0f} s)",
        flush=True,
    )
    if breakdown:
        where_it_fails(fl, rig, bmap, idx, cams, truth, poses, cfg, nrm, rng)
    return res.wrong == 0


def where_it_fails(fl, rig, bmap, idx, cams, truth, poses, cfg, nrm, rng) -> None:
    """The one-call outcomes again (new frames of the same poses), by beacons in the frame
    and whether it carries a reflection: which views the remaining no-fixes are."""
    rows: dict = {}
    freed: dict = {}
    for C, r in poses:
        obs, ids = pose_sim.acquisition_frame(cams, truth, C, r, SIGMA_PX, rng, nrm, SPURIOUS_RATE)
        nb = int(sum(int(np.sum(np.asarray(i) >= 0)) for i in ids))
        refl = any(np.any(np.asarray(i) < 0) for i in ids)
        sol, pr = fl.acquire(rig, bmap, idx, fl.frame(obs), cfg)
        key = (min(nb, 7), refl)
        out = (
            "right"
            if sol.ok and pose_sim.identification_right(sol, ids)
            else ("WRONG" if sol.ok else sol.reason)
        )
        if not sol.ok and sol.reason == "NOT_IDENTIFIED" and pr.budget_out:
            out = "NOT_IDENTIFIED (budget)"
            # the same frame without the cycle's budget: is it the budget only?
            sol2, pr2 = fl.acquire(rig, bmap, idx, fl.frame(obs), cfg, UNBOUNDED_UNITS)
            ok2 = sol2.ok and pose_sim.identification_right(sol2, ids)
            freed.setdefault(min(nb, 7), []).append(
                (ok2, sol2.reason if not sol2.ok else "", pr2.units_total)
            )
        rows.setdefault(key, {}).setdefault(out, 0)
        rows[key][out] += 1
    n = len(poses)
    print("   by beacons in the frame (7: 7 or more), + r: with a reflection; share of all poses:")
    for key in sorted(rows):
        c = rows[key]
        tot = sum(c.values())
        fails = {k: v for k, v in c.items() if k != "right"}
        print(
            f"     {key[0]}{' + r' if key[1] else '    '}: {tot:5d} ({100.0 * tot / n:5.2f} %), right "
            f"{c.get('right', 0)}, not: {fails} ({100.0 * sum(fails.values()) / n:.2f} % of all)"
        )
    for nb in sorted(freed):
        f = freed[nb]
        units = np.array([u for ok, _, u in f if ok]) if any(ok for ok, _, _ in f) else np.zeros(1)
        others: dict = {}
        for ok, why, _ in f:
            if not ok:
                others[why or "WRONG"] = others.get(why or "WRONG", 0) + 1
        print(
            f"   {nb} beacons, stopped by the budget, again without it: "
            f"{sum(ok for ok, _, _ in f)} of {len(f)} "
            f"right (work median {np.median(units):.0f}, max {units.max():.0f} units = "
            f"{units.max() / idx.budget_units:.1f} cycles' budget), not: {others}"
        )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("layouts", nargs="+", help="beacons.csv files (id,x_mm,y_mm,z_mm,sigma_mm)")
    ap.add_argument("--poses", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--box", action="store_true", help="uniform attitude in the map's default box")
    ap.add_argument("--breakdown", action="store_true", help="the no-fixes by beacons in view and reflection")
    ap.add_argument(
        "--map-workspace",
        action="store_true",
        help="build the index over the map's default box (the beacons' box shrunk by 10 %%) instead of "
        "the module workspace the poses come from",
    )
    a = ap.parse_args()
    ok = True
    for csv in a.layouts:
        ok &= run(csv, a.poses, a.seed, a.box, a.breakdown, a.map_workspace)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
