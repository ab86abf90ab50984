"""`mfns live`: the navigation solution as a live Foxglove WebSocket stream on 127.0.0.1
(docs/robotics.md "Live").

Channels, the same ROS 2 messages as `mfns export` (mfns.tlm.rosmsg; CDR with their ros2msg
schemas, which Foxglove decodes and draws: the pose with its covariance ellipsoid, the TF
tree, the camera frusta from CameraInfo, the diagnostics):
/mfns/pose, /tf, /tf_static, /mfns/cam_<k>/camera_info, /diagnostics; and, in Foxglove's own
schema, /mfns/beacons (foxglove.SceneUpdate: a sphere per beacon of the table's map, in the
world frame, with its id). /tf_static, the camera info and the beacons are re-sent every
second: a WebSocket has no latching, a viewer that connects later must still get them.

Sources: a ground output folder (rows replayed at --pace times their UTC spacing, --loop to
repeat), the same folder followed as mfns-ground writes it (--follow: the ground stream live;
mfns-ground flushes each CSV row), or a telemetry recording (decoded with mfns-ground first).
The server listens on 127.0.0.1 only: a navigation stream is not for the network at large.
"""

from __future__ import annotations

import csv
import io
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

from ..core.errors import MfnsError
from ..tlm import rosmsg
from ..tlm.rosexport import Encoders, Frames, ground_folder, load_cameras

HOST = "127.0.0.1"
RESEND_S = 1.0  # /tf_static, camera info and beacons again every second (late viewers)
FOLLOW_POLL_S = 0.05
TOPIC_BEACONS = "/mfns/beacons"


class Tail:
    """Rows of a CSV file that is still being written: complete lines only."""

    def __init__(self, path: Path) -> None:
        self.path, self.pos, self.part = path, 0, ""
        self.header: list[str] | None = None

    def rows(self) -> list[dict]:
        if not self.path.is_file():
            return []
        with open(self.path, newline="") as f:
            f.seek(self.pos)
            data = f.read()
            self.pos = f.tell()
        text = self.part + data
        lines = text.split("\n")
        self.part = lines.pop()  # an unfinished line waits for its end
        out: list[dict[str, str]] = []
        for line in lines:
            if not line:
                continue
            if self.header is None:
                self.header = next(csv.reader(io.StringIO(line)))
                continue
            out.append(dict(zip(self.header, next(csv.reader(io.StringIO(line))), strict=False)))
        return out


class Live:
    """The server and its channels; `publish_row` sends what one ground row means."""

    def __init__(self, port: int, rig: list, beacons, frames: Frames) -> None:
        import foxglove

        self.foxglove = foxglove
        self.rig, self.beacons, self.frames = rig, beacons, frames
        self.enc = Encoders()
        self.server = foxglove.start_server(name="mfns", host=HOST, port=port)
        self.port = self.server.port
        self.channels: dict = {}
        self.last_resend = 0.0
        self.counts: dict[str, int] = {}
        # every ROS channel advertised from the start, so a viewer sees the topics (and can
        # subscribe) before the first pose: a NO_FIX start has none for a while
        topics = [
            (rosmsg.TOPIC_POSE, rosmsg.TYPE_POSE),
            (rosmsg.TOPIC_TF, rosmsg.TYPE_TF),
            (rosmsg.TOPIC_DIAG, rosmsg.TYPE_DIAG),
        ]
        if rig:
            topics.append((rosmsg.TOPIC_TF_STATIC, rosmsg.TYPE_TF))
            topics += [(rosmsg.topic_camera_info(c.name), rosmsg.TYPE_CAMINFO) for c in rig]
        for topic, typename in topics:
            self._channel(topic, typename)

    def _channel(self, topic: str, typename: str):
        ch = self.channels.get(topic)
        if ch is None:
            schema = self.foxglove.Schema(
                name=typename, encoding="ros2msg", data=rosmsg.msgdef(typename).encode()
            )
            ch = self.channels[topic] = self.foxglove.Channel(topic, schema=schema, message_encoding="cdr")
        return ch

    def _ros(self, topic: str, typename: str, msg: dict, ns: int) -> None:
        self._channel(topic, typename).log(self.enc(typename, msg), log_time=ns)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def _beacons(self, ns: int) -> None:
        from foxglove.channels import SceneUpdateChannel
        from foxglove.messages import (
            Color,
            Pose,
            Quaternion,
            SceneEntity,
            SceneUpdate,
            SpherePrimitive,
            TextPrimitive,
            Timestamp,
            Vector3,
        )

        ch = self.channels.get(TOPIC_BEACONS)
        if ch is None:
            ch = self.channels[TOPIC_BEACONS] = SceneUpdateChannel(TOPIC_BEACONS)
        ids, pos_mm = self.beacons
        q = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
        spheres, texts = [], []
        for bid, p in zip(ids, pos_mm, strict=True):
            at = Pose(position=Vector3(x=p[0] / 1000.0, y=p[1] / 1000.0, z=p[2] / 1000.0), orientation=q)
            spheres.append(
                SpherePrimitive(
                    pose=at, size=Vector3(x=0.02, y=0.02, z=0.02), color=Color(r=1.0, g=0.8, b=0.1, a=1.0)
                )
            )
            texts.append(
                TextPrimitive(
                    pose=at,
                    billboard=True,
                    font_size=12.0,
                    scale_invariant=True,
                    text=f"B{int(bid)}",
                    color=Color(r=1.0, g=1.0, b=1.0, a=1.0),
                )
            )
        stamp = Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)
        entity = SceneEntity(
            timestamp=stamp, frame_id=self.frames.world, id="beacons", spheres=spheres, texts=texts
        )
        ch.log(SceneUpdate(entities=[entity]), log_time=ns)
        self.counts[TOPIC_BEACONS] = self.counts.get(TOPIC_BEACONS, 0) + 1

    def _resend(self, ns: int) -> None:
        now = time.monotonic()
        if now - self.last_resend < RESEND_S:
            return
        self.last_resend = now
        if self.rig:
            self._ros(
                rosmsg.TOPIC_TF_STATIC,
                rosmsg.TYPE_TF,
                rosmsg.tf_static_msg(self.rig, ns, self.frames.body),
                ns,
            )
            for cam in self.rig:
                self._ros(
                    rosmsg.topic_camera_info(cam.name),
                    rosmsg.TYPE_CAMINFO,
                    rosmsg.camera_info_msg(cam, ns),
                    ns,
                )
        if self.beacons is not None:
            self._beacons(ns)

    def publish_nav(self, row: dict) -> None:
        ns = rosmsg.row_stamp_ns(row)
        self._resend(ns)
        if rosmsg.usable(row):  # a NO_FIX cycle has no pose to send
            self._ros(rosmsg.TOPIC_POSE, rosmsg.TYPE_POSE, rosmsg.pose_msg(row, self.frames.world), ns)
            self._ros(
                rosmsg.TOPIC_TF,
                rosmsg.TYPE_TF,
                rosmsg.tf_body_msg(row, self.frames.world, self.frames.body),
                ns,
            )
        self._ros(
            rosmsg.TOPIC_DIAG, rosmsg.TYPE_DIAG, rosmsg.diagnostics_msg(ns, [rosmsg.nav_status(row)]), ns
        )

    def publish_camera(self, row: dict) -> None:
        ns = rosmsg.row_stamp_ns(row)
        self._ros(
            rosmsg.TOPIC_DIAG, rosmsg.TYPE_DIAG, rosmsg.diagnostics_msg(ns, [rosmsg.camera_status(row)]), ns
        )

    def stop(self) -> None:
        self.server.stop()


def load_beacons(table: Path | None):
    """(ids, positions mm) of the table's map, or None without a table."""
    if table is None:
        return None
    from ..table.check import read_table

    t = read_table(Path(table).read_bytes())
    return [int(b) for b in t.beacon_ids], [[float(v) for v in p] for p in t.beacon_pos]


def replay(folder: Path, pace: float, loop: bool, deadline: Callable[[], bool]) -> Iterator[tuple[str, dict]]:
    """('nav'|'camera', row) in UTC order, released at `pace` times the recorded spacing
    (0: at once), from the start again with `loop`, until `deadline()`."""
    from ..tlm.rosexport import read_rows

    nav = read_rows(folder / "nav.csv")
    cams = read_rows(folder / "camera.csv") if (folder / "camera.csv").is_file() else []
    if not nav:
        raise MfnsError(f"{folder}/nav.csv has no rows")
    rows = sorted(
        [(rosmsg.row_stamp_ns(r), 0, "nav", r) for r in nav]
        + [(rosmsg.row_stamp_ns(r), 1, "camera", r) for r in cams],
        key=lambda e: e[:2],
    )
    while True:
        t0, w0 = rows[0][0], time.monotonic()
        for ns, _k, kind, row in rows:
            if deadline():
                return
            if pace > 0:
                wait = (ns - t0) / 1e9 / pace - (time.monotonic() - w0)
                if wait > 0:
                    time.sleep(min(wait, 5.0))
            yield kind, row
        if not loop:
            return


def follow(folder: Path, deadline: Callable[[], bool]) -> Iterator[tuple[str, dict]]:
    """Rows as mfns-ground appends them to FOLDER's nav.csv and camera.csv."""
    tails = {"nav": Tail(folder / "nav.csv"), "camera": Tail(folder / "camera.csv")}
    while not deadline():
        got = False
        for kind, t in tails.items():
            for row in t.rows():
                got = True
                yield kind, row
        if not got:
            time.sleep(FOLLOW_POLL_S)


def run(
    source: Path,
    port: int,
    calib: Path | None = None,
    table: Path | None = None,
    pace: float = 1.0,
    loop: bool = False,
    follow_folder: bool = False,
    max_seconds: float | None = None,
    frames: Frames | None = None,
    ground: str | None = None,
    ready: Callable[[int], None] | None = None,
    stop: threading.Event | None = None,
) -> dict[str, int]:
    """Serve until max_seconds, Ctrl-C or `stop` is set (set by another thread: mfns live
    --snapshot's client once it has drawn), or until the data end when neither limit is given."""
    t_end = None if max_seconds is None else time.monotonic() + max_seconds

    def deadline() -> bool:
        return (t_end is not None and time.monotonic() >= t_end) or (stop is not None and stop.is_set())

    rig = load_cameras(calib, table)
    beacons = load_beacons(table)
    with tempfile.TemporaryDirectory(prefix="mfns-live-") as tmp:
        if follow_folder:
            if not Path(source).is_dir():
                raise MfnsError(f"{source}: --follow needs the folder mfns-ground --out writes")
            rows = follow(Path(source), deadline)
        else:
            rows = replay(ground_folder(Path(source), ground, Path(tmp)), pace, loop, deadline)
        live = Live(port, rig, beacons, frames or Frames())
        if ready is not None:
            ready(live.port)
        try:
            for kind, row in rows:
                if kind == "nav":
                    live.publish_nav(row)
                else:
                    live.publish_camera(row)
            while not deadline() and (t_end is not None or stop is not None):  # data ended: serve on
                time.sleep(0.1)
        except KeyboardInterrupt:
            pass
        finally:
            live.stop()
    return live.counts
