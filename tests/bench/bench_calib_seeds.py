"""Multi-seed check of the calibration estimators on corner observations simulated directly
(mfns.calib.evaluate, docs/calibration.md): per quantity the RMS error of the paper's method
and of the refinement, the Cramér-Rao bound, the mean reported 1-sigma, the spread over the
seeds, and the NEES of the truth under the results documents' covariances.

    python tests/bench/bench_calib_seeds.py --seeds 40 [--sigma-px 0.1]   (make bench-calib-seeds)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))

from mfns.calib.evaluate import run_seeds  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="bench_calib_seeds", description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--seeds", type=int, default=40, help="seeds, each new corner noise and angle errors (default 40)"
    )
    p.add_argument("--sigma-px", type=float, default=0.1, help="corner noise, 1-sigma px (default 0.1)")
    p.add_argument("--turntable-views", type=int, default=12, help="turntable views per camera (default 12)")
    p.add_argument("--prepared-views", type=int, default=10, help="prepared-pose views (default 10)")
    a = p.parse_args(argv)
    stats = run_seeds(a.seeds, a.sigma_px, a.turntable_views, a.prepared_views, progress=True)
    print(stats.table())
    return 0


if __name__ == "__main__":
    sys.exit(main())
