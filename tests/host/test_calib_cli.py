"""CLI smoke tests: `mfns sim calib --small` then `mfns calib` on it."""

import csv
import json

import cv2
import numpy as np
import pytest

from mfns.analysis.calib_results import load
from mfns.cli import main


@pytest.fixture(scope="module")
def small_dataset(calib_small_dataset):
    return calib_small_dataset


def test_sim_calib_writes_the_documented_folder(small_dataset):
    meta = json.loads((small_dataset / "dataset.json").read_text())
    assert meta["format"] == "mfns-calib-dataset" and meta["version"] == 1
    assert meta["board"]["inner_corners"] == [9, 6]
    with open(small_dataset / "angles.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3 * (10 + 4)
    for cam in "xyz":
        tt = [r for r in rows if r["camera"] == cam and r["kind"] == "turntable"]
        assert len(tt) == 10
        assert len({(r["Omega_deg"], r["omega_deg"]) for r in tt}) == 10
    img = cv2.imread(str(small_dataset / rows[0]["image"]), cv2.IMREAD_UNCHANGED)
    assert img.dtype == np.uint8 and img.shape == (1024, 1280)
    truth = load(small_dataset / "truth.json")
    assert abs(truth["rig"]["r_wb_w"][2] + meta["caliper"]["height_mm"]) < 1.5  # caliper ~ truth


def test_sim_calib_plan_is_deterministic(small_dataset):
    from mfns.calib.model import Board
    from mfns.simulate.calib import default_truth, make_plan

    truth = default_truth()
    a = make_plan(truth, Board(), np.random.default_rng(7), 10, 2)
    b = make_plan(truth, Board(), np.random.default_rng(7), 10, 2)
    assert [(s.omega_big_deg, s.true_omega_small_deg) for s in a] == [
        (s.omega_big_deg, s.true_omega_small_deg) for s in b
    ]
    assert all(np.array_equal(x.C_k_w, y.C_k_w) for x, y in zip(a, b, strict=True))


def test_calib_cli_writes_results_yaml_and_report(small_dataset, tmp_path, capsys):
    out = tmp_path / "res.json"
    rc = main(
        [
            "calib",
            str(small_dataset),
            "--truth",
            str(small_dataset / "truth.json"),
            "-o",
            str(out),
            "--plots",
            str(tmp_path / "plots"),
            "--report",
            str(tmp_path / "report.txt"),
            "--quiet",
        ]
    )
    assert rc == 0
    doc = load(out)  # validates the calibration-results format
    assert "rig" in doc and len(doc["cameras"]) == 3
    assert all("sigma" in c for c in doc["cameras"])
    truth = load(small_dataset / "truth.json")
    for c, t in zip(doc["cameras"], truth["cameras"], strict=True):
        assert abs(c["fx"] - t["fx"]) < 5.0
        assert np.max(np.abs(np.array(c["r_bk_b"]) - t["r_bk_b"])) < 2.0
    load(tmp_path / "res_paper.json")
    fs = cv2.FileStorage(str(tmp_path / "res_camera_z.yml"), cv2.FILE_STORAGE_READ)
    k = fs.getNode("camera_matrix").mat()
    assert k.shape == (3, 3) and abs(k[0, 0] - doc["cameras"][2]["fx"]) < 1e-9
    fs.release()
    report = (tmp_path / "report.txt").read_text()
    assert "Accuracy vs truth" in report and "CRB" in report and "Table 3 style" in report
    assert (tmp_path / "plots" / "errors_vs_crb.png").stat().st_size > 1000


def test_calib_cli_errors_are_one_line(tmp_path, capsys):
    assert main(["calib", str(tmp_path / "missing")]) == 2
    (tmp_path / "empty").mkdir()
    assert main(["calib", str(tmp_path / "empty")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(line.startswith("mfns calib: error:") for line in err)


def test_sim_calib_refuses_non_empty_output(small_dataset, capsys):
    assert main(["sim", "calib", str(small_dataset), "--quiet"]) == 2
    assert "not empty" in capsys.readouterr().err


def test_calib_without_output_writes_into_the_dataset_not_the_current_folder(
    small_dataset, tmp_path, monkeypatch
):
    """Issue 28 item 5: no -o -> DATASET/calib/calib_results.json and its exports beside it."""
    import shutil

    ds = tmp_path / "ds"
    shutil.copytree(small_dataset, ds)
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    assert main(["calib", str(ds), "--quiet"]) == 0
    assert list(cwd.iterdir()) == []
    names = {p.name for p in (ds / "calib").iterdir()}
    assert {"calib_results.json", "calib_results_mounts.urdf", "calib_results_camchain.yaml"} <= names
    load(ds / "calib" / "calib_results.json")
