"""`mfns report`: time matching, angle wrapping, Table 5 statistics, plots, errors."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from mfns.analysis import report as rpt
from mfns.cli import main
from mfns.core.errors import MfnsError

NAV_HEADER = (
    "t_s,seq,cycle,status,reason,mode,beacons_used,cams_used,iterations,x_mm,y_mm,z_mm,"
    "roll_deg,pitch_deg,yaw_deg,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_roll_deg,sigma_pitch_deg,"
    "sigma_yaw_deg,residual_rms_px"
).split(",")

# Table 5 of the paper (mean, 1-sigma): the synthetic errors below use these.
TABLE5 = {
    "roll": (-0.0030, 0.1541),
    "pitch": (-0.0192, 0.1497),
    "yaw": (0.0066, 0.1729),
    "x": (-0.0553, 1.6043),
    "y": (0.0275, 1.6108),
    "z": (-0.0669, 1.8292),
}


def write_case(tmp: Path, n: int = 400, seed: int = 1, jitter_s: float = 0.003):
    """Turntable truth (0,0,0; yaw sweeping through +-180) and noisy nav with Table 5 errors."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 18.6
    yaw = (np.arange(n) * 1.7 + 150.0 + 180.0) % 360.0 - 180.0  # wraps through +-180
    truth = tmp / "truth.csv"
    with truth.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(rpt.TRUTH_HEADER)
        for i in range(n):
            w.writerow([i, f"{t[i]:.6f}", 0, 0, 0, 0, 0, f"{yaw[i]:.6f}"])
    err = {a: rng.normal(m, s, n) for a, (m, s) in TABLE5.items()}
    status = np.where(np.arange(n) % 25 == 24, "NO_FIX", "FIX")
    nav = tmp / "nav.csv"
    with nav.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(NAV_HEADER)
        for i in range(n):
            y = (yaw[i] + err["yaw"][i] + 180.0) % 360.0 - 180.0
            row = {h: "0" for h in NAV_HEADER}
            row.update(
                t_s=f"{t[i] + rng.uniform(-jitter_s, jitter_s):.6f}",
                seq=str(i),
                cycle=str(i),
                status=status[i],
                mode="TRACK",
                x_mm=f"{err['x'][i]:.3f}",
                y_mm=f"{err['y'][i]:.3f}",
                z_mm=f"{err['z'][i]:.3f}",
                roll_deg=f"{err['roll'][i]:.6f}",
                pitch_deg=f"{err['pitch'][i]:.6f}",
                yaw_deg=f"{y:.6f}",
            )
            w.writerow([row[h] for h in NAV_HEADER])
    return nav, truth, err, status == "FIX"


def test_wrap_and_match():
    assert rpt.wrap_deg(np.array([359.9, -359.9, 180.0, -180.0, 0.2])) == pytest.approx(
        [-0.1, 0.1, -180.0, -180.0, 0.2]
    )
    truth_t = np.array([0.0, 0.1, 0.2, 0.3])
    idx = rpt.match_by_time(np.array([-0.5, 0.01, 0.149, 0.151, 0.29, 0.9]), truth_t, 0.02)
    assert idx.tolist() == [-1, 0, -1, -1, 3, -1]
    idx = rpt.match_by_time(np.array([0.149, 0.151]), truth_t, 0.06)
    assert idx.tolist() == [1, 2]


def test_table5_statistics_with_truth(tmp_path):
    nav_p, truth_p, err, fix = write_case(tmp_path)
    rep = rpt.build_report(rpt.load_nav(nav_p), rpt.load_truth(truth_p), tolerance_s=0.01)
    assert rep.n_used == int(fix.sum())
    assert rep.n_rejected_status == int((~fix).sum())
    assert rep.n_unmatched == 0
    for s in rep.stats:
        e = err[s.axis][fix]
        # the CSV rounds to 1e-3 mm / 1e-6 deg; yaw wraps through +-180 without a 360 jump
        tol = 2e-3 if s.unit == "mm" else 2e-6
        assert s.mean == pytest.approx(np.mean(e), abs=tol)
        assert s.sigma == pytest.approx(np.std(e, ddof=1), abs=tol)
        assert s.n == rep.n_used
    yaw = next(s for s in rep.stats if s.axis == "yaw")
    assert abs(yaw.mean) < 0.05 and yaw.sigma < 0.25


def test_unmatched_rows_are_excluded(tmp_path):
    nav_p, truth_p, _, fix = write_case(tmp_path, n=100, jitter_s=0.0)
    truth = rpt.load_truth(truth_p)
    keep = np.arange(len(truth.t_s)) % 2 == 0  # drop every other truth sample
    truth = rpt.Truth(truth.t_s[keep], {a: v[keep] for a, v in truth.values.items()})
    rep = rpt.build_report(rpt.load_nav(nav_p), truth, tolerance_s=0.01)
    assert rep.n_used == int((fix & keep).sum())
    assert rep.n_unmatched == int((fix & ~keep).sum())
    rep_all = rpt.build_report(rpt.load_nav(nav_p), None, all_status=True)
    assert rep_all.n_used == 100


def test_cli_writes_summary_and_plots(tmp_path, capsys):
    nav_p, truth_p, _, _ = write_case(tmp_path)
    out = tmp_path / "rep"
    assert main(["report", str(nav_p), "--truth", str(truth_p), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| yaw | deg |" in printed
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert [r["axis"] for r in rows] == ["roll", "pitch", "yaw", "x", "y", "z"]
    assert all(r["kind"] == "error" for r in rows)
    assert float(rows[3]["sigma"]) == pytest.approx(1.6043, rel=0.15)
    md = (out / "summary.md").read_text()
    assert md.startswith("| axis | unit |")
    for png in ("nav_errors_vs_time.png", "nav_errors_vs_yaw.png"):
        data = (out / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10000
    # a folder argument and no truth: statistics of the estimates, written next to nav.csv
    assert main(["report", str(tmp_path), "--no-plots"]) == 0
    rows = list(csv.DictReader((tmp_path / "summary.csv").open()))
    assert all(r["kind"] == "estimate" for r in rows)


def test_user_errors(tmp_path):
    with pytest.raises(MfnsError, match="not found"):
        rpt.load_nav(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(MfnsError, match="missing columns"):
        rpt.load_nav(bad)
    with pytest.raises(MfnsError, match="missing columns"):
        rpt.load_truth(bad)
    nav_p, truth_p, _, _ = write_case(tmp_path, n=20)
    nav = rpt.load_nav(nav_p)
    truth = rpt.load_truth(truth_p)
    late = rpt.Truth(truth.t_s + 100.0, truth.values)
    with pytest.raises(MfnsError, match="nothing to report"):
        rpt.build_report(nav, late)
    text = nav_p.read_text()
    nav_p.write_text(text.replace("\n0.", "\nabc", 1))
    with pytest.raises(MfnsError, match="not a number"):
        rpt.load_nav(nav_p)
    assert main(["report", str(tmp_path / "nope.csv")]) == 2


def test_report_on_ground_station_output(tmp_path):
    """The columns mfns-ground writes are the ones the report reads."""
    import subprocess

    repo = Path(__file__).resolve().parents[2]
    bins = repo / "build" / "host-sim" / "bin"
    res = subprocess.run(
        ["make", "--no-print-directory", "-j2", "BOARD=host-sim", "flight"],
        cwd=repo,
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    stream = tmp_path / "s.bin"
    subprocess.run([str(bins / "mfns-tlm-gen"), "--cycles", "60", "--out", str(stream)], check=True)
    subprocess.run(
        [str(bins / "mfns-ground"), "--file", str(stream), "--out", str(tmp_path / "g"), "--no-status"],
        check=True,
        capture_output=True,
    )
    rep = rpt.build_report(rpt.load_nav(tmp_path / "g"), None)
    assert rep.n_used == 54  # cycles 9, 19, ..., 59 are NO_FIX in the synthetic stream
    z = next(s for s in rep.stats if s.axis == "z")
    expected = [500.0 + i / 1000 for i in range(60) if i % 10 != 9]
    assert z.mean == pytest.approx(np.mean(expected), abs=1e-9)


def test_report_refuses_the_truth_of_another_run(tmp_path, capsys):
    """Issue 28 item 3: another scenario's truth (a longer run, a shorter run) is refused with
    one line and exit 2, before anything is written; the run's own truth is accepted."""
    (tmp_path / "a").mkdir()
    (tmp_path / "long").mkdir()
    (tmp_path / "short").mkdir()
    nav_p, truth_p, _, _ = write_case(tmp_path / "a", n=120)
    _, long_truth, _, _ = write_case(tmp_path / "long", n=200, seed=2)
    _, short_truth, _, _ = write_case(tmp_path / "short", n=60, seed=3)
    assert (
        main(["report", str(nav_p), "--truth", str(truth_p), "--out", str(tmp_path / "ok"), "--no-plots"])
        == 0
    )
    capsys.readouterr()
    for bad in (long_truth, short_truth):
        out = tmp_path / f"bad_{bad.parent.name}"
        assert main(["report", str(nav_p), "--truth", str(bad), "--out", str(out), "--no-plots"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "not the same run" in err[0], err
        assert not out.exists()
    # a nav log of part of the run: refused unless --partial, and still held to the span
    nav = rpt.load_nav(nav_p)
    part = rpt.NavLog(nav.t_s[:50], nav.status[:50], {a: v[:50] for a, v in nav.values.items()}, {})
    truth = rpt.load_truth(truth_p)
    with pytest.raises(MfnsError, match="--partial"):
        rpt.check_same_run(part, truth, "nav")
    rpt.check_same_run(part, truth, "nav", partial=True)
    with pytest.raises(MfnsError, match="not the same run"):
        rpt.check_same_run(nav, rpt.load_truth(short_truth), "nav", partial=True)


def test_truth_file_is_held_to_its_run_record(tmp_path):
    """A scenario.json that records its run ("run": truth_sha256) refuses another truth.csv."""
    import hashlib
    import json

    _, truth_p, _, _ = write_case(tmp_path, n=30)
    digest = hashlib.sha256(truth_p.read_bytes()).hexdigest()
    (tmp_path / "scenario.json").write_text(json.dumps({"run": {"truth_sha256": digest, "truth_rows": 30}}))
    rpt.load_truth(truth_p)
    truth_p.write_text(truth_p.read_text() + "30,99.0,0,0,0,0,0,0\n")
    with pytest.raises(MfnsError, match="not the truth of the run"):
        rpt.load_truth(truth_p)


def _shift_truth(src: Path, dst: Path, dx_mm: float = 0.0, dyaw_deg: float = 0.0) -> Path:
    """The truth of another run with the same time base: every pose moved."""
    rows = list(csv.DictReader(src.open()))
    with dst.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=rpt.TRUTH_HEADER)
        w.writeheader()
        for r in rows:
            r["x_mm"] = f"{float(r['x_mm']) + dx_mm:.6f}"
            r["yaw_deg"] = f"{(float(r['yaw_deg']) + dyaw_deg + 180) % 360 - 180:.6f}"
            w.writerow(r)
    return dst


@pytest.mark.parametrize("dx_mm,dyaw_deg,why", [(2500.0, 0.0, "position"), (0.0, 90.0, "attitude")])
def test_report_refuses_a_truth_with_gross_errors(tmp_path, capsys, dx_mm, dyaw_deg, why):
    """Issue 43: a module run's nav against a turntable truth with the same time base passed the
    span and count checks and printed NEES 4e8 with exit 0; the gross-error check refuses it
    (exit 2, one line, nothing written) unless --accept-gross-errors."""
    nav_p, truth_p, _, _ = write_case(tmp_path, n=120)
    (tmp_path / "other").mkdir()
    bad = _shift_truth(truth_p, tmp_path / "other" / "truth.csv", dx_mm, dyaw_deg)
    out = tmp_path / "bad"
    assert main(["report", str(nav_p), "--truth", str(bad), "--out", str(out), "--no-plots"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "gross errors" in err[0] and f"median {why} error" in err[0], err
    assert not out.exists()
    ok = ["report", str(nav_p), "--truth", str(bad), "--out", str(out), "--no-plots", "--accept-gross-errors"]
    assert main(ok) == 0
    # the run's own truth passes
    assert rpt.gross_error(rpt.build_report(rpt.load_nav(nav_p), rpt.load_truth(truth_p))) is None


def test_gross_error_by_nees_alone(tmp_path):
    """A covariance that cannot explain the errors (median NEES > 1e4) even where the errors are
    under the absolute limits: sigma 1 um against errors of ~1.6 mm."""
    nav_p, truth_p, _, _ = write_case(tmp_path, n=80)
    nav = rpt.load_nav(nav_p)
    n = len(nav.t_s)
    nav.extra = {c: np.full(n, 1e-3) for c in rpt.N.SIGMA_COLUMNS}
    rep = rpt.build_report(nav, rpt.load_truth(truth_p))
    assert rep.nees is not None and rep.nees.median > rpt.GROSS_MEDIAN_NEES
    assert "median NEES" in rpt.gross_error(rep)
    nav.extra = {c: np.full(n, 2.0 if c.endswith("_mm") else 0.2) for c in rpt.N.SIGMA_COLUMNS}
    assert rpt.gross_error(rpt.build_report(nav, rpt.load_truth(truth_p))) is None


def test_scenario_rate_is_held_to_the_nav_log(tmp_path, capsys):
    """A truth beside a scenario.json (mfns sim nav) names its scenario and frame rate: a nav log
    at another rate is another run's, refused with the scenario's name and both rates."""
    import json

    nav_p, truth_p, _, _ = write_case(tmp_path, n=60)  # 18.6 Hz
    (tmp_path / "scenario.json").write_text(
        json.dumps({"scenario": "module", "rate_hz": 10.0, "n_frames": 60})
    )
    truth = rpt.load_truth(truth_p)
    assert truth.scenario == {"scenario": "module", "rate_hz": 10.0, "n_frames": 60}
    with pytest.raises(MfnsError, match=r"scenario module runs at 10 Hz.*\(18\.\d+ Hz\)"):
        rpt.check_same_run(rpt.load_nav(nav_p), truth, "nav", partial=True)
    (tmp_path / "scenario.json").write_text(json.dumps({"scenario": "turntable", "rate_hz": 18.6}))
    rpt.check_same_run(rpt.load_nav(nav_p), rpt.load_truth(truth_p), "nav")


def test_plots_carry_the_reported_sigma_band(tmp_path, monkeypatch):
    """Error plots show the reported +-1-sigma of each fix as a band about zero."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nav_p, truth_p, _, fix = write_case(tmp_path, n=60)
    nav = rpt.load_nav(nav_p)
    nav.extra = {c: np.full(len(nav.t_s), 1.5 if c.endswith("_mm") else 0.15) for c in rpt.N.SIGMA_COLUMNS}
    rep = rpt.build_report(nav, rpt.load_truth(truth_p))
    assert rep.sigma is not None and np.all(rep.sigma["x"] == 1.5)
    bands = []
    real_savefig = plt.Figure.savefig

    def spy(fig, path, **kw):
        for ax in fig.axes:
            for coll in ax.collections:
                if coll.get_label() == "±1σ reported":
                    ys = np.concatenate([p.vertices[:, 1] for p in coll.get_paths()])
                    bands.append((ax.get_ylabel(), float(ys.min()), float(ys.max())))
        return real_savefig(fig, path, **kw)

    monkeypatch.setattr(plt.Figure, "savefig", spy)
    rpt.write_plots(rep, tmp_path)
    assert len(bands) == 12  # six axes, two figures
    by_axis = {lab: (lo, hi) for lab, lo, hi in bands}
    assert by_axis["x error (mm)"] == pytest.approx((-1.5, 1.5))
    assert by_axis["yaw error (deg)"] == pytest.approx((-0.15, 0.15))


def test_nees_histogram_axis_is_scaled_to_the_data():
    """Issue 43: data <= 6.5 drew on an axis to 50; the axis now ends just past the data's 99th
    percentile, with the bounds capped for a wild run (the rest counted in the last bin)."""
    from mfns.analysis import nees as N

    v = np.random.default_rng(0).uniform(0, 6.5, 500)
    assert 6.5 < N.hist_top(v) < 7.5
    assert N.hist_top(np.full(10, 1e9)) == N.HIST_TOP_MAX
    assert N.hist_top(np.zeros(5)) == N.HIST_TOP_MIN
