"""`mfns calib DATASET`: Zhang per camera, the paper's CPC, and the joint ML refinement."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..calib_results import load
from ..errors import MfnsError


def calibrate_dataset(dataset, truth_path=None, a10_iterations: int = 10, progress: bool = False):
    """Corner detection, Zhang, CPC, refinement and (with a truth file) the comparison.

    Returns (observations, rejected image names, Calibration, Comparison or None, seconds spent
    on detection, seconds spent on calibration).
    """
    from ..calib.dataset import load_dataset
    from ..calib.pipeline import calibrate
    from ..calib.report import compare
    from ..simulate.calib import truth_from_document

    truth_doc = load(truth_path) if truth_path else None
    t0 = time.monotonic()
    obs, rejected = load_dataset(dataset, progress=progress)
    t1 = time.monotonic()
    cal = calibrate(obs, a10_iterations=a10_iterations)
    cmp = None
    if truth_doc is not None:
        cmp = compare(cal, truth_from_document(truth_doc), obs, truth_doc)
    return obs, rejected, cal, cmp, t1 - t0, time.monotonic() - t1


def run(args) -> int:
    from ..calib.report import accuracy_table, extrinsics_table, intrinsics_table, write_outputs, write_plots

    t0 = time.monotonic()
    _obs, rejected, cal, cmp, t_detect, t_cal = calibrate_dataset(
        args.dataset, args.truth, 1 if args.a10_single_pass else 10, progress=not args.quiet
    )
    for name in rejected:
        print(f"warning: board not found in {name}; image skipped", file=sys.stderr)
    text = [intrinsics_table(cal), "", extrinsics_table(cal)]
    if cmp is not None:
        text += ["", accuracy_table(cmp)]
    out = Path(args.output)
    written = write_outputs(cal, out, f"mfns calib {args.dataset}")
    if args.plots:
        written += write_plots(cal, cmp, Path(args.plots))
    text.append("")
    text.append(
        f"corner detection {t_detect:.1f} s, calibration {t_cal:.1f} s, total {time.monotonic() - t0:.1f} s"
    )
    text.append("wrote " + ", ".join(str(p) for p in written))
    report = "\n".join(text)
    if args.report:
        Path(args.report).write_text(report + "\n")
    if not args.quiet:
        print(report)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calib",
        help="calibrate the MFNS from a turntable dataset (Zhang, CPC, joint ML refinement)",
        description="Detect the board's corners, calibrate each camera (Zhang), run the paper's CPC "
        "(Appendix A) and refine everything jointly by maximum likelihood. Writes the "
        "calibration-results JSON (docs/calib-results.md) of the refined solution, <stem>_paper.json "
        "with the paper's solution and OpenCV YAML per camera.",
    )
    p.add_argument("dataset", metavar="DATASET", help="dataset folder (docs/calib-dataset.md)")
    p.add_argument("--truth", help="truth.json of a simulated dataset: adds errors and the Cramér-Rao bound")
    p.add_argument(
        "-o", "--output", default="calib_results.json", help="results JSON (default calib_results.json)"
    )
    p.add_argument("--plots", metavar="DIR", help="write PNG plots into DIR")
    p.add_argument("--report", metavar="FILE", help="also write the text report to FILE")
    p.add_argument(
        "--a10-single-pass",
        action="store_true",
        help="solve Eq. A10 once, exactly as printed (default: iterate it to convergence)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bars or report on stdout")
    p.set_defaults(func=_checked)


def _checked(args) -> int:
    if not Path(args.dataset).is_dir():
        raise MfnsError(f"{args.dataset}: not a folder")
    return run(args)
