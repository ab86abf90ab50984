"""MFNS telemetry as ROS 2 messages (docs/robotics.md): the one place that maps the ground's
rows (nav.csv, camera.csv) and the calibration onto ROS's units, frames and conventions.

Messages are plain nested dicts in the field layout of the ROS 2 message definitions, so the
same dict is serialised for an MCAP file (mcap-ros2-support), a rosbag2 folder (rosbags) or
a live Foxglove channel. The message definitions themselves come from rosbags' store of the
ROS 2 Humble interfaces (`msgdef`), never from a hand-written copy.

Conventions (REP 103 / REP 105, docs/conventions.md, docs/telemetry.md "nav"):
- lengths in metres, angles in radians, stamps UTC (the ground's `utc` column: the flight time
  correlated to UTC through housekeeping, docs/telemetry.md "Time"), as builtin_interfaces/Time;
- the pose is the body frame in the world frame: position r_wb_w, orientation q_b_w (Hamilton,
  body to world), which is what geometry_msgs/Pose means with header.frame_id = world;
- the covariance: the flight's `cov_*` columns are already over (x, y, z, rx, ry, rz) with the
  position error in the world frame and the attitude error phi_w about the world's fixed axes
  (C_b_w(est) = exp(phi_w) C_b_w(true)), which is ROS's PoseWithCovariance convention for a pose
  whose header.frame_id is the world ("fixed-axis representation": rotation about X, Y, Z of the
  parent frame). So only units change: mm -> m on the first three indices, deg -> rad on the
  last three (`ros_covariance`). The Euler `sigma_*` columns are NOT this covariance's roots;
- camera frames: the MFNS camera frame (+Z optic axis, +X along u, +Y along v) is an optical
  frame in REP 103's sense, named `mfns_cam_<k>_optical_frame`, child of a REP 103 body-style
  `mfns_cam_<k>_link` (x forward along the optic axis, y left, z up) on the body.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from functools import cache

import numpy as np

from ..core.csv_formats import COV_COLUMNS
from . import tlm_dict

# --- frame ids (the defaults; `mfns export --world-frame/--body-frame` rename the two roots)
WORLD_FRAME = "mfns_world"
BODY_FRAME = "mfns_body"


def camera_link(name: str) -> str:
    return f"mfns_cam_{name}_link"


def camera_optical_frame(name: str) -> str:
    return f"mfns_cam_{name}_optical_frame"


# R_lo: the optical frame's axes in the camera link's (REP 103: optical z forward, x right,
# y down; link x forward, y left, z up): p_link = R_LINK_OPTICAL p_optical. It is URDF's
# rpy = (-pi/2, 0, -pi/2), the rotation every ROS camera driver uses between the two.
R_LINK_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
OPTICAL_RPY = (-math.pi / 2.0, 0.0, -math.pi / 2.0)

# --- topics
TOPIC_POSE = "/mfns/pose"
TOPIC_TF = "/tf"
TOPIC_TF_STATIC = "/tf_static"
TOPIC_DIAG = "/diagnostics"


def topic_camera_info(name: str) -> str:
    return f"/mfns/cam_{name}/camera_info"


TYPE_POSE = "geometry_msgs/msg/PoseWithCovarianceStamped"
TYPE_TF = "tf2_msgs/msg/TFMessage"
TYPE_CAMINFO = "sensor_msgs/msg/CameraInfo"
TYPE_DIAG = "diagnostic_msgs/msg/DiagnosticArray"

# COV_COLUMNS: the 21 cov_* columns, upper triangle, row-major, over core.csv_formats.COV_AXES
MM_TO_M = 1e-3
MM_PER_M = 1000.0
DEG_TO_RAD = math.pi / 180.0
COV_SCALE = np.array([MM_TO_M] * 3 + [DEG_TO_RAD] * 3)  # per index: telemetry unit -> SI

# diagnostic_msgs/DiagnosticStatus levels (the message's constants)
DIAG_OK, DIAG_WARN, DIAG_ERROR, DIAG_STALE = 0, 1, 2, 3
NAV_LEVEL = {"FIX": DIAG_OK, "DEGRADED": DIAG_WARN, "NO_FIX": DIAG_ERROR}
CAM_LEVEL = {"OK": DIAG_OK, "SKIPPED": DIAG_WARN, "OFF": DIAG_WARN, "LOST": DIAG_ERROR, "ENDED": DIAG_ERROR}
HARDWARE_ID = "mfns"


@cache
def typestore():
    """rosbags' store of the ROS 2 Humble interfaces (every type used here is in it)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


@cache
def msgdef(typename: str) -> str:
    """The ROS 2 message definition text (with its dependencies, the rosbag2/MCAP `ros2msg`
    schema format) of `typename`, from rosbags' store of the Humble interfaces."""
    text, _md5 = typestore().generate_msgdef(typename, ros_version=2)
    return text


def schema_name(typename: str) -> str:
    """`pkg/msg/Name` -> `pkg/msg/Name` (MCAP's ros2 profile keeps the full name)."""
    return typename


# --------------------------------------------------------------------------- time
def parse_utc(text: str) -> int:
    """ISO 8601 UTC (`2026-12-01T23:19:33.123456Z`) -> integer nanoseconds since 1970 (exact
    to the microsecond the ground prints)."""
    t = text.strip()
    if not t:
        raise ValueError("empty UTC time")
    if t.endswith("Z"):
        t = t[:-1] + "+00:00"
    d = datetime.fromisoformat(t)
    if d.tzinfo is None:
        raise ValueError(f"UTC time without a zone: {text!r}")
    d = d.astimezone(UTC)
    whole = int(d.replace(microsecond=0).timestamp())
    return whole * 1_000_000_000 + d.microsecond * 1000


def stamp(ns: int) -> dict:
    return {"sec": int(ns // 1_000_000_000), "nanosec": int(ns % 1_000_000_000)}


def row_stamp_ns(row: dict) -> int:
    """A row's UTC: the ground's correlated `utc` (flight time + the housekeeping offset), or
    its receipt time `ground_utc` for a folder written before the correlation."""
    t = row.get("utc") or row.get("ground_utc")
    if not t:
        raise ValueError(f"row of cycle {row.get('cycle')} has neither utc nor ground_utc")
    return parse_utc(t)


# --------------------------------------------------------------------------- pose
def usable(row: dict) -> bool:
    """A row with a pose the flight's checks passed (FIX or DEGRADED); NO_FIX rows carry
    zeros that are not a pose."""
    return row.get("status") in tlm_dict.usable_status_names()


def telemetry_covariance(row: dict) -> np.ndarray:
    """The 6x6 covariance of the 21 cov_* columns, telemetry units (mm^2, mm deg, deg^2)."""
    missing = [c for c in COV_COLUMNS if row.get(c) in (None, "")]
    if missing:
        raise ValueError(f"nav row of cycle {row.get('cycle')} lacks {', '.join(missing[:3])}...")
    p = np.zeros((6, 6))
    k = 0
    for i in range(6):
        for j in range(i, 6):
            p[i, j] = p[j, i] = float(row[COV_COLUMNS[k]])
            k += 1
    return p


def ros_covariance(p_tlm: np.ndarray) -> np.ndarray:
    """Telemetry units -> SI (m^2, m rad, rad^2); the frame and the order are already ROS's
    (module docstring), so this is D P D with D = diag(1e-3, 1e-3, 1e-3, pi/180, ...)."""
    return p_tlm * np.outer(COV_SCALE, COV_SCALE)


def position_m(row: dict) -> tuple[float, float, float]:
    x, y, z = (float(row[a + "_mm"]) / MM_PER_M for a in "xyz")  # divided: correctly rounded
    return x, y, z


def orientation_xyzw(row: dict) -> tuple[float, float, float, float]:
    q = np.array([float(row["q_x"]), float(row["q_y"]), float(row["q_z"]), float(row["q_w"])])
    n = float(np.linalg.norm(q))
    if not (0.5 < n < 1.5):
        raise ValueError(f"nav row of cycle {row.get('cycle')}: quaternion norm {n:.3f} is not a rotation")
    x, y, z, w = (float(v) for v in q / n)  # the wire's 2^-30 quantisation, renormalised
    return x, y, z, w


def pose_msg(row: dict, world_frame: str = WORLD_FRAME) -> dict:
    """geometry_msgs/PoseWithCovarianceStamped of a usable nav row."""
    if not usable(row):
        raise ValueError(f"cycle {row.get('cycle')} is {row.get('status')}: no pose")
    x, y, z = position_m(row)
    qx, qy, qz, qw = orientation_xyzw(row)
    return {
        "header": {"stamp": stamp(row_stamp_ns(row)), "frame_id": world_frame},
        "pose": {
            "pose": {
                "position": {"x": x, "y": y, "z": z},
                "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
            },
            "covariance": [float(v) for v in ros_covariance(telemetry_covariance(row)).ravel()],
        },
    }


def transform(parent: str, child: str, ns: int, t_m, q_xyzw) -> dict:
    """geometry_msgs/TransformStamped: the child frame expressed in the parent's."""
    return {
        "header": {"stamp": stamp(ns), "frame_id": parent},
        "child_frame_id": child,
        "transform": {
            "translation": {"x": float(t_m[0]), "y": float(t_m[1]), "z": float(t_m[2])},
            "rotation": {
                "x": float(q_xyzw[0]),
                "y": float(q_xyzw[1]),
                "z": float(q_xyzw[2]),
                "w": float(q_xyzw[3]),
            },
        },
    }


def tf_body_msg(row: dict, world_frame: str = WORLD_FRAME, body_frame: str = BODY_FRAME) -> dict:
    """tf2_msgs/TFMessage: world -> body of a usable row (the same pose as pose_msg)."""
    return {
        "transforms": [
            transform(world_frame, body_frame, row_stamp_ns(row), position_m(row), orientation_xyzw(row))
        ]
    }


def quaternion_xyzw(c: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w), w >= 0, of a rotation matrix (Shepperd's method)."""
    m = np.asarray(c, float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0.0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    qa = np.array(q)
    qa /= np.linalg.norm(qa)
    return -qa if qa[3] < 0 else qa


def camera_link_rotation(C_k_b: np.ndarray) -> np.ndarray:
    """C_link_b: the camera link's axes in the body, from the optical frame's C_k_b
    (C_k_b = C_link_b R_LINK_OPTICAL)."""
    return np.asarray(C_k_b, float) @ R_LINK_OPTICAL.T


def tf_static_msg(cams, ns: int, body_frame: str = BODY_FRAME) -> dict:
    """tf2_msgs/TFMessage of the mounts: body -> mfns_cam_<k>_link -> mfns_cam_<k>_optical_frame
    (cams: objects with name, C_k_b, r_bk_b in mm, e.g. mfns.model.camera.Camera)."""
    out = []
    q_lo = quaternion_xyzw(R_LINK_OPTICAL)
    for cam in cams:
        out.append(
            transform(
                body_frame,
                camera_link(cam.name),
                ns,
                np.asarray(cam.r_bk_b, float) / MM_PER_M,
                quaternion_xyzw(camera_link_rotation(cam.C_k_b)),
            )
        )
        out.append(
            transform(camera_link(cam.name), camera_optical_frame(cam.name), ns, (0.0, 0.0, 0.0), q_lo)
        )
    return {"transforms": out}


def camera_info_msg(cam, ns: int) -> dict:
    """sensor_msgs/CameraInfo of one calibrated camera: plumb_bob [k1 k2 p1 p2 k3] (the
    model's own order, docs/conventions.md), no rectification, frame = its optical frame."""
    k = [float(cam.fx), float(cam.skew), float(cam.cx), 0.0, float(cam.fy), float(cam.cy), 0.0, 0.0, 1.0]
    p = [k[0], k[1], k[2], 0.0, 0.0, k[4], k[5], 0.0, 0.0, 0.0, 1.0, 0.0]
    return {
        "header": {"stamp": stamp(ns), "frame_id": camera_optical_frame(cam.name)},
        "height": int(cam.height),
        "width": int(cam.width),
        "distortion_model": "plumb_bob",
        "d": [float(v) for v in np.asarray(cam.dist, float).ravel()],
        "k": k,
        "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        "p": p,
        "binning_x": 0,
        "binning_y": 0,
        "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False},
    }


def _kv(key: str, value) -> dict:
    return {"key": key, "value": "" if value is None else str(value)}


def reason_name(code) -> str:
    names = tlm_dict.reason_names()
    try:
        c = int(code)
    except (TypeError, ValueError):
        return str(code)
    return names[c] if 0 <= c < len(names) else f"UNKNOWN_{c}"


NAV_KEYS = (
    "cycle",
    "status",
    "mode",
    "beacons_used",
    "cams_used",
    "pl_pos_mm",
    "pl_att_deg",
    "residual_rms_px",
    "time_source",
)


def nav_status(row: dict) -> dict:
    """diagnostic_msgs/DiagnosticStatus of one navigation packet: the level from the status
    (FIX OK, DEGRADED WARN, NO_FIX ERROR), the message `STATUS: REASON`, and the values an
    integrator needs: the protection levels (pl_pos_mm, pl_att_deg: the bound of a single
    beacon fault, docs/pose.md), the reason by name and code, mode, what was used."""
    status = row.get("status", "")
    reason = reason_name(row.get("reason"))
    if row.get("mode") == "STANDBY" and status == "NO_FIX":
        reason = "STANDBY (commanded: the navigator does not run)"  # the wire's reason is NONE
    values = [_kv("reason", reason), _kv("reason_code", row.get("reason"))]
    values += [_kv(k, row.get(k)) for k in NAV_KEYS if k in row]
    return {
        "level": NAV_LEVEL.get(status, DIAG_ERROR),
        "name": "mfns: navigation",
        "message": f"{status}: {reason}",
        "hardware_id": HARDWARE_ID,
        "values": values,
    }


def camera_status(row: dict) -> dict:
    """diagnostic_msgs/DiagnosticStatus of one camera packet (camera.csv row)."""
    state = row.get("state", "")
    keys = ("cycle", "state", "blobs", "beacons_identified", "exposure_us", "gain_db", "frames_dropped")
    return {
        "level": CAM_LEVEL.get(state, DIAG_ERROR),
        "name": f"mfns: camera {row.get('camera')}",
        "message": f"{state}: {row.get('beacons_identified', '?')} beacons identified",
        "hardware_id": HARDWARE_ID,
        "values": [_kv(k, row.get(k)) for k in keys if k in row],
    }


def diagnostics_msg(ns: int, statuses: list[dict]) -> dict:
    return {"header": {"stamp": stamp(ns), "frame_id": ""}, "status": statuses}
