"""`mfns compare`: the paper's comparison from a demo folder, on a small synthetic one.

The folder is made here with known errors, so every number the report prints can be
checked: the calibration errors (with camera Y near gimbal lock), the Table 5 statistics
of each run, and the availability classes with what the truth says about them.
"""

from __future__ import annotations

import copy
import csv
import json
from pathlib import Path

import numpy as np
import pytest

from mfns.analysis import compare
from mfns.analysis.report import NAV_COLUMNS, TRUTH_HEADER
from mfns.cli import main
from mfns.model.rotations import matrix_to_euler213_deg, rot_exp
from mfns.tlm import tlm_dict

REPO = Path(__file__).resolve().parents[2]
PAPER = json.loads((REPO / "host_tools" / "mfns" / "data" / "paper_calib.json").read_text())
RIG = {"C_t_w": np.eye(3).tolist(), "r_wb_w": [60.0, 30.0, -576.9], "r_wt_w": [60.0, 30.0, -684.7]}


def calib_doc(rot_err_deg: float, pos_err_mm: float) -> dict:
    """The paper's rig, every camera turned by rot_err_deg about its body x axis, moved by pos_err_mm in x."""
    doc = copy.deepcopy(PAPER)
    doc["rig"] = copy.deepcopy(RIG)
    turn = rot_exp(np.radians([rot_err_deg, 0.0, 0.0]))
    for cam in doc["cameras"]:
        c = turn @ np.asarray(cam["C_k_b"])
        cam["C_k_b"] = c.tolist()
        cam["euler_213_deg"] = matrix_to_euler213_deg(c).tolist()
        cam["r_bk_b"] = (np.asarray(cam["r_bk_b"]) + [pos_err_mm, 0.0, 0.0]).tolist()
    return doc


def write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


N = 10
CAMS = ("x", "y", "z")
NAV_HEADER = [
    "t_s",
    "seq",
    "cycle",
    "status",
    "reason",
    "mode",
    "beacons_used",
    "cams_used",
    *NAV_COLUMNS.values(),
]


@pytest.fixture
def demo(tmp_path) -> Path:
    d = tmp_path / "demo"
    (d / "calib" / "dataset").mkdir(parents=True)
    (d / "calib" / "dataset" / "truth.json").write_text(json.dumps(calib_doc(0.0, 0.0)))
    (d / "calib" / "refined_paper.json").write_text(json.dumps(calib_doc(0.05, 0.5)))
    (d / "calib" / "refined.json").write_text(json.dumps(calib_doc(0.005, 0.05)))
    frames = d / "module" / "frames"
    t = np.arange(N) / 18.6
    truth = [[k, f"{t[k]:.6f}", 0, 0, 0, 0, 0, float(10 * k)] for k in range(N)]
    write_csv(frames / "truth.csv", TRUTH_HEADER, truth)
    # Cycles 0-1: two beacons in view; 2-9: five, all in cameras X and Y (Z sees none).
    spots = []
    for k in range(N):
        for b in range(2 if k < 2 else 5):
            spots.append([k, "x" if b % 2 else "y", b, 100.0, 100.0, 50.0, 1.3])
        spots.append([k, "z", -1, 10.0, 10.0, 20.0, 3.0])  # a spurious spot does not count
    write_csv(frames / "spots.csv", ["frame", "camera", "beacon_id", "u", "v", "peak_dn", "sigma_px"], spots)
    (frames / "scenario.json").write_text(json.dumps({"scenario": "module", "seed": 7, "n_frames": N}))
    for table, x_err in (("true-rig", 0.1), ("paper-calibration", 1.0)):
        rows = []
        for k in range(N):
            ok = k >= 2
            x = x_err * (1 if k % 2 else -1) + 0.5 if ok else 0.0
            rows.append(
                [
                    f"{t[k]:.6f}",
                    k,
                    k,
                    "DEGRADED" if ok else "NO_FIX",
                    1 if ok else 5,
                    "TRACK" if ok else "ACQUIRE",
                    5 if ok else 0,
                    3 if ok else 0,
                    "0",
                    "0",
                    f"{10 * k if ok else 0:.6f}",
                    f"{x:.3f}",
                    "0",
                    "0",
                ]
            )
        write_csv(d / "module" / table / "ground" / "nav.csv", NAV_HEADER, rows)
    # The centroider of the true-rig run also found the reflection in camera Z.
    cams = [
        [f"{t[k]:.6f}", 3 * k + j, k, c, "OK", n, 0]
        for k in range(N)
        for j, c in enumerate(CAMS)
        for n in [{"x": 1, "y": 1, "z": 1}[c] if k < 2 else {"x": 2, "y": 3, "z": 0}[c]]
    ]
    write_csv(
        d / "module" / "true-rig" / "ground" / "camera.csv",
        ["t_s", "seq", "cycle", "camera", "state", "blobs", "beacons_identified"],
        cams,
    )
    return d


def test_report_answers_the_paper(demo):
    text = compare.build(demo)
    # Table 3 style: the CPC turned every camera by 0.05 deg, the refinement by 0.005 deg.
    assert "| C_x^b | 0.0500 | 0.0050 |" in text
    assert "| C_y^b | 0.0500 | 0.0050 |" in text  # camera Y at gimbal lock: the rotation angle is still right
    assert "θy†" in text and "φy | 90.1636 (0.0301)" in text  # the paper's angles as printed
    assert "| r_bx^b | x | 76.1319 (0.2529) | 76.1319 | 76.6319 | +0.5000 | 76.1819 | +0.0500 |" in text
    assert "CPC (ours) 0.0500 deg (rotation angle), 0.5000 mm; refined 0.0050 deg, 0.0500 mm" in text
    # Table 5 style: x error +-x_err about 0.5 over cycles 2..9 (mean 0.5, sample sigma).
    sigma = np.std([(1 if k % 2 else -1) * 1.0 for k in range(2, N)], ddof=1)
    assert f"| x | mm | -0.0553 / 1.6043 | 0.5000 / {sigma / 10:.4f} | 0.5000 / {sigma:.4f} |" in text
    assert "| cycles with a fix | | (not given) | 8 of 10 | 8 of 10 |" in text
    assert "Simulated by `mfns sim nav --scenario module --seed 7`" in text
    # Availability: the rate, each class with the beacons in view, camera Z explained.
    assert "| true-rig | 10 | 0 | 8 | 2 | 80.0 % |" in text
    assert "| true-rig | NO_FIX | TOO_FEW | 2 | ACQUIRE 2 | 2: 2 | 3: 2 |" in text
    assert "| paper-calibration | NO_FIX | TOO_FEW | 2 | ACQUIRE 2 | 2: 2 | - |" in text  # no camera.csv
    assert "| true-rig | DEGRADED | CAMERA_UNUSED | 8 | TRACK 8 | 5: 8; unused in all: camera Z" in text
    assert "Camera Z has no beacon in its field of view in any cycle" in text
    assert "Cycles in which each camera sees at least one beacon: X 10, Y 10, Z 0 (of 10)" in text
    # Each class's meaning is the flight code's own text (one source: contract/mfns_tm.xml), not a copy.
    reasons = tlm_dict.load().enums["nav_reason_t"]
    too_few = next(desc for label, desc in reasons.values() if label == "TOO_FEW")
    row = next(line for line in text.splitlines() if line.startswith("| true-rig | NO_FIX | TOO_FEW |"))
    meaning = row.rstrip(" |").rsplit(" | ", 1)[1]
    assert meaning and too_few.endswith(meaning), (meaning, too_few)
    assert "**TOO_FEW**" not in text
    # The refined run is missing: it is left out, not invented.
    assert "refined-calibration mean" not in text


def test_cli_writes_report_and_refuses_a_non_demo_folder(demo, tmp_path, capsys):
    assert main(["compare", str(demo)]) == 0
    assert (demo / "report.md").read_text().startswith("# MFNS demo")
    assert f"wrote {demo / 'report.md'}" in capsys.readouterr().out
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["compare", str(empty)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no navigation runs found" in err[0]
    assert main(["compare", str(tmp_path / "missing")]) == 2


def test_planned_layouts_beside_the_originals(demo):
    """Section 5: a planned run (mk/demo.sh: module-planned) is compared with the original."""
    import shutil

    assert "## 5. Beacon layouts planned" not in compare.build(demo)  # no planned run: no section
    planned = demo / "module-planned"
    (planned / "frames").mkdir(parents=True)
    shutil.copy(demo / "module" / "frames" / "truth.csv", planned / "frames" / "truth.csv")
    shutil.copytree(demo / "module" / "true-rig" / "ground", planned / "true-rig" / "ground")
    text = compare.build(demo)
    assert "## 5. Beacon layouts planned" in text
    assert "| module | original | 8 / 10 (80.0 %) |" in text
    assert "| module | planned | 8 / 10 (80.0 %) |" in text
    assert text.count("| - |") >= 2  # no plan.json: its one-call views are not invented
    # the plan's check and baseline give the one-call views and the four-in-view share
    import json

    (demo / "plan" / "module").mkdir(parents=True)
    (demo / "plan" / "module" / "plan.json").write_text(
        json.dumps(
            {
                "check": {"availability_pct": 99.6, "one_call_views_pct": 98.6, "four_in_view_pct": 1.0},
                "baseline": {"availability_pct": 88.6, "one_call_views_pct": 80.1, "four_in_view_pct": 8.5},
            }
        )
    )
    text = compare.build(demo)
    assert "| module | original | 8 / 10 (80.0 %) |" in text and "| 80.1, 8.5 |" in text
    assert "| 98.6, 1.0 |" in text


def test_meaning_column_is_never_silently_empty(monkeypatch):
    """Issue 28 item 1: without the core library the meaning of a reason comes from the TM
    dictionary (package data), never an empty cell."""
    from mfns.core import flight
    from mfns.core.errors import MfnsError

    def no_library(*_a, **_k):
        raise MfnsError("no such library")

    monkeypatch.setattr(flight, "Flight", no_library)
    for code, name in enumerate(flight.REASONS):
        got_name, text = compare._reason_text(code)
        assert got_name == name and text.strip(), (code, name)
    assert "no meaning" in compare._reason_text(250)[1]
