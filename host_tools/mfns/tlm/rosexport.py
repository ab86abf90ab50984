"""`mfns export`: a ground output folder (or a telemetry recording) as an MCAP file or a
rosbag2 folder of ROS 2 messages (docs/robotics.md).

What is written (mfns.tlm.rosmsg holds every convention):
- /mfns/pose  geometry_msgs/PoseWithCovarianceStamped, one per usable cycle (FIX or DEGRADED):
  a NO_FIX cycle writes no pose and no TF (its zeros are not a pose), only its diagnostics;
- /tf  tf2_msgs/TFMessage world -> body with the same pose;
- /tf_static  body -> mfns_cam_<k>_link -> mfns_cam_<k>_optical_frame (with a calibration);
- /mfns/cam_<k>/camera_info  sensor_msgs/CameraInfo, with every navigation packet (a
  calibration); cameras have no images on the link, the info gives a viewer the frusta;
- /diagnostics  diagnostic_msgs/DiagnosticArray: the navigation status, reason, mode and the
  protection levels of every cycle, and each camera's packet.

Every message is stamped (header and log time) with the row's UTC (`utc`, the correlated flight
time). Messages are serialised once (mcap-ros2-support's CDR encoder, from the ROS 2 definitions
rosbags holds) and stored either in an MCAP file with the ros2 profile or in a rosbag2 folder
written by rosbags (storage mcap or sqlite3).
"""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from ..analysis.calib_results import CAMERA_NAMES
from ..core.errors import MfnsError
from . import rosmsg

FORMATS = ("mcap", "rosbag2")
STORAGES = ("mcap", "sqlite3")


@dataclass
class Frames:
    world: str = rosmsg.WORLD_FRAME
    body: str = rosmsg.BODY_FRAME


@dataclass
class Message:
    topic: str
    typename: str
    ns: int  # UTC, nanoseconds since 1970
    msg: dict


@dataclass
class Counts:
    rows: int = 0
    poses: int = 0
    no_fix: int = 0
    by_topic: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- inputs
def read_rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def find_ground(explicit: str | None) -> str:
    """The mfns-ground program that decodes a recording: --ground, $PATH, or the tree's build."""
    if explicit:
        return explicit
    on_path = shutil.which("mfns-ground")
    if on_path:
        return on_path
    tree = Path(__file__).resolve().parents[3] / "build" / "host-sim" / "bin" / "mfns-ground"
    if tree.is_file():
        return str(tree)
    raise MfnsError(
        "a recording needs mfns-ground to decode it: build it (make flight) or give --ground PATH"
    )


def ground_folder(source: Path, ground: str | None, tmp: Path) -> Path:
    """The ground output folder of SOURCE: itself, or mfns-ground --file SOURCE --out tmp."""
    if source.is_dir():
        if not (source / "nav.csv").is_file():
            raise MfnsError(f"{source}: no nav.csv (expected an mfns-ground --out folder)")
        return source
    if not source.is_file():
        raise MfnsError(f"{source}: no such file or folder")
    out = tmp / "ground"
    res = subprocess.run(
        [find_ground(ground), "--file", str(source), "--out", str(out), "--no-status", "-q"],
        check=False,
        capture_output=True,
        text=True,
    )
    if res.returncode != 0 or not (out / "nav.csv").is_file():
        raise MfnsError(
            f"{source}: mfns-ground could not decode it (exit {res.returncode}): {res.stderr.strip()[-300:]}"
        )
    return out


def load_cameras(calib: Path | None, table: Path | None) -> list:
    """The three cameras (name, intrinsics, C_k_b, r_bk_b mm) of a calib.json or a table."""
    from ..model.camera import Camera

    if calib is not None and table is not None:
        raise MfnsError("give --calib or --table, not both")
    if calib is not None:
        from ..analysis import calib_results
        from ..model.camera import rig_from_doc

        return rig_from_doc(calib_results.load(calib))
    if table is not None:
        from ..table.check import read_table

        try:
            t = read_table(Path(table).read_bytes())
        except OSError:
            raise
        except Exception as e:  # the loader's refusal, as one line
            raise MfnsError(f"{table}: not a calibration table the flight accepts: {e}") from e
        return [
            Camera(
                name=CAMERA_NAMES[c.camera_id],
                fx=float(c.fx),
                fy=float(c.fy),
                cx=float(c.cx),
                cy=float(c.cy),
                skew=float(c.skew),
                dist=c.dist,
                width=int(c.width),
                height=int(c.height),
                C_k_b=c.C_k_b,
                r_bk_b=c.r_bk_b,
            )
            for c in t.cameras
        ]
    return []


# --------------------------------------------------------------------------- messages
def messages(
    nav: list[dict], cams: list[dict], rig: list, frames: Frames, counts: Counts
) -> Iterator[Message]:
    """Every message of the run in time order (nav and camera rows merged by UTC)."""
    if not nav:
        raise MfnsError("nav.csv has no rows")
    t0 = rosmsg.row_stamp_ns(nav[0])
    if rig:
        yield Message(rosmsg.TOPIC_TF_STATIC, rosmsg.TYPE_TF, t0, rosmsg.tf_static_msg(rig, t0, frames.body))
    events = [(rosmsg.row_stamp_ns(r), 0, k, r) for k, r in enumerate(nav)]
    events += [(rosmsg.row_stamp_ns(r), 1, k, r) for k, r in enumerate(cams)]
    events.sort(key=lambda e: e[:3])
    for ns, kind, _k, row in events:
        if kind == 1:
            yield Message(
                rosmsg.TOPIC_DIAG,
                rosmsg.TYPE_DIAG,
                ns,
                rosmsg.diagnostics_msg(ns, [rosmsg.camera_status(row)]),
            )
            continue
        counts.rows += 1
        if rosmsg.usable(row):
            counts.poses += 1
            yield Message(rosmsg.TOPIC_POSE, rosmsg.TYPE_POSE, ns, rosmsg.pose_msg(row, frames.world))
            yield Message(
                rosmsg.TOPIC_TF, rosmsg.TYPE_TF, ns, rosmsg.tf_body_msg(row, frames.world, frames.body)
            )
        else:
            counts.no_fix += 1
        yield Message(
            rosmsg.TOPIC_DIAG, rosmsg.TYPE_DIAG, ns, rosmsg.diagnostics_msg(ns, [rosmsg.nav_status(row)])
        )
        for cam in rig:
            yield Message(
                rosmsg.topic_camera_info(cam.name), rosmsg.TYPE_CAMINFO, ns, rosmsg.camera_info_msg(cam, ns)
            )


class Encoders:
    """CDR encoders per message type (mcap-ros2-support's, from rosbags' definitions)."""

    def __init__(self) -> None:
        self._enc: dict = {}

    def __call__(self, typename: str, msg: dict) -> bytes:
        enc = self._enc.get(typename)
        if enc is None:
            from mcap_ros2._dynamic import serialize_dynamic

            enc = serialize_dynamic(typename, rosmsg.msgdef(typename))[typename]
            self._enc[typename] = enc
        return enc(msg)


# --------------------------------------------------------------------------- writers
def write_mcap(path: Path, msgs: Iterable[Message], counts: Counts) -> None:
    from mcap_ros2.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        schemas: dict = {}
        for m in msgs:
            s = schemas.get(m.typename)
            if s is None:
                s = schemas[m.typename] = w.register_msgdef(m.typename, rosmsg.msgdef(m.typename))
            w.write_message(m.topic, s, m.msg, log_time=m.ns, publish_time=m.ns)
            counts.by_topic[m.topic] = counts.by_topic.get(m.topic, 0) + 1
        w.finish()


def _latched_qos() -> tuple:
    """/tf_static's QoS as tf2 publishes it (reliable, transient local, keep last 1), so
    `ros2 bag play` re-publishes the mounts to late subscribers."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    zero = QosTime(0, 0)
    return (
        Qos(
            QosHistory.KEEP_LAST,
            1,
            QosReliability.RELIABLE,
            QosDurability.TRANSIENT_LOCAL,
            zero,
            zero,
            QosLiveliness.AUTOMATIC,
            zero,
            False,
        ),
    )


def write_rosbag2(path: Path, msgs: Iterable[Message], counts: Counts, storage: str = "mcap") -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer

    if path.exists():
        raise MfnsError(f"{path}: exists (a rosbag2 folder is written new)")
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    enc = Encoders()
    store = rosmsg.typestore()
    with Writer(path, version=8, storage_plugin=plugin) as w:
        conns: dict = {}
        for m in msgs:
            c = conns.get(m.topic)
            if c is None:
                qos = _latched_qos() if m.topic == rosmsg.TOPIC_TF_STATIC else ()
                c = conns[m.topic] = w.add_connection(
                    m.topic, m.typename, typestore=store, offered_qos_profiles=qos
                )
            w.write(c, m.ns, enc(m.typename, m.msg))
            counts.by_topic[m.topic] = counts.by_topic.get(m.topic, 0) + 1


def export(
    source: Path,
    output: Path,
    fmt: str,
    calib: Path | None = None,
    table: Path | None = None,
    frames: Frames | None = None,
    storage: str = "mcap",
    ground: str | None = None,
) -> Counts:
    if fmt not in FORMATS:
        raise MfnsError(f"--format {fmt}: expected one of {', '.join(FORMATS)}")
    if storage not in STORAGES:
        raise MfnsError(f"--storage {storage}: expected one of {', '.join(STORAGES)}")
    frames = frames or Frames()
    rig = load_cameras(calib, table)
    counts = Counts()
    with tempfile.TemporaryDirectory(prefix="mfns-export-") as tmp:
        folder = ground_folder(Path(source), ground, Path(tmp))
        nav = read_rows(folder / "nav.csv")
        cams = read_rows(folder / "camera.csv") if (folder / "camera.csv").is_file() else []
        msgs = messages(nav, cams, rig, frames, counts)
        output = Path(output)
        if output.parent and not output.parent.exists():
            os.makedirs(output.parent, exist_ok=True)
        if fmt == "mcap":
            write_mcap(output, msgs, counts)
        else:
            write_rosbag2(output, msgs, counts, storage)
    return counts
