"""`mfns sim nav`: LED-beacon frames of the navigation experiment (docs/nav-frames.md).

Two scenarios:

- ``turntable`` (docs/system.md §6): the paper's ten beacons (Table 4), the paper's rig
  (Tables 2-3), the body origin at the world origin and the turntable turning about Zt:
  truth position (0, 0, 0), attitude (0, 0, psi_t) with psi_t sweeping ``--yaw-span``
  degrees over the run. With these mounts only one to four beacons are in view.
- ``module``: a space-station module 4 m (Xw) x 2 m (Yw) x 2 m (Zw), world origin at its
  centre, ``--beacons`` LEDs on the six walls (stratified, jittered, from the seed; a larger
  share on the end walls, which the cameras see from afar), and a smooth 6-DOF trajectory
  (sums of sinusoids) that keeps the body well inside the module.

Each beacon is projected through the exact camera model (incl. distortion) and rendered
as a Gaussian spot integrated over pixel areas (pixel centres at integer coordinates,
docs/conventions.md); the spot width combines the lens PSF, an extra blur and a
thin-lens defocus term; spot brightness follows 1/r^2 and the LED's emission pattern,
scaled by a per-camera auto-exposure. Noise: Poisson shot noise and Gaussian read noise
in the windows around spots; elsewhere a Gaussian background of the same variance,
drawn from a 16-bit quantile table (for speed: only the windows are rendered in detail).
Occasional spurious reflections add dimmer, wider ghost spots; every spot, real or
spurious, is listed in the ``spots.csv`` sidecar with its true image position.

``--survey-error`` renders every beacon displaced from its map position by a draw of
N(0, sigma_mm^2 I) (its own ``sigma_mm``, from a seeded stream of its own): the map written
to ``beacons.csv`` stays the nominal one, as a real survey is, and the positions the frames
were rendered from go to ``beacons_rendered.csv``.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.special import erf, ndtri

from ..analysis import calib_results
from ..core.csv_formats import BEACON_COLUMNS as BEACONS_HEADER
from ..core.csv_formats import TRUTH_HEADER
from ..core.errors import MfnsError
from ..model.camera import Camera, load_beacons, pose_from_position, rig_from_doc
from ..model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg
from ..tlm.tlm_dict import CYCLE_HZ
from . import module_geom
from .module_geom import DEMO_MODULE, EDGE_MARGIN_MM, ModuleGeometry

DATA = Path(__file__).resolve().parents[1] / "data"
PAPER_CALIB = DATA / "paper_calib.json"
PAPER_BEACONS = DATA / "paper_beacons.csv"

FORMAT = "mfns-nav-frames"
VERSION = 1
CAMERA_LETTERS = calib_results.CAMERA_NAMES  # one home: the flight rig's camera names
# a frames folder's image folder per camera (docs/nav-frames.md): cam_x/, cam_y/, cam_z/
CAMERA_DIRS = tuple(f"cam_{letter}" for letter in CAMERA_LETTERS)
FRAMES_HEADER = ["frame", "t_s", "camera", "file", "exposure_us", "gain_db"]
SPOTS_HEADER = ["frame", "camera", "beacon_id", "u", "v", "peak_dn", "sigma_px"]

# Module geometry (mm): one definition, shared with the planner (module_geom.py); these
# names are the demo module's.
MODULE_HALF = DEMO_MODULE.half
MODULE_EDGE_MARGIN_MM = EDGE_MARGIN_MM
# Share of beacons on the two end walls (x = +-half length): the cameras see them from afar,
# so they carry most of the view; found by sweeping layouts for the visibility target.
MODULE_END_WALL_SHARE = 0.4
# Map accuracy written to beacons.csv for the module (the simulated map is exact; this is
# the survey accuracy a solver should assume, the paper's 0.3963 mm rounded).
MODULE_BEACON_SIGMA_MM = 0.4
# Sinusoidal trajectory (amplitude, period s) per axis; periods are mutually incommensurate
# so the path does not repeat within minutes. Position in mm, attitude in degrees. The
# position amplitude is the module's (ModuleGeometry.pos_amp_mm: the demo's scales with the
# size); the periods and the attitude wobble are the robot's.
MODULE_POS_AMP_MM = DEMO_MODULE.pos_amp_mm
MODULE_POS_PERIOD_S = np.array([47.0, 31.0, 37.0])
MODULE_ATT_AMP_DEG = np.array([20.0, 20.0, 30.0])
MODULE_ATT_PERIOD_S = np.array([29.0, 41.0, 53.0])


def module_workspace(geom: ModuleGeometry = DEMO_MODULE) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): the box the body origin stays in on every module path (the trajectory's
    amplitude about the centre), the robot's workspace its tables are built over
    (scenario.json table_workspace_mm; the acquisition benches)."""
    return geom.workspace()


# Half-width (mm of Xw) of the turn-around manoeuvre at the demo module's centre
# (ModuleGeometry.turn_width_mm scales it with the length).
MODULE_TURN_WIDTH_MM = DEMO_MODULE.turn_width_mm

# Nearest distance at which a beacon is rendered (closer is not a spot but a blob).
MIN_RANGE_MM = 50.0
# Undistorted normalized radius beyond which a projection is discarded: the polynomial
# distortion can fold far off-axis points back into the image (the image corners are ~0.51).
MAX_NORMALIZED_RADIUS = 0.75


@dataclass
class RenderParams:
    """Photometric model. DN = 8-bit digital numbers."""

    background_dn: float = 6.0  # mean dark level + stray light
    vignette_dn: float = 3.0  # extra glow at the image centre, falling off to the corners
    read_noise_dn: float = 1.0
    electrons_per_dn: float = 40.0  # conversion gain (shot noise)
    psf_sigma_px: float = 1.0  # lens PSF + pixel crosstalk (LEDs slightly defocused on purpose)
    blur_px: float = 0.8  # extra Gaussian blur (slight defocus / vibration)
    focus_mm: float = 1500.0  # focused distance of the thin-lens defocus model
    defocus_px_mm: float = 750.0  # blur sigma (px) = this * |1/r - 1/focus|
    peak_ref_dn: float = 200.0  # peak of a frontal LED at 1 m, sigma 1 px, reference exposure
    exposure_ref_us: float = 1000.0
    ae_target_dn: float = 180.0  # auto-exposure puts the brightest spot's peak here
    exposure_min_us: float = 20.0
    exposure_max_us: float = 20000.0
    gain_max_db: float = 12.0
    led_pattern_exp: float = 0.5  # intensity ~ cos(theta)^this (wide-angle LED)
    spurious_rate: float = 0.05  # probability of a ghost spot per (frame, camera)
    noise: bool = True  # False: no shot/read noise (8-bit quantisation stays)

    def to_json(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass
class Scenario:
    name: str
    cams: list[Camera]
    calib_doc: dict
    beacon_ids: np.ndarray
    beacons: np.ndarray  # (N, 3) world mm, the true positions (= the written map)
    beacon_sigma: np.ndarray
    beacon_normals: np.ndarray  # (N, 3) unit emission axes
    t_s: np.ndarray  # (F,)
    r_wb_w: np.ndarray  # (F, 3)
    euler_deg: np.ndarray  # (F, 3) 2-1-3 angles of C_w_b
    info: dict = field(default_factory=dict)
    # (N, 3) where the beacons are rendered when that differs from the map (survey error)
    beacons_rendered: np.ndarray | None = None

    @property
    def render_positions(self) -> np.ndarray:
        return self.beacons if self.beacons_rendered is None else self.beacons_rendered

    @property
    def n_frames(self) -> int:
        return len(self.t_s)

    def pose(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """(C_w_b, r_bw_b) of frame i."""
        c = euler213_deg_to_matrix(self.euler_deg[i])
        return c, pose_from_position(c, self.r_wb_w[i])


# --------------------------------------------------------------------------- geometry
def project_beacons(cam: Camera, C_w_b, r_bw_b, points_w) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points through the body pose and camera -> (uv (N,2), visible (N,), p_c (N,3)).

    Visible: at least MIN_RANGE_MM in front, within MAX_NORMALIZED_RADIUS off axis and with
    the spot centre inside the image.
    """
    p_c = cam.world_to_camera(C_w_b, r_bw_b, points_w)
    uv, front = cam.project_camera_points(p_c)
    z = np.where(p_c[:, 2] > 0, p_c[:, 2], 1.0)
    radius = np.hypot(p_c[:, 0], p_c[:, 1]) / z
    vis = front & (p_c[:, 2] >= MIN_RANGE_MM) & (radius <= MAX_NORMALIZED_RADIUS) & cam.in_image(uv)
    return uv, vis, p_c


def visibility_counts(scn: Scenario) -> np.ndarray:
    """(F, 3) number of beacons whose spot centre is in each camera's image."""
    out = np.zeros((scn.n_frames, 3), dtype=int)
    for i in range(scn.n_frames):
        c, r = scn.pose(i)
        for k, cam in enumerate(scn.cams):
            out[i, k] = int(project_beacons(cam, c, r, scn.render_positions)[1].sum())
    return out


def visibility_stats(counts: np.ndarray) -> dict:
    total = counts.sum(axis=1)
    return {
        "frames": int(len(total)),
        "in_view_mean": round(float(total.mean()), 3) if len(total) else 0.0,
        "in_view_min": int(total.min()) if len(total) else 0,
        "in_view_max": int(total.max()) if len(total) else 0,
        "frac_ge_3": round(float((total >= 3).mean()), 4) if len(total) else 0.0,
        "frac_ge_4": round(float((total >= 4).mean()), 4) if len(total) else 0.0,
        "per_camera_mean": [round(float(v), 3) for v in counts.mean(axis=0)] if len(total) else [0.0] * 3,
        "histogram": {str(n): int(c) for n, c in zip(*np.unique(total, return_counts=True), strict=True)},
    }


def module_beacons(
    n: int, rng: np.random.Generator, half: np.ndarray = MODULE_HALF
) -> tuple[np.ndarray, np.ndarray]:
    """n beacons on the module walls -> (positions (n, 3), inward normals (n, 3)).

    Each wall gets a share of n (end walls MODULE_END_WALL_SHARE in total, the rest spread
    over the four long walls), placed one per cell of a grid shaped like the wall, cells
    chosen at random, position jittered inside the cell, at least MODULE_EDGE_MARGIN_MM
    from the wall's edges. half: the module's half-extents (mm), MODULE_HALF by default.
    """
    if n < 6:
        raise MfnsError("the module needs at least 6 beacons (one per wall)")
    n_end = 2 * max(1, int(round(n * MODULE_END_WALL_SHARE / 2)))
    n_side = n - n_end
    per_wall = [n_end // 2, n_end // 2] + [n_side // 4 + (1 if i < n_side % 4 else 0) for i in range(4)]
    # (normal axis, side, in-plane axes)
    walls = [
        (0, 1.0, 1, 2),
        (0, -1.0, 1, 2),
        (1, 1.0, 0, 2),
        (1, -1.0, 0, 2),
        (2, 1.0, 0, 1),
        (2, -1.0, 0, 1),
    ]
    pos, nrm = [], []
    for (ax, side, ua, va), k in zip(walls, per_wall, strict=True):
        uh = half[ua] - MODULE_EDGE_MARGIN_MM
        vh = half[va] - MODULE_EDGE_MARGIN_MM
        nu = max(1, int(round(math.sqrt(k * uh / vh))))
        nv = max(1, math.ceil(k / nu))
        cells = rng.permutation(nu * nv)[:k]
        for cell in cells:
            i, j = divmod(int(cell), nv)
            p = np.zeros(3)
            p[ax] = side * half[ax]
            p[ua] = -uh + (i + rng.uniform(0.15, 0.85)) * 2 * uh / nu
            p[va] = -vh + (j + rng.uniform(0.15, 0.85)) * 2 * vh / nv
            q = np.zeros(3)
            q[ax] = -side
            pos.append(p)
            nrm.append(q)
    return np.array(pos), np.array(nrm)


def module_trajectory(
    t_s: np.ndarray, rng: np.random.Generator, geom: ModuleGeometry = DEMO_MODULE
) -> tuple[np.ndarray, np.ndarray]:
    """Smooth 6-DOF path -> (r_wb_w (F, 3) mm, euler 2-1-3 of C_w_b (F, 3) deg).

    One sinusoid per axis with seeded phases: the body origin stays within the module's
    path amplitude of the centre (geom.pos_amp_mm; the demo's 800, 300, 300 mm: >= 700 mm
    from every wall), roll/pitch/yaw wobble by MODULE_ATT_AMP_DEG, and on top the robot
    turns around as it crosses the module (yaw offset 90 (1 + tanh(x / geom.turn_width_mm))
    deg), so that camera X faces the far end wall: the end walls, seen from afar, carry
    most of the beacons in view.
    """
    ph = rng.uniform(0.0, 2 * np.pi, 6)
    t = np.asarray(t_s, dtype=float)[:, None]
    pos = geom.pos_amp_mm * np.sin(2 * np.pi * t / MODULE_POS_PERIOD_S + ph[:3])
    att = MODULE_ATT_AMP_DEG * np.sin(2 * np.pi * t / MODULE_ATT_PERIOD_S + ph[3:])
    att[:, 2] += 90.0 * (1.0 + np.tanh(pos[:, 0] / geom.turn_width_mm))
    att[:, 2] = (att[:, 2] + 180.0) % 360.0 - 180.0
    return pos, att


def apply_survey_error(scn: Scenario, seed: int) -> float:
    """Render the beacons away from the map by their survey sigma: each displaced by a draw
    of N(0, sigma_mm^2 I), from a stream of its own seeded by `seed` (the map and the
    trajectory are the scenario seed's as without it). The map (scn.beacons, beacons.csv)
    stays nominal.
    Returns the RMS displacement per axis (mm)."""
    rng = np.random.default_rng([seed, 3])  # survey stream: after geometry (1) and noise (2)
    d = rng.standard_normal(scn.beacons.shape) * np.asarray(scn.beacon_sigma, dtype=float)[:, None]
    scn.beacons_rendered = scn.beacons + d
    return float(np.sqrt(np.mean(d * d))) if d.size else 0.0


def apply_collision(scn: Scenario, t_s: float, v_mm_s, w_deg_s=(0.0, 0.0, 0.0)) -> None:
    """A collision (or a hard burst) at t_s: from then on the path carries a velocity step,
    r_wb_w += v (t - t_s) and the Euler angles of C_w_b += w (t - t_s) (mm/s, deg/s; the
    angles re-extracted as a reader would). Position and attitude stay continuous; velocity
    jumps within one frame period: an acceleration far beyond any propulsion bound."""
    dt = np.clip(np.asarray(scn.t_s, dtype=float) - t_s, 0.0, None)[:, None]
    scn.r_wb_w = scn.r_wb_w + dt * np.asarray(v_mm_s, dtype=float)
    att = scn.euler_deg + dt * np.asarray(w_deg_s, dtype=float)
    scn.euler_deg = np.array([matrix_to_euler213_deg(euler213_deg_to_matrix(a)) for a in att]).reshape(-1, 3)
    scn.info["collision"] = {
        "t_s": t_s,
        "velocity_step_mm_s": [float(v) for v in v_mm_s],
        "rate_step_deg_s": [float(w) for w in w_deg_s],
        "note": "from t_s on: position += v (t - t_s), Euler angles += w (t - t_s)",
    }


def parse_collision(text: str) -> tuple[float, list[float], list[float]]:
    """--collision T,VX,VY,VZ[,WR,WP,WY] -> (t_s, v mm/s, w deg/s)."""
    try:
        vals = [float(x) for x in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (4, 7) or not all(math.isfinite(v) for v in vals):
        raise MfnsError(f"--collision {text!r}: expected T_S,VX,VY,VZ[,WROLL,WPITCH,WYAW] (s, mm/s, deg/s)")
    return vals[0], vals[1:4], (vals[4:7] if len(vals) == 7 else [0.0, 0.0, 0.0])


def true_rig_document(doc: dict) -> dict:
    """The calibration document of the simulated (true) rig: without an estimate's covariance."""
    return {k: v for k, v in doc.items() if k != "covariance"}


def load_rig(path: Path | None) -> tuple[list[Camera], dict]:
    doc = calib_results.load(path or PAPER_CALIB)
    return rig_from_doc(doc), doc


def load_beacon_map(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A beacons.csv given with --beacon-map (validated as `mfns table build` does)."""
    from ..table.builder import load_beacon_csv

    return load_beacon_csv(path)


def wall_normals(pos: np.ndarray, half: np.ndarray = MODULE_HALF) -> np.ndarray:
    """Inward normal of the module wall nearest each beacon (a map given with --beacon-map);
    half: the module's half-extents (mm), the demo's by default."""
    gap = half - np.abs(pos)  # distance to the wall on each axis
    ax = np.argmin(gap, axis=1)
    normals = np.zeros_like(pos)
    normals[np.arange(len(pos)), ax] = -np.sign(pos[np.arange(len(pos)), ax])
    return normals


def turntable_scenario(
    n_frames: int,
    rate_hz: float,
    yaw_start_deg: float,
    yaw_span_deg: float,
    rig: Path | None = None,
    beacon_map: Path | None = None,
) -> Scenario:
    cams, doc = load_rig(rig)
    ids, pos, sigma = load_beacon_map(beacon_map) if beacon_map else load_beacons(PAPER_BEACONS)
    t = np.arange(n_frames) / rate_hz
    yaw = yaw_start_deg + yaw_span_deg * np.arange(n_frames) / max(n_frames, 1)
    euler = np.zeros((n_frames, 3))
    for i, y in enumerate(yaw):  # the Euler angles of C_w_b, as a reader would extract them
        euler[i] = matrix_to_euler213_deg(euler213_deg_to_matrix([0.0, 0.0, y]))
    # LEDs on the steel frame are aimed at the turntable centre.
    normals = -pos / np.linalg.norm(pos, axis=1, keepdims=True)
    return Scenario(
        "turntable",
        cams,
        doc,
        ids,
        pos,
        sigma,
        normals,
        t,
        np.zeros((n_frames, 3)),
        euler,
        {
            "yaw_start_deg": yaw_start_deg,
            "yaw_span_deg": yaw_span_deg,
            "beacon_map": str(beacon_map) if beacon_map else "paper Table 4",
        },
    )


def module_scenario(
    n_frames: int,
    rate_hz: float,
    n_beacons: int,
    seed: int,
    rig: Path | None = None,
    beacon_map: Path | None = None,
    geom: ModuleGeometry = DEMO_MODULE,
) -> Scenario:
    # the reader owns the key; imported here so that importing the simulator stays light
    from ..table.mapindex import WORKSPACE_KEY

    cams, doc = load_rig(rig)
    rng = np.random.default_rng([seed, 1])  # geometry stream, independent of the noise stream
    half = geom.half
    pos, normals = module_beacons(n_beacons, rng, half)  # drawn even with a given map: same trajectory
    ids, sigma = np.arange(len(pos)), np.full(len(pos), MODULE_BEACON_SIGMA_MM)
    map_note = f"{len(pos)} wall beacons from the seed; sigma_mm is nominal, positions exact"
    if beacon_map:
        ids, pos, sigma = load_beacon_map(beacon_map)
        if np.any(np.abs(pos) > half + 1e-6):
            raise MfnsError(
                f"{beacon_map}: a beacon lies outside the module (half-extents {half.tolist()} mm)"
            )
        normals = wall_normals(pos, half)
        map_note = f"{len(pos)} beacons from {beacon_map}; LEDs aimed along the nearest wall's normal"
    t = np.arange(n_frames) / rate_hz
    r_wb_w, att = module_trajectory(t, rng, geom)
    # Written as a reader extracts them from C_w_b (yaw in (-180, 180]).
    euler = np.array([matrix_to_euler213_deg(euler213_deg_to_matrix(a)) for a in att]).reshape(-1, 3)
    return Scenario(
        "module",
        cams,
        doc,
        ids,
        pos,
        sigma,
        normals,
        t,
        r_wb_w,
        euler,
        {
            "module_size_mm": (2 * half).tolist(),
            "module_origin": "centre; Xw along the module's length",
            # the box the body origin stays in on every module path (the trajectory's
            # amplitude about the centre): the robot's workspace, as `mfns table build
            # --workspace` reads it from this file
            WORKSPACE_KEY: np.concatenate(module_workspace(geom)).tolist(),
            "trajectory": {
                "pos_amp_mm": geom.pos_amp_mm.tolist(),
                "pos_period_s": MODULE_POS_PERIOD_S.tolist(),
                "att_amp_deg": MODULE_ATT_AMP_DEG.tolist(),
                "att_period_s": MODULE_ATT_PERIOD_S.tolist(),
                "yaw_turn": "yaw += 90 (1 + tanh(x_mm / turn_width_mm))",
                "turn_width_mm": geom.turn_width_mm,
            },
            "beacon_map": map_note,
        },
    )


# --------------------------------------------------------------------------- rendering
class Renderer:
    """Renders the spots of one image: background noise everywhere, detail in windows."""

    def __init__(self, width: int, height: int, params: RenderParams):
        self.w, self.h, self.p = width, height, params
        yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
        rr = ((xx - width / 2) ** 2 + (yy - height / 2) ** 2) / ((width / 2) ** 2 + (height / 2) ** 2)
        # Whole DN, so that quantisation of a noise-free frame leaves the background exact.
        self.bg = np.rint(params.background_dn + params.vignette_dn * (1.0 - rr)).astype(np.float32)
        sigma_bg = math.sqrt(params.read_noise_dn**2 + params.background_dn / params.electrons_per_dn)
        self.sigma_bg = sigma_bg
        self.noise_lut = (sigma_bg * ndtri((np.arange(65536) + 0.5) / 65536)).astype(np.float32)

    def signal(self, spots: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
        """Noise-free spot signal (DN, no background) on the union of the spots' windows.

        spots (S, 4): u, v, peak_dn, sigma_px -> ((rows, cols) of the window pixels, values).
        Each Gaussian is integrated over the pixel areas [i - 0.5, i + 0.5) (pixel centres
        at integers) within +-(ceil(4.5 sigma_max) + 1) px of its centre.
        """
        sig = np.zeros((self.h, self.w), dtype=np.float64)
        mask = np.zeros((self.h, self.w), dtype=bool)
        rad = int(math.ceil(4.5 * float(spots[:, 3].max()))) + 1
        offs = np.arange(-rad, rad + 1)
        u, v, peak, s = (spots[:, j][:, None] for j in range(4))
        cols = np.rint(u).astype(int) + offs  # (S, 2r+1) pixel columns of each window
        rows = np.rint(v).astype(int) + offs
        gx = 0.5 * (erf((cols + 0.5 - u) / (np.sqrt(2) * s)) - erf((cols - 0.5 - u) / (np.sqrt(2) * s)))
        gy = 0.5 * (erf((rows + 0.5 - v) / (np.sqrt(2) * s)) - erf((rows - 0.5 - v) / (np.sqrt(2) * s)))
        flux = peak[:, 0] * 2 * np.pi * s[:, 0] ** 2  # the continuous Gaussian's volume
        win = flux[:, None, None] * gy[:, :, None] * gx[:, None, :]
        rr = np.broadcast_to(rows[:, :, None], win.shape)
        cc = np.broadcast_to(cols[:, None, :], win.shape)
        ok = (rr >= 0) & (rr < self.h) & (cc >= 0) & (cc < self.w)
        np.add.at(sig, (rr[ok], cc[ok]), win[ok])
        mask[rr[ok], cc[ok]] = True
        r_i, c_i = np.nonzero(mask)
        return (r_i, c_i), sig[r_i, c_i]

    def render(self, spots: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """spots (S, 4): u, v, peak_dn, sigma_px -> uint8 image (H, W)."""
        p = self.p
        if p.noise:
            img = self.noise_lut[rng.integers(0, 65536, (self.h, self.w), dtype=np.uint16)]
            img += self.bg
        else:
            img = self.bg.copy()
        if len(spots):
            idx, sig = self.signal(spots)
            expect = self.bg[idx] + sig
            if p.noise:
                e = rng.poisson(expect * p.electrons_per_dn) / p.electrons_per_dn
                vals = e + rng.normal(0.0, p.read_noise_dn, e.shape)
            else:
                vals = expect
            img[idx] = vals
        np.rint(img, out=img)
        np.clip(img, 0, 255, out=img)
        return img.astype(np.uint8)


def _num(x: float) -> str:
    """Six decimals, never '-0.000000'."""
    return f"{float(x) + 0.0:.6f}".replace("-0.000000", "0.000000")


def write_pgm(path: Path, img: np.ndarray) -> None:
    h, w = img.shape
    with open(path, "wb") as f:
        f.write(f"P5\n{w} {h}\n255\n".encode("ascii"))
        f.write(np.ascontiguousarray(img, dtype=np.uint8).tobytes())


def read_pgm(path: Path) -> np.ndarray:
    """Strict reader of the frames written here: header exactly 'P5\\n<W> <H>\\n255\\n'."""
    data = Path(path).read_bytes()
    parts = data.split(b"\n", 3)
    if len(parts) != 4 or parts[0] != b"P5" or parts[2] != b"255":
        raise MfnsError(f"{path}: not an 8-bit binary PGM with a plain header")
    w, h = (int(x) for x in parts[1].split(b" "))
    if len(parts[3]) != w * h:
        raise MfnsError(f"{path}: {len(parts[3])} pixel bytes, expected {w * h}")
    return np.frombuffer(parts[3], dtype=np.uint8).reshape(h, w)


def spot_sigma(params: RenderParams, range_mm: np.ndarray) -> np.ndarray:
    defocus = params.defocus_px_mm * np.abs(1.0 / range_mm - 1.0 / params.focus_mm)
    return np.sqrt(params.psf_sigma_px**2 + params.blur_px**2 + defocus**2)


def relative_peak(params: RenderParams, range_mm, cos_led, sigma_px) -> np.ndarray:
    """Peak DN at the reference exposure and 0 dB: 1/r^2, LED pattern, spread over sigma^2."""
    pattern = np.clip(cos_led, 0.0, 1.0) ** params.led_pattern_exp
    return params.peak_ref_dn * (1000.0 / range_mm) ** 2 * pattern / sigma_px**2


def auto_exposure(params: RenderParams, brightest_ref_dn: float, previous: tuple[float, float]):
    """(exposure_us, gain_db) that puts the brightest spot at ae_target_dn."""
    if brightest_ref_dn <= 0:
        return previous
    want = params.exposure_ref_us * params.ae_target_dn / brightest_ref_dn
    exposure = float(np.clip(round(want), params.exposure_min_us, params.exposure_max_us))
    gain = 0.0
    if want > exposure:
        gain = float(min(params.gain_max_db, round(20 * math.log10(want / exposure), 1)))
    return exposure, gain


def centroid_window_radius(sigma_px) -> np.ndarray:
    """Half-size of the centroid window the noise prediction assumes: ceil(3 sigma)."""
    return np.ceil(3.0 * np.asarray(sigma_px, dtype=float))


def nominal_centroid_sigma(params: RenderParams, peak_dn, sigma_px) -> np.ndarray:
    """Per-axis 1-sigma (px) of a simple intensity-weighted centroid of a spot.

    Window (2R+1)^2 pixels, R = ceil(3 sigma), background known: shot noise of the spot
    (sigma^2 / N electrons) plus the background noise of every pixel weighted by its
    distance from the centre, sum_window (x - u)^2 * var_bg / flux^2. Quantisation adds
    1/12 DN^2 per pixel. A matched filter would do several times better.
    """
    peak_dn = np.asarray(peak_dn, dtype=float)
    sigma_px = np.asarray(sigma_px, dtype=float)
    flux_dn = 2 * np.pi * sigma_px**2 * peak_dn
    r = centroid_window_radius(sigma_px)
    sum_dx2 = (2 * r + 1) * r * (r + 1) * (2 * r + 1) / 3.0  # sum over the window of (x - cx)^2
    var_pix = 1.0 / 12.0
    shot = 0.0
    if params.noise:
        var_pix = var_pix + params.read_noise_dn**2 + params.background_dn / params.electrons_per_dn
        shot = sigma_px**2 / (flux_dn * params.electrons_per_dn)
    return np.sqrt(shot + sum_dx2 * var_pix / flux_dn**2)


# --------------------------------------------------------------------------- the run
def simulate(
    scn: Scenario, out: Path, seed: int, rate_hz: float, params: RenderParams, progress=True
) -> dict:
    """Render the scenario into `out` (docs/nav-frames.md). Returns the summary dict."""
    from tqdm import tqdm

    rng = np.random.default_rng([seed, 2])  # noise stream
    widths = {(c.width, c.height) for c in scn.cams}
    if len(widths) != 1:
        raise MfnsError("all three cameras must have the same image size for one frame folder")
    width, height = widths.pop()
    renderer = Renderer(width, height, params)
    for d in CAMERA_DIRS:
        (out / d).mkdir(parents=True, exist_ok=True)
    # The rendered rig is exact: its calib.json has no covariance (a table built from it has a
    # zero calibration term), even when --rig named a calibration that carries one.
    calib_results.save(true_rig_document(scn.calib_doc), out / "calib.json")
    with open(out / "beacons.csv", "w", newline="") as f:
        wr = csv.writer(f, lineterminator="\n")
        wr.writerow(BEACONS_HEADER)
        for i, p, s in zip(scn.beacon_ids, scn.beacons, scn.beacon_sigma, strict=True):
            wr.writerow([int(i), f"{p[0]:.4f}", f"{p[1]:.4f}", f"{p[2]:.4f}", f"{s:.4f}"])
    beacons_w = scn.render_positions  # where the LEDs really are (= the map without survey error)
    if scn.beacons_rendered is not None:
        with open(out / "beacons_rendered.csv", "w", newline="") as f:
            wr = csv.writer(f, lineterminator="\n")
            wr.writerow(BEACONS_HEADER)
            for i, p, s in zip(scn.beacon_ids, beacons_w, scn.beacon_sigma, strict=True):
                wr.writerow([int(i), f"{p[0]:.4f}", f"{p[1]:.4f}", f"{p[2]:.4f}", f"{s:.4f}"])

    truth_rows, frame_rows, spot_rows = [], [], []
    counts = np.zeros((scn.n_frames, 3), dtype=int)
    exposure = [(params.exposure_ref_us, 0.0)] * 3
    n_spurious = 0
    all_sigma_c = []
    for i in tqdm(range(scn.n_frames), desc="sim nav", unit="frame", disable=not progress):
        c_w_b, r_bw_b = scn.pose(i)
        t = float(scn.t_s[i])
        truth_rows.append(
            [i, f"{t:.6f}", *(_num(v) for v in scn.r_wb_w[i]), *(_num(a) for a in scn.euler_deg[i])]
        )
        for k, cam in enumerate(scn.cams):
            uv, vis, p_c = project_beacons(cam, c_w_b, r_bw_b, beacons_w)
            counts[i, k] = int(vis.sum())
            ids = scn.beacon_ids[vis]
            uvv = uv[vis]
            rng_mm = np.linalg.norm(p_c[vis], axis=1)
            # LED emission angle: between its axis and the direction to the camera centre.
            cam_w = -c_w_b.T @ r_bw_b + c_w_b.T @ cam.r_bk_b
            to_cam = cam_w - beacons_w[vis]
            cos_led = np.einsum("ij,ij->i", to_cam, scn.beacon_normals[vis]) / np.linalg.norm(to_cam, axis=1)
            sig = spot_sigma(params, rng_mm)
            ref = relative_peak(params, rng_mm, cos_led, sig)
            exposure[k] = auto_exposure(params, float(ref.max()) if len(ref) else 0.0, exposure[k])
            exp_us, gain_db = exposure[k]
            scale = exp_us / params.exposure_ref_us * 10 ** (gain_db / 20)
            peak = ref * scale
            spot_sets = [np.column_stack([uvv, peak, sig])]
            labels = list(ids)
            if params.spurious_rate > 0 and rng.random() < params.spurious_rate:
                spot_sets.append(spurious_spot(rng, spot_sets[0], width, height))
                labels.append(-1)
                n_spurious += 1
            spots = np.vstack(spot_sets) if len(spot_sets) > 1 else spot_sets[0]
            img = renderer.render(spots, rng)
            name = f"{CAMERA_DIRS[k]}/{i:06d}.pgm"
            write_pgm(out / name, img)
            frame_rows.append([i, f"{t:.6f}", CAMERA_LETTERS[k], name, f"{exp_us:.0f}", f"{gain_db:.1f}"])
            for lab, s in zip(labels, spots, strict=True):
                spot_rows.append(
                    [
                        i,
                        CAMERA_LETTERS[k],
                        int(lab),
                        f"{s[0]:.6f}",
                        f"{s[1]:.6f}",
                        f"{s[2]:.2f}",
                        f"{s[3]:.4f}",
                    ]
                )
            all_sigma_c.extend(nominal_centroid_sigma(params, peak, sig).tolist())

    for name, header, rows in (
        ("truth.csv", TRUTH_HEADER, truth_rows),
        ("frames.csv", FRAMES_HEADER, frame_rows),
        ("spots.csv", SPOTS_HEADER, spot_rows),
    ):
        with open(out / name, "w", newline="") as f:
            wr = csv.writer(f, lineterminator="\n")
            wr.writerow(header)
            wr.writerows(rows)

    # the run's identity (docs/nav-frames.md "run"): the truth file's digest, its row count and
    # time span, so `mfns report` can refuse a truth file that is not this run's (deterministic:
    # the same seed and arguments give the same identity)
    truth_bytes = (out / "truth.csv").read_bytes()
    run = {
        "truth_sha256": hashlib.sha256(truth_bytes).hexdigest(),
        "truth_rows": len(truth_rows),
        "t_first_s": float(truth_rows[0][1]) if truth_rows else None,
        "t_last_s": float(truth_rows[-1][1]) if truth_rows else None,
    }
    vis_stats = visibility_stats(counts)
    pixel_noise = float(np.median(all_sigma_c)) if all_sigma_c else 0.0
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "scenario": scn.name,
        "rate_hz": rate_hz,
        "n_frames": scn.n_frames,
        "width": width,
        "height": height,
        "maxval": 255,
        "seed": seed,
        "pixel_noise_px": round(pixel_noise, 5),
        "pixel_noise_note": (
            "median over the rendered spots of the predicted per-axis 1-sigma "
            "of a simple centroid (window +-ceil(3 sigma_px))"
        ),
        "cameras": list(CAMERA_LETTERS),
        "n_beacons": len(scn.beacons),
        "rig": scn.calib_doc.get("source", ""),
        "spots_file": "spots.csv",
        "spurious_spots": n_spurious,
        "run": run,
        "visibility": vis_stats,
        "render": params.to_json(),
        **scn.info,
    }
    (out / "scenario.json").write_text(json.dumps(doc, indent=2) + "\n")
    return doc


def spurious_spot(rng, real: np.ndarray, width: int, height: int) -> np.ndarray:
    """A reflection: a dimmer, wider copy of a real spot offset by 20-200 px (or anywhere)."""
    if len(real):
        j = int(rng.integers(len(real)))
        ang, dist = rng.uniform(0, 2 * np.pi), rng.uniform(20.0, 200.0)
        u = real[j, 0] + dist * math.cos(ang)
        v = real[j, 1] + dist * math.sin(ang)
        peak = real[j, 2] * rng.uniform(0.2, 0.6)
        s = real[j, 3] * rng.uniform(1.5, 3.0)
    else:
        u, v = rng.uniform(0, width - 1), rng.uniform(0, height - 1)
        peak, s = rng.uniform(20.0, 80.0), rng.uniform(1.5, 3.0)
    u = float(np.clip(u, 0.0, width - 1.0))
    v = float(np.clip(v, 0.0, height - 1.0))
    return np.array([[u, v, peak, s]])


def prepare_out(out: Path, force: bool) -> None:
    if out.exists() and not out.is_dir():
        raise MfnsError(f"{out}: exists and is not a directory")
    if out.is_dir() and any(out.iterdir()):
        if not force:
            raise MfnsError(f"{out}: directory not empty (use --force to replace it)")
        if not (out / "scenario.json").is_file():
            raise MfnsError(f"{out}: not a nav-frames folder (no scenario.json); refusing to delete it")
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)


def build_scenario(args) -> Scenario:
    if args.frames < 1:
        raise MfnsError("--frames must be at least 1")
    if not (args.rate_hz > 0):
        raise MfnsError("--rate-hz must be positive")
    rig = Path(args.rig) if args.rig else None
    bmap = Path(args.beacon_map) if args.beacon_map else None
    if args.scenario == "turntable":
        if module_geom.given(args):
            raise MfnsError("--module-size and --module-path-amp shape --scenario module (not the turntable)")
        return turntable_scenario(args.frames, args.rate_hz, args.yaw_start, args.yaw_span, rig, bmap)
    geom = module_geom.from_args(args)
    return module_scenario(args.frames, args.rate_hz, args.beacons, args.seed, rig, bmap, geom)


def run(args) -> int:
    if not (0.0 <= args.spurious_rate <= 1.0):
        raise MfnsError("--spurious-rate must be in [0, 1]")
    scn = build_scenario(args)
    if getattr(args, "collision", None):
        apply_collision(scn, *parse_collision(args.collision))
    if args.survey_seed is not None and not args.survey_error:
        raise MfnsError("--survey-seed needs --survey-error")
    if args.survey_error:
        survey_seed = args.seed if args.survey_seed is None else args.survey_seed
        rms = apply_survey_error(scn, survey_seed)
        scn.info["survey_error"] = {
            "applied": True,
            "seed": survey_seed,
            "rms_displacement_mm": round(rms, 5),
            "rendered_positions": "beacons_rendered.csv",
            "note": "beacons rendered displaced by N(0, sigma_mm^2 I) each; beacons.csv is the nominal map",
        }
    out = Path(args.out)
    prepare_out(out, args.force)
    params = RenderParams(
        spurious_rate=args.spurious_rate,
        read_noise_dn=args.read_noise,
        blur_px=args.blur,
        noise=not args.no_noise,
    )
    t0 = time.perf_counter()
    doc = simulate(scn, out, args.seed, args.rate_hz, params, progress=not args.quiet)
    vis = doc["visibility"]
    print(
        f"sim nav: {doc['scenario']}, {doc['n_frames']} frames x 3 cameras "
        f"in {time.perf_counter() - t0:.1f} s -> {out}\n"
        f"  beacons in view per frame: mean {vis['in_view_mean']}, min {vis['in_view_min']}, "
        f">= 3 in {100 * vis['frac_ge_3']:.1f} %, >= 4 in {100 * vis['frac_ge_4']:.1f} % of frames; "
        f"per camera {vis['per_camera_mean']}\n"
        f"  spurious spots {doc['spurious_spots']}, nominal centroid noise {doc['pixel_noise_px']} px"
    )
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "nav",
        help="LED-beacon frames of the navigation experiment (docs/nav-frames.md)",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("out", metavar="OUT", help="output folder (created; must be empty unless --force)")
    p.add_argument(
        "--scenario",
        choices=("turntable", "module"),
        default="turntable",
        help="turntable: the paper's experiment (yaw sweep); module: a free flight among wall "
        "beacons (default turntable)",
    )
    p.add_argument("--frames", type=int, default=60, help="time steps (default 60)")
    p.add_argument("--seed", type=int, default=0, help="random seed (beacon map, trajectory, noise)")
    p.add_argument(
        "--rate-hz", type=float, default=CYCLE_HZ, help=f"frame rate (default {CYCLE_HZ:g}, the flight cycle)"
    )
    p.add_argument("--rig", help="calibration-results JSON of the simulated rig (default: the paper's)")
    p.add_argument("--beacons", type=int, default=60, help="module: number of wall beacons (default 60)")
    module_geom.add_arguments(p, "its walls carry the --beacons, its path stays inside")
    p.add_argument(
        "--beacon-map",
        metavar="CSV",
        help="beacons.csv to render instead of the scenario's map (e.g. from `mfns plan optimize`); "
        "turntable LEDs are aimed at the centre, module LEDs along their wall's normal",
    )
    p.add_argument("--yaw-start", type=float, default=0.0, help="turntable: first yaw, deg")
    p.add_argument("--yaw-span", type=float, default=360.0, help="turntable: yaw covered by the run, deg")
    p.add_argument("--spurious-rate", type=float, default=0.05, help="ghost-spot probability per image")
    p.add_argument("--read-noise", type=float, default=1.0, help="read noise, DN (default 1)")
    p.add_argument("--blur", type=float, default=0.8, help="extra Gaussian blur sigma, px (default 0.8)")
    p.add_argument("--no-noise", action="store_true", help="no shot/read noise (quantisation stays)")
    p.add_argument(
        "--survey-error",
        action="store_true",
        help="render each beacon displaced from the map by its survey sigma_mm (a seeded N(0, sigma^2) "
        "per axis); beacons.csv keeps the nominal map, beacons_rendered.csv the rendered positions",
    )
    p.add_argument(
        "--survey-seed",
        type=int,
        metavar="S",
        help="with --survey-error: seed of the displacements (default --seed), for several survey "
        "realisations of one scenario",
    )
    p.add_argument(
        "--collision",
        metavar="T,VX,VY,VZ[,WR,WP,WY]",
        help="a collision at T s: a velocity step of (VX, VY, VZ) mm/s in the world frame and "
        "optionally (WR, WP, WY) deg/s on the Euler angles of C_w_b from T on (the fault "
        "campaign's robot beyond its acceleration bound); scenario.json records it",
    )
    p.add_argument("--force", action="store_true", help="replace an existing nav-frames folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
