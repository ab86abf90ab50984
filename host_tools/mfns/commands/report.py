"""`mfns report`: Fig. 11-style plots and a Table 5-style summary from mfns-ground output."""

from __future__ import annotations

from pathlib import Path

from ..analysis import report as rpt
from ..core.errors import MfnsError


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "report",
        help="navigation accuracy plots and summary from mfns-ground's nav.csv (and a truth file)",
        description=(
            "Reads nav.csv written by mfns-ground (or its folder) and optionally a truth.csv "
            "(docs/nav-frames.md); matches them by time; writes nav_errors_vs_time.png, "
            "nav_errors_vs_yaw.png (with truth), summary.csv, summary.md and summary.json, and "
            "prints the mean and 1-sigma per axis (roll, pitch, yaw, x, y, z). With truth it also "
            "checks the reported covariance: the NEES of every fix (e^T P^-1 e with the 6x6 "
            "covariance columns, or the diagonal NEES of the 1-sigma columns of an older nav.csv) "
            "against the chi-square(6) expectation, in the summary and nees.png."
        ),
    )
    p.add_argument("nav", type=Path, help="nav.csv, or the mfns-ground output folder holding it")
    p.add_argument(
        "--truth", type=Path, help="truth.csv: frame,t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg"
    )
    p.add_argument("--out", type=Path, help="output folder (default: the folder of nav.csv)")
    p.add_argument(
        "--time-tolerance",
        type=float,
        default=0.02,
        help="max |t_nav - t_truth| in s for a match (default 0.02, under half a cycle at 18.6 Hz)",
    )
    p.add_argument("--all-status", action="store_true", help="also use NO_FIX rows (default: FIX, DEGRADED)")
    p.add_argument("--no-plots", action="store_true", help="summary only")
    p.add_argument(
        "--partial",
        action="store_true",
        help="the nav log covers part of the truth's run (e.g. mfns-nav --max-cycles); it must "
        "still lie within the truth's time span",
    )
    p.add_argument(
        "--accept-gross-errors",
        action="store_true",
        help="report errors no fix of this run can have (median NEES > 1e4, median position "
        "error > 1 m or attitude error > 30 deg); by default such a truth is refused as another run's",
    )
    p.add_argument("--title", help="name of the run, heading the summary and every figure")
    p.set_defaults(func=run)


def run(args) -> int:
    nav_path = args.nav
    if not 0.0 <= args.time_tolerance < 3600.0:  # also refuses NaN
        raise MfnsError(f"--time-tolerance {args.time_tolerance}: expected seconds in [0, 3600)")
    nav = rpt.load_nav(nav_path)
    truth = rpt.load_truth(args.truth) if args.truth is not None else None
    if truth is not None:
        rpt.check_same_run(nav, truth, str(nav_path), partial=args.partial)
    rep = rpt.build_report(nav, truth, tolerance_s=args.time_tolerance, all_status=args.all_status)
    gross = None if args.accept_gross_errors else rpt.gross_error(rep)
    if gross is not None:
        raise MfnsError(f"{nav_path} against {args.truth}: {gross}")
    out = args.out if args.out is not None else (nav_path if nav_path.is_dir() else nav_path.parent)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MfnsError(f"cannot create {out}: {exc}") from exc
    md = rpt.summary_markdown(rep, args.title)
    (out / "summary.md").write_text(md)
    rpt.write_summary_csv(rep, out / "summary.csv")
    rpt.write_summary_json(rep, out / "summary.json", args.title)
    written = [] if args.no_plots else rpt.write_plots(rep, out, args.title)
    print(md, end="")
    for p in [out / "summary.csv", out / "summary.md", out / "summary.json", *written]:
        print(f"wrote {p}")
    return 0
