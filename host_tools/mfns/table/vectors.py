"""Shared test vectors for the C tests of the calibration table (tests/unit/test_caltable.c,
test_undistort.c), written next to the table by the build (mk/caltable.mk):

  caltable_values.txt       every value the table should hold, one "key value" per line, in
                            the order test_caltable.c regenerates them (floats as %.9g of
                            their binary32 value: identical text means identical values)
  caltable_projections.txt  "pose" line (C_w_b row-major, r_bw_b), then per point
                            "camera xw yw zw u v": OpenCV projectPoints of the world point
                            through the pose and camera k of the table
  caltable_undistort.txt    "camera u v u_ideal v_ideal": exact (double Newton) undistorted
                            pixel positions of pixels spread over each image

Usage: mfns table vectors TABLE OUTDIR
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..model.rotations import euler213_to_matrix
from .check import read_table
from .format import CENTROID_F32, CENTROID_U16, SOLVER_F32, SOLVER_U16, Table, index_summary
from .grid import ideal_pixels, record_camera

NODE_SAMPLE_STRIDE = 509  # every 509th grid node is listed individually (plus the sums)


def _g(x) -> str:
    return f"{float(x):.9g}"


def value_lines(t: Table) -> list[str]:
    out = [f"version {t.version}", f"size_bytes {t.size_bytes}", f"crc32 {t.crc32}"]
    out.append(f"pixel_sigma_px {_g(t.pixel_sigma_px)}")
    out += [f"centroid.{k} {int(t.centroid[k])}" for k in CENTROID_U16]
    out += [f"centroid.{k} {_g(t.centroid[k])}" for k in CENTROID_F32]
    out += [f"solver.{k} {int(t.solver[k])}" for k in SOLVER_U16]
    out += [f"solver.{k} {_g(t.solver[k])}" for k in SOLVER_F32]
    for k, c in enumerate(t.cameras):
        p = f"cam{k}."
        out += [f"{p}width {c.width}", f"{p}height {c.height}"]
        out += [f"{p}{n} {_g(getattr(c, n))}" for n in ("fx", "fy", "cx", "cy", "skew")]
        out += [f"{p}dist{i} {_g(v)}" for i, v in enumerate(c.dist)]
        out += [f"{p}C{r}{q} {_g(c.C_k_b[r][q])}" for r in range(3) for q in range(3)]
        out += [f"{p}r{i} {_g(v)}" for i, v in enumerate(c.r_bk_b)]
        g = c.grid
        out += [f"{p}grid.nx {g.nx}", f"{p}grid.ny {g.ny}"]
        out += [f"{p}grid.origin_u_q8 {g.origin_u_q8}", f"{p}grid.origin_v_q8 {g.origin_v_q8}"]
        out += [f"{p}grid.step_u_q8 {g.step_u_q8}", f"{p}grid.step_v_q8 {g.step_v_q8}"]
        flat = g.nodes.reshape(-1, 2).astype(np.int64)
        out += [f"{p}grid.sum_u {int(flat[:, 0].sum())}", f"{p}grid.sum_v {int(flat[:, 1].sum())}"]
        for n in range(0, len(flat), NODE_SAMPLE_STRIDE):
            out.append(f"{p}grid.node{n} {int(flat[n, 0])} {int(flat[n, 1])}")
    out.append(f"beacons.count {len(t.beacon_ids)}")
    for i, (bid, pos, s) in enumerate(zip(t.beacon_ids, t.beacon_pos, t.beacon_sigma, strict=True)):
        out.append(f"beacon{i} {int(bid)} {_g(pos[0])} {_g(pos[1])} {_g(pos[2])} {_g(s)}")
    ix = index_summary(t)
    out.append(f"index.k_nbr {ix['k_nbr']}")
    out.append(f"index.max_missing {ix['max_missing']} max_unexplained {ix['max_unexplained']}")
    out.append(f"index.budget_units {ix['budget_units']}")
    out.append(f"index.cert {' '.join(str(c) for c in ix['cert_inliers'])}")
    out.append("index.workspace " + " ".join(_g(x) for x in ix["workspace_min_mm"] + ix["workspace_max_mm"]))
    return out


def projection_lines(t: Table, per_camera: int = 60, seed: int = 7) -> list[str]:
    rng = np.random.default_rng(seed)
    C_w_b = np.float32(euler213_to_matrix(*np.radians([2.0, -3.0, 30.0]))).astype(float)
    r_bw_b = np.float32(-C_w_b @ np.array([15.0, -25.0, 8.0])).astype(float)
    out = ["pose " + " ".join(_g(v) for v in [*C_w_b.ravel(), *r_bw_b])]
    for k, rec in enumerate(t.cameras):
        cam = record_camera(rec)
        uv = np.column_stack(
            [rng.uniform(0, cam.width - 1, per_camera), rng.uniform(0, cam.height - 1, per_camera)]
        )
        xy = cam.undistort_pixels(uv)
        depth = rng.uniform(300.0, 3000.0, per_camera)
        p_c = np.column_stack([xy * depth[:, None], depth])
        p_b = p_c @ cam.C_k_b.T + cam.r_bk_b
        p_w = np.float32((p_b - r_bw_b) @ C_w_b).astype(float)  # C_w_b^T (p_b - r_bw_b)
        # the camera-frame points of the binary32 world points, as the C code forms them
        p_c32 = (p_w @ C_w_b.T + r_bw_b - cam.r_bk_b) @ cam.C_k_b
        ref, _ = cv2.projectPoints(p_c32.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), cam.K, cam.dist)
        for pw, q in zip(p_w, ref.reshape(-1, 2), strict=True):
            out.append(f"{k} {_g(pw[0])} {_g(pw[1])} {_g(pw[2])} {q[0]:.17g} {q[1]:.17g}")
    return out


def undistort_lines(t: Table, per_camera: int = 200, seed: int = 8) -> list[str]:
    rng = np.random.default_rng(seed)
    out = []
    for k, rec in enumerate(t.cameras):
        cam = record_camera(rec)
        uv = np.float32(
            np.column_stack(
                [
                    rng.uniform(-0.5, cam.width - 0.5, per_camera),
                    rng.uniform(-0.5, cam.height - 0.5, per_camera),
                ]
            )
        ).astype(float)
        ideal = ideal_pixels(cam, uv)
        for a, b in zip(uv, ideal, strict=True):
            out.append(f"{k} {_g(a[0])} {_g(a[1])} {b[0]:.17g} {b[1]:.17g}")
    return out


def write_vectors(table_path: str | Path, outdir: str | Path) -> None:
    t = read_table(Path(table_path).read_bytes())  # accepted by the flight loader
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    (outdir / "caltable_values.txt").write_text("\n".join(value_lines(t)) + "\n")
    (outdir / "caltable_projections.txt").write_text("\n".join(projection_lines(t)) + "\n")
    (outdir / "caltable_undistort.txt").write_text("\n".join(undistort_lines(t)) + "\n")
