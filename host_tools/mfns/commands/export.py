"""`mfns export SOURCE -o OUTPUT`: the ground's output as ROS 2 messages (MCAP or rosbag2)."""

from __future__ import annotations

from pathlib import Path

from ..core.errors import MfnsError
from ..tlm import rosmsg


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "export",
        help="a ground output folder or recording as ROS 2 messages: MCAP file or rosbag2 folder",
        description=(
            "Reads an mfns-ground output folder (nav.csv, camera.csv) or a telemetry recording "
            "(decoded with mfns-ground) and writes ROS 2 messages (docs/robotics.md): "
            f"{rosmsg.TOPIC_POSE} geometry_msgs/PoseWithCovarianceStamped (metres, radians, the "
            "covariance from the cov_* columns in ROS order and units) for every FIX or DEGRADED "
            "cycle and none for NO_FIX, /tf world -> body, /tf_static body -> camera optical frames "
            "and /mfns/cam_<k>/camera_info (with --calib or --table), /diagnostics (status, reason, "
            "mode, protection levels, cameras). Stamps are UTC (the ground's utc column)."
        ),
    )
    p.add_argument(
        "source", type=Path, help="mfns-ground --out folder, or a recorded telemetry stream (.bin)"
    )
    p.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        metavar="FILE",
        help="the MCAP file or rosbag2 folder to write",
    )
    p.add_argument(
        "--format",
        choices=("mcap", "rosbag2"),
        default=None,
        help="mcap: one .mcap file (ros2 profile); rosbag2: a bag folder (metadata.yaml + storage). "
        "Default: mcap when OUTPUT ends in .mcap, else rosbag2",
    )
    p.add_argument(
        "--storage",
        choices=("mcap", "sqlite3"),
        default="mcap",
        help="rosbag2 storage plugin (default mcap, ROS 2 Iron and later; sqlite3 for Humble's default)",
    )
    p.add_argument(
        "--calib", type=Path, help="calib.json (docs/calib-results.md): camera_info and the camera TF"
    )
    p.add_argument("--table", type=Path, help="a calibration table (.mfnstbl): camera_info and the camera TF")
    p.add_argument(
        "--world-frame",
        default=rosmsg.WORLD_FRAME,
        help=f"frame id of the world (default {rosmsg.WORLD_FRAME})",
    )
    p.add_argument(
        "--body-frame",
        default=rosmsg.BODY_FRAME,
        help=f"frame id of the MFNS body (default {rosmsg.BODY_FRAME})",
    )
    p.add_argument(
        "--ground",
        help="the mfns-ground program that decodes a recording (default: $PATH, then the tree's build)",
    )
    p.set_defaults(func=run)


def need_ros_packages() -> None:
    """The extra "ros" (docs/robotics.md): a clear error, not a traceback, when it is absent."""
    import importlib.util

    missing = [m for m in ("mcap", "mcap_ros2", "rosbags") if importlib.util.find_spec(m) is None]
    if missing:
        raise MfnsError(f"needs {', '.join(missing)}: pip install './host_tools[ros]' (or make venv)")


def run(args) -> int:
    from ..tlm import rosexport

    need_ros_packages()
    fmt = args.format or ("mcap" if args.output.suffix == ".mcap" else "rosbag2")
    counts = rosexport.export(
        args.source,
        args.output,
        fmt,
        calib=args.calib,
        table=args.table,
        frames=rosexport.Frames(args.world_frame, args.body_frame),
        storage=args.storage,
        ground=args.ground,
    )
    print(
        f"{args.output}: {fmt}, {counts.rows} navigation cycles: {counts.poses} poses, "
        f"{counts.no_fix} NO_FIX without a pose; "
        + ", ".join(f"{t} {n}" for t, n in sorted(counts.by_topic.items()))
    )
    return 0
