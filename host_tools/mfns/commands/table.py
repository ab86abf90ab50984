"""`mfns table`: build the binary calibration table and show one (docs/caltable.md); write the
C tests' vectors of a table (`vectors`, run by the build, mk/caltable.mk) and the grid size
study of docs/distortion-grid.md (`gridstudy`)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..core.binding import PX_Q8_ONE as Q8
from ..core.errors import MfnsError
from ..core.validate import read_bytes
from ..model.rotations import matrix_to_euler213_deg
from ..table.check import TableRefused, check_table, core
from ..table.format import CAMERA_NAMES, decode, encode


def _grid_arg(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    m = re.fullmatch(r"(\d{1,5})[xX](\d{1,5})", text)
    if not m:
        raise MfnsError(f"--grid {text!r}: expected NXxNY, e.g. 93x75")
    return int(m.group(1)), int(m.group(2))


def cmd_build(args) -> int:
    from ..table.builder import build_table
    from ..table.settings import load_section, load_settings

    grid = _grid_arg(args.grid)
    centroid, solver = load_settings(args.settings)
    integrity = load_section(args.settings, "integrity")
    motion = load_section(args.settings, "motion")
    if args.pixel_sigma is not None and not 0.0 < args.pixel_sigma <= 10.0:
        raise MfnsError(f"--pixel-sigma {args.pixel_sigma}: expected a value in (0, 10] px")
    from ..table import mapindex

    ws = mapindex.workspace_arg(args.workspace) if args.workspace else None
    if args.certify_samples < 1:
        raise MfnsError(f"--certify-samples {args.certify_samples}: expected at least 1")
    from tqdm import tqdm

    with tqdm(
        total=args.certify_samples,
        desc="map analysis",
        unit="pose",
        disable=True if args.quiet else None,
        leave=False,
    ) as bar:
        table, errors, report = build_table(
            args.calib_json,
            args.beacons_csv,
            grid,
            centroid,
            solver,
            args.pixel_sigma,
            workspace=ws,
            certify_samples=args.certify_samples,
            seed=args.seed,
            progress=bar.update,
            integrity=integrity,
            motion=motion,
            map_datum=args.map_datum,
        )
    data = encode(table)
    try:
        status = check_table(data)  # the flight loader on the very bytes to be written
    except TableRefused as exc:
        raise MfnsError(f"the table built is {exc}; nothing written") from exc
    out = Path(args.output)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(data)
    except OSError as exc:
        raise MfnsError(f"cannot write {out}: {exc.strerror}") from exc
    crc = decode(data).crc32
    print(f"wrote {out}: {len(data)} bytes, CRC-32 0x{crc:08x}, flight loader: {status.message}")
    for name, rec, err in zip(CAMERA_NAMES, table.cameras, errors, strict=True):
        g = rec.grid
        print(
            f"camera {name}: grid {g.nx}x{g.ny} step {g.step_u_q8 / Q8:.3f}x{g.step_v_q8 / Q8:.3f} px, "
            f"worst-case error {err.max_px:.4f} px at ({err.worst_uv[0]:.1f}, {err.worst_uv[1]:.1f}), "
            f"rms {err.rms_px:.4f} px ({err.samples} samples)"
        )
    print(f"grid worst-case error: {max(e.max_px for e in errors):.4f} px")
    for line in report.lines():
        print(line)
    if ws is None:
        # an operator's choice the default cannot make: say what it costs (docs/planning.md)
        print(
            "map index: the workspace is the default (the beacons' box shrunk by 10 %); give --workspace "
            "with the robot's own box (a plan.json, a module scenario.json or six numbers): acquisition "
            "searches less and certifies sooner in a smaller box, and never acquires a pose outside it"
        )
    return 0


def _fmt(v) -> str:
    return " ".join(f"{x:.9g}" for x in np.ravel(v))


def calib_cov_summary(cov) -> str:
    """One or four lines on the calibration-covariance section."""
    if cov is None:
        return "calibration covariance: none (unknown: no calibration term in the pose covariance)"
    from ..table.format import CALIB_PARAM_NAMES

    sd = np.sqrt(np.maximum(np.diag(cov), 0.0)).reshape(len(CAMERA_NAMES), len(CALIB_PARAM_NAMES))
    lines = [f"calibration covariance: {cov.shape[0]} parameters (1-sigma per camera)"]
    for name, s in zip(CAMERA_NAMES, sd, strict=True):
        lines.append(
            f"  {name}: fx {s[0]:.3g} fy {s[1]:.3g} cx {s[2]:.3g} cy {s[3]:.3g} px; "
            f"k1 {s[4]:.2g} k2 {s[5]:.2g} p1 {s[6]:.2g} p2 {s[7]:.2g} k3 {s[8]:.2g}; "
            f"theta {s[9] * 1e3:.3g} {s[10] * 1e3:.3g} {s[11] * 1e3:.3g} mrad; "
            f"r {s[12]:.3g} {s[13]:.3g} {s[14]:.3g} mm"
        )
    return "\n".join(lines)


def map_datum_summary(d) -> str:
    """One line on the table's map datum section."""
    if d is None:
        return "map datum: none (each beacon's sigma is its whole error)"
    sd = np.sqrt(np.maximum(np.diag(d.cov), 0.0))

    def g(v) -> str:
        return " ".join(f"{x:.4g}" for x in v)

    return (
        f"map datum: shift 1-sigma {g(sd[:3])} mm, turn 1-sigma {g(np.degrees(sd[3:]))} deg "
        f"about ({g(d.c_w_mm)}) mm; the beacons' sigma is their relative error"
    )


def cmd_show(args) -> int:
    path = Path(args.table)
    # the flight program's load buffer bounds what it can load: nothing larger is read
    data = read_bytes(path, "calibration table", core().max_bytes)
    try:
        check_table(data)
    except TableRefused as exc:
        raise MfnsError(f"{path}: {exc}") from exc
    t = decode(data)
    print(f"{path}: MFNS calibration table, format version {t.version}, {t.size_bytes} bytes")
    print(f"CRC-32 0x{t.crc32:08x} (verified by the flight loader: {core().load(data).message})")
    if len(data) > t.size_bytes:
        print(f"note: {len(data) - t.size_bytes} bytes after the table's total size (ignored by the loader)")
    print(f"pixel sigma (unmodelled error floor): {t.pixel_sigma_px:.6g} px")
    print(calib_cov_summary(t.calib_cov))
    print(map_datum_summary(t.map_datum))
    print("centroid: " + ", ".join(f"{k}={v:.6g}" for k, v in t.centroid.items()))
    print("solver:   " + ", ".join(f"{k}={v:.6g}" for k, v in t.solver.items()))
    print("integrity: " + ", ".join(f"{k}={v:.6g}" for k, v in t.integrity.items()))
    print("motion: " + ", ".join(f"{k}={v:.6g}" for k, v in t.motion.items()))
    for name, c in zip(CAMERA_NAMES, t.cameras, strict=True):
        g = c.grid
        print(f"camera {name} (id {c.camera_id}): {c.width}x{c.height} px")
        print(f"  fx {c.fx:.6f}  fy {c.fy:.6f}  cx {c.cx:.6f}  cy {c.cy:.6f}  skew {c.skew:.6g}")
        print(f"  dist [k1 k2 p1 p2 k3]: {_fmt(c.dist)}")
        print(f"  C_k_b rows: {_fmt(c.C_k_b[0])} | {_fmt(c.C_k_b[1])} | {_fmt(c.C_k_b[2])}")
        e = matrix_to_euler213_deg(c.C_k_b)
        print(f"  C_k_b Euler 2-1-3 (roll pitch yaw) deg: {e[0]:.4f} {e[1]:.4f} {e[2]:.4f}")
        print(f"  r_bk_b mm: {_fmt(c.r_bk_b)}")
        print(
            f"  grid {g.nx}x{g.ny} nodes, origin ({g.origin_u_q8 / Q8:g}, {g.origin_v_q8 / Q8:g}) px, "
            f"step {g.step_u_q8 / Q8:g} x {g.step_v_q8 / Q8:g} px, {g.nx * g.ny * 8} bytes"
        )
    from ..table.format import index_summary

    ix = index_summary(t)
    print(
        f"map index: {ix['k_nbr']} neighbours per beacon, certificate {ix['cert_inliers']} inliers by "
        f"missing count (at most {ix['max_missing']} missing, {ix['max_unexplained']} unexplained blobs), "
        f"budget {ix['budget_units']} work units per cycle, workspace {ix['workspace_min_mm']} .. "
        f"{ix['workspace_max_mm']} mm, analysis of {ix['analysis_samples']} poses (strongest wrong "
        f"identification {ix['analysis_max_rival']} inliers)"
    )
    print(f"beacons: {len(t.beacon_ids)}")
    for bid, p, s in zip(t.beacon_ids, t.beacon_pos, t.beacon_sigma, strict=True):
        print(f"  {bid:5d}  {p[0]:11.4f} {p[1]:11.4f} {p[2]:11.4f} mm  sigma {s:.4f} mm")
    return 0


def cmd_vectors(args) -> int:
    from ..table.vectors import write_vectors

    write_vectors(args.table, args.outdir)
    return 0


def cmd_gridstudy(args) -> int:
    from ..table.gridstudy import DEFAULT_CALIB, study

    print("\n".join(study(args.calib_json if args.calib_json is not None else DEFAULT_CALIB)))
    return 0


def register(subparsers) -> None:
    parser = subparsers.add_parser("table", help="build or show the binary calibration table")
    sub = parser.add_subparsers(dest="table_command", metavar="ACTION")
    b = sub.add_parser("build", help="build a table from a calibration-results JSON and a beacon CSV")
    b.add_argument(
        "calib_json", metavar="CALIB_JSON", help="calibration-results JSON (docs/calib-results.md) of the rig"
    )
    b.add_argument("beacons_csv", metavar="BEACONS_CSV", help="the beacon map (id,x_mm,y_mm,z_mm,sigma_mm)")
    b.add_argument("-o", "--output", required=True, metavar="OUT", help="the table file to write (.mfnstbl)")
    b.add_argument(
        "--grid",
        metavar="NXxNY",
        help="correction grid nodes (default: the coarsest grid that corrects each lens to 0.01 px)",
    )
    b.add_argument("--settings", metavar="JSON", help="override centroid/solver settings")
    b.add_argument(
        "--pixel-sigma",
        type=float,
        metavar="PX",
        help="the unmodelled pixel error (1-sigma, px) the flight solver adds in quadrature to each "
        "observation's own covariance, and the whole pixel noise when the centroider gives none "
        "(default: the RMS residual of the table's correction grids, or the calibration's pixel_noise_px "
        "when it carries a covariance, whichever is larger)",
    )
    b.add_argument(
        "--workspace",
        metavar="XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX|FILE.json",
        help="box the body origin can be in, world frame, mm, or a JSON file with it as table_workspace_mm "
        "(the plan.json of `mfns plan optimize`, a module scenario.json of `mfns sim nav`); the "
        "acquisition searches over it and certifies no pose outside it (20 mm + 6 sigma) "
        "(default: the map's bounding box shrunk by 10%% of its extent on each side)",
    )
    b.add_argument(
        "--certify-samples",
        type=int,
        default=200,
        metavar="N",
        help="poses of the map analysis that sets the acquisition's certificate (default 200)",
    )
    b.add_argument("--seed", type=int, default=1, help="seed of the map analysis' poses (default 1)")
    b.add_argument(
        "--map-datum",
        metavar="JSON",
        help="the map_datum.json `mfns map refine` writes beside its beacons.csv: the beacons get its "
        "relative sigmas and the table the map's shared error (a rigid shift and turn), which the flight "
        'solver adds to a fix\'s covariance once (docs/caltable.md "Map datum covariance"; default: none, '
        "the CSV's sigma_mm is each beacon's whole error)",
    )
    b.set_defaults(func=cmd_build)
    s = sub.add_parser("show", help="print a table and verify its CRC")
    s.add_argument("table", metavar="TABLE", help="a calibration table (.mfnstbl) to print")
    s.set_defaults(func=cmd_show)
    v = sub.add_parser(
        "vectors",
        help="write the C tests' vectors of a table (caltable_values/projections/undistort.txt)",
        description="The shared test vectors of tests/unit/test_caltable.c and test_undistort.c, written by "
        "the build (mk/caltable.mk) next to the default table: every value the table holds, OpenCV "
        "projections through its cameras, exact undistorted pixels.",
    )
    v.add_argument("table", metavar="TABLE", help="a calibration table (.mfnstbl) the flight loader accepts")
    v.add_argument("outdir", metavar="OUTDIR", help="folder to write the three vector files into")
    v.set_defaults(func=cmd_vectors)
    g = sub.add_parser(
        "gridstudy",
        help="memory vs worst-case error of the correction grid (docs/distortion-grid.md)",
        description="Prints the markdown table of docs/distortion-grid.md: per grid size the bytes per "
        "camera and each camera's worst-case correction error.",
    )
    g.add_argument(
        "calib_json",
        metavar="CALIB_JSON",
        nargs="?",
        default=None,
        help="calibration-results JSON of the cameras (default: the paper's Table 2, "
        "mfns/data/paper_calib.json)",
    )
    g.set_defaults(func=cmd_gridstudy)
    parser.set_defaults(func=lambda args: parser.print_help() or 2)
