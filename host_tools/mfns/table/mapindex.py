"""The beacon map's index for lost-in-space acquisition and its certificate
(firmware/nav/map/beacon_index.h, acquire_certify.h), built by the C core through the
shared library: this module only chooses the workspace, samples the poses the map
analysis runs on, and reports what it found (docs/pose.md "Acquisition").
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import MfnsError
from ..core.flight import CertifyResult, Flight

# The default workspace: the map's bounding box shrunk by this share of its extent on
# each side (the robot moves inside the beacon hull, not on the walls).
WORKSPACE_MARGIN = 0.1
# An axis of the map thinner than this gives no default workspace (a flat map).
MIN_EXTENT_MM = 200.0
# Poses of the map analysis (with >= 4 beacons in view, drawn from at most
# MAX_DRAWS_PER_SAMPLE times as many uniform poses); each may spend
# ANALYSIS_BUDGET_FACTOR times the flight budget.
DEFAULT_SAMPLES = 200
MAX_DRAWS_PER_SAMPLE = 500
ANALYSIS_BUDGET_FACTOR = 3
CHUNK = 10


def default_workspace(pos_w: np.ndarray, warn=None) -> tuple[np.ndarray, np.ndarray]:
    """The map's bounding box shrunk by WORKSPACE_MARGIN of its extent on each side. A map
    thinner than MIN_EXTENT_MM along an axis (beacons on one wall) says nothing of where
    the robot is along it: there the box spans the map's largest extent about its centre,
    and warn (if given) is called with a line saying so (give --workspace instead)."""
    lo, hi = pos_w.min(axis=0), pos_w.max(axis=0)
    ext = hi - lo
    wlo, whi = lo + WORKSPACE_MARGIN * ext, hi - WORKSPACE_MARGIN * ext
    flat = [i for i in range(3) if ext[i] < MIN_EXTENT_MM]
    if flat:
        half = max(float(ext.max()), MIN_EXTENT_MM) / 2.0
        for i in flat:
            c = 0.5 * (lo[i] + hi[i])
            wlo[i], whi[i] = c - half, c + half
        if warn is not None:
            warn(
                f"the beacon map is flat along {', '.join('xyz'[i] for i in flat)}: workspace assumed "
                + " x ".join(f"[{a:.0f}, {b:.0f}]" for a, b in zip(wlo, whi, strict=True))
                + " mm (give --workspace XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX)"
            )
    return wlo, whi


# workspace_arg: a plan.json or scenario.json is a few kB; a larger file is not one.
MAX_WORKSPACE_JSON_BYTES = 1 << 20
# The key of the robot's box in the JSON files --workspace reads (plan.json, a module
# scenario.json): their writers (mfns.plan.run, mfns.simulate.nav) take it from here.
WORKSPACE_KEY = "table_workspace_mm"


def workspace_outside(pos_w: np.ndarray, lo, hi) -> str | None:
    """None when the workspace box [lo, hi] lies inside the beacons' bounding box, else a
    line naming the axes it reaches beyond and by how much: a robot outside its beacons
    sees wall-mounted LEDs from behind, so such a box is more likely a slip (metres for
    millimetres, a sign) than a robot's space (the table is built all the same: a map on
    one wall, or a robot flying past its beacons, has its reasons)."""
    pmin, pmax = pos_w.min(axis=0), pos_w.max(axis=0)
    over = [
        f"{'xyz'[i]} by {max(pmin[i] - lo[i], hi[i] - pmax[i]):.0f} mm"
        for i in range(3)
        if lo[i] < pmin[i] or hi[i] > pmax[i]
    ]
    if not over:
        return None
    return (
        "the workspace "
        + " x ".join(f"[{a:.0f}, {b:.0f}]" for a, b in zip(lo, hi, strict=True))
        + " mm reaches beyond the beacons' bounding box along "
        + ", ".join(over)
        + " (a robot there sees wall-mounted LEDs from behind; if that is not meant, check the "
        "box's units (mm) and signs)"
    )


def workspace_arg(text: str) -> tuple[np.ndarray, np.ndarray]:
    """--workspace of `mfns table build`: six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm), or
    the path of a JSON file holding them as "table_workspace_mm" (the plan.json of `mfns
    plan optimize`: the box the layout was planned for; the scenario.json of `mfns sim nav
    --scenario module`: the box its paths stay in)."""
    path = Path(text)
    if not path.is_file():
        if text.lower().endswith(".json"):
            raise MfnsError(f"--workspace {text}: no such file")
        return parse_workspace(text)
    if path.stat().st_size > MAX_WORKSPACE_JSON_BYTES:
        raise MfnsError(f"--workspace {text}: larger than {MAX_WORKSPACE_JSON_BYTES} bytes (not a plan.json)")
    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MfnsError(f"--workspace {text}: not a readable JSON file ({exc})") from None
    v = doc.get(WORKSPACE_KEY) if isinstance(doc, dict) else None
    if (
        not isinstance(v, list)
        or len(v) != 6
        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
    ):
        raise MfnsError(
            f'--workspace {text}: no "{WORKSPACE_KEY}" of six numbers (a plan.json of `mfns plan '
            "optimize` has one, as does a module scenario.json; else give XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX)"
        )
    return _workspace_box(v, text)


def parse_workspace(text: str) -> tuple[np.ndarray, np.ndarray]:
    return _workspace_box(text.split(","), repr(text))


def _workspace_box(values: list, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Six values XMIN..ZMAX (numbers or their text) -> (lo, hi), or the one clear line
    naming `what` (the argument, or the file it came from)."""
    try:
        v = [float(x) for x in values]
    except (ValueError, OverflowError):  # OverflowError: a JSON integer beyond a double
        raise MfnsError(
            f"--workspace {what}: expected six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm)"
        ) from None
    if len(v) != 6 or not all(np.isfinite(v)):
        raise MfnsError(f"--workspace {what}: expected six finite numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm)")
    lo, hi = np.array(v[:3]), np.array(v[3:])
    if not np.all(lo < hi):
        raise MfnsError(f"--workspace {what}: each minimum must be below its maximum")
    return lo, hi


def random_poses(rng: np.random.Generator, lo, hi, n: int):
    """n poses (C_w_b, r_bw_b): body origin uniform in the box, attitude uniform."""
    from ..model.rotations import random_rotations

    C = random_rotations(rng, n)
    p = rng.uniform(lo, hi, size=(n, 3))
    return [(C[i], -C[i] @ p[i]) for i in range(n)]


def usable_poses(fl: Flight, rig, bmap, idx, rng, lo, hi, n: int):
    """n uniform poses of the workspace from which the rig sees >= 4 beacons (the C
    core's visibility), or fewer when MAX_DRAWS_PER_SAMPLE * n draws do not give them."""
    out = []
    for _ in range(MAX_DRAWS_PER_SAMPLE):
        for C, r in random_poses(rng, lo, hi, max(n, 64)):
            frame, _ = fl.view(rig, bmap, idx, fl.pose(C, r))
            if sum(frame.count) >= 4:
                out.append((C, r))
                if len(out) == n:
                    return out
    return out


@dataclass
class IndexReport:
    workspace_min_mm: np.ndarray
    workspace_max_mm: np.ndarray
    samples: int
    usable: int
    truth_found: int
    ambiguous: int
    max_rival: int
    cert_inliers: list[int]
    capped: bool
    neighbours_mean: float
    never_together_pairs: int
    worst: dict = field(default_factory=dict)

    def lines(self) -> list[str]:
        lo, hi = self.workspace_min_mm, self.workspace_max_mm
        out = [
            "map index: workspace "
            + " x ".join(f"[{a:.0f}, {b:.0f}]" for a, b in zip(lo, hi, strict=True))
            + f" mm, {self.neighbours_mean:.1f} neighbours per beacon, "
            f"{self.never_together_pairs} pairs never in view together",
            f"map analysis: {self.usable} poses with >= 4 beacons in view, right identification among the "
            f"candidates in {self.truth_found}; strongest wrong identification: {self.max_rival} inliers",
            "certificate: a fix needs "
            + ", ".join(f"{c} inliers with {m} missing" for m, c in enumerate(self.cert_inliers)),
        ]
        if self.ambiguous:
            w = self.worst
            out.append(
                f"ambiguous views: {self.ambiguous} of {self.usable} sampled poses have a wrong "
                f"identification that explains every blob; worst at body position "
                f"{np.round(w['r_wb_w'], 0).tolist()} mm: beacons {w['truth']} also fit as {w['rival']} "
                f"({w['rival_inliers']} inliers, {w['rival_missing']} missing)"
            )
        if self.capped:
            out.append("the map is self-similar beyond the certificate's limit: few fixes will be certified")
        return out


def build(
    fl: Flight,
    rig,
    bmap,
    emission: tuple[np.ndarray, np.ndarray] | None,
    workspace: tuple[np.ndarray, np.ndarray],
    sigma_px: float,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 1,
    progress=None,
):
    """The index with its certificate from the map analysis -> (BeaconIndex, IndexReport)."""
    lo, hi = workspace
    em = None
    if emission is not None:
        axes, half = emission
        em = (axes, np.cos(np.radians(half)))
    params = fl.index_params()
    idx = fl.build_index(rig, bmap, lo, hi, emit=em, params=params)
    n = bmap.count
    rng = np.random.default_rng([seed, 11])
    cfg = fl.config(sigma_px=sigma_px)
    poses = usable_poses(fl, rig, bmap, idx, rng, lo, hi, samples)
    budget = ANALYSIS_BUDGET_FACTOR * idx.budget_units
    total = CertifyResult()
    samples = len(poses)
    for start in range(0, samples, CHUNK):
        chunk = poses[start : start + CHUNK]
        part = fl.certify(rig, bmap, idx, cfg, [fl.pose(C, r) for C, r in chunk], budget)
        fl.certify_accumulate(total, part, start)
        if progress is not None:
            progress(len(chunk))
    fl.certify_finish(total, idx)
    fl.certify_apply(idx, total)
    worst: dict = {}
    if total.max_rival > 0:
        w = total.worst
        C, r = poses[w.sample]
        worst = {
            "r_wb_w": -C.T @ r,
            "truth": list(w.truth_id[: w.n_blobs]),
            "rival": [int(x) for x in w.rival_id[: w.n_blobs]],
            "rival_inliers": int(w.rival_inliers),
            "rival_missing": int(w.rival_missing),
        }
    nbr = np.array(list(idx.nbr_count)[:n], dtype=float)
    npairs = n * (n - 1) // 2
    lo_codes = np.array(list(idx.pair_lo)[:npairs])
    hi_codes = np.array(list(idx.pair_hi)[:npairs])
    report = IndexReport(
        workspace_min_mm=np.asarray(lo, float),
        workspace_max_mm=np.asarray(hi, float),
        samples=samples,
        usable=total.usable,
        truth_found=total.truth_found,
        ambiguous=total.ambiguous,
        max_rival=total.max_rival,
        cert_inliers=list(total.cert_inliers)[: idx.max_missing + 1],
        capped=bool(total.cert_capped),
        neighbours_mean=float(nbr.mean()) if n else 0.0,
        never_together_pairs=int(np.sum(lo_codes > hi_codes)),
        worst=worst,
    )
    return idx, report
