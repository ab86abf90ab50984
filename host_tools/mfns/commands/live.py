"""`mfns live SOURCE`: the pose, beacons, camera frusta and status as a Foxglove WebSocket."""

from __future__ import annotations

import math
from pathlib import Path

from ..core.errors import MfnsError
from ..tlm import rosmsg


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "live",
        help="a live Foxglove WebSocket on 127.0.0.1: pose with covariance, TF, beacons, frusta, status",
        description=(
            "Serves the navigation solution to Foxglove (open ws://127.0.0.1:PORT in Foxglove's "
            "'Open connection'; docs/robotics.md): /mfns/pose (PoseWithCovarianceStamped, none on "
            "NO_FIX), /tf, /tf_static, /mfns/cam_<k>/camera_info (frusta), /diagnostics (status, "
            "reason, protection levels) as ROS 2 messages, and /mfns/beacons (the table's map). "
            "SOURCE is an mfns-ground --out folder, replayed at --pace or followed as the ground "
            "writes it (--follow: live), or a telemetry recording. Ctrl-C stops it."
        ),
    )
    p.add_argument(
        "source", type=Path, help="mfns-ground --out folder, or a recorded telemetry stream (.bin)"
    )
    p.add_argument(
        "--port", type=int, default=8765, help="WebSocket port on 127.0.0.1 (default 8765; 0: any free)"
    )
    p.add_argument("--table", type=Path, help="calibration table: camera frusta, camera TF and the beacons")
    p.add_argument("--calib", type=Path, help="calib.json: camera frusta and camera TF (no beacons)")
    p.add_argument(
        "--follow",
        action="store_true",
        help="follow the folder as mfns-ground writes it (the ground stream, live)",
    )
    p.add_argument(
        "--pace",
        type=float,
        default=1.0,
        help="replay at this many times the recorded pace (default 1; 0: at once)",
    )
    p.add_argument("--loop", action="store_true", help="replay from the start again when the data end")
    p.add_argument("--max-seconds", type=float, help="stop serving after S seconds (default: until Ctrl-C)")
    p.add_argument(
        "--world-frame", default=rosmsg.WORLD_FRAME, help=f"world frame id (default {rosmsg.WORLD_FRAME})"
    )
    p.add_argument(
        "--body-frame", default=rosmsg.BODY_FRAME, help=f"body frame id (default {rosmsg.BODY_FRAME})"
    )
    p.add_argument("--ground", help="the mfns-ground program that decodes a recording")
    p.add_argument(
        "--snapshot",
        type=Path,
        metavar="PNG",
        help="connect a client to the server, draw what it receives (beacons, track, pose with its "
        "covariance ellipsoid, camera frusta, status) into PNG and stop: an offline picture of the "
        "stream, drawn with matplotlib, not by the Foxglove app (docs/robotics.md)",
    )
    p.add_argument(
        "--snapshot-seconds",
        type=float,
        default=5.0,
        help="how long the --snapshot client listens before it draws (default 5)",
    )
    p.set_defaults(func=run)


def run(args) -> int:
    import importlib.util

    if importlib.util.find_spec("foxglove") is None or importlib.util.find_spec("mcap_ros2") is None:
        raise MfnsError(
            "needs foxglove-sdk and mcap-ros2-support: pip install './host_tools[ros]' (or make venv)"
        )
    if not (math.isfinite(args.pace) and args.pace >= 0):
        raise MfnsError(f"--pace {args.pace}: expected a factor >= 0")
    if args.max_seconds is not None and not (math.isfinite(args.max_seconds) and args.max_seconds > 0):
        raise MfnsError(f"--max-seconds {args.max_seconds}: expected seconds > 0")
    if not 0 <= args.port <= 65535:
        raise MfnsError(f"--port {args.port}: expected 0..65535")
    if not (math.isfinite(args.snapshot_seconds) and args.snapshot_seconds > 0):
        raise MfnsError(f"--snapshot-seconds {args.snapshot_seconds}: expected seconds > 0")
    import threading

    from ..ground import live
    from ..tlm.rosexport import Frames

    stop = threading.Event() if args.snapshot else None
    shot: dict = {}

    def snapshot(url: str) -> None:
        from ..ground import live_view

        try:
            scene = live_view.capture(url, args.snapshot_seconds)
            shot["drawn"] = live_view.render(scene, args.snapshot, body_frame=args.body_frame)
        except MfnsError as e:
            shot["error"] = str(e)
        except Exception as e:  # reported by the command below, never a hung server
            shot["error"] = f"{type(e).__name__}: {e}"
        finally:
            assert stop is not None
            stop.set()

    def ready(port: int) -> None:
        print(
            f"mfns live: ws://{live.HOST}:{port} (Foxglove: Open connection -> Foxglove WebSocket)",
            flush=True,
        )
        if args.snapshot:
            threading.Thread(target=snapshot, args=(f"ws://{live.HOST}:{port}",), daemon=True).start()

    counts = live.run(
        args.source,
        args.port,
        calib=args.calib,
        table=args.table,
        pace=args.pace,
        loop=args.loop,
        follow_folder=args.follow,
        max_seconds=args.max_seconds,
        frames=Frames(args.world_frame, args.body_frame),
        ground=args.ground,
        ready=ready,
        stop=stop,
    )
    print("mfns live: sent " + ", ".join(f"{t} {n}" for t, n in sorted(counts.items())), flush=True)
    if args.snapshot:
        if "error" in shot:
            raise MfnsError(f"--snapshot: {shot['error']}")
        if "drawn" not in shot:
            raise MfnsError("--snapshot: the server stopped before the picture was drawn (--max-seconds?)")
        d = shot["drawn"]
        print(
            f"mfns live: {args.snapshot}: {d['poses']} poses, {d['beacons']} beacons, {d['frusta']} frusta, "
            f"3-sigma ellipsoid x{d['ellipsoid_gain']:g}",
            flush=True,
        )
    return 0
