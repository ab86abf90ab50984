"""The MFNS imaging model in numpy (double precision), mirroring math/lens.h: the one
numpy lens model (vectorised: simulation, calibration and the host reference solver use
it; tests/host/test_camera_model.py holds it to the C model through the binding).

Pinhole with skew and the 5-coefficient Bouguet/OpenCV distortion [k1, k2, p1, p2, k3];
three cameras on the body (C_k_b maps camera coordinates into the body, r_bk_b in mm);
body pose (C_w_b, r_bw_b). Pixel convention: integer coordinates are pixel centres
(docs/conventions.md), the same as OpenCV's, so cv2.projectPoints agrees with `project`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..analysis.calib_results import CAMERA_NAMES, camera_entry
from ..core import validate as V
from ..core.csv_formats import BEACON_COLUMNS, POSITION_COLUMNS
from ..core.errors import MfnsError


@dataclass
class Camera:
    name: str
    fx: float
    fy: float
    cx: float
    cy: float
    skew: float = 0.0
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    width: int = 1280
    height: int = 1024
    C_k_b: np.ndarray = field(default_factory=lambda: np.eye(3))
    r_bk_b: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, self.skew, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @classmethod
    def from_entry(cls, e: dict) -> Camera:
        return cls(
            name=e["name"],
            fx=float(e["fx"]),
            fy=float(e["fy"]),
            cx=float(e["cx"]),
            cy=float(e["cy"]),
            skew=float(e.get("skew", 0.0)),
            dist=np.asarray(e["dist"], dtype=float),
            width=int(e["image_size"][0]),
            height=int(e["image_size"][1]),
            C_k_b=np.asarray(e["C_k_b"], dtype=float),
            r_bk_b=np.asarray(e["r_bk_b"], dtype=float),
        )

    def to_entry(self, sigma: dict | None = None) -> dict:
        return camera_entry(
            self.name,
            (self.width, self.height),
            self.fx,
            self.fy,
            self.cx,
            self.cy,
            self.skew,
            self.dist,
            self.C_k_b,
            self.r_bk_b,
            sigma,
        )

    # --- normalized <-> pixel -------------------------------------------------
    def distort(self, xy: np.ndarray) -> np.ndarray:
        """Undistorted normalized (..., 2) -> distorted normalized (..., 2)."""
        return distort(self.dist, xy)

    def distorted_to_pixel(self, xyd: np.ndarray) -> np.ndarray:
        u = self.fx * xyd[..., 0] + self.skew * xyd[..., 1] + self.cx
        v = self.fy * xyd[..., 1] + self.cy
        return np.stack([u, v], axis=-1)

    def pixel_to_distorted(self, uv: np.ndarray) -> np.ndarray:
        yd = (uv[..., 1] - self.cy) / self.fy
        xd = (uv[..., 0] - self.cx - self.skew * yd) / self.fx
        return np.stack([xd, yd], axis=-1)

    def undistort_pixels(self, uv: np.ndarray, iterations: int = 50) -> np.ndarray:
        """Pixel (N, 2) -> undistorted normalized (N, 2), by Newton iteration in double.

        Converges to ~1e-15 for the lens distortions of docs/system.md §7, Table 2 over the image.
        """
        target = self.pixel_to_distorted(np.asarray(uv, dtype=float))
        xy = target.copy()
        h = 1e-7
        for _ in range(iterations):
            f = self.distort(xy) - target
            jx = (self.distort(xy + [h, 0.0]) - self.distort(xy - [h, 0.0])) / (2 * h)
            jy = (self.distort(xy + [0.0, h]) - self.distort(xy - [0.0, h])) / (2 * h)
            det = jx[..., 0] * jy[..., 1] - jy[..., 0] * jx[..., 1]
            dx = (jy[..., 1] * f[..., 0] - jy[..., 0] * f[..., 1]) / det
            dy = (-jx[..., 1] * f[..., 0] + jx[..., 0] * f[..., 1]) / det
            xy = xy - np.stack([dx, dy], axis=-1)
            if np.max(np.abs(f)) < 1e-15:
                break
        return xy

    # --- 3-D -> pixel ------------------------------------------------------------
    def normalized_to_pixel(self, xy: np.ndarray) -> np.ndarray:
        """Undistorted normalized (..., 2) -> pixels (..., 2): distortion, then K."""
        return self.distorted_to_pixel(self.distort(xy))

    def project_camera_points(self, p_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points in the camera frame (..., 3) mm -> (pixels (..., 2), in_front mask (...)).

        Behind (depth below 1 mm, lens.h MFNS_CAM_MIN_DEPTH_MM): a placeholder pixel and
        False; (N, 3) or (3,) give (N, 2)."""
        p_c = np.asarray(p_c, dtype=float)
        if p_c.ndim < 2:
            p_c = np.atleast_2d(p_c)
        z = p_c[..., 2]
        front = z >= 1.0
        zs = np.where(front, z, 1.0)
        xy = p_c[..., :2] / zs[..., None]
        return self.normalized_to_pixel(xy), front

    def project_jacobian(self, p_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Camera-frame points (N, 3), in front -> (uv (N, 2), d(uv)/d(p_c) (N, 2, 3)),
        distortion included (lens.h mfns_cam_project_c with its Jacobian)."""
        z = p_c[:, 2]
        x = p_c[:, 0] / z
        y = p_c[:, 1] / z
        xyd, dd = distort_jacobian(self.dist, np.stack([x, y], axis=-1))
        uv = self.distorted_to_pixel(xyd)
        n = len(z)
        dn = np.zeros((n, 2, 3))  # d(x, y)/d(p_c)
        dn[:, 0, 0] = 1.0 / z
        dn[:, 0, 2] = -x / z
        dn[:, 1, 1] = 1.0 / z
        dn[:, 1, 2] = -y / z
        kk = np.array([[self.fx, self.skew], [0.0, self.fy]])
        return uv, np.einsum("ij,njk,nkl->nil", kk, dd, dn)

    def world_to_camera(self, C_w_b: np.ndarray, r_bw_b: np.ndarray, p_w: np.ndarray) -> np.ndarray:
        p_b = np.atleast_2d(p_w) @ np.asarray(C_w_b).T + np.asarray(r_bw_b)
        return (p_b - self.r_bk_b) @ self.C_k_b  # C_k_b^T (p_b - r_bk_b), row-wise

    def project(self, C_w_b, r_bw_b, p_w) -> tuple[np.ndarray, np.ndarray]:
        """World points (N, 3) through the body pose -> (pixels, visible mask).

        visible = in front of the camera and inside [-0.5, W-0.5) x [-0.5, H-0.5).
        """
        uv, front = self.project_camera_points(self.world_to_camera(C_w_b, r_bw_b, p_w))
        return uv, front & self.in_image(uv)

    def in_image(self, uv: np.ndarray) -> np.ndarray:
        """On the sensor: [-0.5, W-0.5) x [-0.5, H-0.5) (lens.h mfns_cam_in_image)."""
        return (
            (uv[..., 0] >= -0.5)
            & (uv[..., 1] >= -0.5)
            & (uv[..., 0] < self.width - 0.5)
            & (uv[..., 1] < self.height - 0.5)
        )


def _distort(dist, xy: np.ndarray, jacobian: bool):
    k1, k2, p1, p2, k3 = dist
    x, y = xy[..., 0], xy[..., 1]
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    xyd = np.stack([xd, yd], axis=-1)
    if not jacobian:
        return xyd, None
    dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d radial / d r2
    dxd_dx = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x
    dxd_dy = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y
    dyd_dy = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x
    jac = np.stack([np.stack([dxd_dx, dxd_dy], -1), np.stack([dxd_dy, dyd_dy], -1)], -2)
    return xyd, jac


def distort(dist, xy: np.ndarray) -> np.ndarray:
    """The lens: undistorted normalized (..., 2) -> distorted normalized (..., 2) with the
    5 coefficients dist = [k1, k2, p1, p2, k3] (lens.h mfns_cam_distort, in double)."""
    return _distort(dist, xy, False)[0]


def distort_jacobian(dist, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """distort and its Jacobian d(xd, yd)/d(x, y) (..., 2, 2)."""
    return _distort(dist, xy, True)


def rig_from_doc(doc: dict) -> list[Camera]:
    """The three cameras of a calibration-results document, in the order x, y, z."""
    cams = [Camera.from_entry(e) for e in doc["cameras"]]
    assert tuple(c.name for c in cams) == CAMERA_NAMES
    return cams


def pose_from_position(C_w_b: np.ndarray, r_wb_w) -> np.ndarray:
    """r_bw_b for a body at r_wb_w (world) with attitude C_w_b."""
    return -np.asarray(C_w_b) @ np.asarray(r_wb_w, dtype=float)


def position_from_pose(C_w_b: np.ndarray, r_bw_b) -> np.ndarray:
    """Navigation output r_wb_w = -C_w_b^T r_bw_b."""
    return -np.asarray(C_w_b).T @ np.asarray(r_bw_b, dtype=float)


# Optional: each LED's emission axis (world frame, unit) and half-angle; all four or none.
EMISSION_COLUMNS = ("axis_x", "axis_y", "axis_z", "half_angle_deg")


def load_beacon_emission(path) -> tuple[np.ndarray, np.ndarray] | None:
    """The optional emission columns of a beacon CSV -> (unit axes (N, 3), half-angles deg),
    or None when the CSV has none of them. Axes are normalised; a zero axis means an LED
    that emits everywhere and must say so with half_angle_deg 180 (a zero axis with a
    narrower cone names no direction). Raises MfnsError (one line) on a partial set or bad
    values. `load_beacons`, the reader every command uses, runs these checks too, so a file
    one command refuses no other accepts."""
    rows = V.read_csv(path, "beacon CSV", BEACON_COLUMNS, max_bytes=4 * V.MIB)
    present = [c for c in EMISSION_COLUMNS if rows and c in rows[0]]
    if not present:
        return None
    if len(present) != len(EMISSION_COLUMNS):
        raise MfnsError(
            f"beacon CSV {path}: emission columns must come together ({', '.join(EMISSION_COLUMNS)})"
        )
    axes, half = [], []
    for n, r in enumerate(rows, start=2):
        where = f"beacon CSV {path} line {n}"
        a = np.array([V.csv_float(r[c], f"{where} {c}") for c in EMISSION_COLUMNS[:3]])
        h = V.csv_float(r["half_angle_deg"], f"{where} half_angle_deg")
        if not 0 < h <= 180:
            raise MfnsError(f"{where} half_angle_deg: expected (0, 180], got {h:g}")
        norm = float(np.linalg.norm(a))
        if norm == 0 and h != 180:
            raise MfnsError(
                f"{where}: a zero emission axis with half_angle_deg {h:g} names no direction "
                "(give the LED's axis, or half_angle_deg 180 for one that emits everywhere)"
            )
        if norm != 0 and not 0.5 <= norm <= 2.0:
            raise MfnsError(
                f"{where}: emission axis of length {norm:.3g} is not a direction (give a unit vector)"
            )
        axes.append(a / norm if norm > 0 else a)
        half.append(h)
    return np.array(axes), np.array(half)


def load_beacons(path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Beacon CSV (id,x_mm,y_mm,z_mm,sigma_mm) -> (ids, positions (N, 3), sigmas).

    Ids are integers 0..65535, unique; positions finite; sigmas finite and positive;
    at least one beacon. Raises MfnsError (one line) otherwise."""
    rows = V.read_csv(path, "beacon CSV", BEACON_COLUMNS, max_bytes=4 * V.MIB)
    if not rows:
        raise MfnsError(f"beacon CSV {path}: no beacons (expected a header and one row per beacon)")
    ids, pos, sig = [], [], []
    for n, r in enumerate(rows, start=2):
        where = f"beacon CSV {path} line {n}"
        ids.append(V.csv_int(r["id"], f"{where} id", 0, 65535))
        pos.append([V.csv_float(r[c], f"{where} {c}") for c in POSITION_COLUMNS])
        s = V.csv_float(r["sigma_mm"], f"{where} sigma_mm")
        if not s > 0:
            raise MfnsError(f"{where} sigma_mm: beacon sigma_mm must be positive, got {s:g}")
        sig.append(s)
    if len(set(ids)) != len(ids):
        raise MfnsError(f"beacon CSV {path}: duplicate beacon ids")
    load_beacon_emission(path)  # the optional columns: checked wherever the map is read
    return np.array(ids, dtype=int), np.array(pos, dtype=float).reshape(-1, 3), np.array(sig, dtype=float)
