"""Issue 46: `mfns live`, bounded in time, serves Foxglove's WebSocket protocol on loopback: a
client (the `websockets` library, not the server's SDK) connects, subscribes and receives
/mfns/pose, decoded with rosbags' CDR decoder equal to a nav.csv row, and /mfns/beacons."""

from __future__ import annotations

import json
import math
import struct
import subprocess
import sys
import threading
import time

import pytest
from flight_replay import fly_replay

pytest.importorskip("foxglove")
ws_client = pytest.importorskip("websockets.sync.client")

SUBPROTOCOL = "foxglove.sdk.v1"  # the SDK 0.30 server's (the older foxglove.websocket.v1 is refused)


def mfns(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True)


@pytest.fixture(scope="module")
def run(bins, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("live")
    frames = tmp / "frames"
    res = mfns("sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "20", "--seed", "3")
    assert res.returncode == 0, res.stderr
    table = tmp / "table.mfnstbl"
    res = mfns(
        "table", "build", str(frames / "calib.json"), str(frames / "beacons.csv"), "-o", str(table), "-q"
    )
    assert res.returncode == 0, res.stderr
    return {"ground": fly_replay(bins, table, frames, tmp).ground, "table": table}


def start(run, *extra):
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "mfns",
            "live",
            str(run["ground"]),
            "--table",
            str(run["table"]),
            "--port",
            "0",
            *extra,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    assert line.startswith("mfns live: ws://127.0.0.1:"), line + proc.stderr.read()
    port = int(line.split("ws://127.0.0.1:")[1].split()[0])
    return proc, port


def test_a_websocket_client_on_loopback_receives_the_pose_and_the_beacons(run):
    from rosbags.typesys import Stores, get_typestore

    from mfns.tlm.rosexport import read_rows

    nav = {r["cycle"]: r for r in read_rows(run["ground"] / "nav.csv") if r["status"] != "NO_FIX"}
    t0 = time.monotonic()
    proc, port = start(run, "--loop", "--max-seconds", "12")
    try:
        with ws_client.connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], open_timeout=5) as ws:
            assert ws.subprotocol == SUBPROTOCOL
            channels: dict = {}
            subscribed: dict[int, str] = {}
            got: dict[str, list[bytes]] = {}
            deadline = time.monotonic() + 8
            while time.monotonic() < deadline and not {"/mfns/pose", "/mfns/beacons"} <= set(got):
                msg = ws.recv(timeout=max(0.1, deadline - time.monotonic()))
                if isinstance(msg, str):
                    op = json.loads(msg)
                    if op.get("op") == "advertise":
                        for c in op["channels"]:
                            channels[c["id"]] = c
                        want = [c for c in op["channels"] if c["topic"] in ("/mfns/pose", "/mfns/beacons")]
                        subs = [{"id": 100 + c["id"], "channelId": c["id"]} for c in want]
                        for s in subs:
                            subscribed[s["id"]] = channels[s["channelId"]]["topic"]
                        if subs:
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                    continue
                assert msg[0] == 0x01  # messageData: opcode, subscription id, log time, payload
                sub_id, _log_ns = struct.unpack_from("<IQ", msg, 1)
                got.setdefault(subscribed[sub_id], []).append(msg[13:])
    finally:
        proc.wait(timeout=30)
    assert proc.returncode == 0, proc.stderr.read()
    assert time.monotonic() - t0 < 25  # bounded by --max-seconds
    pose_ch = next(c for c in channels.values() if c["topic"] == "/mfns/pose")
    assert (
        pose_ch["encoding"] == "cdr"
        and pose_ch["schemaName"] == "geometry_msgs/msg/PoseWithCovarianceStamped"
    )
    store = get_typestore(Stores.ROS2_HUMBLE)
    poses = [
        store.deserialize_cdr(b, "geometry_msgs/msg/PoseWithCovarianceStamped") for b in got["/mfns/pose"]
    ]
    assert poses
    rows_by_stamp = {}
    for r in nav.values():
        from mfns.tlm.rosmsg import row_stamp_ns

        rows_by_stamp[row_stamp_ns(r)] = r
    for m in poses:
        r = rows_by_stamp[m.header.stamp.sec * 10**9 + m.header.stamp.nanosec]  # a FIX/DEGRADED row
        assert m.header.frame_id == "mfns_world"
        assert m.pose.pose.position.x == float(r["x_mm"]) / 1000.0
        assert math.isclose(m.pose.covariance[0], float(r["cov_x_x"]) * 1e-6, rel_tol=1e-12)
    assert got["/mfns/beacons"]
    print(
        f"\nmfns live: {len(poses)} poses and {len(got['/mfns/beacons'])} beacon updates on ws://127.0.0.1:{port}"
    )


def test_bad_options_are_one_line(run):
    res = mfns("live", str(run["ground"]), "--pace", "-1")
    assert res.returncode == 2 and "--pace" in res.stderr and "Traceback" not in res.stderr
    res = mfns("live", str(run["ground"] / "nav.csv"), "--follow")
    assert res.returncode == 2 and "--follow" in res.stderr


def test_tail_gives_whole_rows_only(tmp_path):
    from mfns.ground.live import Tail

    p = tmp_path / "nav.csv"
    t = Tail(p)
    assert t.rows() == []  # not there yet
    p.write_text("cycle,status\n0,NO_")
    assert t.rows() == []  # the header, and a row not finished
    with open(p, "a") as f:
        f.write("FIX\n1,FIX\n2,DEG")
    assert t.rows() == [{"cycle": "0", "status": "NO_FIX"}, {"cycle": "1", "status": "FIX"}]
    with open(p, "a") as f:
        f.write("RADED\n")
    assert t.rows() == [{"cycle": "2", "status": "DEGRADED"}]


def write_rows(path, rows):
    for r in rows:
        with open(path, "a") as f:
            f.write(r)
        time.sleep(0.1)


def test_follow_serves_rows_as_the_ground_writes_them(run, tmp_path):
    """--follow: a folder that grows while the server runs (as mfns-ground writes it)."""
    from rosbags.typesys import Stores, get_typestore

    src = (run["ground"] / "nav.csv").read_text().splitlines(keepends=True)
    live_dir = tmp_path / "ground"
    live_dir.mkdir()
    (live_dir / "nav.csv").write_text(src[0])  # the header only: nothing flown yet
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "mfns",
            "live",
            str(live_dir),
            "--follow",
            "--port",
            "0",
            "--max-seconds",
            "10",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    assert line.startswith("mfns live: ws://127.0.0.1:"), line + proc.stderr.read()
    port = int(line.split("ws://127.0.0.1:")[1].split()[0])
    got = []
    try:
        with ws_client.connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], open_timeout=5) as ws:
            deadline = time.monotonic() + 8
            appended = subscribed = False
            while time.monotonic() < deadline and not got:
                try:
                    msg = ws.recv(timeout=0.5)
                except TimeoutError:
                    msg = None
                if isinstance(msg, str):
                    op = json.loads(msg)
                    if op.get("op") == "advertise":
                        subs = [
                            {"id": 1, "channelId": c["id"]}
                            for c in op["channels"]
                            if c["topic"] == "/mfns/pose"
                        ]
                        if subs:
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                            time.sleep(0.3)  # the subscription in place before any pose
                            subscribed = True
                elif isinstance(msg, bytes) and msg[0] == 0x01:
                    got.append(msg[13:])
                if subscribed and not appended:  # the ground writes its rows now, one per 0.1 s
                    threading.Thread(
                        target=write_rows, args=(live_dir / "nav.csv", src[1:]), daemon=True
                    ).start()
                    appended = True
    finally:
        proc.wait(timeout=30)
    assert proc.returncode == 0, proc.stderr.read()
    m = get_typestore(Stores.ROS2_HUMBLE).deserialize_cdr(
        got[0], "geometry_msgs/msg/PoseWithCovarianceStamped"
    )
    xs = {float(r.split(",")[9]) / 1000.0 for r in src[1:] if ",NO_FIX," not in r}
    assert m.pose.pose.position.x in xs
