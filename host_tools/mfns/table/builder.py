"""Build a calibration table from a calibration-results JSON and a beacon CSV."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis import calib_results
from ..core.errors import MfnsError
from ..model.camera import load_beacon_emission, load_beacons, rig_from_doc
from . import mapindex
from .format import CALIB_PARAM_NAMES, CALIB_PARAMS, CAMERA_NAMES, CameraRecord, Grid, Table, f32
from .generated import layout_gen as L
from .generated.layout_gen import DEFAULT_MIN
from .grid import MAX_GRID_ERROR_PX, GridError, build_grid, grid_error, record_camera, size_grid


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
    return rec


def load_beacon_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from .check import core

    ids, pos, sig = load_beacons(path)  # checked: ids, finite values, sigma > 0, unique
    limit = core().max_beacons  # the flight build's MFNS_MAX_BEACONS
    if len(ids) > limit:
        raise MfnsError(f"{path}: {len(ids)} beacons, the flight loader takes 1..{limit}")
    return ids, pos, sig


def calib_covariance(doc: dict) -> np.ndarray | None:
    """The (45, 45) calibration covariance the table carries (format.CALIB_PARAM_NAMES per
    camera x, y, z) from the document's optional "covariance" (docs/calib-results.md, checked
    by calib_results.validate when the document was loaded); None when absent (unknown: no
    calibration term).

    Parameters are matched by name; one the table does not carry (e.g. "x.skew") is dropped,
    which for a Gaussian is exactly its marginal. The flight loader checks the result again
    (positive semi-definite in float32) when the builder loads its own bytes.
    """
    got = calib_results.covariance(doc)
    if got is None:
        return None
    names, m = got
    slot = {
        f"{c}.{p}": k * len(CALIB_PARAM_NAMES) + i
        for k, c in enumerate(CAMERA_NAMES)
        for i, p in enumerate(CALIB_PARAM_NAMES)
    }
    src = [j for j, n in enumerate(names) if n in slot]
    dst = [slot[names[j]] for j in src]
    if sorted(dst) != list(range(CALIB_PARAMS)):
        raise MfnsError("covariance: the flight table needs every camera's 15 parameters")
    out = np.zeros((CALIB_PARAMS, CALIB_PARAMS))
    out[np.ix_(dst, dst)] = m[np.ix_(src, src)]
    dropped = [n for n in names if n not in slot]
    if dropped:
        _warn(f"covariance parameters not carried by the table (marginalised out): {', '.join(dropped[:8])}")
    return out


def datum_unusable(datum, integrity: dict | None, pos) -> list[str]:
    """Lines saying that the map datum alone leaves no usable fix (issue 45). The flight adds
    the datum once to every fix's covariance, the fault-free one of the protection level
    included, so every PL is at least K_ff times the datum's own sigma on each axis
    (integrity.h: PL_j >= K_ff sqrt(P0f_jj), K_ff = Q^-1(P_md / 2) with the table's P_md,
    computed by the C core's mfns_integrity_q_inv). Per world axis the shift's sigma, per
    attitude axis the turn's: a floor of the datum's share (the turn's lever arm over the
    beacons only adds). What it misses: a datum whose floor is under the limit but whose
    turn over the beacons' lever arm, or whose sum with the measurement noise, passes it
    (usable fixes then depend on the geometry): not warned about."""
    from ..core.binding import load

    lim = dict(L.DEFAULTS["integrity"])
    lim.update({k: v for k, v in (integrity or {}).items() if k in lim})
    al_pos, al_att = float(lim["alert_limit_pos_mm"]), float(lim["alert_limit_att_deg"])
    k_ff = float(load().mfns_integrity_q_inv(float(lim["p_md"]) / 2.0))
    cov = np.asarray(datum.cov, dtype=float)
    s_shift = np.sqrt(np.clip(np.diag(cov)[:3], 0.0, None))
    s_turn = np.sqrt(np.clip(np.diag(cov)[3:], 0.0, None))
    del pos  # the lever arm is not a floor (see above)
    pl_pos = k_ff * s_shift
    pl_att_deg = k_ff * np.degrees(s_turn)
    out = []
    axes = "xyz"
    for i in range(3):
        if pl_pos[i] > al_pos:
            out.append(
                f"map datum: its shared shift alone ({s_shift[i]:.2f} mm 1-sigma on world {axes[i]}) puts "
                f"every protection level at {pl_pos[i]:.1f} mm or more (K_ff {k_ff:.2f}), beyond the "
                f"position alert limit {al_pos:g} mm: no fix from this table will be usable "
                f"(refine the map or widen the limit)"
            )
        if pl_att_deg[i] > al_att:
            out.append(
                f"map datum: its turn alone ({np.degrees(s_turn[i]):.3f} deg 1-sigma about {axes[i]}) puts "
                f"every protection level at {pl_att_deg[i]:.3f} deg or more (K_ff {k_ff:.2f}), beyond the "
                f"attitude alert limit {al_att:g} deg: no fix from this table will be usable"
            )
    return out


def _warn(line: str) -> None:
    import sys

    print(f"mfns table: warning: {line}", file=sys.stderr)


# The smallest default floor (px), the table definition's (caltable_layout.toml): the
# centroid's Q23.8 output step is 1/256 px, whose rounding (1/256/sqrt(12) = 0.0011 px)
# the centroider's covariance already carries; a floor below it would claim a grid
# better than the arithmetic that reads it.
MIN_FLOOR_PX = DEFAULT_MIN["globals"]["pixel_sigma_px"]


def default_floor_px(errors: list[GridError], doc: dict) -> float:
    """The default unmodelled pixel error. The centroider gives each blob's noise and the
    calibration's covariance its own term in the pose covariance; what no term carries is
    the grid's interpolation residual (the RMS over the cameras of their grids' RMS) and,
    for an estimated calibration (one with a covariance), the misfit its own images left:
    its pixel_noise_px, the RMS reprojection residual of the calibration, which also keeps
    the solver's gates and residual check from refusing the calibration's systematic error
    as outliers. A document without a covariance is taken as an exact rig (grid residual
    only; build_table warns). Never below MIN_FLOOR_PX."""
    rms = float(np.sqrt(np.mean([e.rms_px**2 for e in errors])))
    if doc.get("covariance") is not None:
        rms = max(rms, float(doc["pixel_noise_px"]))
    return max(rms, MIN_FLOOR_PX)


def build_table(
    calib_json: str | Path,
    beacons_csv: str | Path,
    grid: tuple[int, int] | None = None,
    centroid: dict | None = None,
    solver: dict | None = None,
    pixel_sigma_px: float | None = None,
    workspace: tuple[np.ndarray, np.ndarray] | None = None,
    certify_samples: int = mapindex.DEFAULT_SAMPLES,
    seed: int = 1,
    progress=None,
    integrity: dict | None = None,
    motion: dict | None = None,
    map_datum: str | Path | None = None,
) -> tuple[Table, list[GridError], mapindex.IndexReport]:
    """The table, per camera the measured worst-case error of its grid, and the report
    of its map index (workspace default: mapindex.default_workspace).

    grid None: each camera gets the coarsest grid that corrects its lens to
    MAX_GRID_ERROR_PX within the loader's node limit (grid.size_grid); a given
    NXxNY grid is used as is, and refused like a lens the limit cannot correct
    when it misses MAX_GRID_ERROR_PX. pixel_sigma_px is the table's pixel sigma: the
    unmodelled pixel error the flight solver adds in quadrature to every observation's
    own covariance (centroid and survey), and the whole pixel noise of observations
    without a centroid covariance (docs/caltable.md). Default: default_floor_px (the
    grids' RMS residual, and an estimated calibration's own reprojection residual).
    The calibration's "covariance", when present, becomes the table's
    calibration-covariance section (calib_covariance); a calibration without one gives
    no calibration term, which is right only for an exact rig (a warning says so).
    integrity: the integrity settings (settings.load_section); None = the defaults.
    motion: the navigation filter's motion bound (settings.load_section); None = the defaults.
    map_datum: a map_datum.json (mfns.map.datum_file, written by `mfns map refine`): the
    table's beacons then carry its relative sigmas and its map datum section the shared
    error; None = no datum (the CSV's sigma_mm is each beacon's whole error).
    """
    from .check import core
    from .settings import load_settings

    max_nodes = core().max_grid_nodes  # the flight build's limit, from the C core
    doc = calib_results.load(calib_json)
    dc, ds = load_settings(None)
    ids, pos, sig = load_beacon_csv(beacons_csv)
    datum = None
    if map_datum is not None:
        from ..map import datum_file

        datum, sig = datum_file.load(map_datum, ids)
    cams, errors = [], []
    for k, e in enumerate(doc["cameras"]):
        rec = _record(k, e)
        cam = record_camera(rec)
        if grid is None:
            rec.grid, err = size_grid(cam, max_nodes)
        else:
            rec.grid = build_grid(cam, *grid, max_nodes=max_nodes)
            err = grid_error(cam, rec.grid)
            if err.max_px > MAX_GRID_ERROR_PX:
                raise MfnsError(
                    f"camera {cam.name}: grid {grid[0]}x{grid[1]} leaves {err.max_px:.4f} px of correction "
                    f"error at ({err.worst_uv[0]:.1f}, {err.worst_uv[1]:.1f}), above {MAX_GRID_ERROR_PX} px"
                )
        errors.append(err)
        cams.append(rec)
    sigma = float(f32(default_floor_px(errors, doc) if pixel_sigma_px is None else pixel_sigma_px))
    if doc.get("covariance") is None and pixel_sigma_px is None:
        _warn(
            f"{calib_json}: no calibration covariance: the table carries no calibration uncertainty "
            f"(right for an exact rig; otherwise give --pixel-sigma at the calibration's residual level)"
        )
    if doc.get("cameras") is not None and len(doc["cameras"]) != 3:
        raise MfnsError(f"{calib_json}: the flight table holds exactly three cameras (x, y, z)")
    from ..core.flight import Flight

    fl = Flight()
    rig = fl.rig(rig_from_doc(doc))
    bmap = fl.beacon_map(f32(pos), f32(sig), ids=ids)
    ws = workspace if workspace is not None else mapindex.default_workspace(f32(pos), _warn)
    if workspace is not None and (line := mapindex.workspace_outside(f32(pos), *workspace)) is not None:
        _warn(line)
    idx, report = mapindex.build(
        fl, rig, bmap, load_beacon_emission(beacons_csv), ws, sigma, certify_samples, seed, progress
    )
    if datum is not None:
        for line in datum_unusable(datum, integrity, pos):
            _warn(line)
    table = Table(
        cameras=cams,
        beacon_ids=ids,
        beacon_pos=f32(pos),
        beacon_sigma=f32(sig),
        pixel_sigma_px=sigma,
        centroid=centroid if centroid is not None else dc,
        solver=solver if solver is not None else ds,
        index_section=fl.encode_index(idx),
        calib_cov=calib_covariance(doc),
        map_datum=datum,
        integrity=dict(integrity) if integrity is not None else {},
        motion=dict(motion) if motion is not None else {},
    )
    return table, errors, report
