"""Issue 46: the Foxglove / Lichtblick layout (ground/foxglove/mfns-layout.json) draws what
`mfns live` sends. Without the app: the layout's topics, frames and diagnostic names are read
from the JSON and compared with what a WebSocket client (the `websockets` library) is told by
a running server (mfns.ground.live.Live on loopback): every topic the layout shows is
advertised with a schema its panel draws, every frame it follows or configures is in the TF
tree the server sends, and the status the Diagnostics panel selects is the navigation's.
The screenshot with the app itself is mk/foxglove_shot.py (docs/robotics.md)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("foxglove")
ws_client = pytest.importorskip("websockets.sync.client")

REPO = Path(__file__).resolve().parents[2]
LAYOUT = REPO / "ground" / "foxglove" / "mfns-layout.json"
SUBPROTOCOL = "foxglove.sdk.v1"
# the message schemas each panel type of the layout draws (Foxglove's and Lichtblick's names)
PANEL_SCHEMAS = {
    "3D": {
        "geometry_msgs/msg/PoseWithCovarianceStamped",
        "sensor_msgs/msg/CameraInfo",
        "foxglove.SceneUpdate",
        "tf2_msgs/msg/TFMessage",
    },
    "DiagnosticSummary": {"diagnostic_msgs/msg/DiagnosticArray"},
    "DiagnosticStatusPanel": {"diagnostic_msgs/msg/DiagnosticArray"},
}


def layout_uses() -> dict:
    """{'topics': {topic: panel type}, 'frames': set, 'statuses': {(hardware_id, name)}}."""
    doc = json.loads(LAYOUT.read_text())
    shown: set[str] = set()

    def leaves(node) -> None:
        if isinstance(node, str):
            shown.add(node)
        else:
            leaves(node["first"])
            leaves(node["second"])

    leaves(doc["layout"])
    assert shown == set(doc["configById"]), "every configured panel is in the layout and back"
    topics: dict[str, str] = {}
    frames: set[str] = set()
    statuses: set[tuple[str, str]] = set()
    for pid, cfg in doc["configById"].items():
        kind = pid.split("!")[0]
        assert kind in PANEL_SCHEMAS, pid
        if kind == "3D":
            topics.update({t: kind for t, s in cfg["topics"].items() if s.get("visible")})
            frames.add(cfg["followTf"])
            frames.update(k.removeprefix("frame:") for k in cfg["transforms"])
            frames.update(layer["frameId"] for layer in cfg["layers"].values() if "frameId" in layer)
        else:
            topics[cfg["topicToRender"]] = kind
            if "selectedName" in cfg:
                statuses.add((cfg["selectedHardwareId"], cfg["selectedName"]))
    return {"topics": topics, "frames": frames, "statuses": statuses}


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """A Live server with a simulated rig and map, one resend and one navigation row sent,
    and what a client was advertised and received on /tf_static and /diagnostics."""
    from rosbags.typesys import Stores, get_typestore

    from mfns.ground.live import TOPIC_BEACONS, Live, load_beacons
    from mfns.tlm import rosmsg
    from mfns.tlm.rosexport import Frames, load_cameras

    tmp = tmp_path_factory.mktemp("layout")
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "mfns",
            "sim",
            "nav",
            str(tmp / "f"),
            "--quiet",
            "--scenario",
            "module",
            "--frames",
            "1",
            "--seed",
            "3",
        ],
        check=False,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr
    assert load_beacons(None) is None
    beacons = ([7, 9], [[1000.0, 0.0, 0.0], [0.0, 500.0, -1000.0]])
    live = Live(0, load_cameras(tmp / "f" / "calib.json", None), beacons, Frames())
    row = {
        "status": "NO_FIX",
        "reason": "0",
        "mode": "ACQUIRE",
        "cycle": "1",
        "utc": "2026-12-06T00:00:00.000000Z",
        "time_source": "FLIGHT_SYNCED",
    }
    try:
        with ws_client.connect(
            f"ws://127.0.0.1:{live.port}", subprotocols=[SUBPROTOCOL], open_timeout=5
        ) as ws:
            channels: dict[str, dict] = {}
            got: dict[str, bytes] = {}
            sub_topic: dict[int, str] = {}
            end = time.monotonic() + 8
            sent = False
            wanted = {rosmsg.TOPIC_TF_STATIC, rosmsg.TOPIC_DIAG}  # data; the beacons: advertised
            while time.monotonic() < end and not (wanted <= set(got) and TOPIC_BEACONS in channels):
                try:
                    m = ws.recv(timeout=0.2)
                except TimeoutError:
                    m = None
                if isinstance(m, str):
                    msg = json.loads(m)
                    if msg.get("op") == "advertise":
                        subs = []
                        for ch in msg["channels"]:
                            channels[ch["topic"]] = ch
                            sid = len(sub_topic) + 1
                            sub_topic[sid] = ch["topic"]
                            subs.append({"id": sid, "channelId": ch["id"]})
                        ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                elif isinstance(m, bytes) and m[0] == 1:  # message data: op, sub id u32, time u64
                    got[sub_topic[int.from_bytes(m[1:5], "little")]] = m[13:]
                if len(channels) >= 7 and not sent:  # pose, tf, tf_static, diagnostics, 3 camera infos
                    time.sleep(0.3)  # the subscriptions reach the server first
                    live.publish_nav(row)  # first the resend: /tf_static, camera info, beacons
                    sent = True
    finally:
        live.stop()
    store = get_typestore(Stores.ROS2_HUMBLE)
    decoded = {
        t: store.deserialize_cdr(got[t], rosmsg.TYPE_TF if t == rosmsg.TOPIC_TF_STATIC else rosmsg.TYPE_DIAG)
        for t in (rosmsg.TOPIC_TF_STATIC, rosmsg.TOPIC_DIAG)
        if t in got
    }
    return {"channels": channels, "decoded": decoded}


def test_every_topic_of_the_layout_is_advertised_with_a_schema_its_panel_draws(served):
    uses = layout_uses()
    assert {"/mfns/pose", "/mfns/beacons", "/diagnostics"} <= set(uses["topics"])
    assert sum(t.endswith("/camera_info") for t in uses["topics"]) == 3, "the three frusta"
    for topic, panel in uses["topics"].items():
        ch = served["channels"].get(topic)
        assert ch is not None, f"the layout shows {topic}, which mfns live does not advertise"
        assert ch["schemaName"] in PANEL_SCHEMAS[panel], (topic, ch["schemaName"], panel)


def test_every_frame_of_the_layout_is_in_the_tf_tree(served):
    from mfns.tlm import rosmsg

    tf = served["decoded"][rosmsg.TOPIC_TF_STATIC]
    tree = {rosmsg.WORLD_FRAME, rosmsg.BODY_FRAME}  # /tf: world -> body with every pose
    tree |= {t.header.frame_id for t in tf.transforms} | {t.child_frame_id for t in tf.transforms}
    missing = layout_uses()["frames"] - tree
    assert not missing, f"the layout names frames mfns live does not send: {sorted(missing)}"


def test_the_status_panel_selects_the_navigation_status(served):
    from mfns.tlm import rosmsg

    diag = served["decoded"][rosmsg.TOPIC_DIAG]
    sent = {(s.hardware_id, s.name) for s in diag.status}
    assert layout_uses()["statuses"] and layout_uses()["statuses"] <= sent, sent
