#!/usr/bin/env python3
"""filter_avail.py OUT FRAMES: the table of mk/filter_avail.sh.

For each case flown off and on (OUT/<case>-<mode>/ground/nav.csv) against the
simulator's truth (FRAMES/<case>/truth.csv, matched by cycle = frame): usable
cycles (status FIX or DEGRADED), the worst |error| per position axis (mm) and
of the attitude (deg: the largest component of log(C_est C_true^T)), the worst
|error| / PL over usable cycles per axis, and the usable fixes whose error on
some axis is beyond its PL (pl_pos_mm / pl_att_deg of the same row).

A second table gives, per run flown with the filter on, every unusable cycle
by its reason (the flight program's, as telemetered) beside the geometry the
simulator put in view at that frame (FRAMES/<case>/spots.csv): how many of
those cycles had three beacons or fewer in view, and how many had every camera
but one holding at most two (a camera's fault then leaves too little to bound
it: docs/pose.md "What each hypothesis misses"), and the time to the first
usable fix: the cycle of the first pose (acquisition's, usable or not) and
the cycle of the first usable one.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

from mfns.model.rotations import euler213_deg_to_matrix, rot_log
from mfns.tlm.tlm_dict import reason_names

CASES = ["module2", "module3", "module4", "module5", "turn1"]
USABLE = ("FIX", "DEGRADED")


def rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def case(out: Path, frames: Path, name: str, mode: str) -> str:
    nav = rows(out / f"{name}-{mode}" / "ground" / "nav.csv")
    truth = {int(r["frame"]): r for r in rows(frames / name / "truth.csv")}
    n = len(nav)
    usable = 0
    cam_unbounded = 0  # usable with reason CAMERA_UNMONITORED (18): camera faults not bounded
    worst = np.zeros(4)
    ratio = np.zeros(4)
    beyond = 0
    for r in nav:
        if r["status"] not in USABLE:
            continue
        usable += 1
        cam_unbounded += int(r["reason"] == "18")
        t = truth.get(int(r["cycle"]))
        if t is None:
            continue
        e = np.array([float(r[a]) - float(t[a]) for a in ("x_mm", "y_mm", "z_mm")])
        c_est = euler213_deg_to_matrix([float(r[a]) for a in ("roll_deg", "pitch_deg", "yaw_deg")])
        c_tru = euler213_deg_to_matrix([float(t[a]) for a in ("roll_deg", "pitch_deg", "yaw_deg")])
        ea = float(np.degrees(np.max(np.abs(rot_log(c_est @ c_tru.T)))))
        err = np.abs(np.append(e, ea))
        pl = np.array([float(r["pl_pos_mm"])] * 3 + [float(r["pl_att_deg"])])
        worst = np.maximum(worst, err)
        rr = err / pl
        ratio = np.maximum(ratio, rr)
        beyond += int(np.any(rr > 1.0))
    w = " / ".join(f"{v:.2f}" for v in worst)
    q = " / ".join(f"{v:.2f}" for v in ratio)
    return f"| {name} | {mode} | {usable} / {n} | {usable - cam_unbounded} | {w} | {q} | {beyond} |"


def in_view(frames: Path, name: str) -> dict[int, dict[str, int]]:
    """frame -> camera -> beacons the simulator drew in view."""
    seen: dict[int, dict[str, int]] = {}
    for r in rows(frames / name / "spots.csv"):
        if r["beacon_id"] in ("", "-1"):
            continue  # a spurious spot, no beacon
        cams = seen.setdefault(int(r["frame"]), {})
        cams[r["camera"]] = cams.get(r["camera"], 0) + 1
    return seen


def reasons(out: Path, frames: Path, name: str) -> str:
    names = reason_names()
    nav = rows(out / f"{name}-on" / "ground" / "nav.csv")
    seen = in_view(frames, name)
    by: dict[str, int] = {}
    sparse = lopsided = 0
    first_pose = next((int(r["cycle"]) for r in nav if int(r["beacons_used"]) > 0), None)
    first_usable = next((int(r["cycle"]) for r in nav if r["status"] in USABLE), None)
    for r in nav:
        if r["status"] in USABLE:
            continue
        code = int(r["reason"])
        label = names[code] if code < len(names) else str(code)
        by[label] = by.get(label, 0) + 1
        cams = seen.get(int(r["cycle"]), {})
        counts = sorted(cams.values(), reverse=True) + [0, 0, 0]
        sparse += int(sum(cams.values()) <= 3)
        lopsided += int(sum(cams.values()) > 3 and counts[1] + counts[2] <= 2)
    n_un = sum(by.values())
    text = ", ".join(f"{k} {v}" for k, v in sorted(by.items(), key=lambda kv: -kv[1])) or "none"
    first = " / ".join("never" if c is None else str(c) for c in (first_pose, first_usable))
    return f"| {name} | {n_un} / {len(nav)} | {text} | {sparse} | {lopsided} | {first} |"


def main() -> int:
    out, frames = Path(sys.argv[1]), Path(sys.argv[2])
    print(
        "| run | filter | usable | of them camera faults bounded | worst error x / y / z mm / att deg "
        "| worst error/PL x / y / z / att | usable beyond PL |"
    )
    print("|---|---|---|---|---|---|---|")
    for name in CASES:
        for mode in ("off", "on"):
            print(case(out, frames, name, mode))
    print()
    print(
        "| run (filter on) | unusable | by reason | of them <= 3 beacons in view "
        "| > 3 in view, the other cameras <= 2 together | first pose / first usable (cycle) |"
    )
    print("|---|---|---|---|---|---|")
    for name in CASES:
        print(reasons(out, frames, name))
    return 0


if __name__ == "__main__":
    sys.exit(main())
