"""Navigation accuracy report from ground-station telemetry (docs/telemetry.md).

Reads the `nav.csv` written by `mfns-ground` and, optionally, a truth file in
the `truth.csv` format of docs/nav-frames.md
(`frame,t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg`), matches them by time,
and produces the paper's Fig. 11-style plots (position and attitude errors
versus time and versus the true yaw) and a Table 5-style summary: mean and
1-sigma (sample standard deviation, ddof=1) per axis of roll, pitch, yaw, x, y, z.

Without truth the same statistics describe the estimates themselves (useful
for a static test, where the spread is the noise).

With truth, the covariance the flight code reported with each fix is checked against the
actual error: the NEES of mfns.analysis.nees (full 6x6 covariance columns, or the diagonal 1-sigma
columns of an older nav.csv), in summary.md, summary.json and nees.png.
"""

from __future__ import annotations

import csv
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import validate as V
from ..core.csv_formats import POSE_COLUMNS, TRUTH_HEADER
from ..core.errors import MfnsError
from ..tlm import tlm_dict
from . import nees as N

AXES = ("roll", "pitch", "yaw", "x", "y", "z")
# axis -> its nav.csv / truth.csv column (roll -> roll_deg), in AXES order
NAV_COLUMNS = {a: c for a in AXES for c in POSE_COLUMNS if c.split("_")[0] == a}
UNITS = {"roll": "deg", "pitch": "deg", "yaw": "deg", "x": "mm", "y": "mm", "z": "mm"}
GOOD_STATUS = tlm_dict.usable_status_names()  # the nav statuses that carry a pose: FIX, DEGRADED


@dataclass
class NavLog:
    t_s: np.ndarray
    status: np.ndarray  # str
    values: dict[str, np.ndarray]  # axis -> value (deg or mm)
    # optional columns (mfns.analysis.nees: covariance, quaternion, 1-sigma), NaN where a field is empty
    extra: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class Truth:
    t_s: np.ndarray
    values: dict[str, np.ndarray]
    path: Path | None = None
    # what scenario.json beside the truth says of the run (`mfns sim nav`): scenario, rate_hz,
    # n_frames; empty for a truth file without one
    scenario: dict = field(default_factory=dict)


@dataclass
class AxisStats:
    axis: str
    unit: str
    mean: float
    sigma: float
    n: int


@dataclass
class Report:
    with_truth: bool
    t_s: np.ndarray
    truth_yaw: np.ndarray | None
    series: dict[str, np.ndarray]  # errors (with truth) or values
    stats: list[AxisStats]
    n_rows: int
    n_used: int
    n_rejected_status: int
    n_unmatched: int
    status: np.ndarray | None = None  # status of each used row (FIX, DEGRADED, ...)
    nees: N.Nees | None = None  # covariance consistency (with truth and covariance columns)
    # the 1-sigma the flight code reported with each used row, per axis (nav.csv's sigma_*
    # columns), NaN where a row has none; None for a nav.csv without them
    sigma: dict[str, np.ndarray] | None = None


MAX_CSV_BYTES = 256 * V.MIB  # ~1.3 M rows of nav.csv: 19 hours at 18.6 Hz


def _read_csv(path: Path, required: list[str], what: str) -> list[dict[str, str]]:
    return V.read_csv(path, what, required, max_bytes=MAX_CSV_BYTES)


def _floats(rows: list[dict[str, str]], col: str, path: Path) -> np.ndarray:
    return np.array(
        [V.csv_float(r[col], f"{path} line {i + 2} {col}") for i, r in enumerate(rows)], dtype=float
    )


def _optional_floats(rows: list[dict[str, str]], col: str, path: Path) -> np.ndarray:
    """A column a row may leave empty (no covariance without a fix) or fill with a non-finite
    value (nan, inf: a covariance the flight code could not give). Such a row is counted as
    one without a usable covariance (mfns.analysis.nees); text that is no number is refused."""
    out = np.empty(len(rows))
    for i, r in enumerate(rows):
        t = r[col].strip()
        if not t:
            out[i] = np.nan
            continue
        try:
            out[i] = float(t)
        except ValueError:
            raise MfnsError(f"{path} line {i + 2} {col}: {r[col]!r} is not a number") from None
    return out


def load_nav(path: Path) -> NavLog:
    """nav.csv of mfns-ground (a folder is read as FOLDER/nav.csv)."""
    path = Path(path)
    if path.is_dir():
        path = path / "nav.csv"
    what = "navigation CSV (nav.csv)"
    rows = _read_csv(path, ["t_s", "status", *NAV_COLUMNS.values()], what)
    header = list(rows[0].keys()) if rows else []
    N.check_columns(header, f"{what} {path}")
    extra = {
        c: _optional_floats(rows, c, path)
        for group in (N.COV_COLUMNS, N.QUAT_COLUMNS, N.SIGMA_COLUMNS)
        if all(c in header for c in group)
        for c in group
    }
    return NavLog(
        t_s=_floats(rows, "t_s", path),
        status=np.array([r["status"] for r in rows], dtype=object),
        values={a: _floats(rows, c, path) for a, c in NAV_COLUMNS.items()},
        extra=extra,
    )


def load_truth(path: Path) -> Truth:
    path = Path(path)
    rows = _read_csv(path, TRUTH_HEADER, "truth CSV (docs/nav-frames.md)")
    t = _floats(rows, "t_s", path)
    if len(t) == 0:
        raise MfnsError(f"{path}: no rows")
    if np.any(np.diff(t) < 0):
        order = np.argsort(t, kind="stable")
        rows = [rows[i] for i in order]
        t = t[order]
    scenario = _check_run_record(path, len(rows))
    return Truth(
        t_s=t,
        values={a: _floats(rows, c, path) for a, c in NAV_COLUMNS.items()},
        path=path,
        scenario=scenario,
    )


def _check_run_record(path: Path, n_rows: int) -> dict:
    """A truth.csv beside a scenario.json that records its run (`mfns sim nav`: "run") must be
    that run's truth file: the same digest (and so the same rows). Returns the scenario's
    identity (scenario, rate_hz, n_frames: the fields present) for check_same_run."""
    scen = path.parent / "scenario.json"
    try:
        doc = json.loads(scen.read_text()) if scen.is_file() else None
    except (OSError, ValueError):
        doc = None  # not a nav-frames record: nothing to hold the truth to
    if not isinstance(doc, dict):
        return {}
    ident = {
        k: doc[k]
        for k, kind in (("scenario", str), ("rate_hz", (int, float)), ("n_frames", int))
        if isinstance(doc.get(k), kind) and not isinstance(doc.get(k), bool)
    }
    run = doc.get("run")
    if not isinstance(run, dict) or not isinstance(run.get("truth_sha256"), str):
        return ident
    if hashlib.sha256(path.read_bytes()).hexdigest() != run["truth_sha256"]:
        raise MfnsError(
            f"{path}: not the truth of the run {scen} records ({n_rows} rows here, "
            f"{run.get('truth_rows')} there; the digest differs)"
        )
    return ident


def check_same_run(nav: NavLog, truth: Truth, nav_name: str, partial: bool = False) -> None:
    """Refuse to compare a nav log with the truth of another run (MfnsError, one line).

    nav.csv carries no run identity (mfns-ground writes what the flight program sent), so the
    check is on what both record: a nav log of the run has no more cycles than the truth has
    frames and lies within the truth's time span; unless `partial`, it also covers that span
    (to two frame periods at each end: the first and last cycles may be lost on the link).
    Another scenario's truth fails one of these (a longer run's truth fails the coverage).
    With a scenario.json beside the truth (Truth.scenario) the nav log's cycle period must
    also be the scenario's frame period (within RATE_TOLERANCE; the median gap, so lost
    cycles do not matter). What this misses: another run of the same scenario, rate and
    length (another seed): gross_error() catches that one when its poses differ."""
    if len(nav.t_s) == 0 or len(truth.t_s) < 2:
        return
    t = nav.t_s[np.isfinite(nav.t_s)]
    if len(t) == 0:
        return
    period = float(np.median(np.diff(truth.t_s)))
    slack = 2.0 * max(period, 0.0)
    n0, n1, t0, t1 = float(t.min()), float(t.max()), float(truth.t_s[0]), float(truth.t_s[-1])
    what = (
        f"{nav_name} ({len(nav.t_s)} cycles, {n0:.2f}..{n1:.2f} s) and {truth.path or 'the truth'} "
        f"({len(truth.t_s)} frames, {t0:.2f}..{t1:.2f} s) are not the same run"
    )
    if len(nav.t_s) > len(truth.t_s) or n0 < t0 - slack or n1 > t1 + slack:
        raise MfnsError(what)
    if not partial and (n0 - t0 > slack or t1 - n1 > slack):
        raise MfnsError(f"{what} (the nav log covers part of it: --partial accepts that)")
    rate = truth.scenario.get("rate_hz")
    if rate and len(t) >= 3:
        gap = float(np.median(np.diff(np.sort(t))))
        if gap > 0 and abs(gap * rate - 1.0) > RATE_TOLERANCE:
            raise MfnsError(
                f"{nav_name} and {truth.path or 'the truth'} are not the same run: scenario "
                f"{truth.scenario.get('scenario', '?')} runs at {rate:g} Hz, the nav log's cycles "
                f"are {gap:.4f} s apart ({1.0 / gap:.2f} Hz)"
            )


# A nav log's median cycle gap may differ this much (relative) from the scenario's period.
RATE_TOLERANCE = 0.2
# gross_error(): errors no covariance of a fix of this run explains. Median NEES 1e4 is a
# median normalised error of ~40 sigma on each of the six axes; a module is a few metres and
# the turntable's truth a fixed point, so a median position error of a metre or an attitude
# error of 30 degrees is a pose of another run, never a fix of this one.
GROSS_MEDIAN_NEES = 1.0e4
GROSS_POS_MM = 1000.0
GROSS_ATT_DEG = 30.0


def gross_error(rep: Report) -> str | None:
    """Why the report's errors are not a fix's errors (a truth of another run or scenario
    with the same time base), or None. Medians, so a few wrong fixes (the ones the report is
    for) do not trip it."""
    if not rep.with_truth or rep.n_used == 0:
        return None
    pos = np.sqrt(sum(rep.series[a] ** 2 for a in ("x", "y", "z")))
    att = np.max(np.abs(np.column_stack([rep.series[a] for a in ("roll", "pitch", "yaw")])), axis=1)
    med_pos, med_att = float(np.median(pos)), float(np.median(att))
    why = []
    if rep.nees is not None and rep.nees.n and rep.nees.median > GROSS_MEDIAN_NEES:
        why.append(f"median NEES {rep.nees.median:.3g} (> {GROSS_MEDIAN_NEES:g})")
    if med_pos > GROSS_POS_MM:
        why.append(f"median position error {med_pos:.0f} mm (> {GROSS_POS_MM:g})")
    if med_att > GROSS_ATT_DEG:
        why.append(f"median attitude error {med_att:.1f} deg (> {GROSS_ATT_DEG:g})")
    if not why:
        return None
    return (
        f"gross errors: {', '.join(why)} over {rep.n_used} fixes: the truth is not this run's "
        "(another scenario or seed with the same time base), or the flight is broken; "
        "--accept-gross-errors reports it anyway"
    )


def wrap_deg(a: np.ndarray) -> np.ndarray:
    """Angles to [-180, 180): a yaw error of 359.9 deg is -0.1 deg."""
    return (np.asarray(a, dtype=float) + 180.0) % 360.0 - 180.0


def match_by_time(t_nav: np.ndarray, t_truth: np.ndarray, tolerance_s: float) -> np.ndarray:
    """Index of the nearest truth sample for each nav time, -1 where none is within tolerance.

    t_truth must be sorted ascending.
    """
    if len(t_truth) == 0:
        return np.full(len(t_nav), -1, dtype=int)
    j = np.searchsorted(t_truth, t_nav)
    lo = np.clip(j - 1, 0, len(t_truth) - 1)
    hi = np.clip(j, 0, len(t_truth) - 1)
    pick = np.where(np.abs(t_truth[lo] - t_nav) <= np.abs(t_truth[hi] - t_nav), lo, hi)
    ok = np.abs(t_truth[pick] - t_nav) <= tolerance_s
    return np.where(ok, pick, -1)


def axis_stats(series: dict[str, np.ndarray]) -> list[AxisStats]:
    out = []
    for a in AXES:
        v = series[a]
        n = len(v)
        out.append(
            AxisStats(
                axis=a,
                unit=UNITS[a],
                mean=float(np.mean(v)) if n else float("nan"),
                sigma=float(np.std(v, ddof=1)) if n > 1 else float("nan"),
                n=n,
            )
        )
    return out


def build_report(
    nav: NavLog, truth: Truth | None, tolerance_s: float = 0.02, all_status: bool = False
) -> Report:
    if tolerance_s <= 0:
        raise MfnsError("time tolerance must be positive")
    n_rows = len(nav.t_s)
    keep = np.ones(n_rows, dtype=bool) if all_status else np.isin(nav.status, GOOD_STATUS)
    n_rejected = int(n_rows - np.count_nonzero(keep))
    n_unmatched = 0
    truth_yaw = None
    nees = None
    if truth is not None:
        idx = match_by_time(nav.t_s, truth.t_s, tolerance_s)
        n_unmatched = int(np.count_nonzero(keep & (idx < 0)))
        keep &= idx >= 0
        idx = idx[keep]
        series = {}
        for a in AXES:
            d = nav.values[a][keep] - truth.values[a][idx]
            series[a] = wrap_deg(d) if UNITS[a] == "deg" else d
        truth_yaw = truth.values["yaw"][idx]
        eul = ("roll", "pitch", "yaw")
        if len(idx):
            nees = N.compute(
                nav.t_s[keep],
                np.column_stack([series[a] for a in ("x", "y", "z")]),
                np.column_stack([series[a] for a in eul]),
                {c: v[keep] for c, v in nav.extra.items()},
                np.column_stack([nav.values[a][keep] for a in eul]),
                np.column_stack([truth.values[a][idx] for a in eul]),
            )
    else:
        series = {a: nav.values[a][keep] for a in AXES}
    n_used = int(np.count_nonzero(keep))
    if n_used == 0:
        why = "no solutions with status FIX/DEGRADED" if not all_status else "no rows"
        if truth is not None:
            why += f" matched to truth within {tolerance_s} s"
        raise MfnsError(f"nothing to report: {why}")
    return Report(
        with_truth=truth is not None,
        t_s=nav.t_s[keep],
        truth_yaw=truth_yaw,
        series=series,
        stats=axis_stats(series),
        n_rows=n_rows,
        n_used=n_used,
        n_rejected_status=n_rejected,
        n_unmatched=n_unmatched,
        status=nav.status[keep],
        nees=nees,
        sigma=_reported_sigma(nav, keep),
    )


def _reported_sigma(nav: NavLog, keep: np.ndarray) -> dict[str, np.ndarray] | None:
    """The reported 1-sigma per axis of the kept rows (N.SIGMA_COLUMNS, in N.DIAG_AXES order)."""
    if not all(c in nav.extra for c in N.SIGMA_COLUMNS):
        return None
    return {a: nav.extra[c][keep] for a, c in zip(N.DIAG_AXES, N.SIGMA_COLUMNS, strict=True)}


def summary_markdown(rep: Report, title: str | None = None) -> str:
    kind = "error (estimate - truth)" if rep.with_truth else "estimate"
    lines = [f"## {title}", ""] if title else []
    lines += [
        f"| axis | unit | mean {kind} | 1-sigma | n |",
        "|---|---|---|---|---|",
    ]
    for s in rep.stats:
        lines.append(f"| {s.axis} | {s.unit} | {s.mean:.4f} | {s.sigma:.4f} | {s.n} |")
    lines.append("")
    lines.append(
        f"{rep.n_used} of {rep.n_rows} solutions used; {rep.n_rejected_status} rejected by status"
        + (f", {rep.n_unmatched} without truth within tolerance" if rep.with_truth else "")
        + "."
    )
    lines.append("")
    if rep.nees is not None:
        lines += N.markdown(rep.nees)
    elif rep.with_truth:
        lines += ["No covariance check: nav.csv has neither covariance (cov_*) nor 1-sigma columns.", ""]
    return "\n".join(lines).rstrip("\n") + "\n"


def summary_json(rep: Report, title: str | None = None) -> dict:
    """The summary as data: statistics per axis and the covariance consistency (NEES)."""
    return {
        "title": title,
        "kind": "error" if rep.with_truth else "estimate",
        "n_rows": rep.n_rows,
        "n_used": rep.n_used,
        "n_rejected_status": rep.n_rejected_status,
        "n_unmatched": rep.n_unmatched,
        "axes": [
            {
                "axis": s.axis,
                "unit": s.unit,
                "mean": s.mean if np.isfinite(s.mean) else None,
                "sigma": s.sigma if np.isfinite(s.sigma) else None,
                "n": s.n,
            }
            for s in rep.stats
        ],
        "nees": rep.nees.to_json() if rep.nees is not None else None,
    }


def write_summary_json(rep: Report, path: Path, title: str | None = None) -> None:
    Path(path).write_text(json.dumps(summary_json(rep, title), indent=2) + "\n")


def write_summary_csv(rep: Report, path: Path) -> None:
    with Path(path).open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["axis", "unit", "kind", "mean", "sigma", "n"])
        kind = "error" if rep.with_truth else "estimate"
        for s in rep.stats:
            w.writerow([s.axis, s.unit, kind, f"{s.mean:.6f}", f"{s.sigma:.6f}", s.n])


def _sigma_band(ax, x: np.ndarray, v: np.ndarray, sigma: np.ndarray, errors: bool) -> None:
    """The reported +-1-sigma of each fix as a shaded band, over x in ascending order: about 0
    for errors (an error outside the band is one the fix's covariance did not expect), about
    the estimate itself without truth. Rows without a sigma leave a gap."""
    order = np.argsort(x, kind="stable")
    xs, sd = x[order], sigma[order]
    mid = np.zeros_like(sd) if errors else v[order]
    if not np.any(np.isfinite(sd)):
        return
    ax.fill_between(
        xs, mid - sd, mid + sd, color="tab:orange", alpha=0.25, lw=0, label="±1σ reported", zorder=0
    )


def write_plots(rep: Report, out_dir: Path, title: str | None = None) -> list[Path]:
    """Fig. 11-style figures: attitude and position errors (or values) vs time, and vs true yaw.

    `title` names the run (experiment and calibration table); it heads every figure, so two
    figures of different runs never look alike.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    label = "error" if rep.with_truth else "estimate"
    written = []

    def panel(x, xlabel: str, name: str, title: str) -> None:
        fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), sharex=True)
        for k, a in enumerate(AXES):
            ax = axes[k // 3][k % 3]
            # One colour per status, so cycles solved with a weaker geometry stand out.
            status = rep.status if rep.status is not None else np.full(len(x), "")
            for st in sorted(set(status)):
                m = status == st
                ax.plot(np.asarray(x)[m], rep.series[a][m], ".", ms=3, label=st or None)
            if k == 0 and len(set(status)) > 1:
                ax.legend(fontsize=8, markerscale=2)
            if rep.sigma is not None:
                _sigma_band(ax, np.asarray(x, dtype=float), rep.series[a], rep.sigma[a], rep.with_truth)
                if k == 0:
                    ax.legend(fontsize=8, markerscale=2)
            s = rep.stats[k]
            ax.axhline(s.mean, color="k", lw=0.8)
            ax.set_title(f"{a}: mean {s.mean:.4f}, 1σ {s.sigma:.4f} {s.unit}", fontsize=9)
            ax.set_ylabel(f"{a} {label} ({s.unit})")
            ax.grid(True, alpha=0.3)
            if k // 3 == 1:
                ax.set_xlabel(xlabel)
        fig.suptitle(title)
        fig.tight_layout()
        p = out_dir / name
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)

    run = f"{title}: " if title else ""
    used = f" ({rep.n_used} of {rep.n_rows} cycles with a fix)"
    panel(rep.t_s, "time (s)", "nav_errors_vs_time.png", f"{run}MFNS navigation {label}s vs time{used}")
    if rep.truth_yaw is not None:
        panel(
            rep.truth_yaw,
            "true yaw (deg)",
            "nav_errors_vs_yaw.png",
            f"{run}MFNS navigation {label}s vs yaw{used}",
        )
    if rep.nees is not None and rep.nees.n:
        p = out_dir / "nees.png"
        N.plot(rep.nees, p, title)
        written.append(p)
    return written
