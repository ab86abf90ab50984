"""Output files of `mfns calib`: results JSON, OpenCV YAML, Kalibr camchain, ROS camera_info,
body->camera transforms (YAML and a URDF of the mounts).

Frames (docs/conventions.md): `C_k_b` maps camera-k coordinates into the body frame and
`r_bk_b` is camera k's origin in the body frame, so p_b = C_k_b p_k + r_bk_b. The 4x4
`T_b_k = [[C_k_b, r_bk_b], [0, 1]]` therefore takes a point from camera k's frame to the body
frame (ROS tf: parent "body", child "camera k"); its inverse T_k_b takes body points into the
camera. Kalibr's `T_cn_cnm1` takes points from camera n-1's frame into camera n's (metres).

YAML is written by hand (flow lists, plain scalars) so the runtime needs no YAML library;
the tests read every file back with PyYAML / cv2.FileStorage.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..analysis.calib_results import CAMERA_NAMES, save
from ..model.camera import Camera
from .pipeline import Calibration
from .report import paper_document, results_document

FRAME_NOTE = (
    "C_k_b maps camera-k coordinates into the body frame: p_b = C_k_b p_k + r_bk_b "
    "(r_bk_b = camera origin in the body frame, mm); T_b_k = [[C_k_b, r_bk_b], [0, 1]] "
    "takes points from the camera frame to the body frame, T_k_b = inverse(T_b_k) the other way"
)


def _num(v: float) -> str:
    return repr(float(v))


def _flow(values) -> str:
    return "[" + ", ".join(_num(v) for v in np.asarray(values, float).ravel()) + "]"


def _rows(m: np.ndarray, indent: str) -> list[str]:
    return [f"{indent}- {_flow(r)}" for r in np.asarray(m, float)]


def t_b_k(cam: Camera, scale: float = 1.0) -> np.ndarray:
    """4x4 camera -> body transform (translation in mm * scale)."""
    t = np.eye(4)
    t[:3, :3] = cam.C_k_b
    t[:3, 3] = np.asarray(cam.r_bk_b, float) * scale
    return t


def _inverse(t: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def quaternion_xyzw(c: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w), w >= 0, of the rotation matrix c (ROS order)."""
    m = np.asarray(c, float)
    w = np.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    x = np.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2.0
    y = np.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2.0
    z = np.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2.0
    x = np.copysign(x, m[2, 1] - m[1, 2])
    y = np.copysign(y, m[0, 2] - m[2, 0])
    z = np.copysign(z, m[1, 0] - m[0, 1])
    q = np.array([x, y, z, w])
    return q / np.linalg.norm(q)


# --- Kalibr radtan: 4 coefficients ---------------------------------------------------------------
def fit_radtan4(cam: Camera, grid: int = 41) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Fit (fx, fy, cx, cy, k1, k2, p1, p2) with k3 = 0 to the 5-coefficient model.

    Over a grid of rays covering the sensor the 4-coefficient projection is fitted in pixels
    (linear in fx, fy, cx, cy after Gauss-Newton on k1, k2, p1, p2). Returns (intrinsics4,
    dist4, max px error of the fit, max px error of simply dropping k3) over the grid.
    """
    from scipy.optimize import least_squares

    u, v = np.meshgrid(np.linspace(0, cam.width - 1, grid), np.linspace(0, cam.height - 1, grid))
    uv = np.column_stack([u.ravel(), v.ravel()])
    xy = cam.undistort_pixels(uv)
    p_c = np.column_stack([xy, np.ones(len(xy))])

    def proj(params):
        fx, fy, cx, cy, k1, k2, p1, p2 = params
        c = Camera(cam.name, fx, fy, cx, cy, 0.0, np.array([k1, k2, p1, p2, 0.0]), cam.width, cam.height)
        return c.project_camera_points(p_c)[0]

    x0 = np.array([cam.fx, cam.fy, cam.cx, cam.cy, *cam.dist[:4]])
    drop = float(np.max(np.linalg.norm(proj(x0) - uv, axis=1)))
    if cam.dist[4] == 0.0:
        return x0[:4], x0[4:], 0.0, 0.0
    res = least_squares(lambda p: (proj(p) - uv).ravel(), x0, method="lm", xtol=1e-14, ftol=1e-14)
    fit = float(np.max(np.linalg.norm(proj(res.x) - uv, axis=1)))
    return res.x[:4], res.x[4:], fit, drop


def kalibr_camchain(cams: list[Camera]) -> tuple[str, list[str]]:
    """camchain.yaml text (Kalibr pinhole-radtan) and one note per camera on the k3 fit."""
    lines = [
        "# Kalibr camera chain written by mfns calib (pinhole, radtan = k1 k2 p1 p2).",
        "# T_cn_cnm1 takes points from camera n-1's frame into camera n's frame (metres).",
        "# k3 of the 5-coefficient model is not in radtan: the 4 coefficients and the",
        "# intrinsics are refitted over the sensor; the residual of that fit is given per camera.",
    ]
    notes = []
    for n, cam in enumerate(cams):
        intr, dist, fit, drop = fit_radtan4(cam)
        note = (
            f"camera {cam.name}: Kalibr radtan has no k3 ({cam.dist[4]:+.5g}); dropping it moves "
            f"projections up to {drop:.3f} px, the refitted 4-coefficient model up to {fit:.4f} px"
        )
        notes.append(note)
        lines += [
            f"cam{n}:",
            f"  # {note}",
            "  camera_model: pinhole",
            f"  intrinsics: {_flow(intr)}",
            "  distortion_model: radtan",
            f"  distortion_coeffs: {_flow(dist)}",
            f"  resolution: [{int(cam.width)}, {int(cam.height)}]",
            f"  rostopic: /mfns/{cam.name}/image_raw",
            "  cam_overlaps: []",
        ]
        if n > 0:
            t = _inverse(t_b_k(cam, 1e-3)) @ t_b_k(cams[n - 1], 1e-3)
            lines.append("  T_cn_cnm1:")
            lines += _rows(t, "  ")
    return "\n".join(lines) + "\n", notes


def ros_camera_info(cam: Camera) -> str:
    """camera_info YAML (camera_calibration_parsers' format), plumb_bob = [k1 k2 p1 p2 k3]."""
    k = cam.K
    p = np.hstack([k, np.zeros((3, 1))])
    out = [
        f"# ROS camera_info of camera {cam.name}, written by mfns calib (no rectification).",
        f"image_width: {int(cam.width)}",
        f"image_height: {int(cam.height)}",
        f"camera_name: {cam.name}",
        "camera_matrix:",
        "  rows: 3",
        "  cols: 3",
        f"  data: {_flow(k)}",
        "distortion_model: plumb_bob",
        "distortion_coefficients:",
        "  rows: 1",
        "  cols: 5",
        f"  data: {_flow(cam.dist)}",
        "rectification_matrix:",
        "  rows: 3",
        "  cols: 3",
        f"  data: {_flow(np.eye(3))}",
        "projection_matrix:",
        "  rows: 3",
        "  cols: 4",
        f"  data: {_flow(p)}",
    ]
    return "\n".join(out) + "\n"


def body_transforms(cams: list[Camera]) -> str:
    out = [
        "# Camera mounts from mfns calib.",
        "# T_b_k takes a point from camera k's frame into the body frame: p_b = R p_k + t,",
        "# R = C_k_b, t = r_bk_b (the camera origin in the body frame). As a ROS tf: parent_frame",
        "# body, child_frame the camera, translation_m = t, rotation_xyzw = quaternion of R.",
        "# T_k_b = inverse(T_b_k) takes body points into the camera frame.",
        "direction: camera_to_body",
        "cameras:",
    ]
    for cam in cams:
        t = t_b_k(cam)
        out += [
            f"  - name: {cam.name}",
            "    parent_frame: body",
            f"    child_frame: {cam.name}",
            f"    translation_mm: {_flow(cam.r_bk_b)}",
            f"    translation_m: {_flow(np.asarray(cam.r_bk_b) * 1e-3)}",
            f"    rotation_xyzw: {_flow(quaternion_xyzw(cam.C_k_b))}",
            "    T_b_k_mm:",
            *_rows(t, "      "),
            "    T_k_b_mm:",
            *_rows(_inverse(t), "      "),
        ]
    return "\n".join(out) + "\n"


# Below this |cos(pitch)| the URDF roll and yaw are not separable (pitch = +-90 deg): roll is
# set to 0 and yaw carries the whole rotation about the vertical (exact, not an approximation).
_GIMBAL_COS = 1e-9


def urdf_rpy(c: np.ndarray) -> tuple[float, float, float]:
    """URDF's (roll, pitch, yaw) in radians of the rotation matrix c.

    URDF's convention (the <origin rpy> of a joint): fixed axes X, then Y, then Z, i.e.
    c = Rz(yaw) @ Ry(pitch) @ Rx(roll), with pitch in [-pi/2, pi/2]."""
    c = np.asarray(c, float)
    pitch = float(np.arcsin(np.clip(-c[2, 0], -1.0, 1.0)))
    if np.hypot(c[0, 0], c[1, 0]) > _GIMBAL_COS:
        roll = float(np.arctan2(c[2, 1], c[2, 2]))
        yaw = float(np.arctan2(c[1, 0], c[0, 0]))
    else:
        roll = 0.0
        yaw = float(np.arctan2(-c[0, 1], c[1, 1]))
    return roll, pitch, yaw


def urdf_mounts(cams: list[Camera], robot: str = "mfns") -> str:
    """A URDF of the body-to-camera mounts, frames named as REP 103 expects (mfns.tlm.rosmsg).

    Link `mfns_body`; per camera a link `mfns_cam_<k>_link` (REP 103 body axes: x forward
    along the optic axis, y left, z up) on a fixed joint `mfns_body_to_cam_<k>` whose <origin>
    is that link in the body frame (xyz = r_bk_b in metres, rpy from C_link_b = C_k_b R_lo^T,
    `urdf_rpy`), and the camera frame of docs/conventions.md (+Z optic axis, +X along u, +Y
    along v) as `mfns_cam_<k>_optical_frame` on a fixed joint with rpy = (-pi/2, 0, -pi/2),
    the rotation every ROS camera driver uses between a camera link and its optical frame.
    Through both joints a point p_k of the camera frame is p_b = C_k_b p_k + r_bk_b, the
    same transform as T_b_k of <stem>_body_to_camera.yaml, and the same frames as the TF of
    `mfns export` (docs/robotics.md)."""
    from ..tlm.rosmsg import BODY_FRAME, OPTICAL_RPY, camera_link, camera_link_rotation, camera_optical_frame

    out = [
        '<?xml version="1.0"?>',
        "<!-- Camera mounts from mfns calib (REP 103 names). mfns_body -> mfns_cam_<k>_link:",
        "     xyz = r_bk_b (m), R(rpy) = Rz(yaw) Ry(pitch) Rx(roll) = C_k_b R_lo^T (rad);",
        "     mfns_cam_<k>_link -> mfns_cam_<k>_optical_frame: rpy = (-pi/2, 0, -pi/2) = R_lo.",
        "     The optical frame is the mfns camera frame: p_body = C_k_b p_optical + r_bk_b,",
        "     as T_b_k of <stem>_body_to_camera.yaml. -->",
        f'<robot name="{robot}">',
        f'  <link name="{BODY_FRAME}"/>',
    ]
    for cam in cams:
        roll, pitch, yaw = urdf_rpy(camera_link_rotation(cam.C_k_b))
        xyz = np.asarray(cam.r_bk_b, float) * 1e-3
        link, optical = camera_link(cam.name), camera_optical_frame(cam.name)
        out += [
            f'  <link name="{link}"/>',
            f'  <joint name="{BODY_FRAME}_to_cam_{cam.name}" type="fixed">',
            f'    <parent link="{BODY_FRAME}"/>',
            f'    <child link="{link}"/>',
            f'    <origin xyz="{" ".join(_num(v) for v in xyz)}" '
            f'rpy="{" ".join(_num(v) for v in (roll, pitch, yaw))}"/>',
            "  </joint>",
            f'  <link name="{optical}"/>',
            f'  <joint name="cam_{cam.name}_link_to_optical" type="fixed">',
            f'    <parent link="{link}"/>',
            f'    <child link="{optical}"/>',
            f'    <origin xyz="0 0 0" rpy="{" ".join(_num(v) for v in OPTICAL_RPY)}"/>',
            "  </joint>",
        ]
    out.append("</robot>")
    return "\n".join(out) + "\n"


def write_opencv_yaml(cam: Camera, path: Path, sigma_px: float) -> None:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.writeComment(f"camera {cam.name} from mfns calib. {FRAME_NOTE}.")
    fs.write("camera_name", cam.name)
    fs.write("image_width", int(cam.width))
    fs.write("image_height", int(cam.height))
    fs.write("camera_matrix", cam.K)
    fs.write("distortion_coefficients", np.asarray(cam.dist, float).reshape(1, 5))
    fs.writeComment("C_k_b: camera -> body rotation (p_b = C_k_b p_k + r_bk_b)")
    fs.write("C_k_b", np.asarray(cam.C_k_b, float))
    fs.write("r_bk_b_mm", np.asarray(cam.r_bk_b, float).reshape(3, 1))
    fs.writeComment("T_b_k: 4x4 camera -> body transform, mm")
    fs.write("T_b_k_mm", t_b_k(cam))
    fs.write("pixel_noise_px", float(sigma_px))
    fs.release()


def write_outputs(cal: Calibration, out: Path, source: str) -> tuple[list[Path], list[str]]:
    """Every output file next to `out` (the results JSON); returns (paths, notes for the report)."""
    cams = cal.refined.rig.cams
    flight = tuple(c.name for c in cams) == CAMERA_NAMES
    written = [out]
    out.parent.mkdir(parents=True, exist_ok=True)
    save(results_document(cal, source), out, flight=flight)
    if cal.paper is not None:
        paper_path = out.with_name(out.stem + "_paper.json")
        save(paper_document(cal, source + " (paper CPC)"), paper_path, flight=flight)
        written.append(paper_path)
    for cam in cams:
        path = out.with_name(f"{out.stem}_camera_{cam.name}.yml")
        write_opencv_yaml(cam, path, cal.refined.sigma_px)
        written.append(path)
        path = out.with_name(f"{out.stem}_camera_info_{cam.name}.yaml")
        path.write_text(ros_camera_info(cam))
        written.append(path)
    text, notes = kalibr_camchain(cams)
    path = out.with_name(f"{out.stem}_camchain.yaml")
    path.write_text(text)
    written.append(path)
    path = out.with_name(f"{out.stem}_body_to_camera.yaml")
    path.write_text(body_transforms(cams))
    written.append(path)
    path = out.with_name(f"{out.stem}_mounts.urdf")
    path.write_text(urdf_mounts(cams))
    written.append(path)
    return written, notes
