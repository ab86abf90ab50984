"""Acceptance of issue 12 item 5: the covariance the flight program reports means what it says.

The demo's module scenario (mk/demo.sh: `mfns sim nav --scenario module --frames 120 --seed 2`)
is flown through the whole chain, `mfns table build` -> `mfns-nav` (replay cameras) ->
telemetry -> `mfns-ground` -> nav.csv -> `mfns report --truth`, and the NEES of the fixes
(e^T P^-1 e with the full 6x6 covariance of the nav packet, chi-square(6) when P is right) is
held to the issue's bounds:

- the table from the true rig: mean NEES 6 +- 20 %;
- the same with the survey error applied to the rendered beacons (`mfns sim nav
  --survey-error`: every LED rendered displaced by N(0, sigma_mm^2 I); the table keeps the
  nominal map with its 0.4 mm): 6 +- 20 %;
- the table from the refined calibration (its calibration term included): mean within
  0.5x-2x of 6;
- the table from the paper-method calibration: its covariance, with its calibration term,
  covers its bias: >= 90 % of the fixes inside the chi-square(6) 99 % bound.

A covariance can only be held to the truth when the table's inputs are true:

- Without `--survey-error` the simulated map is exact (docs/nav-frames.md), so the tables
  flown on those frames get the map with the accuracy it has, `sigma_mm` = 0.0001 mm (the
  resolution of beacons.csv; the reader refuses 0). With the 0.4 mm the file states, the
  covariance carries a survey term that is not in the data (the solver's survey term is
  ~20x the centroid noise in this geometry) and the NEES is ~0.01 however right the rest is.
- The survey error of one run is ONE draw of the 60 displacements, shared by every fix: the
  mean NEES of one realisation scatters by ~27 % (six realisations measured, 3.4-7.8 with a
  consistent covariance), so the 6 +- 20 % is held on the pool of SURVEY_SEEDS realisations
  (the demo's seed first, then the next ones; not chosen).

The tables are built with `mfns table build`'s defaults (no `--pixel-sigma` budget): the
point is that the covariance is right by itself; only the integrity alert limits are
opened (OPEN_ALERT_LIMITS) so that the NEES is measured on every certified fix. The
calibration is the demo's (`mfns sim calib` + `mfns calib`, about 30 s), run while the
navigation frames are simulated.
"""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from flight_replay import fly_replay  # tests/host

from mfns.analysis import nees as N

REPO = Path(__file__).resolve().parents[2]
BIN = REPO / "build" / "host-sim" / "bin"
SIM = ["--scenario", "module", "--frames", "120", "--seed", "2"]  # mk/demo.sh's module run
SURVEY_SEEDS = (2, 3, 4, 5)  # survey realisations pooled (the first is the demo's seed)
EXACT_SIGMA_MM = "0.0001"  # the resolution of beacons.csv (four decimals)
LOW, HIGH = 6 * 0.8, 6 * 1.2  # the 6 +- 20 %


def mfns(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True, timeout=timeout
    )


# The covariance is held on every fix the solver certifies, not only on those whose
# protection level is inside the default alert limits (issue 23: 20 mm, 1 deg, which keep
# about a fifth of this scenario's fixes): the integrity gate is a separate policy
# (test_fault_campaign, make faults) and must not choose the fixes the NEES is measured on.
OPEN_ALERT_LIMITS = {"integrity": {"alert_limit_pos_mm": 1e4, "alert_limit_att_deg": 180}}


def build_table(out: Path, calib: Path, beacons: Path) -> Path:
    table = out / "table.mfnstbl"
    out.mkdir(parents=True, exist_ok=True)
    settings = out / "settings.json"
    settings.write_text(json.dumps(OPEN_ALERT_LIMITS))
    res = mfns("table", "build", str(calib), str(beacons), "-o", str(table), "--settings", str(settings))
    assert res.returncode == 0, res.stderr
    return table


def fly(out: Path, frames: Path, table: Path) -> dict:
    """mfns-nav on the frames with the table -> mfns-ground -> mfns report (summary.json)."""
    fly_replay(BIN, table, frames, out, tlm_name="telemetry.bin")
    rep = mfns(
        "report", str(out / "ground"), "--truth", str(frames / "truth.csv"), "--out", str(out / "report")
    )
    assert rep.returncode == 0, rep.stderr
    doc = json.loads((out / "report" / "summary.json").read_text())
    doc["_summary_md"] = (out / "report" / "summary.md").read_text()
    doc["_header"] = (out / "ground" / "nav.csv").read_text().split("\n", 1)[0].split(",")
    return doc


def exact_map(beacons: Path, out: Path) -> Path:
    """The map of a simulation without survey error, with the accuracy it has."""
    with beacons.open(newline="") as f:
        rows = list(csv.DictReader(f))
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({**r, "sigma_mm": EXACT_SIGMA_MM})
    return out


def pooled(docs: list[dict]) -> dict:
    """The NEES of several runs as one sample: means and fractions weighted by their fixes."""
    ns = [full_nees(d) for d in docs]
    n = sum(x["n_used"] for x in ns)
    return {
        "n_used": n,
        "mean": sum(x["mean"] * x["n_used"] for x in ns) / n,
        "frac_inside_95": sum(x["frac_inside_95"] * x["n_used"] for x in ns) / n,
        "frac_inside_99": sum(x["frac_inside_99"] * x["n_used"] for x in ns) / n,
        "per_run": [round(x["mean"], 3) for x in ns],
    }


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict:
    built = subprocess.run(
        ["make", "--no-print-directory", "-j2", "BOARD=host-sim", "flight"],
        cwd=REPO,
        check=False,
        capture_output=True,
        text=True,
    )
    assert built.returncode == 0, built.stdout + built.stderr
    d = tmp_path_factory.mktemp("nees_acceptance")
    ds = d / "calib" / "dataset"
    refined = d / "calib" / "refined.json"
    calib = subprocess.Popen(  # the demo's calibration, alongside the flights of the true rig
        [
            "sh",
            "-c",
            f'"{sys.executable}" -m mfns sim calib "{ds}" --quiet && '
            f'"{sys.executable}" -m mfns calib "{ds}" --truth "{ds / "truth.json"}" -o "{refined}" --quiet',
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    out: dict = {}
    try:
        frames = d / "frames"
        res = mfns("sim", "nav", str(frames), "--quiet", *SIM)
        assert res.returncode == 0, res.stderr
        exact = exact_map(frames / "beacons.csv", d / "beacons_exact.csv")
        out["true-rig"] = fly(
            d / "true-rig", frames, build_table(d / "true-rig", frames / "calib.json", exact)
        )
        # survey error: the table of the nominal map, the same for every realisation
        nominal = build_table(d / "true-rig-survey", frames / "calib.json", frames / "beacons.csv")
        survey = []
        for s in SURVEY_SEEDS:
            f = d / f"frames-survey-{s}"
            res = mfns("sim", "nav", str(f), "--quiet", *SIM, "--survey-error", "--survey-seed", str(s))
            assert res.returncode == 0, res.stderr
            for name in ("beacons.csv", "calib.json", "truth.csv"):
                assert (f / name).read_bytes() == (frames / name).read_bytes(), name
            survey.append(fly(d / f"true-rig-survey-{s}", f, nominal))
            for cam in ("cam_x", "cam_y", "cam_z"):  # 450 MB of frames per realisation
                shutil.rmtree(f / cam)
        out["true-rig, survey error"] = survey
        log, _ = calib.communicate(timeout=600)
        assert calib.returncode == 0, log
    finally:
        if calib.poll() is None:
            calib.kill()
            calib.wait()
    for name, doc in (
        ("refined-calibration", refined),
        ("paper-calibration", d / "calib" / "refined_paper.json"),
    ):
        out[name] = fly(d / name, frames, build_table(d / name, doc, exact))
    print("\nNEES on the module scenario (mfns report summary.json):")
    print("| table | fixes used / with truth | not PD | mean NEES | inside 95 % | inside 99 % |")
    for name, doc in out.items():
        for k, one in enumerate(doc if isinstance(doc, list) else [doc]):
            n = one["nees"]
            label = f"{name} (survey seed {SURVEY_SEEDS[k]})" if isinstance(doc, list) else name
            if n is None:
                print(f"| {label} | no covariance columns | | | | |")
                continue
            print(
                f"| {label} ({n['kind']}) | {n['n_used']} / {n['n_fixes']} | {n['n_not_positive_definite']} "
                f"| {n['mean']:.3f} | {100 * n['frac_inside_95']:.1f} % | {100 * n['frac_inside_99']:.1f} % |"
            )
    return out


def full_nees(doc: dict) -> dict:
    """The NEES block of a run, which must come from the full covariance and the quaternion."""
    n = doc["nees"]
    assert n is not None, "nav.csv has no covariance columns:\n" + doc["_summary_md"]
    assert n["kind"] == "full", "nav.csv has only the diagonal 1-sigma columns:\n" + doc["_summary_md"]
    assert any("quaternion" in note for note in n["notes"]), n["notes"]
    # every fix of the flight program carries a usable covariance and a unit quaternion
    assert n["n_not_positive_definite"] == 0 and n["n_bad_quaternion"] == 0, doc["_summary_md"]
    # enough fixes for a statistic (a quarter of the cycles)
    assert n["n_used"] == n["n_fixes"] == doc["n_used"] and n["n_used"] >= 30, doc["_summary_md"]
    return n


def test_ground_writes_the_quaternion_and_covariance_columns(runs):
    """The contract between mfns-ground and mfns report (docs/telemetry.md, nav.csv)."""
    header = runs["true-rig"]["_header"]
    missing = [c for c in (*N.QUAT_COLUMNS, *N.COV_COLUMNS) if c not in header]
    assert not missing, f"nav.csv header {header} lacks {missing}"


def test_true_rig_mean_nees_is_6_within_20_percent(runs):
    n = full_nees(runs["true-rig"])
    assert LOW <= n["mean"] <= HIGH, runs["true-rig"]["_summary_md"]


def test_true_rig_with_survey_error_mean_nees_is_6_within_20_percent(runs):
    p = pooled(runs["true-rig, survey error"])
    assert LOW <= p["mean"] <= HIGH, p


def test_refined_calibration_mean_nees_within_half_to_twice_6(runs):
    doc = runs["refined-calibration"]
    n = full_nees(doc)
    assert 0.5 * 6 <= n["mean"] <= 2 * 6, doc["_summary_md"]


def test_paper_calibration_covariance_covers_its_bias(runs):
    """The paper-method calibration is biased; its covariance says by how much. The pose
    covariance carries it (pose_cov.c), and so does the time-offset monitor's test variance
    (integrity_lag.c static_var): before the latter, the monitor took the bias for a lag and
    refused 107 of the 120 fixes (issue 23)."""
    doc = runs["paper-calibration"]
    n = full_nees(doc)
    assert n["frac_inside_99"] >= 0.90, doc["_summary_md"]
