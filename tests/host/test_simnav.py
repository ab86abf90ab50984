"""`mfns sim nav`: projection, rendering and the frame-folder format of docs/nav-frames.md."""

from __future__ import annotations

import csv
import hashlib
import json
import re

import cv2
import numpy as np
import pytest

from mfns.analysis import calib_results
from mfns.cli import main
from mfns.model.rotations import euler213_deg_to_matrix
from mfns.simulate import nav

W, H = 1280, 1024


def _sim(tmp, *extra):
    assert main(["sim", "nav", str(tmp), "--quiet", *extra]) == 0
    return tmp


@pytest.fixture(scope="module")
def module_noisy(tmp_path_factory):
    return _sim(
        tmp_path_factory.mktemp("mod") / "out", "--scenario", "module", "--frames", "8", "--seed", "3"
    )


@pytest.fixture(scope="module")
def module_clean(tmp_path_factory):
    return _sim(
        tmp_path_factory.mktemp("modc") / "out",
        "--scenario",
        "module",
        "--frames",
        "8",
        "--seed",
        "3",
        "--no-noise",
    )


@pytest.fixture(scope="module")
def turntable(tmp_path_factory):
    return _sim(tmp_path_factory.mktemp("tt") / "out", "--frames", "12", "--spurious-rate", "0.5")


def read_csv_strict(path, header):
    with open(path, newline="") as f:
        text = f.read()
    assert text.endswith("\n") and "\r" not in text
    lines = text.split("\n")[:-1]
    assert lines[0] == ",".join(header), f"{path.name}: header {lines[0]!r}"
    rows = [line.split(",") for line in lines[1:]]
    assert all(len(r) == len(header) for r in rows)
    return [dict(zip(header, r, strict=True)) for r in rows]


# --------------------------------------------------------------------------- projection
def test_projection_matches_opencv():
    scn = nav.module_scenario(40, 1.0, 60, seed=5)
    checked = 0
    for i in range(0, 40, 4):
        c_w_b, r_bw_b = scn.pose(i)
        for cam in scn.cams:
            uv, vis, _ = nav.project_beacons(cam, c_w_b, r_bw_b, scn.beacons)
            # world -> camera: R = C_k_b^T C_w_b, t = C_k_b^T (r_bw_b - r_bk_b)
            rot = cam.C_k_b.T @ c_w_b
            t = cam.C_k_b.T @ (r_bw_b - cam.r_bk_b)
            rvec, _ = cv2.Rodrigues(rot)
            pts = scn.beacons[vis].reshape(-1, 1, 3)
            if len(pts) == 0:
                continue
            ref, _ = cv2.projectPoints(pts, rvec, t, cam.K, cam.dist)
            assert np.max(np.abs(uv[vis] - ref.reshape(-1, 2))) < 1e-8
            checked += len(pts)
    assert checked > 50


def test_projection_rejects_points_behind_and_outside():
    cam = nav.load_rig(None)[0][2]  # camera Z looks along +Zb
    pts_b = np.array([[0.0, 0.0, 1000.0], [0.0, 0.0, -1000.0], [5000.0, 0.0, 1000.0], [0.0, 0.0, 10.0]])
    _, vis, _ = nav.project_beacons(cam, np.eye(3), np.zeros(3), pts_b)
    assert vis.tolist() == [True, False, False, False]


# --------------------------------------------------------------------------- rendering
def test_spot_signal_is_centred_on_the_true_position():
    """Float-level check of the pixel-area integration and the pixel-centre convention."""
    rng = np.random.default_rng(7)
    r = nav.Renderer(W, H, nav.RenderParams(noise=False))
    for _ in range(20):
        s = rng.uniform(0.8, 2.5)  # below ~0.7 px the pixel sampling itself biases centroids
        spot = np.array([[rng.uniform(30, W - 30), rng.uniform(30, H - 30), rng.uniform(20, 200), s]])
        (rows, cols), val = r.signal(spot)
        assert abs(val.sum() - 2 * np.pi * s**2 * spot[0, 2]) < 1e-3 * val.sum()
        assert abs((val * cols).sum() / val.sum() - spot[0, 0]) < 1e-4
        assert abs((val * rows).sum() / val.sum() - spot[0, 1]) < 1e-4
        m = np.argmax(val)
        assert abs(cols[m] - spot[0, 0]) <= 0.5 and abs(rows[m] - spot[0, 1]) <= 0.5


def centroid_errors(folder):
    """Simple intensity-weighted centroid of every isolated interior real spot vs spots.csv.

    Window +-ceil(3 sigma) around the rounded true position, background = the renderer's
    background map (from scenario.json's render parameters). Returns rows (du, dv, pred_sigma).
    """
    doc = json.loads((folder / "scenario.json").read_text())
    params = nav.RenderParams(**doc["render"])
    bg = nav.Renderer(doc["width"], doc["height"], params).bg
    spots = read_csv_strict(folder / "spots.csv", nav.SPOTS_HEADER)
    by_image: dict = {}
    for s in spots:
        by_image.setdefault((int(s["frame"]), s["camera"]), []).append(s)
    out = []
    for (frame, cam), group in by_image.items():
        img = nav.read_pgm(folder / f"cam_{cam}/{frame:06d}.pgm").astype(float) - bg
        for s in group:
            if s["beacon_id"] == "-1":
                continue
            u, v, sg = float(s["u"]), float(s["v"]), float(s["sigma_px"])
            if any(o is not s and abs(float(o["u"]) - u) < 30 and abs(float(o["v"]) - v) < 30 for o in group):
                continue
            rad = int(np.ceil(3 * sg))
            cu, cv = int(round(u)), int(round(v))
            if cu - rad < 0 or cv - rad < 0 or cu + rad >= W or cv + rad >= H:
                continue
            win = img[cv - rad : cv + rad + 1, cu - rad : cu + rad + 1]
            yy, xx = np.mgrid[cv - rad : cv + rad + 1, cu - rad : cu + rad + 1]
            du = (win * xx).sum() / win.sum() - u
            dv = (win * yy).sum() / win.sum() - v
            pred = float(nav.nominal_centroid_sigma(params, float(s["peak_dn"]), sg))
            out.append((du, dv, pred))
    return np.array(out)


def test_noise_free_frame_centroids_match_truth(module_clean):
    e = centroid_errors(module_clean)
    assert len(e) >= 30
    assert np.max(np.abs(e[:, :2])) < 0.05


def test_noisy_frame_centroids_match_truth(module_noisy):
    e = centroid_errors(module_noisy)
    assert len(e) >= 30
    assert np.sqrt(np.mean(e[:, :2] ** 2)) < 0.05
    assert np.all(np.abs(np.mean(e[:, :2], axis=0)) < 0.01)  # no bias
    # the predicted centroid noise (scenario.json pixel_noise_px is its median) is realistic
    ratio = np.sqrt(np.mean((e[:, :2] / e[:, 2:3]) ** 2))
    assert 0.6 < ratio < 1.5


def test_noise_statistics_of_the_background(module_noisy):
    doc = json.loads((module_noisy / "scenario.json").read_text())
    params = nav.RenderParams(**doc["render"])
    r = nav.Renderer(W, H, params)
    img = nav.read_pgm(module_noisy / "cam_y/000000.pgm").astype(float)
    patch = (img - r.bg)[400:600, 100:300]  # far from most spots; allow for a few
    patch = patch[np.abs(patch) < 8]  # drop spot pixels, if any
    assert abs(np.mean(patch)) < 0.05
    # whole-DN samples: the variance gains the quantisation's 1/12
    assert abs(np.std(patch) - np.sqrt(r.sigma_bg**2 + 1 / 12)) < 0.05


# --------------------------------------------------------------------------- files
def check_folder(folder, scenario):
    doc = json.loads((folder / "scenario.json").read_text())
    assert doc["format"] == "mfns-nav-frames" and doc["version"] == 1
    assert doc["scenario"] == scenario
    for key, typ in (("rate_hz", float), ("n_frames", int), ("width", int), ("height", int), ("maxval", int)):
        assert isinstance(doc[key], typ)
    assert isinstance(doc["seed"], int) and isinstance(doc["pixel_noise_px"], float)
    assert (doc["width"], doc["height"], doc["maxval"]) == (W, H, 255)
    n, rate = doc["n_frames"], doc["rate_hz"]

    truth = read_csv_strict(folder / "truth.csv", nav.TRUTH_HEADER)
    assert [int(r["frame"]) for r in truth] == list(range(n))
    num = re.compile(r"^-?\d+\.\d{6}$")
    for r in truth:
        assert abs(float(r["t_s"]) - int(r["frame"]) / rate) < 1e-6
        for k in nav.TRUTH_HEADER[1:]:
            assert num.match(r[k]) and r[k] != "-0.000000", r[k]
    if scenario == "module":
        # the robot's workspace the tables are built over holds every pose of the path
        box = np.array(doc["table_workspace_mm"], dtype=float)
        xyz = np.array([[float(r[k]) for k in ("x_mm", "y_mm", "z_mm")] for r in truth])
        assert box.shape == (6,) and np.all(xyz >= box[:3]) and np.all(xyz <= box[3:])

    frames = read_csv_strict(folder / "frames.csv", nav.FRAMES_HEADER)
    assert len(frames) == 3 * n
    header = f"P5\n{W} {H}\n255\n".encode()
    for j, r in enumerate(frames):
        i, cam = divmod(j, 3)
        assert int(r["frame"]) == i and r["camera"] == "xyz"[cam]
        assert r["t_s"] == truth[i]["t_s"]
        assert r["file"] == f"cam_{'xyz'[cam]}/{i:06d}.pgm"
        assert re.match(r"^\d+$", r["exposure_us"]) and int(r["exposure_us"]) > 0
        assert 0.0 <= float(r["gain_db"]) <= 24.0
        data = (folder / r["file"]).read_bytes()
        assert data.startswith(header) and len(data) == len(header) + W * H

    cal = calib_results.load(folder / "calib.json")
    assert [c["name"] for c in cal["cameras"]] == ["x", "y", "z"]

    beacons = read_csv_strict(folder / "beacons.csv", nav.BEACONS_HEADER)
    ids = [int(b["id"]) for b in beacons]
    assert len(set(ids)) == len(ids) == doc["n_beacons"]
    pos = {int(b["id"]): np.array([float(b[k]) for k in ("x_mm", "y_mm", "z_mm")]) for b in beacons}

    # the truth, the calibration and the map reproduce every real spot's position
    cams = nav.rig_from_doc(cal)
    spots = read_csv_strict(folder / "spots.csv", nav.SPOTS_HEADER)
    n_spurious = 0
    for s in spots:
        bid = int(s["beacon_id"])
        if bid == -1:
            n_spurious += 1
            continue
        t = truth[int(s["frame"])]
        c_w_b = euler213_deg_to_matrix([float(t[k]) for k in ("roll_deg", "pitch_deg", "yaw_deg")])
        r_bw_b = nav.pose_from_position(c_w_b, [float(t[k]) for k in ("x_mm", "y_mm", "z_mm")])
        uv, vis, _ = nav.project_beacons(cams["xyz".index(s["camera"])], c_w_b, r_bw_b, pos[bid][None])
        assert vis[0]
        assert np.max(np.abs(uv[0] - [float(s["u"]), float(s["v"])])) < 2e-4  # 4-decimal map, 6-decimal truth
    assert n_spurious == doc["spurious_spots"]
    return doc, truth, spots


def test_module_folder_follows_the_doc(module_noisy):
    doc, _, spots = check_folder(module_noisy, "module")
    assert doc["n_beacons"] == 60
    assert len(spots) >= 8 * 4


def test_turntable_folder_follows_the_doc(turntable):
    doc, truth, spots = check_folder(turntable, "turntable")
    assert doc["n_beacons"] == 10
    assert doc["spurious_spots"] > 0  # rate 0.5 over 36 images
    for i, r in enumerate(truth):
        assert [float(r[k]) for k in ("x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg")] == [0.0] * 5
        yaw = (360.0 * i / 12 + 180.0) % 360.0 - 180.0
        assert abs(float(r["yaw_deg"]) - yaw) < 1e-6 or abs(abs(yaw) - 180.0) < 1e-6


def test_turntable_sees_the_beacons_the_reference_names():
    """docs/system.md §6: yaw 0: beacon 8 in X, 9 in Z; yaw 30: 7 in X, 4 and 5 in Y, 9 in Z."""
    scn = nav.turntable_scenario(12, 18.6, 0.0, 360.0)
    seen = {}
    for i in (0, 1):
        c, r = scn.pose(i)
        seen[i] = [
            sorted(scn.beacon_ids[nav.project_beacons(cam, c, r, scn.beacons)[1]].tolist())
            for cam in scn.cams
        ]
    assert seen[0] == [[8], [], [9]]
    assert seen[1] == [[7], [4, 5], [9]]
    counts = nav.visibility_counts(nav.turntable_scenario(360, 18.6, 0.0, 360.0)).sum(axis=1)
    assert counts.min() >= 1 and counts.max() <= 4


def test_module_geometry_and_visibility():
    scn = nav.module_scenario(1500, 5.0, 60, seed=0)  # 300 s of the path
    half = nav.MODULE_HALF
    on_wall = np.isclose(np.abs(scn.beacons), half).sum(axis=1)
    assert np.all(on_wall == 1)
    assert np.all(np.abs(scn.beacons) <= half + 1e-9)
    clearance = (half - np.abs(scn.r_wb_w)).min()
    assert clearance >= 600.0
    # smooth: bounded speed and turn rate between consecutive 0.2 s steps
    assert np.max(np.linalg.norm(np.diff(scn.r_wb_w, axis=0), axis=1)) * 5.0 < 400.0
    d_att = np.diff(np.unwrap(np.deg2rad(scn.euler_deg), axis=0), axis=0)
    assert np.rad2deg(np.max(np.abs(d_att))) * 5.0 < 60.0
    stats = nav.visibility_stats(nav.visibility_counts(scn))
    assert stats["frac_ge_4"] >= 0.9
    assert stats["frac_ge_3"] >= 0.97


def test_same_seed_same_files_other_seed_other_map(tmp_path):
    a = _sim(tmp_path / "a", "--scenario", "module", "--frames", "2", "--seed", "11")
    b = _sim(tmp_path / "b", "--scenario", "module", "--frames", "2", "--seed", "11")
    c = _sim(tmp_path / "c", "--scenario", "module", "--frames", "2", "--seed", "12")
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert len(files) == 6 + 6

    def digest(root, rel):
        return hashlib.sha256((root / rel).read_bytes()).hexdigest()

    assert all(digest(a, f) == digest(b, f) for f in files)
    assert digest(a, "beacons.csv") != digest(c, "beacons.csv")
    assert digest(a, "cam_x/000000.pgm") != digest(c, "cam_x/000000.pgm")


def test_survey_error_displaces_the_rendered_beacons_not_the_map(tmp_path):
    """--survey-error: the LEDs are rendered off their map positions by their sigma_mm; the
    map, the trajectory and the truth stay those of the seed."""
    args = ("--scenario", "module", "--frames", "3", "--seed", "11")
    a = _sim(tmp_path / "a", *args)
    b = _sim(tmp_path / "b", *args, "--survey-error")
    assert (a / "beacons.csv").read_bytes() == (b / "beacons.csv").read_bytes()
    assert (a / "truth.csv").read_bytes() == (b / "truth.csv").read_bytes()
    assert not (a / "beacons_rendered.csv").exists()
    nominal = read_csv_strict(a / "beacons.csv", nav.BEACONS_HEADER)
    rendered = read_csv_strict(b / "beacons_rendered.csv", nav.BEACONS_HEADER)
    assert [r["id"] for r in rendered] == [r["id"] for r in nominal]
    d = np.array(
        [
            [float(r[k]) - float(n[k]) for k in ("x_mm", "y_mm", "z_mm")]
            for r, n in zip(rendered, nominal, strict=True)
        ]
    )
    sigma = np.array([float(n["sigma_mm"]) for n in nominal])
    z = d / sigma[:, None]  # N(0, 1) per axis: 180 draws
    assert abs(np.mean(z)) < 0.3 and 0.8 < np.std(z) < 1.2
    doc = json.loads((b / "scenario.json").read_text())
    assert doc["survey_error"]["applied"] is True
    assert doc["survey_error"]["rms_displacement_mm"] == pytest.approx(np.sqrt(np.mean(d**2)), abs=1e-3)
    assert "survey_error" not in json.loads((a / "scenario.json").read_text())
    # the spots are where the displaced LEDs project (spots.csv), so the frames differ
    spots_a = {(r["frame"], r["camera"], r["beacon_id"]): r for r in csv.DictReader((a / "spots.csv").open())}
    spots_b = {(r["frame"], r["camera"], r["beacon_id"]): r for r in csv.DictReader((b / "spots.csv").open())}
    common = [k for k in spots_a if k in spots_b and k[2] != "-1"]
    shift = [abs(float(spots_a[k]["u"]) - float(spots_b[k]["u"])) for k in common]
    assert len(common) > 10 and 0.0 < np.median(shift) < 5.0


# --------------------------------------------------------------------------- CLI
def test_cli_refuses_non_empty_out_and_bad_arguments(tmp_path, capsys):
    out = _sim(tmp_path / "o", "--frames", "1")
    capsys.readouterr()
    assert main(["sim", "nav", str(out), "--frames", "1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not empty" in err[0]
    assert main(["sim", "nav", str(out), "--frames", "1", "--quiet", "--force", "--scenario", "module"]) == 0
    assert json.loads((out / "scenario.json").read_text())["scenario"] == "module"
    assert main(["sim", "nav", str(tmp_path / "p"), "--frames", "0", "--quiet"]) == 2
    assert main(["sim", "nav", str(tmp_path / "q"), "--scenario", "module", "--beacons", "3", "--quiet"]) == 2
    other = tmp_path / "other"
    other.mkdir()
    (other / "keep.txt").write_text("x")
    assert main(["sim", "nav", str(other), "--frames", "1", "--quiet", "--force"]) == 2
    assert (other / "keep.txt").exists()


def test_cli_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["sim", "nav", "--help"])
    assert exc.value.code == 0
    assert "--scenario" in capsys.readouterr().out


def test_spots_sidecar_rows_are_consistent(turntable):
    spots = read_csv_strict(turntable / "spots.csv", nav.SPOTS_HEADER)
    with open(turntable / "beacons.csv") as f:
        ids = {int(r["id"]) for r in csv.DictReader(f)}
    for s in spots:
        assert int(s["beacon_id"]) in ids | {-1}
        assert -0.5 <= float(s["u"]) < W - 0.5 and -0.5 <= float(s["v"]) < H - 0.5
        assert float(s["peak_dn"]) > 0 and float(s["sigma_px"]) > 0
