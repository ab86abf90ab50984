"""The `mfns plan analyze` and `mfns plan optimize` actions (arguments: commands/plan.py)."""

from __future__ import annotations

import csv
import json
import sys
import time
from pathlib import Path

import numpy as np

from ..analysis import calib_results
from ..analysis.mc import PAPER_BEACON_MM
from ..core.csv_formats import BEACON_COLUMNS
from ..core.errors import MfnsError
from ..core.study import options_from_args, run_tasks
from ..model.camera import rig_from_doc
from ..simulate import module_geom
from ..simulate.nav import PAPER_BEACONS, PAPER_CALIB
from ..table.builder import load_beacon_csv
from ..table.mapindex import WORKSPACE_KEY
from . import optimize as opt
from . import report, surfaces, usable, workspace
from .analyze import CERT_MIN_IN_VIEW, FIX_MIN_IN_VIEW, analyze
from .core import Core, require_map_size
from .crlb import CalibrationError

# the optimiser's work: 10 million annealing moves per restart and 1000 restarts are hours
MAX_ITERATIONS, MAX_RESTARTS = 10_000_000, 1000
# Survey 1-sigma the optimiser assumes for new beacons unless --beacon-sigma is given or
# the --baseline beacons.csv states one (its median sigma_mm: the same survey places the
# new layout): the paper's map accuracy (docs/system.md Table 4).
DEFAULT_SURVEY_SIGMA_MM = PAPER_BEACON_MM
# What plan.json's check (independent samples) and its baseline carry from the analysis.
CHECK_KEYS = ("availability_pct", "one_call_views_pct", "four_in_view_pct", "samples", "flight_verdict")


def _triple(text: str | None, name: str, n: int):
    if text is None:
        return None
    try:
        v = [float(t) for t in text.split(",")]
    except ValueError as exc:
        raise MfnsError(f"--{name} {text!r}: expected {n} comma-separated numbers") from exc
    if len(v) != n or not np.all(np.isfinite(v)):
        raise MfnsError(f"--{name} {text!r}: expected {n} comma-separated numbers")
    return v


def module_of(args) -> module_geom.ModuleGeometry:
    """The module --workspace module and --surfaces module stand for (--module-size,
    --module-path-amp; the demo's by default). Options that shape no module are refused."""
    geom = module_geom.from_args(args)
    uses = args.workspace == "module" or getattr(args, "surfaces", None) == "module"
    if module_geom.given(args) and not uses:
        raise MfnsError(
            "--module-size and --module-path-amp shape --workspace module and --surfaces module; "
            "neither is asked"
        )
    return geom


def build_workspace(args, stream: int = 0) -> workspace.Workspace:
    """The workspace of the arguments; stream separates the optimiser's samples from the
    independent samples the result is checked on."""
    rng = np.random.default_rng([args.seed, stream])
    if args.workspace == "truth":
        if not args.truth:
            raise MfnsError("--workspace truth needs --truth truth.csv")
        return workspace.from_truth(args.truth)
    if args.workspace == "turntable":
        return workspace.turntable(args.samples, args.yaw_start, args.yaw_span)
    if args.workspace == "module":
        return workspace.module(args.samples, rng, module_of(args))
    b = _triple(args.box, "box", 6)
    if b is None:
        raise MfnsError("--workspace box needs --box x0,y0,z0,x1,y1,z1 (mm)")
    ranges = {k: _triple(getattr(args, k), k, 2) or [-180.0, 180.0] for k in ("roll", "pitch", "yaw")}
    attitude = "ranges" if any(getattr(args, k) for k in ("roll", "pitch", "yaw")) else "uniform"
    return workspace.box(
        args.samples, b[:3], b[3:], rng, attitude, ranges["roll"], ranges["pitch"], ranges["yaw"]
    )


def _load_rig(args):
    doc = calib_results.load(args.rig or PAPER_CALIB)
    return doc, rig_from_doc(doc)


def _noise(args, doc, core, sigma_mm: np.ndarray):
    sigma_px = args.pixel_sigma if args.pixel_sigma is not None else float(doc["pixel_noise_px"])
    if not sigma_px > 0:
        raise MfnsError("--pixel-sigma must be positive")
    if args.beacon_sigma is not None:
        if not args.beacon_sigma >= 0:
            raise MfnsError("--beacon-sigma must be >= 0")
        sigma_mm = np.full(len(sigma_mm), args.beacon_sigma)
    calib = None if args.no_calib_sigma else CalibrationError(core, doc)
    calib = calib if calib else None
    survey = "per beacons.csv" if args.beacon_sigma is None else f"{args.beacon_sigma:g} mm"
    cal = "from the rig sigma entries" if calib else "not included"
    text = f"pixel {sigma_px:g} px; survey {survey}; calibration {cal}"
    return sigma_px, sigma_mm, calib, text


def _prepare(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise MfnsError(f"{out}: exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)


def _analyze_into(out, core, beacons, sigma_mm, ws, sigma_px, calib, info, title, progress, ident=False):
    a = analyze(core, beacons, sigma_mm, ws, sigma_px, calib, progress=progress, desc=title, ident=ident)
    _prepare(out)
    report.write_samples(a, out / "samples.csv")
    s = report.summarize(a, info)
    # what flies: the C core's solver and integrity on each sample's view (usable.py), over
    # the map index of the planned box, with the survey sigma the map states
    lo, hi = table_workspace(ws)
    s["flight_verdict"] = usable.evaluate(core, beacons, sigma_mm, ws, sigma_px, lo, hi).summary()
    report.write_summary(s, out, title)
    report.write_plots(a, out, title)
    return s


def run_analyze(args) -> int:
    doc, cams = _load_rig(args)
    core = Core(cams)
    bpath = Path(args.beacons) if args.beacons else PAPER_BEACONS
    _, pos, sig = load_beacon_csv(bpath)
    sigma_px, sig, calib, noise = _noise(args, doc, core, sig)
    ws = build_workspace(args)
    t0 = time.perf_counter()
    info = {"beacons": str(bpath), "n_beacons": len(pos), "rig": str(args.rig or PAPER_CALIB), "noise": noise}
    info["seed"] = args.seed
    s = _analyze_into(
        Path(args.out),
        core,
        pos,
        sig,
        ws,
        sigma_px,
        calib,
        info,
        "plan analyze",
        not args.quiet,
        ident=not args.no_ident_margin,
    )
    _print(
        s,
        f"plan analyze: {len(pos)} beacons, {ws.n} samples in {time.perf_counter() - t0:.1f} s -> {args.out}",
    )
    return 0


def _survey_sigma(args) -> tuple[float, str]:
    """The survey 1-sigma of the new layout and where it comes from: --beacon-sigma, else
    the sigma_mm beacons.csv of --baseline states (median), else the paper's."""
    if args.beacon_sigma is not None:
        if not args.beacon_sigma >= 0:
            raise MfnsError("--beacon-sigma must be >= 0")
        return float(args.beacon_sigma), "--beacon-sigma"
    if args.baseline:
        _, _, bsig = load_beacon_csv(args.baseline)
        return float(np.median(bsig)), f"sigma_mm of {args.baseline} (median)"
    return DEFAULT_SURVEY_SIGMA_MM, "the paper's map accuracy (docs/system.md Table 4)"


# table_workspace: the samples' box is widened by this share of its span and this many mm
# (poses between and just beyond the samples).
TABLE_WS_PAD_SHARE = 0.05
TABLE_WS_PAD_MM = 1.0


def table_workspace(ws) -> tuple[np.ndarray, np.ndarray]:
    """The box of the body origin a layout is planned for, as `mfns table build --workspace`
    takes it (plan.json "table_workspace_mm"): the samples' positions' bounding box widened
    by TABLE_WS_PAD_SHARE of its span and TABLE_WS_PAD_MM. The flight's map index and the
    acquisition's physical test are built over the table's workspace; the table's default
    (the beacons' bounding box shrunk by 10 %) need not contain this box (a layout with no
    beacon low on the walls leaves the robot's lowest poses outside: never acquired) and is
    larger where it does (more admissible beacon pairs: more work per acquisition;
    docs/planning.md)."""
    lo, hi = ws.r_wb_w.min(axis=0), ws.r_wb_w.max(axis=0)
    span = np.maximum(hi - lo, 1.0)
    pad = TABLE_WS_PAD_SHARE * span + TABLE_WS_PAD_MM
    return lo - pad, hi + pad


def ident_check(core, layout: np.ndarray, sigma_mm: float, ws, sigma_px: float, n: int) -> dict:
    """The acquisition's map analysis (ident.py, the C core through the binding) on the
    first n pose samples of ws with >= 4 beacons in view: how many views are ambiguous
    (identification margin <= 0: the flight code refuses them) and the margins, over the
    map index of the planned workspace (table_workspace)."""
    from .ident import IdentMargin

    lo, hi = table_workspace(ws)
    im = IdentMargin(core.flight, core.rig, layout, np.full(len(layout), sigma_mm), lo, hi, sigma_px)
    m: list[float] = []
    for i in range(ws.n):
        if len(m) >= n:
            break
        v = im.margin(ws.C_w_b[i], ws.r_bw_b(i))
        if v is not None:
            m.append(v)
    a = np.array(m, dtype=float)
    return {
        "views": len(m),
        "ambiguous": int(np.sum(a <= 0)) if len(a) else 0,
        "margin_le_1": int(np.sum(a <= 1)) if len(a) else 0,
        "margin_median": float(np.median(a)) if len(a) else None,
    }


def write_beacons(path: Path, pos: np.ndarray, sigma_mm: float) -> None:
    """beacons.csv as `mfns sim nav` writes and reads it (docs/nav-frames.md)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(BEACON_COLUMNS)
        for i, p in enumerate(pos):
            w.writerow([i, *(f"{v + 0.0:.4f}" for v in p), f"{sigma_mm:.4f}"])


def run_optimize(args) -> int:
    if args.count < 4:
        raise MfnsError("--count must be at least 4 (a fix needs four beacons in view)")
    require_map_size(args.count)
    if args.iterations < 0 or args.min_spacing < 0 or args.restarts < 1 or args.margin < 0:
        raise MfnsError("--iterations, --min-spacing and --margin must be >= 0, --restarts >= 1")
    if not 0 <= args.polish <= MAX_ITERATIONS:
        raise MfnsError(f"--polish must be 0 to {MAX_ITERATIONS}")
    if args.fly_frames < 0 or args.fly_paths < 1 or args.fly_frames > 10_000:
        raise MfnsError("--fly-frames must be 0 to 10000, --fly-paths at least 1")
    if not 0 <= getattr(args, "fly_starts", 0) <= 10_000:
        raise MfnsError("--fly-starts must be 0 to 10000")
    if getattr(args, "cert_in_view", None) is not None and args.cert_in_view < 0:
        raise MfnsError("--cert-in-view must be >= 0")
    # bounded like the samples: beyond these a run is hours (a typo, not a plan)
    if args.iterations > MAX_ITERATIONS or args.restarts > MAX_RESTARTS:
        raise MfnsError(f"--iterations at most {MAX_ITERATIONS}, --restarts at most {MAX_RESTARTS}")
    doc, cams = _load_rig(args)
    core = Core(cams)
    geom = module_of(args)
    surf, keep = surfaces.load(args.surfaces, geom)
    keep += [surfaces.parse_box(k) for k in args.keep_out or []]
    cand, _ = surfaces.candidates(surf, args.grid, keep)
    survey, survey_from = _survey_sigma(args)
    sigma_px, _, calib, noise = _noise(args, doc, core, np.zeros(0))
    noise = (
        f"pixel {sigma_px:g} px; survey {survey:g} mm ({survey_from}); "
        "calibration not in the optimiser's objective"
    )
    check_noise = noise + ("; the analysis includes the rig's calibration sigma" if calib else "")
    ws = build_workspace(args, stream=0)
    progress = not args.quiet
    t0 = time.perf_counter()
    prob = opt.build_problem(core, cand, ws, sigma_px, survey, progress)
    res, res_ident, res_use, search_s, restart_usable = None, None, None, [], []
    certify = not args.no_certify
    for r in range(args.restarts):
        rng = np.random.default_rng([args.seed, 7, r])
        one = opt.optimize(
            prob,
            args.count,
            args.min_spacing,
            args.iterations,
            rng,
            progress=progress,
            margin=args.margin,
            certify=certify,
            cert_in_view=getattr(args, "cert_in_view", None),
        )
        search_s.append(round(one.greedy_s + one.search_s, 2))
        # the identification margin (C map analysis) decides between layouts of equal
        # availability and certifiable views: fewer ambiguous views first
        one_ident = (
            ident_check(core, cand[one.chosen], survey, ws, sigma_px, args.ident_samples)
            if certify and args.ident_samples > 0
            else None
        )
        # the flight's verdict (usable.py: the C solver and integrity) on the samples decides
        # first: beacons in view are not what flies (a blind camera, a PL over the limit)
        one_use = usable.evaluate(
            core, cand[one.chosen], np.full(args.count, survey), ws, sigma_px, *table_workspace(ws)
        ).summary()
        restart_usable.append(one_use["usable_pct"])
        if res is None or _preferred(one, one_ident, res, res_ident, one_use, res_use):
            res, res_ident, res_use = one, one_ident, one_use
    if res is None:  # --restarts >= 1
        raise MfnsError("plan optimize: no restart ran (--restarts must be at least 1)")
    pol = None
    if args.polish > 0:
        # the flight's verdict as the objective (usable.polish): the C core judges each move
        pol = usable.polish(
            core,
            prob,
            res.chosen,
            survey,
            sigma_px,
            args.polish,
            args.min_spacing,
            np.random.default_rng([args.seed, 13]),
            *table_workspace(ws),
        )
        res.chosen = pol.chosen
    total_s = time.perf_counter() - t0
    out = Path(args.out)
    _prepare(out)
    layout = cand[res.chosen]
    write_beacons(out / "beacons.csv", layout, survey if survey > 0 else DEFAULT_SURVEY_SIGMA_MM)
    plan_doc = {
        "algorithm": "greedy construction, then simulated annealing (mfns.plan.optimize)",
        "surfaces": args.surfaces,
        "candidates": int(len(cand)),
        "grid_mm": args.grid,
        "count": args.count,
        "min_spacing_mm": args.min_spacing,
        "keep_out": [[k.lo.tolist(), k.hi.tolist()] for k in keep],
        "optimised_on": ws.description,
        # the module of --surfaces module / --workspace module (the fly check flies it)
        "module": geom.to_doc() if "module" in (args.workspace, args.surfaces) else None,
        # the box to build the layout's flight table over (`mfns table build --workspace`
        # takes this file): the one the map analysis above used
        WORKSPACE_KEY: [round(float(v), 1) for v in np.concatenate(table_workspace(ws))],
        "noise": noise,
        "iterations": args.iterations,
        "restarts": args.restarts,
        "margin": args.margin,
        "cert_in_view": getattr(args, "cert_in_view", None),
        "moves_tried": res.moves_tried,
        "moves_kept": res.moves_kept,
        "seed": args.seed,
        "certifiable_objective": certify,
        "survey_sigma_mm": survey,
        "survey_sigma_from": survey_from,
        "ident": res_ident,
        "objective": _obj_doc(res.objective, ws.n),
        "greedy_objective": _obj_doc(res.greedy_objective, ws.n),
        "run_time_s": {
            "candidates_in_view": round(prob.build_s, 2),
            "greedy": round(res.greedy_s, 2),
            "annealing": round(res.search_s, 2),
            "per_restart": search_s,
            "total": round(total_s, 2),
        },
    }
    # check on independent samples (the turntable sweep is the sweep itself)
    ws_check = build_workspace(args, stream=1)
    info = {"beacons": str(out / "beacons.csv"), "n_beacons": args.count, "rig": str(args.rig or PAPER_CALIB)}
    info["noise"] = check_noise
    sig = np.full(args.count, survey)
    s = _analyze_into(out, core, layout, sig, ws_check, sigma_px, calib, info, "plan optimize", progress)
    plan_doc["check"] = {k: s[k] for k in CHECK_KEYS}
    if args.baseline:
        _, bpos, _ = load_beacon_csv(args.baseline)
        bsig = np.full(len(bpos), survey)
        binfo = {**info, "beacons": str(args.baseline), "n_beacons": len(bpos)}
        bs = _analyze_into(
            out / "baseline", core, bpos, bsig, ws_check, sigma_px, calib, binfo, "baseline", progress
        )
        plan_doc["baseline"] = {
            "beacons": str(args.baseline),
            **{k: bs[k] for k in CHECK_KEYS if k != "samples"},
        }
        plan_doc["baseline"]["sigma_p99"] = {
            k: v["p99"] for k, v in bs["sigma_percentiles_over_fix_samples"].items()
        }
        if certify and args.ident_samples > 0:
            plan_doc["baseline"]["ident"] = ident_check(core, bpos, survey, ws, sigma_px, args.ident_samples)
    plan_doc["sigma_p99"] = {k: v["p99"] for k, v in s["sigma_percentiles_over_fix_samples"].items()}
    plan_doc["restart_usable_pct"] = restart_usable
    if pol is not None:
        plan_doc["polish"] = {
            "what": "hill climb on the flight's verdict (mfns.plan.usable.polish), the samples optimised on",
            "usable": f"{pol.usable_before} -> {pol.usable_after} of {ws.n}",
            "one_call": f"{pol.one_call_before} -> {pol.one_call_after} of {ws.n}",
            "moves_tried": pol.moves_tried,
            "moves_kept": pol.moves_kept,
            "seconds": round(pol.seconds, 1),
        }
    (out / "plan.json").write_text(json.dumps(plan_doc, indent=2) + "\n")
    if args.fly_frames > 0 and args.workspace == "module":
        plan_doc["fly"] = fly_check(args, core, out, sigma_px, progress)
        (out / "plan.json").write_text(json.dumps(plan_doc, indent=2) + "\n")
    elif args.fly_frames > 0:
        print(f"  fly check: not run (flown paths are module paths; the workspace is {args.workspace})")
    rt = plan_doc["run_time_s"]
    _print(
        s,
        f"plan optimize: {args.count} beacons from {len(cand)} candidates on {args.surfaces}, "
        f"{ws.n} samples; {rt['total']} s (in view {rt['candidates_in_view']} s, {args.restarts} x greedy + "
        f"annealing {rt['per_restart']} s; best: {res.moves_kept}/{res.moves_tried} moves kept)\n"
        f"  -> {out / 'beacons.csv'}",
    )
    if res_ident is not None:
        print(
            f"  identification (map analysis, {res_ident['views']} views): "
            f"{res_ident['ambiguous']} ambiguous, "
            f"margin median {res_ident['margin_median']}; survey sigma {survey:g} mm ({survey_from})"
        )
    if args.baseline:
        b = plan_doc["baseline"]
        print(
            f"  baseline {args.baseline}: availability {b['availability_pct']} %, one-call views "
            f"{b['one_call_views_pct']} %, four in view {b['four_in_view_pct']} %"
        )
    if "polish" in plan_doc:
        pd = plan_doc["polish"]
        print(
            f"  polish on the flight's verdict: usable {pd['usable']}, one call {pd['one_call']} "
            f"({pd['moves_kept']}/{pd['moves_tried']} moves kept, {pd['seconds']} s)"
        )
    if args.baseline:
        bv = plan_doc["baseline"]["flight_verdict"]
        print(
            f"  baseline by the flight's verdict: usable {bv['usable_pct']} %, "
            f"one call {bv['one_call_pct']} %; "
            f"cameras x/y/z see beacons in {bv['per_camera_seen_pct']} % of the samples"
        )
    fly_failed = plan_doc.get("fly", {}).pop("failed", None)
    if fly_failed:
        plan_doc["fly_failed"] = fly_failed
        (out / "plan.json").write_text(json.dumps(plan_doc, indent=2) + "\n")
    for name, f in plan_doc.get("fly", {}).items():
        print(
            f"  flown ({name}, {f['paths']} fresh paths x {f['frames_per_path']} frames): "
            f"usable {f['flown_usable_pct']} %"
            f" (predicted on the flown poses {f['predicted_usable_pct']} %); first fix at cycle "
            f"{f['first_fix_cycles']}; error 1-sigma {f['error_sigma']}"
        )
        oc = f.get("one_call")
        if oc:
            print(
                f"    one call, measured: {oc['certified_first_cycle']} of {oc['starts']} lost starts "
                f"({oc['measured_pct']} %) certified a fix in their first cycle; predicted on the same "
                f"poses {oc['predicted_pct']} % (not certified: {oc['not_certified_reasons'] or 'none'})"
            )
    box = ",".join(f"{v:g}" for v in plan_doc[WORKSPACE_KEY])
    print(
        f"  its flight table: mfns table build CALIB {out / 'beacons.csv'} --workspace {out / 'plan.json'} "
        f"(the planned box {box} mm; the default, the beacons' box shrunk by 10 %, may not hold it)"
    )
    if fly_failed:
        print(f"plan optimize: fly check: {fly_failed}", file=sys.stderr)
        return 1
    return 0


def _preferred(a, a_ident, b, b_ident, a_use=None, b_use=None) -> bool:
    """Layout a over b: more poses the flight would use (usable.py), then more of them
    certifiable in one call, then more poses with a fix, then more certifiable in one call,
    then fewer ambiguous views (the map analysis), then the rest of the objective."""
    if a_use is not None and b_use is not None:
        ua, ub = (a_use["usable_pct"], a_use["one_call_pct"]), (b_use["usable_pct"], b_use["one_call_pct"])
        if ua != ub:
            return ua > ub
    ka, kb = a.objective[:2], b.objective[:2]
    if ka != kb:
        return ka > kb
    if a_ident is not None and b_ident is not None and a_ident["ambiguous"] != b_ident["ambiguous"]:
        return a_ident["ambiguous"] < b_ident["ambiguous"]
    return opt.better(a.objective, b.objective)


def _obj_doc(obj: tuple, n: int) -> dict:
    return {
        "poses_with_fix": f"{obj[0]}/{n}",
        "poses_certifiable_in_one_call": f"{obj[1]}/{n}",
        "missing_beacons": -obj[2],
        "worst_score": -obj[3],
        "mean_score": -obj[4],
        "score": f"max(position 1-sigma / {opt.POS_SCALE_MM:g} mm, "
        f"attitude 1-sigma / {opt.ATT_SCALE_DEG:g} deg)",
    }


def _print(s: dict, head: str) -> None:
    p = s["sigma_percentiles_over_fix_samples"]
    worst = ", ".join(f"{k} {v['p100']:.3g}" for k, v in p.items() if v["p100"] is not None)
    print(
        f"{head}\n  availability {s['availability_pct']} % (>= 4 in view), track {s['track_pct']} % (>= 3)"
        + (
            ""
            if s["availability_flight_pct"] is None
            else f", nav-cycle rule {s['availability_flight_pct']} %"
        )
        + f"; one-call views {s['one_call_views_pct']} % (>= {CERT_MIN_IN_VIEW} in view; exactly "
        f"{FIX_MIN_IN_VIEW}: {s['four_in_view_pct']} %, acquired over cycles only)\n  "
        f"in view mean {s['in_view_mean']}, min {s['in_view_min']}, per camera {s['per_camera_mean']}\n"
        f"  worst 1-sigma over fix samples: {worst or 'none (no fix)'}"
    )
    v = s.get("flight_verdict")
    if v:
        why = ", ".join(f"{k} {c}" for k, c in v["unusable_reasons"].items()) or "none"
        print(
            f"  the flight's verdict (C solver + integrity, survey sigma as the map states): usable "
            f"{v['usable_pct']} %, one call {v['one_call_pct']} % (not usable: {why}); cameras x/y/z see "
            f"beacons in {v['per_camera_seen_pct']} % of the samples"
        )


# The fly check's paths: seeds of their own (never the planner's samples), one per path.
FLY_SEED_BASE = 9100


def fly_check(args, core, out: Path, sigma_px: float, progress: bool) -> dict:
    """Fly the planned layout (and the baseline) on fresh module paths (fly.py): flown usable
    % against the flight's verdict predicted on the very poses flown, per layout. A flight that
    failed twice is left out of its layout's figures and named in res["failed"]."""
    from . import fly  # the flight programs' runner: loaded only when a plan is flown

    layouts = {"planned": out / "beacons.csv"}
    if args.baseline:
        layouts["baseline"] = Path(args.baseline)
    # every flight is a study task (mfns.core.study): fly.fly on its own work folder and seed
    flights = [
        (
            name,
            csv_path,
            out / "plan.json",
            out / "fly" / f"{name}-{k}",
            args.fly_frames,
            FLY_SEED_BASE + 17 * args.seed + k,
            k,
            module_of(args),
            getattr(args, "fly_starts", 0),
        )
        for name, csv_path in layouts.items()
        for k in range(args.fly_paths)
    ]
    options = options_from_args(args, progress=None if progress else False)
    if progress:
        print(f"  fly check: {len(flights)} flights, {options.describe()}", flush=True)
    done = run_tasks(_fly_one, flights, options, "plan-fly")
    res: dict = {}
    for name, csv_path in layouts.items():
        # (path index, result) of this layout's flights that came back
        paths = [
            (f[6], r) for f, r in zip(flights, done.results, strict=True) if f[0] == name and r is not None
        ]
        runs = [r for _, r in paths]
        pred_usable, n_pred = 0, 0
        outcomes: list[tuple[str, str]] = []
        predicted: list[bool] = []
        per_start: list[list] = []  # path, frame, status, reason, in view (predicted), one call predicted
        for k, r in paths:
            _, pos, sig = load_beacon_csv(csv_path)
            ws_f = workspace.from_truth(Path(r["work"]) / "frames" / "truth.csv")
            u = usable.evaluate(core, pos, sig, ws_f, sigma_px, *table_workspace(ws_f))
            pred_usable += int(u.usable.sum())
            n_pred += ws_f.n
            # the planner's one-call prediction on the very poses the lost starts begin at
            one_call = u.usable & (u.in_view_cam.sum(axis=1) >= CERT_MIN_IN_VIEW)
            outcomes += [tuple(o) for o in r["start_outcomes"]]
            predicted += [bool(one_call[i]) for i in r["start_frames"]]
            per_start += [
                [k, i, *o, int(u.in_view_cam[i].sum()), bool(one_call[i])]
                for i, o in zip(r["start_frames"], r["start_outcomes"], strict=True)
            ]
        frames = sum(r["frames"] for r in runs)
        used = sum(r["usable"] for r in runs)
        reasons: dict[str, int] = {}
        for r in runs:
            for k2, c in r["unusable_reasons"].items():
                reasons[k2] = reasons.get(k2, 0) + c
        sig_axes = [r["error_sigma"] for r in runs if r["error_sigma"]]
        res[name] = {
            "beacons": str(csv_path),
            "paths": args.fly_paths,
            "frames_per_path": args.fly_frames,
            "flown_usable_pct": round(100.0 * used / frames, 2) if frames else None,
            "predicted_usable_pct": round(100.0 * pred_usable / n_pred, 2) if n_pred else None,
            "unusable_reasons": reasons,
            "first_fix_cycles": [r["first_fix_cycle"] for r in runs],
            # measured one-call: the flight started lost at frames of the flown paths (fly.py)
            "one_call": {
                **fly.one_call_summary(outcomes, predicted),
                "per_start": per_start,
                "per_start_columns": ["path", "frame", "status", "reason", "in_view", "one_call_predicted"],
            }
            if outcomes
            else None,
            "error_sigma": {
                a: round(float(np.sqrt(np.mean([d[a] ** 2 for d in sig_axes]))), 4) for a in sig_axes[0]
            }
            if sig_axes
            else None,
            "seeds": [r["seed"] for r in runs],
        }
    if done.failures:
        res["failed"] = done.failed_summary("flights")
    return res


def _fly_one(flight: tuple) -> dict:
    """One fly-check flight (a study task): fly.fly(layout, plan.json, work, frames, seed, module,
    lost starts); the flight tuple is (layout name, those inputs with the path index after the
    seed)."""
    from . import fly

    _name, layout, plan_json, work, frames, seed, _path, geom, starts = flight
    return fly.fly(layout, plan_json, work, frames, seed, geom, starts)


def _counts(text: str) -> list[int]:
    try:
        v = sorted({int(t) for t in text.split(",") if t.strip()})
    except ValueError as exc:
        raise MfnsError(f"--counts {text!r}: expected comma-separated beacon counts") from exc
    if not v or v[0] < 4:
        raise MfnsError(f"--counts {text!r}: every count must be at least 4")
    require_map_size(v[-1])
    return v


def _pct(text: float | None, name: str) -> float | None:
    if text is not None and not 0.0 < text <= 100.0:
        raise MfnsError(f"--{name} {text}: expected a percentage in (0, 100]")
    return text


def run_size(args) -> int:
    """`mfns plan size`: the LED count a module needs for a target usable rate and one-call
    rate. For each count, a layout is planned (greedy + annealing, one restart) and judged by
    the flight's verdict (usable.py) on independent samples: the curve count -> usable %,
    one-call %; the answer is the smallest count that reaches both targets, and every count
    that cannot is named with the target it misses."""
    counts = _counts(args.counts)
    t_use, t_one = _pct(args.target_usable, "target-usable"), _pct(args.target_one_call, "target-one-call")
    if not (0 <= args.iterations <= MAX_ITERATIONS and 0 <= args.polish <= MAX_ITERATIONS):
        raise MfnsError(f"--iterations and --polish must be 0 to {MAX_ITERATIONS}")
    doc, cams = _load_rig(args)
    core = Core(cams)
    surf, keep = surfaces.load(args.surfaces, module_of(args))
    keep += [surfaces.parse_box(k) for k in args.keep_out or []]
    cand, _ = surfaces.candidates(surf, args.grid, keep)
    survey = args.beacon_sigma if args.beacon_sigma is not None else DEFAULT_SURVEY_SIGMA_MM
    if not survey >= 0:
        raise MfnsError("--beacon-sigma must be >= 0")
    sigma_px, _, _, _ = _noise(args, doc, core, np.zeros(0))
    ws, ws_check = build_workspace(args, stream=0), build_workspace(args, stream=1)
    progress = not args.quiet
    t0 = time.perf_counter()
    prob = opt.build_problem(core, cand, ws, sigma_px, survey, progress)
    out = Path(args.out)
    _prepare(out)
    rows = []
    for n in counts:
        if n > len(cand):
            raise MfnsError(
                f"{n} beacons: only {len(cand)} candidates on {args.surfaces} (try a finer --grid)"
            )
        rng = np.random.default_rng([args.seed, 11, n])
        res = opt.optimize(prob, n, args.min_spacing, args.iterations, rng, margin=args.margin)
        chosen = res.chosen
        if args.polish > 0:  # the flight's verdict as the objective, as plan optimize does
            lo_hi = table_workspace(ws)
            chosen = usable.polish(
                core, prob, chosen, survey, sigma_px, args.polish, args.min_spacing, rng, *lo_hi
            ).chosen
        layout = cand[chosen]
        v = usable.evaluate(core, layout, np.full(n, survey), ws_check, sigma_px, *table_workspace(ws_check))
        s = v.summary()
        write_beacons(out / f"beacons_{n}.csv", layout, survey if survey > 0 else DEFAULT_SURVEY_SIGMA_MM)
        misses = []
        if t_use is not None and s["usable_pct"] < t_use:
            misses.append(f"usable {s['usable_pct']} % < {t_use:g} %")
        if t_one is not None and s["one_call_pct"] < t_one:
            misses.append(f"one call {s['one_call_pct']} % < {t_one:g} %")
        rows.append({"count": n, **s, "misses": misses})
        if progress:
            print(f"  {n} beacons: usable {s['usable_pct']} %, one call {s['one_call_pct']} %", flush=True)
    enough = [r["count"] for r in rows if not r["misses"]]
    doc_out = {
        "surfaces": args.surfaces,
        "workspace": ws_check.description,
        "samples": ws_check.n,
        "survey_sigma_mm": survey,
        "pixel_sigma_px": sigma_px,
        "target_usable_pct": t_use,
        "target_one_call_pct": t_one,
        "verdict": "the flight's own (C solver + integrity per view, mfns.plan.usable); the one-call "
        f"rate counts usable views with >= {CERT_MIN_IN_VIEW} beacons in view",
        "curve": rows,
        "answer": enough[0] if enough else None,
        "run_time_s": round(time.perf_counter() - t0, 1),
    }
    (out / "size.json").write_text(json.dumps(doc_out, indent=2) + "\n")
    with open(out / "size.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["count", "usable_pct", "one_call_pct", "per_camera_seen_pct", "misses"])
        for r in rows:
            w.writerow(
                [
                    r["count"],
                    r["usable_pct"],
                    r["one_call_pct"],
                    r["per_camera_seen_pct"],
                    "; ".join(r["misses"]),
                ]
            )
    _size_plot(rows, t_use, t_one, out / "size.png", args.surfaces)
    for r in rows:
        print(
            f"{r['count']:4d} LEDs: usable {r['usable_pct']:6.2f} %, one call {r['one_call_pct']:6.2f} %"
            + (f"  cannot reach: {', '.join(r['misses'])}" if r["misses"] else "")
        )
    if t_use is not None or t_one is not None:
        targets = " and ".join(
            t
            for t in (f"usable >= {t_use:g} %" if t_use else "", f"one call >= {t_one:g} %" if t_one else "")
            if t
        )
        if enough:
            print(f"plan size: {enough[0]} LEDs reach {targets} (of the counts tried)")
        else:
            print(f"plan size: no count tried reaches {targets}: try more LEDs (--counts)")
    print(f"wrote {out / 'size.json'}, {out / 'size.csv'}, {out / 'size.png'}")
    return 0


def _size_plot(rows, t_use, t_one, path: Path, surfaces_name: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [r["count"] for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(n, [r["usable_pct"] for r in rows], "o-", label="usable (flight verdict)")
    ax.plot(n, [r["one_call_pct"] for r in rows], "s-", label="usable in one call")
    for t, st, lab in ((t_use, "--", "target usable"), (t_one, ":", "target one call")):
        if t is not None:
            ax.axhline(t, color="k", ls=st, lw=0.9, label=lab)
    ax.set_xlabel("LEDs")
    ax.set_ylabel("% of workspace poses")
    ax.set_title(f"LED count -> rates ({surfaces_name})")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
