"""Re-rendering a camera's frames of an `mfns sim nav` folder, for the injectors that change
what a camera sees rather than which file it delivers (a knocked mount, a frozen scene with
fresh sensor noise, reflections beside the beacons).

Everything comes from the folder itself: the rig (calib.json), the beacons as rendered
(beacons_rendered.csv when the simulation had survey error, else beacons.csv), the true body
pose of each frame (truth.csv), the exposure and gain the simulator's auto-exposure chose
(frames.csv) and the photometric model (scenario.json "render"). Spots are projected and
rendered with the simulator's own functions (mfns.simulate.nav: project_beacons, spot_sigma,
relative_peak, Renderer), so a spot re-rendered with an unchanged camera lands where the
simulator put it (to 1e-4 px: truth.csv's six decimals; tests/host/test_fault_campaign.py).

Misses: the simulator's spurious reflections of the original frame are not re-rendered (a
re-rendered image holds only beacon spots); the sensor noise is a new draw (seeded), not the
original frame's.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mfns.analysis import calib_results
from mfns.model.camera import Camera, pose_from_position, rig_from_doc
from mfns.model.rotations import euler213_deg_to_matrix
from mfns.simulate import nav as sim

CAMERAS = "xyz"


def rot_about(axis: np.ndarray, deg: float) -> np.ndarray:
    """The rotation matrix of deg degrees about a unit axis (right-handed)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    th = np.radians(deg)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + np.sin(th) * k + (1.0 - np.cos(th)) * (k @ k)


def knocked(cam: Camera, axis_c: np.ndarray, deg: float) -> Camera:
    """The camera with its mount turned deg about axis_c (camera axes: x right, y down, z along
    the optical axis): p_b = C_k_b R p_c, so C_k_b becomes C_k_b R. Its position is kept."""
    return Camera(**{**cam.__dict__, "C_k_b": cam.C_k_b @ rot_about(axis_c, deg)})


@dataclass
class Scene:
    """What a folder's frames were rendered from."""

    folder: Path
    cams: list[Camera]
    ids: np.ndarray
    beacons_w: np.ndarray
    normals_w: np.ndarray
    truth: dict[int, tuple[np.ndarray, np.ndarray]]  # frame -> (C_w_b, r_wb_w mm)
    exposure: dict[tuple[str, int], tuple[float, float]]  # (camera, frame) -> (us, dB)
    params: sim.RenderParams

    @classmethod
    def load(cls, folder: Path) -> Scene:
        folder = Path(folder)
        cams = rig_from_doc(calib_results.load(folder / "calib.json"))
        scen = json.loads((folder / "scenario.json").read_text())
        rendered = folder / "beacons_rendered.csv"
        ids, pos = [], []
        with open(rendered if rendered.exists() else folder / "beacons.csv", newline="") as f:
            for r in csv.DictReader(f):
                ids.append(int(r["id"]))
                pos.append([float(r[a]) for a in ("x_mm", "y_mm", "z_mm")])
        pos_a = np.array(pos)
        if scen.get("scenario") == "turntable":  # LEDs aimed at the turntable centre (the simulator's)
            normals = -pos_a / np.linalg.norm(pos_a, axis=1, keepdims=True)
        else:  # module LEDs along their wall's inward normal
            normals = sim.wall_normals(pos_a)
        truth = {}
        with open(folder / "truth.csv", newline="") as f:
            for r in csv.DictReader(f):
                c = euler213_deg_to_matrix([float(r[a]) for a in ("roll_deg", "pitch_deg", "yaw_deg")])
                truth[int(r["frame"])] = (c, np.array([float(r[a]) for a in ("x_mm", "y_mm", "z_mm")]))
        exposure = {}
        with open(folder / "frames.csv", newline="") as f:
            for r in csv.DictReader(f):
                exposure[(r["camera"], int(r["frame"]))] = (float(r["exposure_us"]), float(r["gain_db"]))
        known = set(sim.RenderParams.__dataclass_fields__)
        params = sim.RenderParams(**{k: v for k, v in scen.get("render", {}).items() if k in known})
        return cls(folder, cams, np.array(ids), pos_a, normals, truth, exposure, params)

    def spots(self, cam_letter: str, frame: int, cam: Camera | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(spots (S, 4): u, v, peak_dn, sigma_px; beacon ids (S,)) of the beacons camera
        cam_letter sees in frame (cam: the camera model to project with, default the rig's),
        at the exposure and gain frames.csv records for that image."""
        k = CAMERAS.index(cam_letter)
        cam = cam or self.cams[k]
        c_w_b, r_wb_w = self.truth[frame]
        r_bw_b = pose_from_position(c_w_b, r_wb_w)
        uv, vis, p_c = sim.project_beacons(cam, c_w_b, r_bw_b, self.beacons_w)
        rng_mm = np.linalg.norm(p_c[vis], axis=1)
        cam_w = -c_w_b.T @ r_bw_b + c_w_b.T @ cam.r_bk_b
        to_cam = cam_w - self.beacons_w[vis]
        cos_led = np.einsum("ij,ij->i", to_cam, self.normals_w[vis]) / np.linalg.norm(to_cam, axis=1)
        sig = sim.spot_sigma(self.params, rng_mm)
        exp_us, gain_db = self.exposure[(cam_letter, frame)]
        scale = exp_us / self.params.exposure_ref_us * 10 ** (gain_db / 20)
        peak = sim.relative_peak(self.params, rng_mm, cos_led, sig) * scale
        return np.column_stack([uv[vis], peak, sig]), self.ids[vis]

    def renderer(self) -> sim.Renderer:
        cam = self.cams[0]
        return sim.Renderer(cam.width, cam.height, self.params)


def render_pgm(renderer: sim.Renderer, spots: np.ndarray, rng: np.random.Generator) -> bytes:
    """One 8-bit PGM of the given spots with fresh sensor noise (the simulator's renderer)."""
    img = renderer.render(spots, rng)
    h, w = img.shape
    return f"P5\n{w} {h}\n255\n".encode() + np.ascontiguousarray(img, dtype=np.uint8).tobytes()


def read_spots(folder: Path) -> list[dict]:
    with open(folder / "spots.csv", newline="") as f:
        return list(csv.DictReader(f))


def write_spots(folder: Path, rows: list[dict]) -> None:
    """spots.csv rewritten (a new file: the linked folder's is a copy, never shared)."""
    rows = sorted(rows, key=lambda r: (int(r["frame"]), CAMERAS.index(r["camera"])))
    with open(folder / "spots.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=sim.SPOTS_HEADER, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)


def spot_row(frame: int, cam: str, beacon_id: int, s: np.ndarray) -> dict:
    return {
        "frame": frame,
        "camera": cam,
        "beacon_id": int(beacon_id),
        "u": f"{s[0]:.6f}",
        "v": f"{s[1]:.6f}",
        "peak_dn": f"{s[2]:.2f}",
        "sigma_px": f"{s[3]:.4f}",
    }
