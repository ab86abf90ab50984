"""`mfns compare DEMO_DIR`: the paper's comparison (Tables 3 and 5, availability) as report.md."""

from __future__ import annotations

from pathlib import Path

from ..core.errors import MfnsError


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "compare",
        help="one report beside the paper: Table 3 and Table 5 style, availability, figures",
        description="Reads a `make demo` folder (mk/demo.sh: calib/, turntable/, module/) and writes "
        "report.md: the paper's CPC vs our refinement vs truth (Table 3 style), mean and 1-sigma per "
        "axis for every calibration table in both experiments (Table 5 style), the fix rate with the "
        "reason for every class of cycle without a fix, and the figures of every run.",
    )
    p.add_argument("demo_dir", metavar="DEMO_DIR", help="the demo output folder (build/demo)")
    p.add_argument("-o", "--output", metavar="FILE", help="report file (default DEMO_DIR/report.md)")
    p.set_defaults(func=_run)


def _run(args) -> int:
    from ..analysis import compare

    if not Path(args.demo_dir).is_dir():
        raise MfnsError(f"{args.demo_dir}: not a folder")
    return compare.run(args)
