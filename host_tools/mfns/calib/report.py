"""Tables (Table 2 / Table 3 style, paper vs refined vs truth vs CRB) and the results documents.

Output files are written by exports.py, plots by plots.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..analysis.calib_results import FORMAT, VERSION, camera_entry
from ..model.rotations import matrix_to_euler213_deg
from .covariance import (
    euler_sigma,
    nees,
    paper_covariance,
    parameter_error,
    refined_covariance,
    sigma_block,
)
from .model import Observations, Rig
from .pipeline import Calibration, paper_quantities
from .refine import cramer_rao, quantities, rig0
from .zhang import INTRINSIC_NAMES


def euler_sigmas(cal: Calibration) -> dict[str, np.ndarray]:
    """Euler-angle 1-sigma of C_t_w and each C_k_b from the refinement covariance."""
    cov = cal.refined.cov_params
    cams = cal.refined.rig.cams
    r0 = rig0(len(cams))
    out = {"C_t_w": euler_sigma(cal.refined.rig.C_t_w, cov[r0 : r0 + 3, r0 : r0 + 3])}
    names, cov_c = refined_covariance(cal.refined)
    for cam in cams:
        out[cam.name] = np.array(sigma_block(names, cov_c, cam.name, cam.C_k_b)["euler_213_deg"])
    return out


def intrinsics_table(cal: Calibration) -> str:
    lines = ["Intrinsics (Table 2 style): Zhang (paper) +- OpenCV 1-sigma | refined +- 1-sigma"]
    sig = dict(zip(cal.refined.names, cal.refined.sigma, strict=True))
    for k, z in enumerate(cal.zhang):
        cam = cal.refined.rig.cams[k]
        ref = [cam.fx, cam.fy, cam.cx, cam.cy, *cam.dist]
        lines.append(
            f"  camera {cam.name}: Zhang reprojection RMS {z.rms_px:.4f} px over {len(z.names)} images"
        )
        for i, n in enumerate(INTRINSIC_NAMES):
            s = sig[f"{cam.name}.{n}"]
            lines.append(
                f"    {n:3s} {z.intrinsics[i]:13.6f} +- {z.sigma[i]:9.6f} | {ref[i]:13.6f} +- {s:9.6f}"
            )
    return "\n".join(lines)


def extrinsics_table(cal: Calibration) -> str:
    r, p = cal.refined.rig, cal.paper
    sig = dict(zip(cal.refined.names, cal.refined.sigma, strict=True))
    es = euler_sigmas(cal)
    nan3 = np.full(3, np.nan)

    def e(c):
        return matrix_to_euler213_deg(c) if c is not None else nan3

    def fmt3(v):
        return " ".join(f"{x:10.4f}" for x in v)

    lines = ["Extrinsics (Table 3 style): paper CPC | refined (1-sigma); Euler 2-1-3 deg, mm"]
    if p is None:
        lines.append(f"  ({cal.paper_note}; the refinement started from {cal.init}; paper column n/a)")
    lines.append(
        f"  C_t_w  (a,b,g)  {fmt3(e(p.C_t_w if p else None))} | {fmt3(e(r.C_t_w))}  ({fmt3(es['C_t_w'])})"
    )
    for k, cam in enumerate(r.cams):
        n = cam.name
        pc = e(p.cams[k].C_k_b) if p else nan3
        lines.append(f"  C_{n}_b  (phi,theta,psi) {fmt3(pc)} | {fmt3(e(cam.C_k_b))}  ({fmt3(es[n])})")
    rs = [sig[f"r_wb_w.{a}"] for a in "xyz"]
    lines.append(f"  r_wb_w {fmt3(cal.cpc.r_wb_w if cal.cpc else nan3)} | {fmt3(r.r_wb_w)}  ({fmt3(rs)})")
    rs = [sig[f"r_wt_w.{a}"] for a in "xyz"]
    lines.append(f"  r_wt_w {fmt3(p.r_wt_w if p else nan3)} | {fmt3(r.r_wt_w)}  ({fmt3(rs)})")
    s_h = sig["r_tb_b.z"]
    lines.append(f"  r_tb_b {fmt3(p.r_tb_b if p else nan3)} | {fmt3(r.r_tb_b)}  (     0      0 {s_h:10.4f})")
    for k, cam in enumerate(r.cams):
        n = cam.name
        rs = [sig[f"{n}.r_b{n}{a}"] for a in "xyz"]
        pr = p.cams[k].r_bk_b if p else nan3
        lines.append(f"  r_b{n}_b {fmt3(pr)} | {fmt3(cam.r_bk_b)}  ({fmt3(rs)})")
    a10 = f"A10 Gauss-Newton passes {cal.cpc.a10_iterations}" if cal.cpc else "A10 not run"
    lines.append(
        f"  corner noise estimated {cal.refined.sigma_px:.4f} px, "
        f"refined RMS {cal.refined.rms_px:.4f} px; {a10}"
    )
    return "\n".join(lines)


@dataclass
class Comparison:
    names: list[str]
    truth: np.ndarray
    paper_err: np.ndarray
    refined_err: np.ndarray
    refined_sigma: np.ndarray
    crb: np.ndarray | None
    # NEES of the truth under the documents' covariances (covariance.py), and their parameter count
    nees_refined: float = float("nan")
    nees_paper: float = float("nan")  # NaN: the paper's method was not applicable
    n_parameters: int = 0

    EXTRINSIC_PREFIXES = ("rot", "r_")

    def is_extrinsic(self, name: str) -> bool:
        tail = name.split(".", 1)[1] if "." in name else name
        return name.startswith(("C_t_w", "r_wt", "r_tb", "r_wb")) or tail.startswith(self.EXTRINSIC_PREFIXES)

    def group(self, name: str) -> str:
        if not self.is_extrinsic(name):
            return "intrinsics"
        return "attitudes" if ".rot" in name else "positions"


def compare(cal: Calibration, truth: Rig, obs: Observations, truth_doc: dict | None) -> Comparison:
    names, q_true = quantities(truth, truth)
    _, q_ref = quantities(cal.refined.rig, truth)
    _, q_pap = paper_quantities(cal, truth)
    crb = None
    extra = (truth_doc or {}).get("truth")
    if extra is not None:
        by_name = {(d["camera"], d["name"]): d for d in extra["images"]}
        prep, ang = [], []
        ok = True
        for im in obs.images:
            d = by_name.get((obs.camera_names[im.camera], im.name))
            if d is None:
                ok = False
                break
            if im.kind == "prepared":
                c = np.asarray(d["C_k_w"], float)
                prep.append((c.T, -c.T @ np.asarray(d["r_wk_w"], float)))
            else:
                ang.append((d["Omega_deg"], d["omega_deg"]))
        if ok:
            _, crb = cramer_rao(obs, truth, prep, np.array(ang).reshape(-1, 2), cal.refined.sigma_px)
    _, cov = refined_covariance(cal.refined)
    nr = nees(parameter_error(cal.refined.rig, truth), cov)
    np_ = float("nan")
    if cal.paper is not None:
        np_ = nees(parameter_error(cal.paper, truth), paper_covariance(cal.paper, cal.refined)[1])
    return Comparison(
        names, q_true, q_pap - q_true, q_ref - q_true, cal.refined.sigma, crb, nr, np_, len(cov)
    )


def accuracy_table(cmp: Comparison) -> str:
    head = (
        f"  {'quantity':14s} {'truth':>12s} {'paper err':>11s} {'refined err':>11s} {'1-sigma':>9s}"
        f" {'CRB':>9s} {'ref/CRB':>8s} {'ref/paper':>9s}"
    )
    lines = ["Accuracy vs truth (attitudes: rotation-vector error, deg, body/world axes; mm; px)", head]
    for i, n in enumerate(cmp.names):
        crb = cmp.crb[i] if cmp.crb is not None else float("nan")
        rc = abs(cmp.refined_err[i]) / crb if cmp.crb is not None else float("nan")
        rp = (
            abs(cmp.refined_err[i]) / max(abs(cmp.paper_err[i]), 1e-15)
            if np.isfinite(cmp.paper_err[i])
            else np.nan
        )
        lines.append(
            f"  {n:14s} {cmp.truth[i]:12.5f} {cmp.paper_err[i]:+11.5f} {cmp.refined_err[i]:+11.5f}"
            f" {cmp.refined_sigma[i]:9.5f} {crb:9.5f} {rc:8.2f} {rp:9.2f}"
        )
    if cmp.crb is not None:
        lines.append("  RMS of (refined error / CRB) per group:")
        for g in ("intrinsics", "attitudes", "positions"):
            sel = [i for i, n in enumerate(cmp.names) if cmp.group(n) == g]
            z = cmp.refined_err[sel] / cmp.crb[sel]
            zp = cmp.paper_err[sel] / cmp.crb[sel]
            lines.append(
                f"    {g:10s} refined {np.sqrt(np.mean(z**2)):6.2f}   paper {np.sqrt(np.mean(zp**2)):8.2f}"
            )
    if cmp.n_parameters:
        from scipy.stats import chi2

        lines.append(
            f"  NEES of the truth under the results' covariances ({cmp.n_parameters} parameters, "
            f"99 % bound {chi2.ppf(0.99, cmp.n_parameters):.1f}): refined {cmp.nees_refined:.1f}, "
            f"paper {cmp.nees_paper:.1f}"
        )
    return "\n".join(lines)


def covariance_entry(names: list[str], cov: np.ndarray) -> dict:
    """The document's "covariance" (docs/calib-results.md)."""
    return {"parameters": list(names), "matrix": [[float(v) for v in row] for row in cov]}


def _camera_entries(rig: Rig, names: list[str], cov: np.ndarray) -> list[dict]:
    return [
        camera_entry(
            cam.name,
            (cam.width, cam.height),
            cam.fx,
            cam.fy,
            cam.cx,
            cam.cy,
            0.0,
            cam.dist,
            cam.C_k_b,
            cam.r_bk_b,
            sigma_block(names, cov, cam.name, cam.C_k_b),
        )
        for cam in rig.cams
    ]


def results_document(cal: Calibration, source: str) -> dict:
    """The refined solution; sigma and covariance from the refinement (covariance.py)."""
    r = cal.refined.rig
    names, cov = refined_covariance(cal.refined)
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "source": source,
        "pixel_noise_px": float(cal.refined.sigma_px),
        "cameras": _camera_entries(r, names, cov),
        "covariance": covariance_entry(names, cov),
        "rig": {
            "C_t_w": r.C_t_w.tolist(),
            "euler_t_w_deg": matrix_to_euler213_deg(r.C_t_w).tolist(),
            "r_wt_w": [float(v) for v in r.r_wt_w],
            "r_wb_w": [float(v) for v in r.r_wb_w],
            "r_tb_b": [float(v) for v in r.r_tb_b],
        },
    }
    if cal.corner_order:  # symmetric board, a camera turning about one axis: the joint decision
        doc["corner_order"] = [d.to_dict() for d in cal.corner_order]
    return doc


def paper_document(cal: Calibration, source: str) -> dict:
    """The paper's solution; covariance Cov(ML) + d d^T (covariance.paper_covariance), sigma from it."""
    p = cal.paper
    assert p is not None and cal.cpc is not None
    names, cov = paper_covariance(p, cal.refined)
    rms = float(np.sqrt(np.mean([z.rms_px**2 for z in cal.zhang])))
    return {
        "format": FORMAT,
        "version": VERSION,
        "source": source,
        "pixel_noise_px": max(rms, 1e-6),
        "cameras": _camera_entries(p, names, cov),
        "covariance": covariance_entry(names, cov),
        "rig": {
            "C_t_w": p.C_t_w.tolist(),
            "euler_t_w_deg": matrix_to_euler213_deg(p.C_t_w).tolist(),
            "r_wt_w": [float(v) for v in p.r_wt_w],
            "r_wb_w": [float(v) for v in cal.cpc.r_wb_w],
            "r_tb_b": [float(v) for v in p.r_tb_b],
        },
    }
