"""`mfns map`: the beacon map after the survey (docs/self_survey.md): `refine` a map from a fix
log, and the self-survey `demo` of `make demo`."""

from __future__ import annotations

import json
from pathlib import Path

from ..core.errors import MfnsError


def cmd_refine(args) -> int:
    import numpy as np

    from ..analysis import calib_results
    from ..map import fixlog, refine
    from ..model.camera import load_beacons, rig_from_doc

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fixes, incomplete = fixlog.read(Path(args.fixlog))
    if args.every > 1:
        fixes = fixes[:: args.every]
    ids, p, sigma = load_beacons(args.beacons)
    doc = calib_results.load(args.calib)
    cams = rig_from_doc(doc)
    if not args.pixel_floor > 0:
        raise MfnsError(f"--pixel-floor {args.pixel_floor}: expected a positive value (px)")
    pb = refine.build_problem(fixes, cams, ids, p, sigma, mounts=args.mounts, pixel_floor_px=args.pixel_floor)
    res = refine.refine(pb)
    refine.write_beacons(out / "beacons.csv", res)
    from ..map import datum_file

    datum_file.write(
        out / "map_datum.json",
        res.ids,
        res.sigma_relative,
        res.datum_centre,
        res.datum_cov,
        source=f"mfns map refine of {args.fixlog} over {args.beacons}",
    )
    rep = refine.report(res)
    rep["incomplete_fixes_left_out"] = incomplete
    (out / "refine.json").write_text(json.dumps(rep, indent=2) + "\n")
    if args.mounts:
        calib_results.save(refine.refined_rig_doc(doc, res), out / "calib.json")
    shift = np.linalg.norm(res.p - res.p_survey, axis=1)
    print(
        f"map refine: {res.n_fixes} fixes, {res.n_assoc} associations "
        f"({incomplete} incomplete fixes left out), sigma0 {res.sigma0:.3f}; "
        f"beacons moved by median {np.median(shift):.3f} mm, max {shift.max():.3f} mm; "
        f"refined sigma median {np.median(res.sigma):.3f} mm (survey {np.median(res.sigma_survey):.3f})"
    )
    moved = ", ".join(
        f"{int(i)} ({c:.0f})" for i, c in zip(res.ids[res.moved], res.chi2_moved[res.moved], strict=True)
    )
    print(f"  beacons off their survey (chi2 3 dof > {refine.CHI2_3:.1f}): {moved or 'none'}")
    if args.mounts:
        for k in range(3):
            print(
                f"  camera {'xyz'[k]}: rotation {np.round(res.mount_rot_deg[k], 4).tolist()} deg, "
                f"offset {np.round(res.mount_off_mm[k], 3).tolist()} mm, chi2 {res.mount_chi2[k, 0]:.1f} / "
                f"{res.mount_chi2[k, 1]:.1f}{'  MOVED' if res.mount_moved[k] else ''}"
            )
    # refine() fills both (None only in a Result built by hand)
    assert res.datum_cov is not None and res.sigma_relative is not None
    sd = np.sqrt(np.diag(res.datum_cov))
    print(
        f"  map datum (shared by every beacon): shift 1-sigma {np.round(sd[:3], 4).tolist()} mm, turn "
        f"{np.round(np.degrees(sd[3:]), 5).tolist()} deg; relative sigma median "
        f"{np.median(res.sigma_relative):.3f} mm"
    )
    print(
        f"wrote {out / 'beacons.csv'}, {out / 'map_datum.json'}, {out / 'refine.json'}"
        + (f", {out / 'calib.json'}" if args.mounts else "")
    )
    print(
        f"  fly it: mfns table build CALIB {out / 'beacons.csv'} --map-datum "
        f"{out / 'map_datum.json'} -o TABLE"
    )
    return 0


def cmd_demo(args) -> int:
    from ..map.refine_demo import demo

    return demo(args)


def register(subparsers) -> None:
    from ..map.refine_demo import FRESH_SEED, SEED, SURVEY_RATE_HZ

    p = subparsers.add_parser(
        "map", help="the beacon map after the survey: self-survey (docs/self_survey.md)"
    )
    sub = p.add_subparsers(dest="map_command", metavar="SUBCOMMAND", required=True)
    r = sub.add_parser(
        "refine",
        help="bundle adjustment of the map (and camera mounts) from a fix log",
        description="Refine beacon positions (the survey as prior) and optionally the camera mounts from "
        "the fixes of a fix log (mfns-nav --fixlog DIR, or a telemetry recording); writes beacons.csv "
        "with per-beacon sigma, refine.json (moved beacons, moved mounts) and, with --mounts, calib.json.",
    )
    r.add_argument("fixlog", metavar="FIXLOG", help="a --fixlog directory or a telemetry recording")
    r.add_argument("--beacons", required=True, metavar="CSV", help="the surveyed map (beacons.csv)")
    r.add_argument(
        "--calib", required=True, metavar="JSON", help="the calibration the flight table was built from"
    )
    r.add_argument("out", metavar="OUT", help="output folder")
    r.add_argument("--mounts", action="store_true", help="also refine each camera's mount (rotation, offset)")
    r.add_argument(
        "--pixel-floor",
        type=float,
        default=0.005,
        metavar="PX",
        help="pixel error added to each centroid's own covariance (default 0.005 px)",
    )
    r.add_argument("--every", type=int, default=1, metavar="N", help="use every Nth fix (default all)")
    r.set_defaults(func=cmd_refine)
    d = sub.add_parser(
        "demo",
        help="the self-survey of make demo: survey flight, map refine, fresh frames on each map",
        description="The module scenario with its survey error rendered, flown with the fix log on; "
        "`mfns map refine`; then fresh frames (another path and noise, the same LEDs) flown with the "
        "surveyed and the refined map: navigation errors against truth and the NEES. Writes "
        "OUT/self_survey.md and appends it to --report.",
    )
    d.add_argument("out", metavar="OUT", help="output folder (emptied first)")
    d.add_argument("--report", metavar="FILE", help="markdown report to append the section to")
    d.add_argument("--minutes", type=float, default=3.0, help="survey flight (default 3 min)")
    d.add_argument(
        "--rate-hz",
        type=float,
        default=SURVEY_RATE_HZ,
        help=f"survey frame rate (default {SURVEY_RATE_HZ:g})",
    )
    d.add_argument("--seed", type=int, default=SEED, help=f"map and survey error (default {SEED})")
    d.add_argument(
        "--fresh-seed",
        type=int,
        help=f"path and noise of the fresh frames (default: seed + {FRESH_SEED - SEED})",
    )
    d.add_argument(
        "--bin",
        default="build/host-sim/bin",
        metavar="DIR",
        help="folder of the host-sim mfns-nav and mfns-ground (default build/host-sim/bin)",
    )
    d.set_defaults(func=cmd_demo)
