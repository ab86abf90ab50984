"""A picture of what `mfns live` serves, drawn from its Foxglove WebSocket (docs/robotics.md).

The Foxglove app is a web app fetched from its vendor: it cannot be run offline, so this
module is the offline stand-in for its 3D panel. It is a plain client of the stream (the
foxglove.sdk.v1 WebSocket subprotocol, through the `websockets` library, not the server's
SDK): it subscribes to every channel, decodes the ROS 2 messages with rosbags' CDR decoder
and the beacons' foxglove.SceneUpdate with a small protobuf reader, and draws with
matplotlib (Agg) the module frame: the beacons, the body's track and pose with its position
covariance (the 3-sigma ellipsoid, magnified and labelled so), the camera frusta from
CameraInfo placed by /tf_static, and the status of /diagnostics. What it draws is only what
came over the socket; nothing is read from the files the server reads.
"""

from __future__ import annotations

import json
import math
import struct
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import MfnsError
from ..tlm import rosmsg

SUBPROTOCOL = "foxglove.sdk.v1"
OP_MESSAGE_DATA = 0x01  # binary opcode: u8 op, u32 subscription id, u64 log time (ns), payload
TOPIC_BEACONS = "/mfns/beacons"
FRUSTUM_DEPTH_M = 0.25  # how far the frusta are drawn: a symbol, not the cameras' range
ELLIPSOID_SIGMA = 3.0  # the position covariance's ellipsoid at 3 sigma


@dataclass
class Scene:
    """The latest of each topic, as decoded from the stream."""

    poses: list[Any] = field(default_factory=list)  # PoseWithCovarianceStamped, in arrival order
    tf_static: dict[str, Any] = field(default_factory=dict)  # child frame -> TransformStamped
    camera_info: dict[str, Any] = field(default_factory=dict)  # camera name -> CameraInfo
    beacons: list[tuple[str, np.ndarray]] = field(default_factory=list)  # (label, position m)
    diagnostics: dict[str, Any] = field(default_factory=dict)  # status name -> DiagnosticStatus
    counts: dict[str, int] = field(default_factory=dict)  # messages received per topic


# --------------------------------------------------------------------------- protobuf
def _varint(b: bytes, i: int) -> tuple[int, int]:
    v = shift = 0
    while True:
        if i >= len(b) or shift > 63:
            raise ValueError("protobuf: truncated varint")
        c = b[i]
        i += 1
        v |= (c & 0x7F) << shift
        shift += 7
        if not c & 0x80:
            return v, i


def pb_fields(b: bytes) -> list[tuple[int, int, Any]]:
    """The (field number, wire type, value) of one protobuf message: varints as int, fixed64
    and fixed32 as their bytes, length-delimited as bytes (a nested message or a string)."""
    out: list[tuple[int, int, Any]] = []
    i = 0
    while i < len(b):
        key, i = _varint(b, i)
        num, wt = key >> 3, key & 7
        v: int | bytes
        if wt == 0:
            v, i = _varint(b, i)
        elif wt == 1:
            v, i = b[i : i + 8], i + 8
        elif wt == 5:
            v, i = b[i : i + 4], i + 4
        elif wt == 2:
            n, i = _varint(b, i)
            v, i = b[i : i + n], i + n
        else:
            raise ValueError(f"protobuf: wire type {wt} not expected in a SceneUpdate")
        if i > len(b):
            raise ValueError("protobuf: truncated field")
        out.append((num, wt, v))
    return out


def _vector3(b: bytes) -> np.ndarray:
    xyz = [0.0, 0.0, 0.0]  # proto3: a zero coordinate is not written
    for num, wt, v in pb_fields(b):
        if wt == 1 and 1 <= num <= 3:
            xyz[num - 1] = struct.unpack("<d", v)[0]
    return np.array(xyz)


def _pose_position(b: bytes) -> np.ndarray:
    for num, wt, v in pb_fields(b):
        if num == 1 and wt == 2:  # foxglove.Pose.position
            return _vector3(v)
    return np.zeros(3)


def scene_update_beacons(payload: bytes) -> list[tuple[str, np.ndarray]]:
    """The labelled spheres of a foxglove.SceneUpdate (field numbers of the foxglove schemas:
    SceneUpdate.entities 2; SceneEntity.spheres 9, texts 13; SpherePrimitive.pose 1;
    TextPrimitive.pose 1, text 6; Pose.position 1; Vector3 x y z 1 2 3): (label, position)."""
    out = []
    for num, wt, ent in pb_fields(payload):
        if num != 2 or wt != 2:
            continue
        spheres, labels = [], {}
        for n, w, v in pb_fields(ent):
            if n == 9 and w == 2:
                spheres.append(_pose_position(next(x for k, t, x in pb_fields(v) if k == 1 and t == 2)))
            elif n == 13 and w == 2:
                f = {k: x for k, t, x in pb_fields(v) if t == 2}
                labels[tuple(np.round(_pose_position(f[1]), 9))] = f[6].decode()
        for p in spheres:
            out.append((labels.get(tuple(np.round(p, 9)), ""), p))
    return out


# --------------------------------------------------------------------------- the client
def capture(url: str, seconds: float) -> Scene:
    """Connect to a Foxglove WebSocket, subscribe to every channel and keep what comes for
    this many seconds."""
    from rosbags.typesys import Stores, get_typestore
    from websockets.sync.client import connect

    store = get_typestore(Stores.ROS2_HUMBLE)
    scene = Scene()
    subs: dict[int, dict] = {}
    next_id = 1
    deadline = time.monotonic() + seconds
    with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=5) as ws:  # type: ignore[list-item]
        while (left := deadline - time.monotonic()) > 0:
            try:
                msg = ws.recv(timeout=left)
            except TimeoutError:
                break
            if isinstance(msg, str):
                op = json.loads(msg)
                if op.get("op") == "advertise":
                    new = []
                    for ch in op["channels"]:
                        subs[next_id] = ch
                        new.append({"id": next_id, "channelId": ch["id"]})
                        next_id += 1
                    ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
                continue
            if len(msg) < 13 or msg[0] != OP_MESSAGE_DATA:
                continue
            ch = subs.get(struct.unpack_from("<I", msg, 1)[0])
            if ch is None:
                continue
            payload, topic = bytes(msg[13:]), ch["topic"]
            scene.counts[topic] = scene.counts.get(topic, 0) + 1
            if topic == TOPIC_BEACONS:
                scene.beacons = scene_update_beacons(payload)
                continue
            if ch.get("encoding") != "cdr":
                continue
            m: Any = store.deserialize_cdr(payload, ch["schemaName"])
            if topic == rosmsg.TOPIC_POSE:
                scene.poses.append(m)
            elif topic == rosmsg.TOPIC_TF_STATIC:
                for t in m.transforms:
                    scene.tf_static[t.child_frame_id] = t
            elif topic == rosmsg.TOPIC_DIAG:
                for s in m.status:
                    scene.diagnostics[s.name] = s
            elif topic.endswith("/camera_info"):
                scene.camera_info[topic.split("/")[2].removeprefix("cam_")] = m
    return scene


# --------------------------------------------------------------------------- geometry
def quat_matrix(q) -> np.ndarray:
    """The rotation of a unit quaternion (x, y, z, w; Hamilton), as ROS and TF define it."""
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _transform(t) -> tuple[np.ndarray, np.ndarray]:
    tr = t.transform.translation
    return quat_matrix(t.transform.rotation), np.array([tr.x, tr.y, tr.z])


def frame_in_body(scene: Scene, child: str, body: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(R, p) of frame child in the body frame, composed along /tf_static (p_body = R p + p)."""
    R, p = np.eye(3), np.zeros(3)
    f = child
    for _ in range(8):  # a short chain: body -> link -> optical
        if f == body:
            return R, p
        t = scene.tf_static.get(f)
        if t is None:
            return None
        Rt, pt = _transform(t)
        R, p = Rt @ R, Rt @ p + pt
        f = t.header.frame_id
    return None


def frustum_corners(info, depth_m: float) -> np.ndarray:
    """The four corners of the image at this depth, in the optical frame (K^-1 [u v 1] d)."""
    K = np.array(info.k, dtype=float).reshape(3, 3)
    w, h = float(info.width), float(info.height)
    uv1 = np.array([[0.0, 0.0, 1.0], [w, 0.0, 1.0], [w, h, 1.0], [0.0, h, 1.0]])
    return (np.linalg.solve(K, uv1.T) * depth_m).T


# --------------------------------------------------------------------------- the picture
def _status_lines(scene: Scene) -> list[str]:
    lines = []
    nav = scene.diagnostics.get("mfns: navigation")
    if nav is not None:
        kv = {v.key: v.value for v in nav.values}
        lines.append(f"navigation: {nav.message}")
        lines.append(
            f"cycle {kv.get('cycle', '?')}  mode {kv.get('mode', '?')}  beacons {kv.get('beacons_used', '?')}"
            f"  cams mask {kv.get('cams_used', '?')}"
        )
        lines.append(f"protection level: {kv.get('pl_pos_mm', '?')} mm, {kv.get('pl_att_deg', '?')} deg")
    for name in sorted(scene.diagnostics):
        if name.startswith("mfns: camera"):
            kv = {v.key: v.value for v in scene.diagnostics[name].values}
            lines.append(
                f"{name.removeprefix('mfns: ')}: {kv.get('state', '?')}, {kv.get('blobs', '?')} blobs"
            )
    return lines


def _draw(ax, scene: Scene, body_frame: str, half: float | None, drawn: dict) -> None:
    """One 3D view: the whole module (half None: the beacons' extent) or a cube of this half
    size around the robot."""
    last = scene.poses[-1]
    track = np.array(
        [[m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z] for m in scene.poses]
    )
    R_wb, r_wb = quat_matrix(last.pose.pose.orientation), track[-1]
    if half is None:
        pts = np.vstack([track, *([np.array([p for _, p in scene.beacons])] if scene.beacons else [])])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        mid, lim = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 0.3) + 0.1
    else:
        mid, lim = r_wb, half
    if scene.beacons:
        near = [(lab, p) for lab, p in scene.beacons if np.all(np.abs(p - mid) <= lim)]
        if near:
            b = np.array([p for _, p in near])
            ax.scatter(b[:, 0], b[:, 1], b[:, 2], s=14, c="#e0a000", depthshade=False, label="beacons")
            for lab, p in near:
                ax.text(p[0], p[1], p[2], " " + lab, fontsize=5, color="#806000")
    ax.plot(track[:, 0], track[:, 1], track[:, 2], c="#1f77b4", lw=1.0, label="track (/mfns/pose)")
    axis_len = 0.2 if half is None else 0.4 * lim
    for k, col in enumerate(("r", "g", "b")):  # the body axes x y z
        e = r_wb + axis_len * R_wb[:, k]
        ax.plot(*zip(r_wb, e, strict=True), c=col, lw=2)
    ax.plot_wireframe(*drawn["_ellipsoid"], color="#9467bd", lw=0.4, alpha=0.8)
    depth = FRUSTUM_DEPTH_M if half is None else 0.6 * lim
    n_frusta = 0
    for name, info in sorted(scene.camera_info.items()):
        placed = frame_in_body(scene, info.header.frame_id, body_frame)
        if placed is None:
            continue
        R_bo, p_bo = placed
        c = frustum_corners(info, depth)
        apex = r_wb + R_wb @ p_bo
        corners = r_wb + (R_wb @ (R_bo @ c.T + p_bo[:, None])).T
        for q in corners:
            ax.plot(*zip(apex, q, strict=True), c="#2ca02c", lw=0.8)
        loop = np.vstack([corners, corners[:1]])
        ax.plot(loop[:, 0], loop[:, 1], loop[:, 2], c="#2ca02c", lw=0.8)
        ax.text(*corners.mean(axis=0), f" cam {name}", fontsize=7, color="#2ca02c")
        n_frusta += 1
    drawn["frusta"] = n_frusta
    ax.set_xlim(mid[0] - lim, mid[0] + lim)
    ax.set_ylim(mid[1] - lim, mid[1] + lim)
    ax.set_zlim(mid[2] - lim, mid[2] + lim)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x m", fontsize=7)
    ax.set_ylabel("y m", fontsize=7)
    ax.set_zlabel("z m", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.view_init(elev=24, azim=-58)


def render(scene: Scene, png: Path, body_frame: str = rosmsg.BODY_FRAME, title: str = "") -> dict:
    """Draw the scene into png: the module, and the robot close up; returns what was drawn
    (counts, the covariance ellipsoid's magnification, the 1-sigma position in mm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not scene.poses:
        raise MfnsError("no /mfns/pose received: nothing to draw (a NO_FIX stream sends no pose)")
    last = scene.poses[-1]
    p = last.pose.pose.position
    r_wb = np.array([p.x, p.y, p.z])
    # the position covariance (m^2, world axes) as its 3-sigma ellipsoid, magnified to be seen
    P = np.array(last.pose.covariance, dtype=float).reshape(6, 6)[:3, :3]
    vals, vecs = np.linalg.eigh(0.5 * (P + P.T))
    semi = ELLIPSOID_SIGMA * np.sqrt(np.clip(vals, 0.0, None))
    gain = 10.0 ** math.ceil(math.log10(0.04 / max(float(semi.max()), 1e-12)))  # largest axis 4-40 cm
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, np.pi, 12))
    unit = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    ell = r_wb + gain * (unit * semi) @ vecs.T
    drawn: dict[str, Any] = {
        "beacons": len(scene.beacons),
        "frusta": 0,
        "poses": len(scene.poses),
        "ellipsoid_gain": gain,
        "sigma_mm": (np.sqrt(np.clip(vals, 0.0, None)) * 1e3).tolist(),
        "_ellipsoid": (ell[..., 0], ell[..., 1], ell[..., 2]),
    }
    fig = plt.figure(figsize=(11.0, 6.6), dpi=80)
    whole = fig.add_axes((0.0, 0.22, 0.5, 0.66), projection="3d")
    close = fig.add_axes((0.5, 0.22, 0.5, 0.66), projection="3d")
    _draw(whole, scene, body_frame, None, drawn)
    whole.set_title("the module: beacons (/mfns/beacons), track, robot", fontsize=8)
    whole.legend(loc="upper left", fontsize=7)
    _draw(close, scene, body_frame, 0.5, drawn)
    close.set_title(
        f"the robot: body axes (x red, y green, z blue), frusta from CameraInfo + /tf_static,\n"
        f"3-sigma position ellipsoid magnified x{gain:g} (purple)",
        fontsize=8,
    )
    del drawn["_ellipsoid"]
    st = last.header.stamp
    left = [
        f"/mfns/pose  frame {last.header.frame_id}  stamp "
        f"{time.strftime('%Y-%m-%dT%H:%M:%S', time.gmtime(st.sec))}.{st.nanosec // 1_000_000:03d}Z",
        f"position {p.x:.4f} {p.y:.4f} {p.z:.4f} m   1-sigma axes "
        + " ".join(f"{x:.3f}" for x in drawn["sigma_mm"])
        + " mm",
        *_status_lines(scene)[:3],
    ]
    right = [
        *_status_lines(scene)[3:],
        "received (messages per topic):",
        *(f"  {t} {n}" for t, n in sorted(scene.counts.items())),
    ]
    fig.text(0.02, 0.2, "\n".join(left), fontsize=7.5, va="top", family="monospace")
    fig.text(0.52, 0.2, "\n".join(right[:3]), fontsize=7.5, va="top", family="monospace")
    fig.text(0.72, 0.2, "\n".join(right[3:]), fontsize=7.0, va="top", family="monospace")
    fig.suptitle(
        title
        or "mfns live, drawn from its Foxglove WebSocket by mfns.ground.live_view "
        "(offline; not the Foxglove app)",
        fontsize=9,
        y=0.985,
    )
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=80)
    plt.close(fig)
    return drawn
