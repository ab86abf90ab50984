"""The self-survey in `make demo` (docs/self_survey.md): the module scenario with its survey
error rendered, flown for a few minutes with the fix log on; `mfns map refine`; then the
same LEDs flown on fresh frames (another trajectory and noise) with the surveyed map and
with the refined one, side by side: navigation errors against truth and the NEES.

    mfns map demo OUT [--report REPORT.md] [--minutes M]

Appends its section to REPORT.md (the demo's report) and writes OUT/self_survey.md.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from ..analysis.report import AXES
from ..model.camera import load_beacons
from ..simulate.nav import CAMERA_DIRS
from . import fixlog

SURVEY_RATE_HZ = 2.0  # frames of the survey flight: one every 0.5 s is plenty for a map
FRESH_FRAMES = 120  # the demo's module run: 6.5 s at 18.6 Hz
SEED, FRESH_SEED = 2, 7
MIN_SEEN_FIXES = 10  # a beacon "seen" by the survey flight: used in at least this many fixes


def _run(cmd: list[str], log: Path | None = None, allow: str | None = None) -> bool:
    """Run cmd into log; False when it fails with a log line holding allow (an expected
    outcome, not an error), else a failure ends the run."""
    with open(log, "w") if log else open("/dev/null", "w") as f:
        res = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, check=False)
    if res.returncode != 0:
        if allow is not None and log is not None and allow in log.read_text(errors="replace"):
            return False
        raise SystemExit(f"refine_demo: {' '.join(cmd[:4])} ... failed (exit {res.returncode}; {log})")
    return True


def _no_fix_summary() -> dict:
    """The summary of a flight with no usable fix matched to truth (`mfns report` has
    nothing to report): no fixes, every figure undefined."""
    nan = float("nan")
    axes = [{"axis": a, "mean": nan, "sigma": nan} for a in AXES]
    return {"n_used": 0, "axes": axes, "nees": {"mean": nan}}


def _fly(
    py: str,
    bins: Path,
    frames: Path,
    calib: Path,
    beacons: Path,
    out: Path,
    fixlog: Path | None = None,
    datum: Path | None = None,
):
    out.mkdir(parents=True, exist_ok=True)
    build = [py, "-m", "mfns", "table", "build", str(calib), str(beacons), "-o", str(out / "table.mfnstbl")]
    if datum is not None:
        build += ["--map-datum", str(datum)]
    _run(build, out / "table.log")
    nav = [
        str(bins / "mfns-nav"),
        "--table",
        str(out / "table.mfnstbl"),
        "--replay",
        str(frames),
        "--tlm-file",
        str(out / "telemetry.bin"),
        "--quiet",
    ]
    if fixlog is not None:
        nav += ["--fixlog", str(fixlog)]
    _run(nav, out / "nav.log")
    _run(
        [
            str(bins / "mfns-ground"),
            "--file",
            str(out / "telemetry.bin"),
            "--out",
            str(out / "ground"),
            "--no-status",
        ],
        out / "ground.log",
    )
    reported = _run(
        [
            py,
            "-m",
            "mfns",
            "report",
            str(out / "ground"),
            "--truth",
            str(frames / "truth.csv"),
            "--out",
            str(out / "report"),
            "--title",
            out.name,
        ],
        out / "report.log",
        allow="nothing to report",  # a path with no usable fix: a result, not a failure
    )
    if not reported:
        (out / "report").mkdir(parents=True, exist_ok=True)
        (out / "report" / "summary.json").write_text(json.dumps(_no_fix_summary()) + "\n")
    return json.loads((out / "report" / "summary.json").read_text())


def rigid_to(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """src moved by the rotation and translation that best fit it to dst (least squares)."""
    ms, md = src.mean(0), dst.mean(0)
    u, _, vt = np.linalg.svd((dst - md).T @ (src - ms))
    r = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    return (src - ms) @ r.T + md


def map_figures(run: Path) -> dict:
    """A refine_demo run's map against truth: RMS per coordinate and per beacon (3-D), over
    all beacons and over those used in >= MIN_SEEN_FIXES survey fixes, against the true
    positions (`truth`) and against the truth in the survey's datum (`datum`: the truth
    moved rigidly onto the survey, the frame the refinement keeps: docs/self_survey.md)."""
    ids, p_s, _ = load_beacons(run / "survey-frames" / "beacons.csv")
    _, p_t, _ = load_beacons(run / "survey-frames" / "beacons_rendered.csv")
    _, p_r, sig_r = load_beacons(run / "refined" / "beacons.csv")
    fixes, _ = fixlog.read(run / "fixlog")
    seen = {int(i): 0 for i in ids}
    for f in fixes:
        for b in f.beacon_id[f.used]:
            seen[int(b)] += 1
    n = np.array([seen[int(i)] for i in ids])
    p_td = rigid_to(p_t, p_s)

    def rms(d):
        return float(np.sqrt(np.mean(d**2))) if d.size else float("nan")

    def rms3(d):
        return float(np.sqrt(np.mean(np.sum(d**2, axis=1)))) if d.size else float("nan")

    out = {"beacons": int(len(ids)), "fixes": len(fixes), "unseen": [int(i) for i in ids[n < MIN_SEEN_FIXES]]}
    for sel_name, sel in (("all", np.ones(len(ids), bool)), ("seen", n >= MIN_SEEN_FIXES)):
        for ref_name, ref in (("truth", p_t), ("datum", p_td)):
            out[f"refined_{sel_name}_{ref_name}"] = (rms((p_r - ref)[sel]), rms3((p_r - ref)[sel]))
            out[f"survey_{sel_name}_{ref_name}"] = (rms((p_s - ref)[sel]), rms3((p_s - ref)[sel]))
    out["datum_error"] = (rms(p_td - p_t), rms3(p_td - p_t))  # the survey's own datum, against truth
    out["sigma_median"] = float(np.median(sig_r))
    out["fixes_per_beacon_median"] = float(np.median(n))
    return out


def _ids(ids: list[int]) -> str:
    """A list of beacon ids for a sentence: none, the ids, or how many when many."""
    if not ids:
        return "none"
    return ", ".join(map(str, ids)) if len(ids) <= 8 else f"{len(ids)} beacons"


def summary_num(v) -> float:
    """A figure of `mfns report`'s summary.json: null (undefined, e.g. the 1-sigma of a
    single fix) is nan."""
    return float("nan") if v is None else float(v)


def axis_rms(s: dict, axis: str) -> float:
    """The error RMS on one axis of a summary.json (its mean and 1-sigma together)."""
    a = next(x for x in s["axes"] if x["axis"] == axis)
    return float(np.hypot(summary_num(a["mean"]), summary_num(a["sigma"])))


def _row(name: str, s: dict) -> str:
    pos = " | ".join(f"{axis_rms(s, a):.3f}" for a in ("x", "y", "z"))
    att = " | ".join(f"{axis_rms(s, a):.4f}" for a in ("roll", "pitch", "yaw"))
    return f"| {name} | {s['n_used']} | {pos} | {att} | {summary_num(s['nees']['mean']):.2f} |"


def demo(a) -> int:
    """The demo: `a` holds the options of `mfns map demo` (commands/map.py)."""
    py, bins, out = sys.executable, Path(a.bin), Path(a.out)
    seed = a.seed
    fresh_seed = a.fresh_seed if a.fresh_seed is not None else seed + FRESH_SEED - SEED
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    t0 = time.monotonic()
    n_survey = int(round(a.minutes * 60 * a.rate_hz))
    survey, fresh = out / "survey-frames", out / "fresh-frames"
    _run(
        [
            py,
            "-m",
            "mfns",
            "sim",
            "nav",
            str(survey),
            "--scenario",
            "module",
            "--frames",
            str(n_survey),
            "--rate-hz",
            str(a.rate_hz),
            "--seed",
            str(seed),
            "--survey-error",
            "--quiet",
        ],
        out / "sim.log",
    )
    calib, surveyed = survey / "calib.json", survey / "beacons.csv"
    _fly(py, bins, survey, calib, surveyed, out / "survey-flight", fixlog=out / "fixlog")
    for c in CAMERA_DIRS:  # 2.7 MB per frame set: keep what describes the run
        shutil.rmtree(survey / c)
    _run(
        [
            py,
            "-m",
            "mfns",
            "map",
            "refine",
            str(out / "fixlog"),
            "--beacons",
            str(surveyed),
            "--calib",
            str(calib),
            "--out",
            str(out / "refined"),
        ],
        out / "refine.log",
    )
    # fresh frames: the same LEDs (map and survey error of the survey's seed), another path and noise
    _run(
        [
            py,
            "-m",
            "mfns",
            "sim",
            "nav",
            str(fresh),
            "--scenario",
            "module",
            "--frames",
            str(FRESH_FRAMES),
            "--seed",
            str(fresh_seed),
            "--beacon-map",
            str(surveyed),
            "--survey-error",
            "--survey-seed",
            str(seed),
            "--quiet",
        ],
        out / "sim-fresh.log",
    )
    before = _fly(py, bins, fresh, calib, surveyed, out / "surveyed-map")
    refined = out / "refined"
    after = _fly(
        py, bins, fresh, calib, refined / "beacons.csv", out / "refined-map", datum=refined / "map_datum.json"
    )
    # the same refined map with its whole sigma per beacon and no datum section: what the
    # split buys (docs/self_survey.md "Which part of the 1-sigma is the map's")
    whole = _fly(py, bins, fresh, calib, refined / "beacons.csv", out / "refined-map-no-datum")
    for c in CAMERA_DIRS:
        shutil.rmtree(fresh / c)
    rep = json.loads((out / "refined" / "refine.json").read_text())
    fig = map_figures(out)
    rel = json.loads((refined / "map_datum.json").read_text())["sigma_relative_mm"]
    rel_median = float(np.median(list(rel.values())))

    def pair(v):
        return f"{v[0]:.3f} / {v[1]:.3f} mm"

    lines = [
        "## Self-survey: the map refined from flight data (docs/self_survey.md)",
        "",
        f"Module scenario, survey error rendered (sigma 0.4 mm): {a.minutes:g} minutes of flight at "
        f"{a.rate_hz:g} Hz with the fix log on ({rep['fixes']} usable fixes, {rep['associations']} "
        f"associations), `mfns map refine`, then fresh frames (seed {fresh_seed}, {FRESH_FRAMES} frames, "
        "the same LEDs) flown with each map. Errors are RMS against truth (mean and 1-sigma together).",
        "",
        "Beacon position error RMS, per coordinate / per beacon (3-D): surveyed "
        f"{pair(fig['survey_all_truth'])}; refined {pair(fig['refined_all_truth'])} against the true "
        f"positions, {pair(fig['refined_all_datum'])} in the survey's datum (the survey's own datum error: "
        f"{pair(fig['datum_error'])}); beacons the flight saw in fewer than {MIN_SEEN_FIXES} fixes: "
        f"{_ids(fig['unseen'])}; refined sigma median {fig['sigma_median']:.3f} mm; beacons flagged "
        f"as moved: {rep['moved_beacons'] or 'none'}.",
        "",
        "| map | fixes | x mm | y mm | z mm | roll deg | pitch deg | yaw deg | mean NEES (6) |",
        "|---|---|---|---|---|---|---|---|---|",
        _row("surveyed", before),
        _row("refined", after),
        _row("refined, no datum", whole),
        "",
        '"refined" flies the refined map as `mfns map refine` hands it over: each beacon\'s relative '
        f"sigma (median {rel_median:.3f} mm) "
        "and the map datum the beacons share (a rigid shift and turn) in the table's own section, added to "
        'each fix once; "no datum" flies the same beacons.csv alone, its sigma_mm each beacon\'s whole error '
        "treated as independent.",
        "",
        f"({time.monotonic() - t0:.0f} s; everything in {out}/)",
        "",
    ]
    text = "\n".join(lines)
    (out / "self_survey.md").write_text(text)
    if a.report:
        with open(a.report, "a") as f:
            f.write("\n" + text)
    first = next(i for i, line in enumerate(lines) if line.startswith("| map |"))
    print("\n".join(lines[first - 2 : first + 5]))
    return 0
