"""`mfns ground`: the Yamcs ground system and the operator's view over it (mfns.ground;
docs/uplink.md "Yamcs", docs/operators.md). Both need the ground's Python packages
(ground/requirements.txt, `make ground-venv`); `make ground-yamcs` and `make ground-view` run them."""

from __future__ import annotations

from pathlib import Path

DEFAULT_VIEW_PORT = 8095


def _yamcs(args) -> int:
    from ..ground import ground_yamcs as gy

    rundir = Path(args.rundir).resolve()
    rundir.mkdir(parents=True, exist_ok=True)
    return gy.serve(rundir)


def _check(args) -> int:
    from ..ground import ground_yamcs as gy

    reason = gy.why_not()
    print(reason or "ok")
    return 0 if reason is None else 1


def _view(args) -> int:
    from ..ground import ground_yamcs_view as view

    return view.run(args.port)


def register(subparsers) -> None:
    parser = subparsers.add_parser("ground", help="the Yamcs ground system and the operator's view over it")
    sub = parser.add_subparsers(dest="ground_command", metavar="PART")
    p = sub.add_parser(
        "yamcs",
        help="run Yamcs with the project's dictionaries in the foreground (Ctrl-C stops it)",
        description="Prepare RUNDIR (etc/, mdb/) and run the Yamcs server on 127.0.0.1 with the "
        "MFNS telemetry, telecommand and ground dictionaries; prints the links to feed it.",
    )
    p.add_argument("rundir", metavar="RUNDIR", help="run folder (created if missing)")
    p.set_defaults(func=_yamcs)
    p = sub.add_parser(
        "check",
        help="say whether Yamcs can run here (prints ok or the reason; exit 1 if it cannot)",
        description="Check the Java runtime and the Yamcs bundle the ground system needs.",
    )
    p.set_defaults(func=_check)
    p = sub.add_parser(
        "view",
        help="the operator's view: a local web page over a running Yamcs (docs/operators.md)",
        description="Serve the operator's view on 127.0.0.1:PORT over the Yamcs that "
        "`mfns ground yamcs` (make ground-yamcs) runs.",
    )
    p.add_argument(
        "--port",
        type=int,
        default=DEFAULT_VIEW_PORT,
        help=f"HTTP port on 127.0.0.1 (default {DEFAULT_VIEW_PORT})",
    )
    p.set_defaults(func=_view)
    parser.set_defaults(func=lambda args: parser.print_help() or 2)
