"""Synthetic beacon observations for the pose solver's tests and benchmarks.

The paper's rig (docs/system.md §7 Tables 2-3, mfns/data/paper_calib.json) and beacon map
(Table 4, paper_beacons.csv); random poses with a required number of beacons in view
(vectorised rejection sampling: with these mounts only one to four of the ten beacons
are in view at a time); frames of (u, v) pixels with Gaussian noise and the matching
undistorted normalized (x, y), as the flight solver takes them.
"""

from __future__ import annotations

import json
from importlib import resources

import numpy as np

from .camera import Camera, load_beacons, rig_from_doc


def paper_rig() -> list[Camera]:
    doc = json.loads(resources.files("mfns.data").joinpath("paper_calib.json").read_text())
    return rig_from_doc(doc)


def paper_beacons() -> np.ndarray:
    with resources.as_file(resources.files("mfns.data").joinpath("paper_beacons.csv")) as p:
        return load_beacons(p)[1]


def random_rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    """n uniformly distributed rotation matrices (from unit quaternions)."""
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=1,
    )


def visible_counts(cams: list[Camera], beacons: np.ndarray, C: np.ndarray, r_bw_b: np.ndarray) -> np.ndarray:
    """Beacons in view (in front, inside the image) for poses C (n,3,3), r_bw_b (n,3)."""
    p_b = np.einsum("nij,bj->nbi", C, beacons) + r_bw_b[:, None, :]
    total = np.zeros(len(C), dtype=int)
    for cam in cams:
        p_c = (p_b - cam.r_bk_b) @ cam.C_k_b
        z = p_c[..., 2]
        front = z >= 1.0
        xy = p_c[..., :2] / np.where(front, z, 1.0)[..., None]
        uv = cam.distorted_to_pixel(cam.distort(xy))
        inside = (
            (uv[..., 0] >= -0.5)
            & (uv[..., 1] >= -0.5)
            & (uv[..., 0] < cam.width - 0.5)
            & (uv[..., 1] < cam.height - 0.5)
        )
        total += np.sum(front & inside, axis=1)
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


def identification_sweep(
    flight, rig, bmap, cams, beacons, poses, sigma: float, rng: np.random.Generator, cfg
):
    """Cold acquisition (flight.acquire, no prior) on a frame of each pose ->
    (right, wrong, {no-fix reason: count}). A fix is right when every inlier carries its
    true beacon and every beacon in view is used; anything else reported as a fix is wrong."""
    right = wrong = 0
    reasons: dict[str, int] = {}
    for C, r in poses:
        obs, ids = make_frame(cams, beacons, C, r, sigma, rng)
        sol = flight.acquire(rig, bmap, flight.frame(obs), cfg)
        if not sol.ok:
            reasons[sol.reason] = reasons.get(sol.reason, 0) + 1
            continue
        correct = all(
            (not sol.inlier[c][i]) or sol.assoc[c][i] == ids[c][i]
            for c in range(len(ids))
            for i in range(len(ids[c]))
        )
        correct &= sol.beacons_used == sum(len(i) for i in ids)
        right += int(correct)
        wrong += int(not correct)
    return right, wrong, reasons
