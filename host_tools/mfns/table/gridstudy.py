"""Memory vs worst-case error of the correction grid for the cameras of a
calibration-results JSON (the table of docs/distortion-grid.md).

Usage: mfns table gridstudy [CALIB_JSON]   (default: the paper's Table 2, DEFAULT_CALIB)
"""

from __future__ import annotations

from pathlib import Path

from ..analysis import calib_results
from .builder import _record
from .check import core
from .format import NODE_SIZE
from .grid import build_grid, grid_error, record_camera

DEFAULT_CALIB = Path(__file__).resolve().parents[1] / "data" / "paper_calib.json"

SIZES = [
    (17, 14),
    (33, 27),
    (41, 33),
    (65, 52),
    (81, 65),
    (86, 69),
    (93, 75),
    (100, 80),
    (107, 86),
    (129, 103),
]


def study(calib_json: str | Path) -> list[str]:
    doc = calib_results.load(calib_json)
    cams = [record_camera(_record(k, e)) for k, e in enumerate(doc["cameras"])]
    limit = core().max_grid_nodes
    rows = [
        f"| grid (nx x ny) | spacing (px) | nodes | bytes/camera | bytes (3 cameras) | fits {limit} | "
        + " | ".join(f"worst error {c.name} (px)" for c in cams)
        + " |",
        "|---|---|---|---|---|---|" + "---|" * len(cams),
    ]
    for nx, ny in SIZES:
        errs = []
        for cam in cams:
            # grids beyond the flight maximum are measured too (limit lifted)
            g = build_grid(cam, nx, ny, max_nodes=max(nx * ny, limit))
            errs.append(grid_error(cam, g).max_px)
        n = nx * ny
        step = f"{cams[0].width / (nx - 1):.1f} x {cams[0].height / (ny - 1):.1f}"
        rows.append(
            f"| {nx} x {ny} | {step} | {n} | {n * NODE_SIZE} | {3 * n * NODE_SIZE} | "
            f"{'yes' if n <= limit else 'no'} | " + " | ".join(f"{e:.4f}" for e in errs) + " |"
        )
    return rows
