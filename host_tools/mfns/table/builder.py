"""Build a calibration table from a calibration-results JSON and a beacon CSV."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import calib_results
from ..camera import load_beacons
from ..errors import MfnsError
from .format import MAX_BEACONS, CameraRecord, Grid, Table, f32
from .grid import DEFAULT_GRID, GridError, build_grid, grid_error, record_camera


def _record(k: int, e: dict) -> CameraRecord:
    w, h = e["image_size"]
    rec = CameraRecord(
        camera_id=k,
        width=int(w),
        height=int(h),
        fx=float(f32(e["fx"])),
        fy=float(f32(e["fy"])),
        cx=float(f32(e["cx"])),
        cy=float(f32(e["cy"])),
        skew=float(f32(e["skew"])),
        dist=f32(e["dist"]),
        C_k_b=f32(e["C_k_b"]),
        r_bk_b=f32(e["r_bk_b"]),
        grid=Grid(0, 0, 0, 0, np.zeros((0, 0, 2), dtype=np.int32)),
    )
    if not (-0.5 <= rec.cx <= rec.width - 0.5 and -0.5 <= rec.cy <= rec.height - 0.5):
        raise MfnsError(f"camera {e['name']}: principal point outside the image")
    return rec


def load_beacon_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    try:
        ids, pos, sig = load_beacons(path)
    except (ValueError, KeyError, TypeError) as exc:
        raise MfnsError(f"{path}: not a beacon CSV with columns id,x_mm,y_mm,z_mm,sigma_mm ({exc})") from exc
    if len(ids) == 0 or len(ids) > MAX_BEACONS:
        raise MfnsError(f"{path}: {len(ids)} beacons, expected 1..{MAX_BEACONS}")
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(sig))):
        raise MfnsError(f"{path}: a beacon value is missing or not finite")
    if np.any(sig <= 0):
        raise MfnsError(f"{path}: beacon sigma_mm must be positive")
    if np.any(ids < 0) or np.any(ids > 65535):
        raise MfnsError(f"{path}: beacon ids must be in 0..65535")
    if len(set(ids.tolist())) != len(ids):
        raise MfnsError(f"{path}: duplicate beacon ids")
    return ids, pos, sig


def build_table(
    calib_json: str | Path,
    beacons_csv: str | Path,
    grid: tuple[int, int] = DEFAULT_GRID,
    centroid: dict | None = None,
    solver: dict | None = None,
    pixel_sigma_px: float | None = None,
) -> tuple[Table, list[GridError]]:
    """The table and, per camera, the measured worst-case error of its grid.

    pixel_sigma_px overrides the calibration's pixel_noise_px as the noise the
    flight solver assumes (centroid noise plus what calibration errors add).
    """
    from .settings import load_settings

    doc = calib_results.load(calib_json)
    dc, ds = load_settings(None)
    ids, pos, sig = load_beacon_csv(beacons_csv)
    cams, errors = [], []
    for k, e in enumerate(doc["cameras"]):
        rec = _record(k, e)
        cam = record_camera(rec)
        rec.grid = build_grid(cam, *grid)
        errors.append(grid_error(cam, rec.grid))
        cams.append(rec)
    table = Table(
        cameras=cams,
        beacon_ids=ids,
        beacon_pos=f32(pos),
        beacon_sigma=f32(sig),
        pixel_sigma_px=float(f32(doc["pixel_noise_px"] if pixel_sigma_px is None else pixel_sigma_px)),
        centroid=centroid if centroid is not None else dc,
        solver=solver if solver is not None else ds,
    )
    return table, errors
