"""The self-survey in `make demo` (docs/self_survey.md): the module scenario with its survey
error rendered, flown for a few minutes with the fix log on; `mfns map refine`; then the
same LEDs flown on fresh frames (another trajectory and noise) with the surveyed map and
with the refined one, side by side: navigation errors against truth and the NEES.

    python -m mfns.map.refine_demo OUT [--report REPORT.md] [--minutes M]

Appends its section to REPORT.md (the demo's report) and writes OUT/self_survey.md.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from ..camera import load_beacons

SURVEY_RATE_HZ = 2.0  # frames of the survey flight: one every 0.5 s is plenty for a map
FRESH_FRAMES = 120  # the demo's module run: 6.5 s at 18.6 Hz
SEED, FRESH_SEED = 2, 7


def _run(cmd: list[str], log: Path | None = None) -> None:
    with open(log, "w") if log else open("/dev/null", "w") as f:
        res = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, check=False)
    if res.returncode != 0:
        raise SystemExit(f"refine_demo: {' '.join(cmd[:4])} ... failed (exit {res.returncode}; {log})")


def _fly(
    py: str, bins: Path, frames: Path, calib: Path, beacons: Path, out: Path, fixlog: Path | None = None
):
    out.mkdir(parents=True, exist_ok=True)
    _run(
        [py, "-m", "mfns", "table", "build", str(calib), str(beacons), "-o", str(out / "table.mfnstbl")],
        out / "table.log",
    )
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
    _run(
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
    )
    return json.loads((out / "report" / "summary.json").read_text())


def _row(name: str, s: dict) -> str:
    ax = {a["axis"]: a for a in s["axes"]}
    pos = " | ".join(f"{np.hypot(ax[a]['mean'], ax[a]['sigma']):.3f}" for a in ("x", "y", "z"))
    att = " | ".join(f"{np.hypot(ax[a]['mean'], ax[a]['sigma']):.4f}" for a in ("roll", "pitch", "yaw"))
    n = s["nees"]
    return f"| {name} | {s['n_used']} | {pos} | {att} | {n['mean']:.2f} |"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="refine_demo", description=__doc__.split("\n\n")[0])
    ap.add_argument("out")
    ap.add_argument("--report", help="markdown report to append the section to")
    ap.add_argument("--minutes", type=float, default=3.0, help="survey flight (default 3 min)")
    ap.add_argument("--bin", default="build/host-sim/bin")
    a = ap.parse_args(argv)
    py, bins, out = sys.executable, Path(a.bin), Path(a.out)
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    t0 = time.monotonic()
    n_survey = int(round(a.minutes * 60 * SURVEY_RATE_HZ))
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
            str(SURVEY_RATE_HZ),
            "--seed",
            str(SEED),
            "--survey-error",
            "--quiet",
        ],
        out / "sim.log",
    )
    calib, surveyed = survey / "calib.json", survey / "beacons.csv"
    _fly(py, bins, survey, calib, surveyed, out / "survey-flight", fixlog=out / "fixlog")
    for c in ("cam_x", "cam_y", "cam_z"):  # 2.7 MB per frame set: keep what describes the run
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
    # fresh frames: the same LEDs (map and survey error of seed 2), another path and noise
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
            str(FRESH_SEED),
            "--beacon-map",
            str(surveyed),
            "--survey-error",
            "--survey-seed",
            str(SEED),
            "--quiet",
        ],
        out / "sim-fresh.log",
    )
    before = _fly(py, bins, fresh, calib, surveyed, out / "surveyed-map")
    after = _fly(py, bins, fresh, calib, out / "refined" / "beacons.csv", out / "refined-map")
    for c in ("cam_x", "cam_y", "cam_z"):
        shutil.rmtree(fresh / c)
    ids, p_s, _ = load_beacons(surveyed)
    _, p_true, _ = load_beacons(survey / "beacons_rendered.csv")
    _, p_r, sig_r = load_beacons(out / "refined" / "beacons.csv")
    rep = json.loads((out / "refined" / "refine.json").read_text())

    def rms(d):
        return float(np.sqrt(np.mean(d**2)))

    def rms3(d):
        return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))

    lines = [
        "## Self-survey: the map refined from flight data (docs/self_survey.md)",
        "",
        f"Module scenario, survey error rendered (sigma 0.4 mm): {a.minutes:g} minutes of flight at "
        f"{SURVEY_RATE_HZ:g} Hz with the fix log on ({rep['fixes']} usable fixes, {rep['associations']} "
        f"associations), `mfns map refine`, then fresh frames (seed {FRESH_SEED}, {FRESH_FRAMES} frames, "
        "the same LEDs) flown with each map. Errors are RMS against truth (mean and 1-sigma together).",
        "",
        f"Beacon position error RMS per coordinate: surveyed {rms(p_s - p_true):.3f} mm, refined "
        f"{rms(p_r - p_true):.3f} mm (per beacon, 3-D: {rms3(p_r - p_true):.3f} mm); "
        f"refined sigma median {np.median(sig_r):.3f} mm; beacons flagged as moved: "
        f"{rep['moved_beacons'] or 'none'}.",
        "",
        "| map | fixes | x mm | y mm | z mm | roll deg | pitch deg | yaw deg | mean NEES (6) |",
        "|---|---|---|---|---|---|---|---|---|",
        _row("surveyed", before),
        _row("refined", after),
        "",
        f"({time.monotonic() - t0:.0f} s; everything in {out}/)",
        "",
    ]
    text = "\n".join(lines)
    (out / "self_survey.md").write_text(text)
    if a.report:
        with open(a.report, "a") as f:
            f.write("\n" + text)
    print("\n".join(lines[-8:-2]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
