"""`mfns mc`: the paper's Section 3 error analysis by Monte Carlo (mfns.analysis.mc)."""

from __future__ import annotations

from ..analysis import mc
from ..core import study


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "mc",
        help="error analysis: pixel error vs calibration errors (Figs. 4-6), pose error extension",
        description="Monte Carlo of the paper's Section 3 with Table 1's parameters; "
        "writes fig4-6 PNG/CSV, pose_vs_calib.{csv,png} and summary.json into OUT. The pose "
        "extension's points run as a study (docs/studies.md): on a local Dask cluster by default, "
        "--serial in this process, --scheduler on a cluster; the same numbers on each.",
    )
    p.add_argument("out", metavar="OUT", help="output folder (created if missing; files are overwritten)")
    p.add_argument("--trials", type=int, default=10000, help="trials per point (default 10000)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--z-min", type=float, default=mc.DEFAULT_Z_MIN_MM, help="nearest beacon depth, mm (default 100)"
    )
    p.add_argument(
        "--pose-trials",
        type=int,
        default=200,
        help="trials per point of the end-to-end pose extension, 0 to skip (default 200)",
    )
    p.add_argument(
        "--solver",
        choices=("flight", "reference"),
        default="flight",
        help="pose solver of the extension: flight = the C solver of firmware/nav/pose/pose.h through "
        "the core library (the installed package's own, else $MFNS_CORE_LIB, else the tree's "
        "`make lib`); reference = the host "
        "Python Gauss-Newton (mfns.model.pose_ref) (default flight)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    study.add_arguments(p)
    p.set_defaults(func=mc.run)
