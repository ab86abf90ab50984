"""Fault injectors for `mfns sim nav` folders (docs/nav-frames.md) and beacon maps.

Each injector does one thing to a folder made by link_frames() (or to a beacons.csv) and
returns what the scorer must know about it: the injectors that change which instant an image
shows return {(camera, frame): frame whose content it now holds}; the others return a count or
nothing. Frame images in a linked folder share their inode with the source folder, so every
write goes through replace_file() (a new file renamed over the name): the source stays intact.

Images are binary PGM as the simulator writes them: `P5\\n<W> <H>\\n<maxval>\\n`, 8-bit
(maxval 255) or 16-bit big-endian (maxval > 255).
"""

from __future__ import annotations

import csv
import math
import os
import shutil
from pathlib import Path

import numpy as np

FRAMES_HEADER = "frame,t_s,camera,file,exposure_us,gain_db"
AXES = ("x_mm", "y_mm", "z_mm")

ContentMap = dict[tuple[str, int], int]


# --------------------------------------------------------------------------- files
def replace_file(path: Path, data: bytes) -> None:
    """Writes data as a new file under path's name (never through a shared inode)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def link_frames(src: Path, dst: Path) -> Path:
    """A copy of a frame folder whose images are hard links to src's (copies where the file
    system cannot link); the small text files are real copies."""
    if dst.exists():
        shutil.rmtree(dst)
    dst.mkdir(parents=True)
    for p in sorted(src.iterdir()):
        if p.is_dir():
            (dst / p.name).mkdir()
            for f in sorted(p.iterdir()):
                try:
                    os.link(f, dst / p.name / f.name)
                except OSError:
                    shutil.copy2(f, dst / p.name / f.name)
        else:
            shutil.copy2(p, dst / p.name)
    return dst


def read_pgm(path: Path) -> tuple[np.ndarray, int]:
    """(pixels as float64 H x W, maxval)."""
    parts = path.read_bytes().split(b"\n", 3)
    if parts[0] != b"P5":
        raise ValueError(f"{path}: not a binary PGM")
    w, h = map(int, parts[1].split())
    maxv = int(parts[2])
    dtype = np.uint8 if maxv < 256 else np.dtype(">u2")
    px = np.frombuffer(parts[3], dtype=dtype, count=w * h).reshape(h, w).astype(float)
    return px, maxv


def pgm_bytes(px: np.ndarray, maxv: int) -> bytes:
    dtype = np.uint8 if maxv < 256 else np.dtype(">u2")
    h, w = px.shape
    out = np.clip(np.rint(px), 0, maxv).astype(dtype)
    return f"P5\n{w} {h}\n{maxv}\n".encode() + out.tobytes()


def frame_rows(folder: Path) -> list[dict]:
    """frames.csv as dicts (frame int, t_s float, camera, file)."""
    with open(folder / "frames.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        r["frame"] = int(r["frame"])
        r["t_s"] = float(r["t_s"])
    return rows


def camera_files(folder: Path, cam: str) -> dict[int, Path]:
    """frame -> image path of one camera, from frames.csv."""
    return {r["frame"]: folder / r["file"] for r in frame_rows(folder) if r["camera"] == cam}


# --------------------------------------------------------------------------- camera faults
def freeze_camera(folder: Path, cam: str, first: int) -> ContentMap:
    """From frame `first` on, camera cam's images are byte copies of frame `first` (a stuck
    sensor or ISP); frames.csv (time stamps, sequence) advances as normal."""
    files = camera_files(folder, cam)
    data = files[first].read_bytes()
    done: ContentMap = {}
    for f, p in sorted(files.items()):
        if f > first:
            replace_file(p, data)
        if f >= first:
            done[(cam, f)] = first
    return done


def clock_step(folder: Path, cam: str, first: int, dt_s: float) -> ContentMap:
    """Camera cam's t_s in frames.csv shifted by dt_s from frame `first` on (a camera clock
    that steps); the images are unchanged, so what they show is still their original instant."""
    lines = (folder / "frames.csv").read_text().split("\n")
    out = []
    for ln in lines:
        p = ln.split(",")
        if len(p) == 6 and p[0].isdigit() and p[2] == cam and int(p[0]) >= first:
            p[1] = f"{float(p[1]) + dt_s:.6f}"
            ln = ",".join(p)
        out.append(ln)
    replace_file(folder / "frames.csv", "\n".join(out).encode())
    return {}


def stale_frames(folder: Path, cam: str, first: int, n: int) -> ContentMap:
    """From frame `first` on, camera cam's image of frame f is its image of frame f-n while its
    frames.csv row keeps t_f (a driver or camera that stamps on arrival, n periods late)."""
    files = camera_files(folder, cam)
    done: ContentMap = {}
    for f in sorted(files, reverse=True):  # newest first: f-n is still the original
        if f >= first and f - n in files:
            replace_file(files[f], files[f - n].read_bytes())
            done[(cam, f)] = f - n
    return done


def kill_camera(folder: Path, cam: str, first: int) -> ContentMap:
    """Camera cam's image files missing from frame `first` on (a camera dying)."""
    for f, p in camera_files(folder, cam).items():
        if f >= first:
            p.unlink()
    return {}


HOSTILE = [
    lambda r: [r.rsplit(b",", 1)[0]],
    lambda r: [r + b",7"],
    lambda r: [r.replace(b"cam_", b"cam\0")],
    lambda r: [r.replace(b"cam_", b"../cam_")],
    lambda r: [b",".join(r.split(b",")[:4] + [b"-5"] + r.split(b",")[5:])],
    lambda r: [b",".join(r.split(b",")[:2] + [b"w"] + r.split(b",")[3:])],
    lambda r: [r, r],
]


def desync_rows(folder: Path) -> ContentMap:
    """One hostile frames.csv row (5 or 7 fields, a NUL, a ../ path, a negative exposure,
    camera w, a duplicate) every 8 frames, the camera rotating."""
    lines = (folder / "frames.csv").read_bytes().split(b"\n")
    out = []
    for ln in lines:
        parts = ln.split(b",")
        if len(parts) > 2 and parts[0].isdigit():
            f = int(parts[0])
            cam = "xyz"[(f // 8) % 3]
            if f % 8 == 3 and parts[2] == cam.encode():
                out += HOSTILE[(f // 8) % len(HOSTILE)](ln)
                continue
        out.append(ln)
    replace_file(folder / "frames.csv", b"\n".join(out))
    return {}


def add_spots(folder: Path, n_total: int, seed: int) -> ContentMap:
    """n_total spurious Gaussian dots of random size and brightness at random places."""
    rng = np.random.default_rng(seed)
    files = sorted(folder.glob("cam_*/*.pgm"))
    per = np.bincount(rng.integers(0, len(files), n_total), minlength=len(files))
    for path, k in zip(files, per, strict=True):
        if k == 0:
            continue
        px, maxv = read_pgm(path)
        h, w = px.shape
        for _ in range(k):
            u, v = rng.uniform(5, w - 5), rng.uniform(5, h - 5)
            s, a = rng.uniform(0.8, 2.0), rng.uniform(40, 200)
            y0, x0 = int(v) - 6, int(u) - 6
            yy, xx = np.mgrid[y0 : y0 + 13, x0 : x0 + 13]
            ok = (yy >= 0) & (yy < h) & (xx >= 0) & (xx < w)
            px[yy[ok], xx[ok]] += a * np.exp(-((xx[ok] - u) ** 2 + (yy[ok] - v) ** 2) / (2 * s * s))
        replace_file(path, pgm_bytes(np.floor(px), maxv))
    return {}


# --------------------------------------------------------------------------- beacon faults
def read_beacons(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_beacons(rows: list[dict], path: Path) -> Path:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return path


def displaced_map(src: Path, out: Path, seed: int) -> Path:
    """beacons.csv with every beacon moved by N(0, sigma_mm) per coordinate (survey error)."""
    rng = np.random.default_rng(seed)
    rows = read_beacons(src)
    for r in rows:
        s = float(r["sigma_mm"])
        for a in AXES:
            r[a] = f"{float(r[a]) + rng.normal(0.0, s):.4f}"
    return write_beacons(rows, out)


def most_seen_beacon(spots_csv: Path) -> int:
    """The beacon with the most rendered spots (rows of spots.csv), lowest id on a tie."""
    counts: dict[int, int] = {}
    with open(spots_csv, newline="") as f:
        for r in csv.DictReader(f):
            b = int(r["beacon_id"])
            if b >= 0:
                counts[b] = counts.get(b, 0) + 1
    if not counts:
        raise ValueError(f"{spots_csv}: no beacon spots")
    return min(counts, key=lambda b: (-counts[b], b))


def first_seen_frame(spots_csv: Path, beacon_id: int) -> int | None:
    with open(spots_csv, newline="") as f:
        frames = [int(r["frame"]) for r in csv.DictReader(f) if int(r["beacon_id"]) == beacon_id]
    return min(frames) if frames else None


def beacon_wall(rows: list[dict], beacon_id: int) -> tuple[int, float]:
    """(axis 0..2, inward sign +-1) of the wall a beacon is mounted on: the axis on which the
    beacon lies closest to the extreme of the map's bounding box (the module's wall); inward
    is towards the inside of the box."""
    pos = np.array([[float(r[a]) for a in AXES] for r in rows])
    ids = [int(r["id"]) for r in rows]
    p = pos[ids.index(beacon_id)]
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    gaps = [(abs(p[a] - hi[a]), a, -1.0) for a in range(3)] + [(abs(p[a] - lo[a]), a, 1.0) for a in range(3)]
    _, axis, inward = min(gaps)
    return axis, inward


def move_vector(rows: list[dict], beacon_id: int, d_mm: float, along: bool) -> np.ndarray:
    """The move of d_mm of a beacon: normal to its wall (inward, off the wall) or along it
    (the first axis in the wall's plane, positive)."""
    axis, inward = beacon_wall(rows, beacon_id)
    v = np.zeros(3)
    if along:
        v[(axis + 1) % 3] = d_mm
    else:
        v[axis] = inward * d_mm
    return v


def moved_beacon_map(src: Path, out: Path, beacon_id: int, move_mm: np.ndarray) -> Path:
    """The map a table is built from when the beacon was moved by move_mm after the survey:
    the frames show it where src says, so the map says src - move_mm (all others as in src)."""
    rows = read_beacons(src)
    hit = [r for r in rows if int(r["id"]) == beacon_id]
    if len(hit) != 1:
        raise ValueError(f"{src}: beacon {beacon_id} not found once")
    for a, m in zip(AXES, move_mm, strict=True):
        hit[0][a] = f"{float(hit[0][a]) - float(m):.4f}"
    return write_beacons(rows, out)


def dead_led(folder: Path, beacon_id: int, seed: int, n_sigma: float = 4.0) -> int:
    """A dead LED: the beacon's spot (spots.csv: frame, camera, u, v, sigma_px) erased from every
    image it appears in. A square window of n_sigma sigma (+2 px) around the spot is replaced by
    the median of the window's two-pixel border plus Gaussian noise of the border's own robust
    spread. Returns the number of spots erased. Misses: reflections of the LED (spurious spots,
    beacon_id -1) stay; another spot inside the window would be erased with it."""
    rng = np.random.default_rng(seed)
    by_image: dict[tuple[int, str], list[tuple[float, float, float]]] = {}
    with open(folder / "spots.csv", newline="") as f:
        for r in csv.DictReader(f):
            if int(r["beacon_id"]) == beacon_id:
                key = (int(r["frame"]), r["camera"])
                by_image.setdefault(key, []).append((float(r["u"]), float(r["v"]), float(r["sigma_px"])))
    files = {(r["frame"], r["camera"]): folder / r["file"] for r in frame_rows(folder)}
    n = 0
    for key, spots in sorted(by_image.items()):
        path = files.get(key)
        if path is None or not path.exists():
            continue
        px, maxv = read_pgm(path)
        for u, v, s in spots:
            erase_spot(px, u, v, s, rng, n_sigma)
            n += 1
        replace_file(path, pgm_bytes(px, maxv))
    return n


def erase_spot(px: np.ndarray, u: float, v: float, sigma_px: float, rng, n_sigma: float = 4.0) -> None:
    """In place: the window of half-width ceil(n_sigma sigma) + 2 around (u, v) (pixel centres at
    integer coordinates) becomes the border's background plus noise of its level."""
    h, w = px.shape
    r = math.ceil(n_sigma * sigma_px) + 2
    cu, cv = int(round(u)), int(round(v))
    x0, x1 = max(cu - r, 0), min(cu + r + 1, w)
    y0, y1 = max(cv - r, 0), min(cv + r + 1, h)
    win = px[y0:y1, x0:x1]
    if win.shape[0] < 5 or win.shape[1] < 5:
        return
    border = np.concatenate(
        [win[:2].ravel(), win[-2:].ravel(), win[2:-2, :2].ravel(), win[2:-2, -2:].ravel()]
    )
    bg = float(np.median(border))
    noise = 1.4826 * float(np.median(np.abs(border - bg)))
    if noise == 0.0:
        noise = float(np.std(border))
    inner = win[2:-2, 2:-2]
    inner[...] = bg + rng.normal(0.0, noise, inner.shape)


# --------------------------------------------------------------------------- the grown campaign
# (issue 42 item 4). Faults that change what a camera sees are re-rendered through the
# simulator's own projection and renderer (render.py), so their spots are physically right.
def _rows_text(folder: Path) -> list[str]:
    return (folder / "frames.csv").read_text().split("\n")


def point_camera(folder: Path, cam: str, first: int, axis_c, deg: float, seed: int) -> dict:
    """A camera mount knocked at frame `first`: from then on camera cam's images are
    re-rendered as the camera turned deg degrees about axis_c (its own axes: x right, y down,
    z optical) sees the beacons (render.knocked), with fresh sensor noise; spots.csv is
    updated for those images. frames.csv and the capture instants are unchanged. Returns
    {"images": re-rendered, "spots": beacon spots in them, "shift_px": median spot shift}."""
    from . import render

    scene = render.Scene.load(folder)
    k = render.CAMERAS.index(cam)
    moved = render.knocked(scene.cams[k], np.asarray(axis_c, dtype=float), deg)
    renderer = scene.renderer()
    rng = np.random.default_rng([seed, 42, k])
    spots = [r for r in render.read_spots(folder) if not (r["camera"] == cam and int(r["frame"]) >= first)]
    shifts, n_img, n_spots = [], 0, 0
    for f, path in sorted(camera_files(folder, cam).items()):
        if f < first:
            continue
        s_new, ids_new = scene.spots(cam, f, moved)
        s_old, ids_old = scene.spots(cam, f)
        old = {int(i): s for i, s in zip(ids_old, s_old, strict=True)}
        shifts += [
            float(np.hypot(*(s[:2] - old[int(i)][:2])))
            for i, s in zip(ids_new, s_new, strict=True)
            if int(i) in old
        ]
        replace_file(path, render.render_pgm(renderer, s_new, rng))
        spots += [render.spot_row(f, cam, i, s) for i, s in zip(ids_new, s_new, strict=True)]
        n_img += 1
        n_spots += len(ids_new)
    render.write_spots(folder, spots)
    return {"images": n_img, "spots": n_spots, "shift_px": float(np.median(shifts)) if shifts else None}


def clock_drift(folder: Path, cam: str, first: int, per_frame_s: float) -> ContentMap:
    """Camera cam's clock drifting from frame `first`: its frames.csv t_s of frame f >= first
    is the true instant plus per_frame_s * (f - first + 1), a ramp (a clock running fast by
    per_frame_s per frame period). The images are unchanged: the light reached the sensor at
    the true instant, the camera's clock labels it wrongly. The scorer's capture time is the
    image's (the original row's), so a fix stamped by the drifting clock is judged by how far
    its stamp is from when its frames were taken."""
    out = []
    for ln in _rows_text(folder):
        p = ln.split(",")
        if len(p) == 6 and p[0].isdigit() and p[2] == cam and int(p[0]) >= first:
            p[1] = f"{float(p[1]) + per_frame_s * (int(p[0]) - first + 1):.6f}"
            ln = ",".join(p)
        out.append(ln)
    replace_file(folder / "frames.csv", "\n".join(out).encode())
    return {}


def stale_after_drop(folder: Path, cam: str, first: int) -> ContentMap:
    """A camera that drops frame `first` and from then on delivers each frame one period
    late, stamped on arrival: its frames.csv row of frame `first` is gone (the driver never
    got it: the replay shows the frame-index gap, as a V4L2 sequence gap would, with no
    error) and its image of frame f > first is its image of f-1 while the row keeps t_f.
    No image is repeated: the contents delivered are ..., first-1, first, first+1, ... at
    the stamps ..., t_(first-1), t_(first+1), t_(first+2), ..."""
    files = camera_files(folder, cam)
    done: ContentMap = {}
    for f in sorted(files, reverse=True):  # newest first: f-1 is still the original
        if f > first and f - 1 in files:
            replace_file(files[f], files[f - 1].read_bytes())
            done[(cam, f)] = f - 1
    out = []
    for ln in _rows_text(folder):
        p = ln.split(",")
        if len(p) == 6 and p[0].isdigit() and p[2] == cam and int(p[0]) == first:
            continue
        out.append(ln)
    replace_file(folder / "frames.csv", "\n".join(out).encode())
    files[first].unlink()
    return done


def alternate_buffers(folder: Path, cam: str, first: int) -> ContentMap:
    """A capture stuck on two buffers from frame `first`: images first-1 and first are the
    last two written, and from then on the camera delivers them in turn (f > first: image
    first-1 when f - first is odd, image first when even), stamps advancing. Byte-identical
    repeats, but never two equal images in a row."""
    files = camera_files(folder, cam)
    bufs = {0: files[first].read_bytes(), 1: files[first - 1].read_bytes()}
    done: ContentMap = {(cam, first): first}
    for f, p in sorted(files.items()):
        if f > first:
            replace_file(p, bufs[(f - first) % 2])
            done[(cam, f)] = first - (f - first) % 2
    return done


def frozen_noisy(folder: Path, cam: str, first: int, seed: int) -> ContentMap:
    """A frozen scene with live sensor noise (a stuck ISP crop or a mirror: the sensor keeps
    reading out): from frame `first` on, camera cam's images are its frame `first` spots
    (spots.csv, reflections included) re-rendered with a fresh noise draw each frame. No two
    images are byte-equal; what they show is frame `first`."""
    from . import render

    scene = render.Scene.load(folder)
    renderer = scene.renderer()
    rows = render.read_spots(folder)
    spots = np.array(
        [
            [float(r[c]) for c in ("u", "v", "peak_dn", "sigma_px")]
            for r in rows
            if r["camera"] == cam and int(r["frame"]) == first
        ]
    ).reshape(-1, 4)
    rng = np.random.default_rng([seed, 43, render.CAMERAS.index(cam)])
    done: ContentMap = {}
    keep = [r for r in rows if not (r["camera"] == cam and int(r["frame"]) > first)]
    same = [r for r in rows if r["camera"] == cam and int(r["frame"]) == first]
    for f, p in sorted(camera_files(folder, cam).items()):
        if f > first:
            replace_file(p, render.render_pgm(renderer, spots, rng))
            keep += [r | {"frame": str(f)} for r in same]
        if f >= first:
            done[(cam, f)] = first
    render.write_spots(folder, keep)
    return done


def reflections(
    folder: Path, cam: str, first: int, seed: int, dist_px=(3.0, 6.0), rel_peak=(0.3, 0.6)
) -> int:
    """A reflection beside every beacon of one camera from frame `first` (a shiny bracket by
    each LED, or a cover glass ghost): for every beacon spot of camera cam in spots.csv, a
    second spot dist_px away (uniform, random direction), rel_peak of its peak and as wide,
    added to the image with its shot noise; spots.csv lists it (beacon_id -1). At 3-6 px, two
    to four spot sigmas, the ghost is a separate blob or merges with the beacon and pulls its
    centroid. Returns the number of reflections added."""
    from . import render

    scene = render.Scene.load(folder)
    renderer = scene.renderer()
    rng = np.random.default_rng([seed, 44, render.CAMERAS.index(cam)])
    rows = render.read_spots(folder)
    by_frame: dict[int, list[dict]] = {}
    for r in rows:
        if r["camera"] == cam and int(r["frame"]) >= first and int(r["beacon_id"]) >= 0:
            by_frame.setdefault(int(r["frame"]), []).append(r)
    files = camera_files(folder, cam)
    n = 0
    e_dn = scene.params.electrons_per_dn
    for f, beacon_rows in sorted(by_frame.items()):
        ghosts = []
        for r in beacon_rows:
            ang, d = rng.uniform(0.0, 2 * np.pi), rng.uniform(*dist_px)
            u, v = float(r["u"]) + d * np.cos(ang), float(r["v"]) + d * np.sin(ang)
            ghosts.append([u, v, float(r["peak_dn"]) * rng.uniform(*rel_peak), float(r["sigma_px"])])
        g = np.array(ghosts)
        px, maxv = read_pgm(files[f])
        idx, sig = renderer.signal(g)
        px[idx] += rng.poisson(np.maximum(sig, 0.0) * e_dn) / e_dn  # the ghost's light and its shot noise
        replace_file(files[f], pgm_bytes(px, maxv))
        rows += [render.spot_row(f, cam, -1, s) for s in g]
        n += len(g)
    render.write_spots(folder, rows)
    return n


def swap_streams(folder: Path, a: str, b: str, first: int) -> int:
    """Two cameras' streams swapped from frame `first` (two cables or device nodes crossed
    after a driver restart): camera a's file of frame f holds camera b's image of frame f and
    the reverse; frames.csv is unchanged, so each image keeps its instant. Returns the number
    of frames swapped."""
    fa, fb = camera_files(folder, a), camera_files(folder, b)
    n = 0
    for f in sorted(fa):
        if f >= first and f in fb:
            da, db = fa[f].read_bytes(), fb[f].read_bytes()
            replace_file(fa[f], db)
            replace_file(fb[f], da)
            n += 1
    return n


def scale_gain(folder: Path, cam: str, first: int, factor: float) -> int:
    """Camera cam's gain multiplied by factor from frame `first` (every DN scaled, background
    included; rounded) while frames.csv keeps the gain it reported: a gain register lost or
    a half-scaled readout. Returns the number of images changed."""
    n = 0
    for f, p in sorted(camera_files(folder, cam).items()):
        if f >= first:
            px, maxv = read_pgm(p)
            replace_file(p, pgm_bytes(np.floor(px * factor + 0.5), maxv))
            n += 1
    return n


def seen_beacons(spots_csv: Path) -> list[int]:
    """Beacon ids by how many rendered spots they have, most first (lowest id on a tie)."""
    counts: dict[int, int] = {}
    with open(spots_csv, newline="") as f:
        for r in csv.DictReader(f):
            b = int(r["beacon_id"])
            if b >= 0:
                counts[b] = counts.get(b, 0) + 1
    return sorted(counts, key=lambda b: (-counts[b], b))


def moved_beacons_map(src: Path, out: Path, moves: dict[int, np.ndarray]) -> Path:
    """moved_beacon_map for several beacons at once."""
    rows = read_beacons(src)
    for beacon_id, move_mm in moves.items():
        hit = [r for r in rows if int(r["id"]) == beacon_id]
        if len(hit) != 1:
            raise ValueError(f"{src}: beacon {beacon_id} not found once")
        for a, m in zip(AXES, move_mm, strict=True):
            hit[0][a] = f"{float(hit[0][a]) - float(m):.4f}"
    return write_beacons(rows, out)
