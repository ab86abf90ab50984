"""Outputs of an analysis: per-sample CSV, summary (JSON and Markdown), plots."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from ..core.csv_formats import POSE_COLUMNS, SIGMA_COLUMNS
from .analyze import CERT_MIN_IN_VIEW, FIX_MIN_IN_VIEW, TRACK_MIN_IN_VIEW, Analysis

SAMPLES_HEADER = [
    "sample",
    *POSE_COLUMNS,
    "in_view_x",
    "in_view_y",
    "in_view_z",
    "in_view",
    "fix",
    "track",
    "fix_flight",
    *SIGMA_COLUMNS,
    *(f"flight_{c}" for c in SIGMA_COLUMNS),
    "ident_margin",
]
PERCENTILES = (50, 90, 99, 100)
N_WORST = 5


def write_samples(a: Analysis, path: Path) -> None:
    """One row per pose sample; sigma empty where not determined (< 3 beacons, singular),
    fix_flight empty for an unordered workspace, ident_margin empty with fewer than 4
    beacons in view or when the map analysis was skipped (ident.py)."""
    ff = a.fix_flight
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(SAMPLES_HEADER)
        for i in range(a.ws.n):
            sig = ["" if not np.isfinite(v) else f"{v:.6g}" for v in (*a.sigma[i], *a.flight_sigma[i])]
            m = a.margin[i]
            w.writerow(
                [
                    i,
                    *(f"{v + 0.0:.3f}" for v in a.ws.r_wb_w[i]),
                    *(f"{v + 0.0:.4f}" for v in a.ws.euler_deg[i]),
                    *(int(v) for v in a.in_view_cam[i]),
                    int(a.in_view[i]),
                    int(a.fix[i]),
                    int(a.track[i]),
                    "" if ff is None else int(ff[i]),
                    *sig,
                    "" if m is None else f"{m:.6g}",
                ]
            )


def _region_keys(a: Analysis) -> tuple[list[str], np.ndarray]:
    """Region label per sample: yaw bins of 10 deg for the turntable, else a 4-bin grid on
    each position axis the workspace spans and 4 yaw quadrants."""
    ws = a.ws
    yaw = ws.euler_deg[:, 2]
    if ws.kind == "turntable":
        b = np.floor(yaw / 10.0).astype(int)
        labels = [f"yaw {10 * k:+d}..{10 * k + 10:+d} deg" for k in b]
        return labels, b
    parts, label_parts = [], []
    for ax, name in enumerate("xyz"):
        lo, hi = ws.r_wb_w[:, ax].min(), ws.r_wb_w[:, ax].max()
        if hi - lo > 1.0:
            edges = np.linspace(lo, hi, 5)
            k = np.clip(np.searchsorted(edges, ws.r_wb_w[:, ax], side="right") - 1, 0, 3)
            parts.append(k)
            label_parts.append([f"{name} {edges[j]:.0f}..{edges[j + 1]:.0f}" for j in k])
    q = np.floor((yaw + 180.0) / 90.0).astype(int) % 4
    parts.append(q)
    label_parts.append([f"yaw {-180 + 90 * j:+d}..{-90 + 90 * j:+d}" for j in q])
    key = np.zeros(ws.n, dtype=int)
    for p in parts:
        key = key * 4 + p
    labels = [", ".join(lp[i] for lp in label_parts) + " (mm, deg)" for i in range(ws.n)]
    return labels, key


def _percentiles(sig: np.ndarray) -> dict:
    pct = {}
    for j, ax in enumerate(POSE_COLUMNS):
        v = sig[:, j][np.isfinite(sig[:, j])]
        pct[ax] = {f"p{p}": (round(float(np.percentile(v, p)), 6) if len(v) else None) for p in PERCENTILES}
    return pct


def summarize(a: Analysis, info: dict) -> dict:
    fix = a.fix
    pct, fpct = _percentiles(a.sigma[fix]), _percentiles(a.flight_sigma[fix])
    labels, key = _region_keys(a)
    regions: list[dict[str, Any]] = []  # one JSON row per region
    pos_worst = np.max(np.where(np.isfinite(a.sigma[:, :3]), a.sigma[:, :3], -np.inf), axis=1)
    att_worst = np.max(np.where(np.isfinite(a.sigma[:, 3:]), a.sigma[:, 3:], -np.inf), axis=1)
    for k in np.unique(key):
        m = key == k
        mf = m & fix
        regions.append(
            {
                "region": labels[int(np.nonzero(m)[0][0])],
                "samples": int(m.sum()),
                "availability_pct": round(100.0 * float(fix[m].mean()), 2),
                "in_view_mean": round(float(a.in_view[m].mean()), 2),
                "sigma_pos_max_mm": round(float(np.max(pos_worst[mf])), 5) if mf.any() else None,
                "sigma_att_max_deg": round(float(np.max(att_worst[mf])), 6) if mf.any() else None,
            }
        )
    regions.sort(key=lambda r: (r["availability_pct"], -(r["sigma_pos_max_mm"] or 0.0)))
    total = a.in_view
    return {
        **info,
        "samples": int(a.ws.n),
        "workspace": a.ws.description,
        "fix_rule": f">= {FIX_MIN_IN_VIEW} distinct beacons in view (track: >= {TRACK_MIN_IN_VIEW})",
        "availability_pct": round(100.0 * float(fix.mean()), 2),
        "track_pct": round(100.0 * float(a.track.mean()), 2),
        # the one-call ceiling: views the acquisition can certify at once (>= the
        # certificate's floor), and the views of exactly four it acquires over cycles only
        "one_call_views_pct": round(100.0 * float(np.mean(total >= CERT_MIN_IN_VIEW)), 2),
        "four_in_view_pct": round(100.0 * float(np.mean(total == FIX_MIN_IN_VIEW)), 2),
        "availability_flight_pct": None
        if a.fix_flight is None
        else round(100.0 * float(a.fix_flight.mean()), 2),
        "in_view_mean": round(float(total.mean()), 3),
        "in_view_min": int(total.min()),
        "per_camera_mean": [round(float(v), 3) for v in a.in_view_cam.mean(axis=0)],
        "in_view_histogram": {
            str(n): int(c) for n, c in zip(*np.unique(total, return_counts=True), strict=True)
        },
        "sigma_percentiles_over_fix_samples": pct,
        "flight_sigma_percentiles_over_fix_samples": fpct,
        "worst_regions": regions[:N_WORST],
        "ident_margin": _margin_summary(a),
    }


def _margin_summary(a: Analysis) -> str:
    m = np.array([v for v in a.margin if v is not None], dtype=float)
    if not len(m):
        return "not computed (--no-ident-margin, or no sample with >= 4 beacons in view)"
    amb = int(np.sum(m <= 0))
    return (
        f"over {len(m)} samples with >= 4 in view: median {np.median(m):g}, minimum {m.min():g} blobs more "
        f"than the strongest wrong identification; {amb} ambiguous views (margin <= 0: the flight code "
        "refuses them)"
    )


def _verdict_line(v: dict | None) -> str:
    if not v:
        return "- the flight's verdict: not computed"
    why = ", ".join(f"{k} {c}" for k, c in v["unusable_reasons"].items()) or "none"
    return (
        f"- **usable {v['usable_pct']} %** by the flight's own verdict (the C solver and integrity on "
        f"each view: PL within the alert limits, faults monitorable; mfns.plan.usable), one call "
        f"{v['one_call_pct']} %; not usable: {why}; cameras x/y/z see beacons in "
        f"{v['per_camera_seen_pct']} % of the samples"
    )


def summary_markdown(s: dict, title: str) -> str:
    lines = [
        f"# {title}",
        "",
        f"- workspace: {s['workspace']}",
        f"- map: {s.get('beacons', '?')} ({s.get('n_beacons', '?')} beacons); rig: {s.get('rig', '?')}",
        f"- noise: {s.get('noise', '?')}",
        f"- fix rule: {s['fix_rule']}",
        f"- **availability {s['availability_pct']} %** (track {s['track_pct']} %); beacons in view mean "
        f"{s['in_view_mean']}, min {s['in_view_min']}; per camera {s['per_camera_mean']}",
        f"- **one-call views {s['one_call_views_pct']} %** (>= {CERT_MIN_IN_VIEW} in view: the acquisition "
        f"can certify them in one call); exactly {FIX_MIN_IN_VIEW} in view {s['four_in_view_pct']} % "
        "(certified only by the completion, over cycles: the one-call rate's ceiling)",
        _verdict_line(s.get("flight_verdict")),
        f"- fixes by the navigation cycle's rule along the sequence: "
        f"{'-' if s['availability_flight_pct'] is None else str(s['availability_flight_pct']) + ' %'}",
        "",
        "Cramer-Rao 1-sigma over the samples with a fix:",
        "",
        "| axis | p50 | p90 | p99 | max |",
        "|---|---|---|---|---|",
    ]
    for ax, p in s["sigma_percentiles_over_fix_samples"].items():
        cells = ["-" if p[f"p{q}"] is None else f"{p[f'p{q}']:.4g}" for q in PERCENTILES]
        lines.append(f"| {ax} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "The flight solver's expected 1-sigma (equal-weight pixel fit; above the bound when survey",
        "or calibration errors are modelled):",
        "",
        "| axis | p50 | p90 | p99 | max |",
        "|---|---|---|---|---|",
    ]
    for ax, p in s["flight_sigma_percentiles_over_fix_samples"].items():
        cells = ["-" if p[f"p{q}"] is None else f"{p[f'p{q}']:.4g}" for q in PERCENTILES]
        lines.append(f"| {ax} | " + " | ".join(cells) + " |")
    lines += ["", "Worst regions (lowest availability, then largest position 1-sigma):", ""]
    lines += ["| region | samples | availability % | in view | max pos 1-sigma mm | max att 1-sigma deg |"]
    lines += ["|---|---|---|---|---|---|"]
    for r in s["worst_regions"]:
        pm = "-" if r["sigma_pos_max_mm"] is None else f"{r['sigma_pos_max_mm']:.4g}"
        am = "-" if r["sigma_att_max_deg"] is None else f"{r['sigma_att_max_deg']:.4g}"
        row = (r["region"], r["samples"], r["availability_pct"], r["in_view_mean"], pm, am)
        lines.append("| " + " | ".join(str(c) for c in row) + " |")
    lines += ["", f"Identification margin: {s['ident_margin']}.", ""]
    return "\n".join(lines)


def write_summary(s: dict, out: Path, title: str) -> None:
    (out / "summary.json").write_text(json.dumps(s, indent=2) + "\n")
    (out / "summary.md").write_text(summary_markdown(s, title))


# --------------------------------------------------------------------------- plots
def write_plots(a: Analysis, out: Path, title: str) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    # histogram of beacons in view
    fig, ax = plt.subplots(figsize=(7, 4))
    n_max = int(a.in_view.max()) if a.ws.n else 0
    bins = (np.arange(n_max + 2) - 0.5).tolist()
    ax.hist(a.in_view, bins=bins, color="tab:blue", alpha=0.8, label="all cameras (distinct)")
    for k, (name, col) in enumerate(zip("XYZ", ("tab:orange", "tab:green", "tab:red"), strict=True)):
        ax.hist(a.in_view_cam[:, k], bins=bins, histtype="step", lw=1.8, color=col, label=f"camera {name}")
    ax.axvline(FIX_MIN_IN_VIEW - 0.5, color="k", ls="--", lw=1)
    ax.text(FIX_MIN_IN_VIEW - 0.4, ax.get_ylim()[1] * 0.92, "fix", fontsize=9)
    ax.set_xlabel("beacons in view")
    ax.set_ylabel("pose samples")
    ax.set_title(f"{title}: beacons in view (availability {100 * a.fix.mean():.1f} %)", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths.append(out / "in_view_hist.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    if a.ws.kind == "turntable":
        paths += _plots_sweep(plt, a, out, title)
    else:
        paths += _plots_slices(plt, a, out, title)
    return paths


def _plots_sweep(plt, a: Analysis, out: Path, title: str) -> list[Path]:
    yaw = np.unwrap(np.deg2rad(a.ws.euler_deg[:, 2]))
    yaw = np.rad2deg(yaw)
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.stackplot(
        yaw,
        a.in_view_cam.T,
        labels=["camera X", "camera Y", "camera Z"],
        colors=("tab:orange", "tab:green", "tab:red"),
        alpha=0.75,
        step="mid",
    )
    ax.axhline(FIX_MIN_IN_VIEW, color="k", ls="--", lw=1, label=f"fix (>= {FIX_MIN_IN_VIEW})")
    ax.set_xlabel("turntable yaw (deg)")
    ax.set_ylabel("beacons in view")
    ax.set_title(f"{title}: availability {100 * a.fix.mean():.1f} % over the sweep", fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    p1 = out / "availability.png"
    fig.savefig(p1, dpi=110)
    plt.close(fig)

    fig, axs = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for j, name in enumerate(("x", "y", "z")):
        axs[0].plot(yaw, a.sigma[:, j], ".", ms=3, label=name)
    for j, name in enumerate(("roll", "pitch", "yaw")):
        axs[1].plot(yaw, a.sigma[:, 3 + j], ".", ms=3, label=name)
    axs[0].set_ylabel("position 1-sigma (mm)")
    axs[1].set_ylabel("attitude 1-sigma (deg)")
    axs[1].set_xlabel("turntable yaw (deg)")
    for ax in axs:
        ax.legend(fontsize=8, ncol=3)
        ax.grid(alpha=0.3)
    axs[0].set_title(f"{title}: Cramer-Rao 1-sigma (gaps: fewer than 3 beacons)", fontsize=10)
    fig.tight_layout()
    p2 = out / "sigma.png"
    fig.savefig(p2, dpi=110)
    plt.close(fig)
    return [p1, p2]


def _binned(x, y, v, nx=12, ny=8, stat="mean"):
    xe = np.linspace(x.min(), x.max() + 1e-9, nx + 1)
    ye = np.linspace(y.min(), y.max() + 1e-9, ny + 1)
    ix = np.clip(np.searchsorted(xe, x, side="right") - 1, 0, nx - 1)
    iy = np.clip(np.searchsorted(ye, y, side="right") - 1, 0, ny - 1)
    grid = np.full((ny, nx), np.nan)
    for i in range(nx):
        for j in range(ny):
            m = (ix == i) & (iy == j) & np.isfinite(v)
            if m.any():
                grid[j, i] = np.mean(v[m]) if stat == "mean" else np.median(v[m])
    return grid, xe, ye


def _plots_slices(plt, a: Analysis, out: Path, title: str) -> list[Path]:
    pos = a.ws.r_wb_w
    slices = [
        (0, 1, "x (mm)", "y (mm)", "over z and attitude"),
        (0, 2, "x (mm)", "z (mm)", "over y and attitude"),
    ]
    fig, axs = plt.subplots(1, 2, figsize=(12, 3.6))
    for ax, (i, j, xl, yl, over) in zip(axs, slices, strict=True):
        g, xe, ye = _binned(pos[:, i], pos[:, j], a.fix.astype(float))
        im = ax.pcolormesh(xe, ye, 100 * g, vmin=0, vmax=100, cmap="RdYlGn")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(f"availability % ({over})", fontsize=9)
        ax.set_aspect("equal")
        fig.colorbar(im, ax=ax, shrink=0.8)
    fig.suptitle(f"{title}: availability {100 * a.fix.mean():.1f} %", fontsize=10)
    fig.tight_layout()
    p1 = out / "availability.png"
    fig.savefig(p1, dpi=110)
    plt.close(fig)

    sig = np.where(a.fix[:, None], a.sigma, np.nan)
    pos_w = np.nanmax(sig[:, :3], axis=1, initial=-np.inf)
    att_w = np.nanmax(sig[:, 3:], axis=1, initial=-np.inf)
    pos_w[~np.isfinite(pos_w)] = np.nan
    att_w[~np.isfinite(att_w)] = np.nan
    fig, axs = plt.subplots(2, 2, figsize=(11, 7))
    for r, (v, lab) in enumerate(
        ((pos_w, "largest position 1-sigma (mm)"), (att_w, "largest attitude 1-sigma (deg)"))
    ):
        for c, (i, j, xl, yl, over) in enumerate(slices):
            ax = axs[r, c]
            g, xe, ye = _binned(pos[:, i], pos[:, j], v, stat="median")
            im = ax.pcolormesh(xe, ye, g, cmap="viridis")
            ax.set_xlabel(xl)
            ax.set_ylabel(yl)
            ax.set_title(f"median {lab}\n({over}, samples with a fix)", fontsize=9)
            ax.set_aspect("equal")
            fig.colorbar(im, ax=ax, shrink=0.8)
    fig.suptitle(f"{title}: Cramer-Rao 1-sigma", fontsize=10)
    fig.tight_layout()
    p2 = out / "sigma.png"
    fig.savefig(p2, dpi=110)
    plt.close(fig)
    return [p1, p2]
