"""`mfns nees`: does the flight pose covariance mean what it says? (mfns.analysis.mc_nees)."""

from __future__ import annotations

from ..analysis import mc_nees


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "nees",
        help="consistency of the flight pose covariance: NEES of the C solver on the module scenario",
        description="Mean NEES and the fraction inside the chi-square(6) 95 % bound of the flight "
        "solver's covariance (firmware/nav/pose/pose.h through the core library) with pixel noise, "
        "survey error and calibration error (docs/error-analysis.md); prints the table.",
    )
    p.add_argument("--trials", type=int, default=2000, help="poses per case (default 2000)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.set_defaults(func=mc_nees.report)
