"""The calibration experiment's geometry: board, turntable kinematic chain, observations.

Shared by the simulator (`mfns sim calib`) and the calibration (`mfns calib`) so both use
one model. Conventions (docs/system.md §2, §5; docs/conventions.md):

- world w: the board's first inner corner, Xw/Yw along the grid, Zw the board normal pointing
  away from the cameras (a camera in front of the board sits at negative Zw);
- turntable: `C_b'_t = Rx(omega) Rz(Omega)` (main axis Zt inner, auxiliary axis Xt outer),
  `C_b_t = I` at zero angles, so for an image taken at (Omega, omega):
  `C_k_w = C_t_w Rx(omega) Rz(Omega) C_k_b` and
  `r_wk_w = r_wt_w + C_t_w Rx(omega) Rz(Omega) (r_tb_b + r_bk_b)`;
- the body origin lies on the main axis Zt (the mount is centred by its locating holes):
  `r_tb_b = (0, 0, h)`; h is coupled with the cameras' heights and fixed by the caliper
  measurement of the board-to-body height `-r_wb_w[2]` (Appendix A.2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..analysis.calib_results import CAMERA_NAMES
from ..model.camera import Camera
from ..model.rotations import rx, rz

ARCSEC = np.pi / (180.0 * 3600.0)
PURE_AXIS_SIGMAS = 5.0  # a recorded angle within 5 sigma of 0 was commanded to 0


CHARUCO_DICTIONARIES = ("DICT_4X4_250", "DICT_5X5_250", "DICT_6X6_250", "DICT_APRILTAG_36h11")


@dataclass(frozen=True)
class Board:
    """Checkerboard: `cols` x `rows` inner corners, `square` mm; squares span one square beyond.

    kind "charuco": the same grid with ArUco markers (`dictionary`, side `marker` mm) in the
    white squares, OpenCV's CharucoBoard((cols + 1, rows + 1)) (top-left square black, corner
    id = row * cols + col), so views need not show the whole board.
    """

    cols: int = 9
    rows: int = 6
    square: float = 25.0
    margin: float = 20.0  # white border around the outer squares, mm
    kind: str = "chessboard"
    dictionary: str = ""
    marker: float = 0.0

    @property
    def symmetric(self) -> bool:
        """A plain chessboard whose half turn maps the colours onto themselves (even square sum)."""
        return self.kind == "chessboard" and (self.cols + self.rows) % 2 == 0

    def charuco(self):
        import cv2

        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.cols + 1, self.rows + 1), self.square, self.marker, d)

    @property
    def n(self) -> int:
        return self.cols * self.rows

    def object_points(self) -> np.ndarray:
        """(N, 3) corner k = r * cols + c at (c * square, r * square, 0)."""
        c, r = np.meshgrid(np.arange(self.cols), np.arange(self.rows))
        return np.column_stack([c.ravel() * self.square, r.ravel() * self.square, np.zeros(self.n)]).astype(
            float
        )

    def outline(self) -> np.ndarray:
        """Corners of the printed board (incl. margin), (4, 3) mm."""
        lo = -self.square - self.margin
        hx = self.cols * self.square + self.margin
        hy = self.rows * self.square + self.margin
        return np.array([[lo, lo, 0], [hx, lo, 0], [hx, hy, 0], [lo, hy, 0]], dtype=float)

    def to_dict(self) -> dict:
        d = {
            "type": self.kind,
            "inner_corners": [self.cols, self.rows],
            "square_mm": self.square,
            "margin_mm": self.margin,
            "corner_order": "row-major: k = row * cols + col at (col * square, row * square, 0) mm",
            "first_square": "the square between corners (0,0),(1,0),(0,1),(1,1) is black",
        }
        if self.kind == "charuco":
            d["dictionary"] = self.dictionary
            d["marker_mm"] = self.marker
        return d


def turntable_matrix(omega_big: float, omega_small: float) -> np.ndarray:
    """C_b'_b = Rx(omega) Rz(Omega), radians."""
    return rx(omega_small) @ rz(omega_big)


@dataclass
class Rig:
    """The MFNS cameras on the turntable: everything the calibration estimates."""

    cams: list[Camera]
    C_t_w: np.ndarray = field(default_factory=lambda: np.eye(3))
    r_wt_w: np.ndarray = field(default_factory=lambda: np.zeros(3))
    r_tb_b: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def r_wb_w(self) -> np.ndarray:
        """Body origin at zero turntable angles."""
        return np.asarray(self.r_wt_w) + np.asarray(self.C_t_w) @ np.asarray(self.r_tb_b)

    def camera_pose(self, k: int, omega_big: float, omega_small: float) -> tuple[np.ndarray, np.ndarray]:
        """(C_k_w, r_wk_w) of camera k at turntable angles (radians)."""
        cam = self.cams[k]
        a = self.C_t_w @ turntable_matrix(omega_big, omega_small)
        return a @ cam.C_k_b, self.r_wt_w + a @ (self.r_tb_b + cam.r_bk_b)


def world_to_pixels(cam: Camera, C_k_w: np.ndarray, r_wk_w: np.ndarray, p_w: np.ndarray):
    """World points (N, 3) seen by `cam` at pose (C_k_w, r_wk_w) -> (pixels, visible)."""
    p_c = (np.atleast_2d(p_w) - r_wk_w) @ C_k_w  # C_k_w^T (p - r), row-wise
    uv, front = cam.project_camera_points(p_c)
    return uv, front & cam.in_image(uv)


def pure_axis(omega_big_deg: float, omega_small_deg: float, angle_sigma_rad: float) -> str:
    """Which single axis turned: "Omega" (omega commanded 0), "omega" (Omega commanded 0) or "".

    A real turntable logs its encoders, so an image taken at a commanded zero carries the
    angle noise (e.g. 0.0021 deg at 8"). |angle| <= PURE_AXIS_SIGMAS sigma counts as zero; at
    (0, 0) the image is pure-Omega (the paper's Eq. A10 rows for Omega images apply).
    """
    tol = np.rad2deg(PURE_AXIS_SIGMAS * angle_sigma_rad) + 1e-12
    if abs(omega_small_deg) <= tol:
        return "Omega"
    if abs(omega_big_deg) <= tol:
        return "omega"
    return ""


@dataclass
class ImageObs:
    """One image's corner observations, row-major over the board's corners.

    Rows of `uv` are NaN for corners not seen (ChArUco partial views); a chessboard image
    holds every corner.
    """

    camera: int
    kind: str  # "turntable" or "prepared"
    name: str
    uv: np.ndarray  # (N, 2) px
    omega_big_deg: float = float("nan")  # recorded turntable angles (turntable images)
    omega_small_deg: float = float("nan")
    pure: str = ""  # "Omega" / "omega": only that axis was commanded (pure_axis or the csv kind)

    @property
    def seen(self) -> np.ndarray:
        """(N,) bool: corners observed in this image."""
        return np.all(np.isfinite(self.uv), axis=1)


@dataclass
class Observations:
    board: Board
    images: list[ImageObs]
    caliper_height_mm: float  # measured -r_wb_w[2]
    caliper_sigma_mm: float
    angle_sigma_rad: float
    image_size: tuple[int, int] = (1280, 1024)
    camera_names: tuple[str, ...] = CAMERA_NAMES

    @property
    def n_cams(self) -> int:
        return len(self.camera_names)

    def of_camera(self, k: int, kind: str | None = None) -> list[ImageObs]:
        return [im for im in self.images if im.camera == k and (kind is None or im.kind == kind)]
