"""Issue 46: a picture of the live Foxglove stream (`mfns live --snapshot`, mfns.ground.live_view).

The Foxglove app needs its vendor's web site, which this machine cannot reach: the picture is
drawn offline (matplotlib) by a client of the stream, from what came over the WebSocket only.
Checked: the protobuf reader of the beacons' SceneUpdate against the SDK's own encoder, and a
flown module run served by `mfns live` and drawn: every beacon of the table, the three frusta
placed by /tf_static, the poses; the PNG is a picture (not blank) and small. Set
MFNS_LIVE_SHOT=PATH (make live-view-shot) to keep it there (docs/img/live-view.png).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from flight_replay import fly_replay

pytest.importorskip("foxglove")
pytest.importorskip("websockets.sync.client")

REPO = Path(__file__).resolve().parents[2]
SHOT_LIMIT_BYTES = 200_000  # a picture committed under docs/ stays small


def mfns(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True, timeout=timeout
    )


def test_the_scene_update_reader_reads_what_the_sdk_encodes():
    from foxglove.messages import (
        Color,
        Pose,
        Quaternion,
        SceneEntity,
        SceneUpdate,
        SpherePrimitive,
        TextPrimitive,
        Vector3,
    )

    from mfns.ground.live_view import scene_update_beacons

    q = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    pts = [(1.25, -0.5, 0.0), (0.0, 2.0, 3.5), (-1e-3, 0.0, 7.0)]
    at = [Pose(position=Vector3(x=x, y=y, z=z), orientation=q) for x, y, z in pts]
    ent = SceneEntity(
        frame_id="w",
        id="beacons",
        spheres=[
            SpherePrimitive(pose=a, size=Vector3(x=0.02, y=0.02, z=0.02), color=Color(r=1.0)) for a in at
        ],
        texts=[TextPrimitive(pose=a, text=f"B{i}") for i, a in enumerate(at)],
    )
    got = scene_update_beacons(SceneUpdate(entities=[ent]).encode())
    assert [lab for lab, _ in got] == ["B0", "B1", "B2"]
    assert np.array_equal(np.array([p for _, p in got]), np.array(pts))


def test_mfns_live_snapshot_draws_the_stream(bins, tmp_path):
    frames = tmp_path / "frames"
    res = mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "40", "--seed", "3")
    assert res.returncode == 0, res.stderr
    table = tmp_path / "table.mfnstbl"
    res = mfns(
        "table", "build", str(frames / "calib.json"), str(frames / "beacons.csv"), "-o", str(table), "-q"
    )
    assert res.returncode == 0, res.stderr
    ground = fly_replay(bins, table, frames, tmp_path).ground
    shot = tmp_path / "live-view.png"
    res = mfns(
        "live",
        str(ground),
        "--table",
        str(table),
        "--port",
        "0",
        "--loop",
        "--pace",
        "2",
        "--snapshot",
        str(shot),
        "--snapshot-seconds",
        "4",
        "--max-seconds",
        "60",
    )
    assert res.returncode == 0, res.stderr
    m = re.search(r"(\d+) poses, (\d+) beacons, (\d+) frusta, 3-sigma ellipsoid x(\S+)", res.stdout)
    assert m, res.stdout
    n_beacons = len((frames / "beacons.csv").read_text().strip().splitlines()) - 1
    assert int(m[1]) > 0 and int(m[2]) == n_beacons and int(m[3]) == 3, res.stdout
    import matplotlib.image as mpimg

    img = mpimg.imread(shot)
    assert img.shape[0] >= 400 and img.shape[1] >= 600
    assert float(img[..., :3].std()) > 0.05  # a picture, not a blank page
    size = shot.stat().st_size
    assert size < SHOT_LIMIT_BYTES, size
    keep = os.environ.get("MFNS_LIVE_SHOT")
    if keep:
        dest = Path(keep) if Path(keep).is_absolute() else REPO / keep
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(shot, dest)
    print(f"\nmfns live --snapshot: {res.stdout.strip().splitlines()[-1]}; {size} bytes")


def test_snapshot_without_poses_is_a_clear_error(tmp_path):
    """A stream with no pose (all NO_FIX) has nothing to draw: one line, exit 2 (bad input)."""
    g = tmp_path / "g"
    g.mkdir()
    (g / "nav.csv").write_text(
        "t_s,seq,cycle,status,reason,mode,utc,time_source,ground_utc\n"
        "0.0,0,0,NO_FIX,TOO_FEW,ACQUIRE,2026-12-06T00:00:00.000000Z,FLIGHT_SYNCED,2026-12-06T00:00:00.000000Z\n"
    )
    res = mfns(
        "live", str(g), "--port", "0", "--snapshot", str(tmp_path / "x.png"), "--snapshot-seconds", "1.5"
    )
    assert res.returncode == 2 and "--snapshot: no /mfns/pose received" in res.stderr, res.stderr
    assert "Traceback" not in res.stderr


def build_strict(store, msgtype: str, value):
    """A rosbags message of msgtype from the dict the ROS 2 node of docs/robotics.md hands
    to rosidl's set_message_fields: every field given, no other key (set_message_fields
    refuses an unknown one), arrays of the declared length."""
    from rosbags.typesys.base import Nodetype

    _, fields = store.fielddefs[msgtype]
    assert set(value) == {n for n, _ in fields}, (msgtype, sorted(value))
    args = {}
    for name, (kind, detail) in fields:
        v = value[name]
        if kind == Nodetype.NAME:
            args[name] = build_strict(store, detail, v)
        elif kind == Nodetype.ARRAY:
            (sub, _), n = detail
            assert sub == Nodetype.BASE and len(v) == n, (msgtype, name)
            args[name] = np.array(v, dtype=np.float64)
        else:
            args[name] = v
    return store.types[msgtype](**args)


def test_the_ros2_node_of_the_docs_gets_whole_messages(bins, tmp_path):
    """The live ROS 2 path of docs/robotics.md (no ROS 2 here: its data only): its code block
    names the functions used here; the rows `follow` yields as mfns-ground writes them, given
    to rosmsg.pose_msg, are whole PoseWithCovarianceStamped messages (built strictly, CDR
    round trip) equal to nav.csv, and NO_FIX rows give none."""
    from rosbags.typesys import Stores, get_typestore

    from mfns.ground.live import follow
    from mfns.tlm import rosmsg

    doc = (REPO / "docs" / "robotics.md").read_text()
    block = doc.split("```python\n")[-1].split("```")[0]
    for name in ("follow(", "rosmsg.usable(row)", "rosmsg.pose_msg(row)", "set_message_fields(msg,"):
        assert name in block, name
    frames = tmp_path / "frames"
    res = mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "12", "--seed", "3")
    assert res.returncode == 0, res.stderr
    table = tmp_path / "table.mfnstbl"
    res = mfns(
        "table", "build", str(frames / "calib.json"), str(frames / "beacons.csv"), "-o", str(table), "-q"
    )
    assert res.returncode == 0, res.stderr
    ground = fly_replay(bins, table, frames, tmp_path).ground
    store = get_typestore(Stores.ROS2_HUMBLE)
    t_end = time.monotonic() + 3.0
    published, nofix = [], 0
    for kind, row in follow(ground, deadline=lambda: time.monotonic() > t_end):
        if kind != "nav":
            continue
        if not rosmsg.usable(row):
            nofix += 1
            continue
        msg = build_strict(store, rosmsg.TYPE_POSE, rosmsg.pose_msg(row))
        back = store.deserialize_cdr(store.serialize_cdr(msg, rosmsg.TYPE_POSE), rosmsg.TYPE_POSE)
        assert back.header.frame_id == rosmsg.WORLD_FRAME
        assert back.pose.pose.position.x == float(row["x_mm"]) / 1000.0
        assert back.pose.covariance[0] == pytest.approx(float(row["cov_x_x"]) * 1e-6, rel=1e-12)
        published.append(back)
    nav = (ground / "nav.csv").read_text().splitlines()[1:]
    assert len(published) + nofix == len(nav) and published and nofix
