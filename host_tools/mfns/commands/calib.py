"""`mfns calib DATASET`: Zhang per camera, the paper's CPC, and the joint ML refinement."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..analysis.calib_results import load
from ..core.errors import MfnsError


def calibrate_dataset(
    dataset, truth_path=None, a10_iterations: int = 10, progress: bool = False, workers: int | None = None
):
    """Corner detection, Zhang, CPC, refinement and (with a truth file) the comparison.

    Returns (observations, rejected images as (camera, path, reason), Calibration, Comparison
    or None, seconds spent on detection, seconds spent on calibration).
    """
    import cv2
    from threadpoolctl import threadpool_limits

    # Results must not depend on the machine's core count: OpenCV's own threads and the
    # OpenBLAS of numpy/scipy and of OpenCV's wheel change the last bits of Zhang's and the
    # refinement's covariances with their thread count. Corner detection uses processes.
    cv2.setNumThreads(1)
    with threadpool_limits(limits=1):
        return _calibrate_dataset(dataset, truth_path, a10_iterations, progress, workers)


def _calibrate_dataset(dataset, truth_path, a10_iterations, progress, workers):
    from ..calib.dataset import load_dataset
    from ..calib.pipeline import calibrate
    from ..calib.report import compare
    from ..simulate.calib import truth_from_document

    truth_doc = load(truth_path, flight=False) if truth_path else None
    t0 = time.monotonic()
    obs, rejected = load_dataset(dataset, progress=progress, workers=workers)
    t1 = time.monotonic()
    cal = calibrate(obs, a10_iterations=a10_iterations)
    cmp = None
    if truth_doc is not None:
        cmp = compare(cal, truth_from_document(truth_doc), obs, truth_doc)
    return obs, rejected, cal, cmp, t1 - t0, time.monotonic() - t1


def run(args) -> int:
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # the exports' fits too (see calibrate_dataset)
        return _run(args)


def _run(args) -> int:
    from ..calib.exports import write_outputs
    from ..calib.plots import write_plots
    from ..calib.report import accuracy_table, extrinsics_table, intrinsics_table

    t0 = time.monotonic()
    obs, rejected, cal, cmp, t_detect, t_cal = calibrate_dataset(
        args.dataset,
        args.truth,
        1 if args.a10_single_pass else 10,
        progress=not args.quiet,
        workers=args.jobs,
    )
    for name, path, why in rejected:  # on stderr too: --quiet keeps stdout empty
        print(f"warning: camera {name}: {path} skipped: {why}", file=sys.stderr)
    text = []
    for k, name in enumerate(obs.camera_names):
        bad = [r for r in rejected if r[0] == name]
        text.append(f"camera {name}: {len(obs.of_camera(k))} images used, {len(bad)} skipped")
        text += [f"  skipped {path}: {why}" for _c, path, why in bad]
    if obs.board.symmetric:
        text.append(
            f"board symmetric under a half turn: corner 0 set by the turntable chain "
            f"({cal.half_turned} images' corner order reversed)"
        )
        text += [d.line() for d in cal.corner_order]
    if cal.paper is None:
        text.append(f"{cal.paper_note}; the refinement started from {cal.init}")
    text += ["", intrinsics_table(cal), "", extrinsics_table(cal)]
    if cmp is not None:
        text += ["", accuracy_table(cmp)]
    out = Path(args.output) if args.output else Path(args.dataset) / "calib" / "calib_results.json"
    written, notes = write_outputs(cal, out, f"mfns calib {args.dataset}")
    text += ["", *notes]
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
    elif rejected:
        print(f"warning: {len(rejected)} images without the board skipped (see the report)", file=sys.stderr)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calib",
        help="calibrate the MFNS from a turntable dataset (Zhang, CPC, joint ML refinement)",
        description="Detect the board's corners, calibrate each camera (Zhang), run the paper's CPC "
        "(Appendix A) and refine everything jointly by maximum likelihood. Writes the "
        "calibration-results JSON (docs/calib-results.md) of the refined solution, <stem>_paper.json "
        "with the paper's solution, and exports (docs/calibration.md): OpenCV YAML and ROS camera_info "
        "per camera, Kalibr camchain.yaml, body-to-camera transforms.",
    )
    p.add_argument("dataset", metavar="DATASET", help="dataset folder (docs/calib-dataset.md)")
    p.add_argument("--truth", help="truth.json of a simulated dataset: adds errors and the Cramér-Rao bound")
    p.add_argument(
        "-o",
        "--output",
        default=None,
        help="results JSON; the exports are written beside it, named after it (default "
        "DATASET/calib/calib_results.json: never into the current folder)",
    )
    p.add_argument("--plots", metavar="DIR", help="write PNG plots into DIR")
    p.add_argument("--report", metavar="FILE", help="also write the text report to FILE")
    p.add_argument(
        "--a10-single-pass",
        action="store_true",
        help="solve Eq. A10 once, exactly as printed (default: iterate it to convergence)",
    )
    p.add_argument(
        "-j", "--jobs", type=int, default=None, help="corner detection processes (default: one per core)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress bars or report on stdout")
    p.set_defaults(func=_checked)


def _checked(args) -> int:
    if not Path(args.dataset).is_dir():
        raise MfnsError(f"{args.dataset}: not a folder")
    if args.jobs is not None and not 1 <= args.jobs <= 256:
        raise MfnsError("--jobs must be 1 to 256")
    return run(args)
