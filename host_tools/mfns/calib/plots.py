"""Diagnostic plots of `mfns calib --plots DIR` (PNG, matplotlib Agg).

All cameras: the refined residual scatter and, with --truth, |error| / CRB per extrinsic.
Per camera k: residual RMS per image, corner coverage over the sensor, and the histogram of
the whitened residuals against N(0, 1) (the noise the refinement estimated).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .pipeline import Calibration
from .report import Comparison


def corner_residuals(cal: Calibration) -> list[tuple[int, str, np.ndarray, np.ndarray]]:
    """Per image (camera, name, observed uv (n, 2), residual uv (n, 2) px) of the seen corners."""
    prob = cal.refined.problem
    res = prob.residuals(cal.refined.x)[: prob.n_corner_slots].reshape(-1, prob.obs.board.n, 2)
    out = []
    for i, im in enumerate(prob.tt + prob.prep):
        m = im.seen
        out.append((im.camera, im.name, im.uv[m], res[i][m] * prob.sigma_px))
    return out


def write_plots(cal: Calibration, cmp: Comparison | None, folder: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    per_image = corner_residuals(cal)
    sigma = cal.refined.sigma_px
    res = np.vstack([r for *_x, r in per_image])
    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    ax.scatter(res[:, 0], res[:, 1], s=2, alpha=0.5)
    ax.set_xlabel("u residual (px)")
    ax.set_ylabel("v residual (px)")
    ax.set_title("refined reprojection residuals, all cameras")
    ax.set_aspect("equal")
    fig.tight_layout()
    paths = [folder / "residuals.png"]
    fig.savefig(paths[0], dpi=100, bbox_inches="tight")
    plt.close(fig)
    for k, cam in enumerate(cal.refined.rig.cams):
        mine = [p for p in per_image if p[0] == k]
        fig, axes = plt.subplots(1, 3, figsize=(16, 4.8))
        rms = [float(np.sqrt(np.mean(r**2))) for *_x, r in mine]
        axes[0].bar(np.arange(len(mine)), rms)
        axes[0].axhline(sigma, color="k", lw=0.8, label=f"estimated noise {sigma:.3f} px")
        axes[0].set_xticks(np.arange(len(mine)), [p[1] for p in mine], rotation=90, fontsize=6)
        axes[0].set_ylabel("residual RMS per coordinate (px)")
        axes[0].set_title(f"camera {cam.name}: residuals per image")
        axes[0].legend(fontsize=7)
        uv = np.vstack([p[2] for p in mine])
        axes[1].scatter(uv[:, 0], uv[:, 1], s=1, alpha=0.4)
        axes[1].add_patch(plt.Rectangle((-0.5, -0.5), cam.width, cam.height, fill=False, color="k"))
        axes[1].set_xlim(-0.05 * cam.width, 1.05 * cam.width)
        axes[1].set_ylim(1.05 * cam.height, -0.05 * cam.height)
        axes[1].set_aspect("equal")
        axes[1].set_xlabel("u (px)")
        axes[1].set_ylabel("v (px)")
        axes[1].set_title(f"camera {cam.name}: corner coverage ({len(uv)} corners)")
        z = np.vstack([p[3] for p in mine]).ravel() / sigma
        axes[2].hist(z, bins=60, range=(-5, 5), density=True, alpha=0.7, label="u, v residual / noise")
        g = np.linspace(-5, 5, 201)
        axes[2].plot(g, np.exp(-0.5 * g**2) / np.sqrt(2 * np.pi), "k", lw=1, label="N(0, 1)")
        axes[2].set_xlabel(f"residual / estimated noise ({sigma:.3f} px)")
        axes[2].set_ylabel("density")
        axes[2].set_title(f"camera {cam.name}: residual histogram")
        axes[2].legend(fontsize=7)
        fig.tight_layout()
        paths.append(folder / f"camera_{cam.name}.png")
        fig.savefig(paths[-1], dpi=90, bbox_inches="tight")
        plt.close(fig)
    if cmp is not None and cmp.crb is not None:
        sel = [i for i, n in enumerate(cmp.names) if cmp.is_extrinsic(n)]
        fig, ax = plt.subplots(figsize=(12, 4))
        x = np.arange(len(sel))
        if np.all(np.isfinite(cmp.paper_err[sel])):
            ax.bar(x - 0.25, np.abs(cmp.paper_err[sel]) / cmp.crb[sel], 0.25, label="|paper err| / CRB")
        ax.bar(x, np.abs(cmp.refined_err[sel]) / cmp.crb[sel], 0.25, label="|refined err| / CRB")
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_yscale("log")
        ax.set_xticks(x, [cmp.names[i] for i in sel], rotation=90, fontsize=7)
        ax.legend()
        fig.tight_layout()
        paths.append(folder / "errors_vs_crb.png")
        fig.savefig(paths[-1], dpi=100, bbox_inches="tight")
        plt.close(fig)
    return paths
