"""The fault campaign's injectors and scorer (tests/bench/faults, `make faults`) on tiny
synthetic inputs: a 3-frame folder of small PGMs, a hand-written nav.csv/camera.csv/truth."""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "bench"))

from faults import inject, mdb, score  # noqa: E402

W, H = 40, 32
PERIOD = 0.05


def pgm(value: int, spot: tuple[float, float, float, float] | None = None, maxv: int = 255) -> bytes:
    yy, xx = np.mgrid[0:H, 0:W]
    px = np.full((H, W), float(value))
    if spot is not None:
        u, v, s, a = spot
        px += a * np.exp(-((xx - u) ** 2 + (yy - v) ** 2) / (2 * s * s))
    return inject.pgm_bytes(px, maxv)


@pytest.fixture()
def folder(tmp_path: Path) -> Path:
    """3 frames x 3 cameras; image (f, cam) uniform at 10 * f + cam index + 1; camera y's
    frames carry beacon 7's spot at (20.3, 15.6), sigma 1.2 px, peak 150 DN."""
    src = tmp_path / "src"
    rows = ["frame,t_s,camera,file,exposure_us,gain_db"]
    spots = ["frame,camera,beacon_id,u,v,peak_dn,sigma_px"]
    for f in range(3):
        for k, c in enumerate("xyz"):
            (src / f"cam_{c}").mkdir(parents=True, exist_ok=True)
            spot = (20.3, 15.6, 1.2, 150.0) if c == "y" else None
            (src / f"cam_{c}" / f"{f:06d}.pgm").write_bytes(pgm(10 * f + k + 1, spot))
            rows.append(f"{f},{f * PERIOD:.6f},{c},cam_{c}/{f:06d}.pgm,1000,0.0")
            if spot:
                spots.append(f"{f},{c},7,20.300000,15.600000,150.00,1.2000")
    (src / "frames.csv").write_text("\n".join(rows) + "\n")
    (src / "spots.csv").write_text("\n".join(spots) + "\n")
    (src / "beacons.csv").write_text(
        "id,x_mm,y_mm,z_mm,sigma_mm\n"
        "3,2000.0000,100.0000,-50.0000,0.4000\n"
        "7,-300.0000,1000.0000,200.0000,0.4000\n"
        "9,-2000.0000,-400.0000,-1000.0000,0.4000\n"
        "12,500.0000,-1000.0000,1000.0000,0.4000\n"
    )
    return src


def img(folder: Path, cam: str, f: int) -> bytes:
    return (folder / f"cam_{cam}" / f"{f:06d}.pgm").read_bytes()


def test_freeze_copies_bytes_and_leaves_the_source(folder: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder, tmp_path / "d")
    done = inject.freeze_camera(d, "x", 1)
    assert done == {("x", 1): 1, ("x", 2): 1}
    assert img(d, "x", 2) == img(d, "x", 1) == img(folder, "x", 1) != img(folder, "x", 2)
    assert img(d, "x", 0) == img(folder, "x", 0)
    for f in range(3):
        assert img(d, "y", f) == img(folder, "y", f)
    assert img(folder, "x", 2) == pgm(21)  # the linked source is untouched
    assert (d / "frames.csv").read_bytes() == (folder / "frames.csv").read_bytes()


def test_clock_step_shifts_only_that_cameras_rows_from_k(folder: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder, tmp_path / "d")
    inject.clock_step(d, "y", 1, -1.0)
    before = {(r["camera"], r["frame"]): r for r in inject.frame_rows(folder)}
    after = {(r["camera"], r["frame"]): r for r in inject.frame_rows(d)}
    assert before.keys() == after.keys()
    for key, r in before.items():
        shift = -1.0 if key[0] == "y" and key[1] >= 1 else 0.0
        assert after[key]["t_s"] == pytest.approx(r["t_s"] + shift, abs=1e-9), key
        assert after[key]["file"] == r["file"]
    assert (folder / "frames.csv").read_text().count("-0.95") == 0


def test_stale_shifts_images_and_keeps_the_rows(folder: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder, tmp_path / "d")
    done = inject.stale_frames(d, "z", 1, 1)
    assert done == {("z", 1): 0, ("z", 2): 1}
    assert img(d, "z", 1) == img(folder, "z", 0) and img(d, "z", 2) == img(folder, "z", 1)
    assert img(d, "z", 0) == img(folder, "z", 0) and img(d, "x", 2) == img(folder, "x", 2)
    assert (d / "frames.csv").read_bytes() == (folder / "frames.csv").read_bytes()
    d2 = inject.link_frames(folder, tmp_path / "d2")
    assert inject.stale_frames(d2, "z", 1, 2) == {("z", 2): 0}
    assert img(d2, "z", 2) == img(folder, "z", 0) and img(d2, "z", 1) == img(folder, "z", 1)
    cap = score.capture_times(inject.frame_rows(folder), done)
    assert cap[("z", 2)] == pytest.approx(PERIOD) and cap[("x", 2)] == pytest.approx(2 * PERIOD)


@pytest.mark.parametrize(("along", "axis"), [(False, 0), (True, 1)])
def test_moved_beacon_moves_only_that_beacon_by_d(
    folder: Path, tmp_path: Path, along: bool, axis: int
) -> None:
    rows = inject.read_beacons(folder / "beacons.csv")
    assert inject.beacon_wall(rows, 3) == (0, -1.0)  # on the max x wall, inward is -x
    mv = inject.move_vector(rows, 3, 20.0, along)
    assert np.linalg.norm(mv) == pytest.approx(20.0) and abs(mv[axis]) == pytest.approx(20.0)
    out = inject.moved_beacon_map(folder / "beacons.csv", tmp_path / "b.csv", 3, mv)
    new = {int(r["id"]): r for r in inject.read_beacons(out)}
    for r in rows:
        p0 = np.array([float(r[a]) for a in inject.AXES])
        p1 = np.array([float(new[int(r["id"])][a]) for a in inject.AXES])
        want = -mv if int(r["id"]) == 3 else np.zeros(3)
        np.testing.assert_allclose(p1 - p0, want, atol=1e-4)
    if not along:  # off the wall: the map puts it behind the wall, the frames show it inside
        assert float(new[3]["x_mm"]) == pytest.approx(2020.0)


def test_most_seen_beacon_and_walls(folder: Path) -> None:
    assert inject.most_seen_beacon(folder / "spots.csv") == 7
    rows = inject.read_beacons(folder / "beacons.csv")
    assert inject.beacon_wall(rows, 7) == (1, -1.0)
    assert inject.beacon_wall(rows, 9)[1] == 1.0  # a min wall: inward is +


def test_dead_led_lowers_the_peak_at_the_spot(folder: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder, tmp_path / "d")
    assert inject.dead_led(d, 7, seed=1) == 3
    for f in range(3):
        px, _ = inject.read_pgm(d / "cam_y" / f"{f:06d}.pgm")
        px0, _ = inject.read_pgm(folder / "cam_y" / f"{f:06d}.pgm")
        bg = 10 * f + 2
        assert px0[16, 20] > bg + 100
        assert px[14:18, 18:23].max() <= bg + 1  # the background is flat: no noise to add
        assert px[0, 0] == bg and px.shape == px0.shape
    assert img(d, "x", 1) == img(folder, "x", 1)


def test_erase_spot_adds_the_images_noise_level() -> None:
    rng = np.random.default_rng(3)
    px = 50.0 + rng.normal(0.0, 2.0, (60, 60))
    yy, xx = np.mgrid[0:60, 0:60]
    px += 200.0 * np.exp(-((xx - 30.4) ** 2 + (yy - 29.7) ** 2) / (2 * 1.3**2))
    inject.erase_spot(px, 30.4, 29.7, 1.3, np.random.default_rng(4))
    inner = px[24:36, 24:37]
    assert abs(inner.mean() - 50.0) < 1.0 and 1.0 < inner.std() < 3.5


def test_16_bit_images_round_trip(tmp_path: Path) -> None:
    p = tmp_path / "a.pgm"
    p.write_bytes(pgm(1000, maxv=4095))
    px, maxv = inject.read_pgm(p)
    assert maxv == 4095 and px.shape == (H, W) and px[0, 0] == 1000.0
    assert inject.pgm_bytes(px, maxv) == p.read_bytes()


# --------------------------------------------------------------------------- the scorer
EULER = [(10.0, -5.0, 30.0), (10.5, -5.2, 31.0), (11.0, -5.4, 32.0)]
POS = [(100.0, 200.0, 300.0), (110.0, 201.0, 299.0), (120.0, 202.0, 298.0)]


def truth() -> score.Truth:
    return score.Truth(
        [
            {
                "frame": f,
                "t_s": f * PERIOD,
                **{f"{a}_mm": p for a, p in zip("xyz", POS[f], strict=True)},
                **{f"{a}_deg": e for a, e in zip(("roll", "pitch", "yaw"), EULER[f], strict=True)},
            }
            for f in range(3)
        ]
    )


def quat_of(c: np.ndarray) -> np.ndarray:
    w = math.sqrt(max(1.0 + np.trace(c), 1e-12)) / 2
    return np.array(
        [w, (c[2, 1] - c[1, 2]) / (4 * w), (c[0, 2] - c[2, 0]) / (4 * w), (c[1, 0] - c[0, 1]) / (4 * w)]
    )


def nav_row(cycle: int, t_s: float, frame: int, d_mm=(0.0, 0.0, 0.0), sigma_mm=1.0, **extra) -> dict:
    c_b_w = score.rot_from_euler213_deg(*EULER[frame]).T
    q = quat_of(c_b_w)
    row = {"t_s": f"{t_s:.6f}", "cycle": str(cycle), "status": "FIX", "cams_used": "1"}
    row |= {f"{a}_mm": str(POS[frame][i] + d_mm[i]) for i, a in enumerate("xyz")}
    row |= {f"{a}_deg": str(e) for a, e in zip(("roll", "pitch", "yaw"), EULER[frame], strict=True)}
    row |= {k: repr(float(v)) for k, v in zip(("q_w", "q_x", "q_y", "q_z"), q, strict=True)}
    for i, a in enumerate(score.AXES_ROS):
        for j in range(i, 6):
            var = (sigma_mm**2 if i < 3 else 0.01**2) if i == j else 0.0
            row[f"cov_{a}_{score.AXES_ROS[j]}"] = str(var)
    return row | {k: str(v) for k, v in extra.items()}


def cam_rows(cycle: int, seq: int) -> list[dict]:
    return [
        {"cycle": str(cycle), "camera": "x", "state": "OK", "beacons_identified": "4", "frame_seq": str(seq)}
    ]


def one(row: dict, seq: int) -> dict:
    cap = {("x", f): f * PERIOD for f in range(3)}
    return score.score_run([row], cam_rows(int(row["cycle"]), seq), truth(), cap, PERIOD)


def test_scorer_passes_an_exact_fix() -> None:
    r = one(nav_row(1, PERIOD, 1), 1)
    assert r["usable"] == 1 and r["misleading"] == 0
    assert r["worst_mm"] < 1e-6 and r["worst_deg"] < 1e-6 and r["worst_nees"] < 1e-6


def test_scorer_flags_a_fix_25_mm_off() -> None:
    r = one(nav_row(1, PERIOD, 1, d_mm=(0.0, 25.0, 0.0), sigma_mm=100.0), 1)
    assert r["misleading"] == 1 and r["misleading_stamp"] == 0
    assert r["worst_mm"] == pytest.approx(25.0, abs=1e-6) and r["worst_sigma"] < 1.0


def test_scorer_flags_a_fix_6_sigma_off() -> None:
    r = one(nav_row(1, PERIOD, 1, d_mm=(0.0, 0.0, 6.0)), 1)
    assert r["misleading"] == 1 and r["worst_sigma"] == pytest.approx(6.0, rel=1e-6)
    assert one(nav_row(1, PERIOD, 1, d_mm=(0.0, 0.0, 4.0)), 1)["misleading"] == 0


def test_scorer_flags_a_fix_stamped_two_periods_from_its_frames() -> None:
    # the pose of frame 0, from frame 0, stamped at frame 2's time: wrong at its stamp, and
    # stamped two periods from its frame
    r = one(nav_row(2, 2 * PERIOD, 0), 0)
    assert r["misleading"] == 1 and r["misleading_stamp"] == 1 and r["misleading_error"] == 1
    assert r["worst_mm"] == pytest.approx(np.linalg.norm(np.subtract(POS[2], POS[0])))
    assert r["worst_stamp_s"] == pytest.approx(2 * PERIOD)
    # one period late passes the stamp rule (a frame that is exactly one period stale), but the
    # pose of frame 0 is still wrong for the stamp of frame 1 (here by 10 mm at 1 mm sigma)
    r = one(nav_row(1, PERIOD, 0), 0)
    assert r["misleading_stamp"] == 0 and r["misleading_error"] == 1


def test_scorer_judges_a_fix_at_its_stamp_whatever_its_frames_show() -> None:
    cams = cam_rows(1, 1) + [
        {"cycle": "1", "camera": "y", "state": "OK", "beacons_identified": "3", "frame_seq": "1"}
    ]
    cap = {("x", 1): PERIOD, ("y", 1): 0.0}  # y's image of frame 1 shows frame 0
    # right at its stamp (a filter that took y's late frame with its time offset eliminated):
    # counted as fused out of step, not misleading
    r = score.score_run([nav_row(1, PERIOD, 1, cams_used=3)], cams, truth(), cap, PERIOD)
    assert r["out_of_step_fixes"] == 1 and r["misleading"] == 0 and r["worst_mm"] < 1e-6
    # the pose of y's instant stamped with x's (a blend gone to the stale camera): misleading
    r = score.score_run([nav_row(1, PERIOD, 0, cams_used=3)], cams, truth(), cap, PERIOD)
    assert r["out_of_step_fixes"] == 1 and r["misleading"] == 1
    assert r["worst_mm"] == pytest.approx(np.linalg.norm(np.subtract(POS[1], POS[0])))


def test_scorer_interpolates_truth_between_frames() -> None:
    p, _, _ = truth().at(0.5 * PERIOD)
    np.testing.assert_allclose(p, (105.0, 200.5, 299.5))


def test_scorer_protection_levels() -> None:
    r = one(nav_row(1, PERIOD, 1, d_mm=(3.0, 4.0, 0.0), sigma_mm=10.0, pl_pos_mm=10.0, pl_att_deg=0.5), 1)
    assert r["pl_columns"] == ["pl_pos_mm", "pl_att_deg"]
    assert r["worst_pl_ratio"] == pytest.approx(0.5) and r["pl_exceeded"] == 0
    r = one(nav_row(1, PERIOD, 1, d_mm=(3.0, 4.0, 0.0), sigma_mm=10.0, pl_pos_mm=2.5, pl_att_deg="inf"), 1)
    assert r["worst_pl_ratio"] == pytest.approx(2.0) and r["pl_exceeded"] == 1 and r["pl_missing"] == 1
    assert one(nav_row(1, PERIOD, 1), 1)["worst_pl_ratio"] is None


def test_first_report_by_name_and_subject() -> None:
    ev = [
        {"cycle": "0", "seq": "0", "event": "BOOT", "subject": "0"},
        {"cycle": "2", "seq": "1", "event": "CAMERA_STALE", "subject": "1"},  # before the onset
        {"cycle": "4", "seq": "2", "event": "CAMERA_RECOVERED", "subject": "1"},  # ordinary
        {"cycle": "5", "seq": "3", "event": "CAMERA_FROZEN", "subject": "0"},  # another camera
        {"cycle": "6", "seq": "4", "event": "MODE_CHANGE", "subject": "1"},  # no camera subject
        {"cycle": "7", "seq": "5", "event": "CAMERA_FROZEN", "subject": "1"},
        {"cycle": "8", "seq": "6", "event": "BEACON_EXCLUDED", "subject": "1"},
    ]
    assert score.first_report(ev, "camera", 1, 3) == {"cycle": 7, "delay": 4, "event": "CAMERA_FROZEN"}
    assert score.first_report(ev, "beacon", 1, 3) == {"cycle": 8, "delay": 5, "event": "BEACON_EXCLUDED"}
    assert score.first_report(ev, "camera", 2, 0) is None
    # the dictionary says what a subject is when the name does not
    ev.append({"cycle": "5", "seq": "7", "event": "FDE_OUTLIER", "subject": "1"})
    assert score.first_report(ev, "beacon", 1, 3) == {"cycle": 8, "delay": 5, "event": "BEACON_EXCLUDED"}
    got = score.first_report(ev, "beacon", 1, 3, {"FDE_OUTLIER": "beacon"})
    assert got == {"cycle": 5, "delay": 2, "event": "FDE_OUTLIER"}
    assert score.dictionary_subjects().get("CAMERA_STALE") == "camera"
    # coming back is no report; a beacon id above 254 is in arg1
    ev = [
        {"cycle": "4", "seq": "0", "event": "CAMERA_HEALTHY", "subject": "2"},
        {"cycle": "4", "seq": "1", "event": "BEACON_READMITTED", "subject": "255", "arg1": "300"},
        {"cycle": "6", "seq": "2", "event": "BEACON_EXCLUDED", "subject": "255", "arg1": "300"},
    ]
    assert score.first_report(ev, "camera", 2, 0) is None
    assert score.first_report(ev, "beacon", 300, 1) == {"cycle": 6, "delay": 5, "event": "BEACON_EXCLUDED"}
    cams = [
        {"cycle": "3", "camera": "x", "frame_seq": "29"},
        {"cycle": "4", "camera": "x", "frame_seq": "30"},
    ]
    assert score.onset_cycle(cams, 30) == 4 and score.onset_cycle(cams, 99) == 99


def test_first_report_of_a_pair_of_cameras() -> None:
    """CAMERAS_DISAGREE names two cameras (subject and arg1): either is reported by it."""
    ev = [{"cycle": "9", "seq": "0", "event": "CAMERAS_DISAGREE", "subject": "0", "arg0": "20", "arg1": "1"}]
    for cam in (0, 1):
        assert score.first_report(ev, "camera", cam, 3) == {
            "cycle": 9,
            "delay": 6,
            "event": "CAMERAS_DISAGREE",
        }
    assert score.first_report(ev, "camera", 2, 3) is None
    assert score.dictionary_subjects().get("CAMERAS_DISAGREE") == "camera"
    assert score.dictionary_subjects().get("CAMERA_INCONSISTENT") == "camera"


def _mdb_scene():
    """Two cameras looking along +x and -y from the origin, six beacons in each view."""

    def cam(name: str, c_k_b: list[list[float]]):
        return mdb.Camera.from_entry(
            {
                "name": name,
                "image_size": [1280, 1024],
                "fx": 1600.0,
                "fy": 1600.0,
                "cx": 640.0,
                "cy": 512.0,
                "dist": [0, 0, 0, 0, 0],
                "C_k_b": c_k_b,
                "r_bk_b": [0.0, 0.0, 0.0],
            }
        )

    # camera z axis (optical) along body +x, and along body -y
    cams = {
        "x": cam("x", [[0, 0, 1], [1, 0, 0], [0, 1, 0]]),
        "y": cam("y", [[1, 0, 0], [0, 0, -1], [0, 1, 0]]),
    }
    pts = {}
    spots = []
    for i, (dy, dz) in enumerate([(-300, -200), (250, -150), (0, 300), (-200, 200), (300, 250), (100, -300)]):
        pts[i] = (np.array([2000.0, dy, dz]), 1e-4)
        spots.append(("x", i))
        pts[10 + i] = (np.array([dy, -2000.0, dz]), 1e-4)
        spots.append(("y", 10 + i))
    return cams, pts, spots


def test_mdb_scales_with_the_noise_and_needs_the_beacon() -> None:
    cams, pts, spots = _mdb_scene()
    eye, zero = np.eye(3), np.zeros(3)
    u = np.array([0.0, 1.0, 0.0])
    a = mdb.fix_mdb(cams, pts, spots, eye, zero, 2, u, 0.02)
    b = mdb.fix_mdb(cams, pts, spots, eye, zero, 2, u, 0.04)
    assert a is not None and 0.0 < a < 1e3
    assert b == pytest.approx(2 * a, rel=0.02)  # an exact map: the MDB is linear in the pixel noise
    assert mdb.fix_mdb(cams, pts, spots, eye, zero, 99, u, 0.02) is None  # not in the fix
    # a move along the line of sight changes no pixel: not detectable
    los = pts[2][0] / np.linalg.norm(pts[2][0])
    along = mdb.fix_mdb(cams, pts, spots, eye, zero, 2, los, 0.02)
    assert along is None or along > 50 * a


def test_scorer_reads_csv_files(tmp_path: Path) -> None:
    p = tmp_path / "nav.csv"
    row = nav_row(1, PERIOD, 1)
    with open(p, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(row))
        w.writeheader()
        w.writerow(row)
    assert score.read_csv(p) == [row] and score.read_csv(tmp_path / "none.csv") == []


# --------------------------------------------------------------------------- the grown campaign (issue 42)
def make_folder(root: Path, n: int) -> Path:
    """n frames x 3 cameras of uniform images (value 10 * f + camera index + 1)."""
    rows = ["frame,t_s,camera,file,exposure_us,gain_db"]
    for f in range(n):
        for k, c in enumerate("xyz"):
            (root / f"cam_{c}").mkdir(parents=True, exist_ok=True)
            (root / f"cam_{c}" / f"{f:06d}.pgm").write_bytes(pgm(10 * f + k + 1))
            rows.append(f"{f},{f * PERIOD:.6f},{c},cam_{c}/{f:06d}.pgm,1000,0.0")
    (root / "frames.csv").write_text("\n".join(rows) + "\n")
    return root


@pytest.fixture()
def folder6(tmp_path: Path) -> Path:
    return make_folder(tmp_path / "src6", 6)


@pytest.fixture(scope="module")
def simfolder(tmp_path_factory) -> Path:
    """A real `mfns sim nav` module folder of 4 frames (seed 2), rendered in-process."""
    from mfns.simulate import nav as sim

    out = tmp_path_factory.mktemp("sim") / "frames"
    out.mkdir()
    scn = sim.module_scenario(4, 18.6, 60, 2)
    sim.simulate(scn, out, 2, 18.6, sim.RenderParams(spurious_rate=0.0), progress=False)
    return out


def spots_of(folder: Path, cam: str, frame: int, beacons_only: bool = True) -> dict[int, tuple[float, float]]:
    out = {}
    for r in score.read_csv(folder / "spots.csv"):
        if r["camera"] == cam and int(r["frame"]) == frame and (int(r["beacon_id"]) >= 0 or not beacons_only):
            out[int(r["beacon_id"])] = (float(r["u"]), float(r["v"]))
    return out


def centroid(px: np.ndarray, u: float, v: float, r: int = 5) -> tuple[float, float]:
    """Intensity-weighted centroid above the window's median, around (u, v)."""
    cu, cv = int(round(u)), int(round(v))
    win = px[cv - r : cv + r + 1, cu - r : cu + r + 1]
    w = np.clip(win - np.median(px), 0.0, None)
    yy, xx = np.mgrid[cv - r : cv + r + 1, cu - r : cu + r + 1]
    return float((w * xx).sum() / w.sum()), float((w * yy).sum() / w.sum())


def busy_camera(folder: Path) -> str:
    """The camera with the most beacon spots in frame 1."""
    return max("xyz", key=lambda c: len(spots_of(folder, c, 1)))


def test_rerender_puts_spots_where_the_simulator_did(simfolder: Path) -> None:
    from faults import render

    scene = render.Scene.load(simfolder)
    cam = busy_camera(simfolder)
    s, ids = scene.spots(cam, 2)
    want = spots_of(simfolder, cam, 2)
    assert sorted(int(i) for i in ids) == sorted(want) and len(want) >= 3
    for i, row in zip(ids, s, strict=True):
        assert np.hypot(row[0] - want[int(i)][0], row[1] - want[int(i)][1]) < 1e-3


@pytest.mark.parametrize(("axis", "deg"), [((0.0, 1.0, 0.0), 0.3), ((1.0, 0.0, 0.0), 1.0)])
def test_knocked_camera_moves_its_spots_by_the_angle(simfolder: Path, tmp_path: Path, axis, deg) -> None:
    cam = busy_camera(simfolder)
    d = inject.link_frames(simfolder, tmp_path / "d")
    info = inject.point_camera(d, cam, 2, axis, deg, seed=1)
    assert info["images"] == 2 and info["spots"] > 0
    fx = json_cam(simfolder, cam)["fx"]
    expect_px = fx * math.tan(math.radians(deg))  # on the axis; more off it (distortion, 1 + x^2)
    before, after = spots_of(simfolder, cam, 3), spots_of(d, cam, 3)
    common = sorted(set(before) & set(after))
    assert common
    px, _ = inject.read_pgm(d / f"cam_{cam}" / "000003.pgm")
    for b in common:
        du, dv = np.subtract(after[b], before[b])
        along, across = (du, dv) if axis[1] else (dv, du)
        # camera turned +deg about its y (x) axis: the world moves -x (+y) in its image
        assert (-along if axis[1] else along) == pytest.approx(expect_px, rel=0.25), (b, du, dv)
        assert abs(across) < 0.2 * expect_px
        cu, cv = centroid(px, *after[b])  # the image really has the spot where spots.csv says
        assert np.hypot(cu - after[b][0], cv - after[b][1]) < 0.5
    # frames before the onset, the other cameras and frames.csv untouched
    assert img(d, cam, 1) == img(simfolder, cam, 1) and img(d, cam, 3) != img(simfolder, cam, 3)
    other = next(c for c in "xyz" if c != cam)
    assert img(d, other, 3) == img(simfolder, other, 3)
    assert (d / "frames.csv").read_bytes() == (simfolder / "frames.csv").read_bytes()


def json_cam(folder: Path, cam: str) -> dict:
    import json

    doc = json.loads((folder / "calib.json").read_text())
    return doc["cameras"]["xyz".index(cam)]


@pytest.mark.parametrize("rate_s", [0.5e-3, 2e-3, 100e-6 * PERIOD])
def test_clock_drift_grows_by_its_rate_per_frame(folder6: Path, tmp_path: Path, rate_s: float) -> None:
    d = inject.link_frames(folder6, tmp_path / "d")
    assert inject.clock_drift(d, "y", 2, rate_s) == {}
    before = {(r["camera"], r["frame"]): r for r in inject.frame_rows(folder6)}
    after = {(r["camera"], r["frame"]): r for r in inject.frame_rows(d)}
    for (c, f), r in before.items():
        drift = rate_s * (f - 1) if c == "y" and f >= 2 else 0.0
        assert after[(c, f)]["t_s"] - r["t_s"] == pytest.approx(drift, abs=1.5e-6), (c, f)
    for f in range(6):
        assert img(d, "y", f) == img(folder6, "y", f)  # the images are taken at the true instant
    # the scorer judges by the image's instant: a fix stamped by the drifting clock is that far off
    cap = score.capture_times(inject.frame_rows(folder6), {})
    assert cap[("y", 5)] == pytest.approx(5 * PERIOD)


def test_stale_after_a_drop_repeats_no_image(folder6: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder6, tmp_path / "d")
    done = inject.stale_after_drop(d, "x", 2)
    assert done == {("x", f): f - 1 for f in range(3, 6)}
    assert not (d / "cam_x" / "000002.pgm").exists()  # the dropped frame
    delivered = [img(d, "x", f) for f in (0, 1, 3, 4, 5)]
    assert delivered == [img(folder6, "x", f) for f in (0, 1, 2, 3, 4)]
    assert len(set(delivered)) == len(delivered)  # no repeated image at the onset
    rows0 = {(r["camera"], r["frame"]): r["t_s"] for r in inject.frame_rows(folder6)}
    rows1 = {(r["camera"], r["frame"]): r["t_s"] for r in inject.frame_rows(d)}
    assert set(rows0) - set(rows1) == {("x", 2)}  # its row is gone: a gap, no error
    assert all(rows1[key] == rows0[key] for key in rows1)  # fresh stamps: image f-1 at t_f
    assert img(d, "y", 3) == img(folder6, "y", 3)


def test_alternating_buffers_never_repeat_in_a_row(folder6: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder6, tmp_path / "d")
    done = inject.alternate_buffers(d, "z", 2)
    assert done == {("z", 2): 2, ("z", 3): 1, ("z", 4): 2, ("z", 5): 1}
    seq = [img(d, "z", f) for f in range(6)]
    assert seq[2:] == [img(folder6, "z", f) for f in (2, 1, 2, 1)]
    assert all(a != b for a, b in zip(seq, seq[1:], strict=False))  # a digest of the last frame misses it
    assert seq[:2] == [img(folder6, "z", f) for f in (0, 1)]


def test_frozen_scene_keeps_fresh_noise(simfolder: Path, tmp_path: Path) -> None:
    cam = busy_camera(simfolder)
    d = inject.link_frames(simfolder, tmp_path / "d")
    done = inject.frozen_noisy(d, cam, 1, seed=3)
    assert done == {(cam, f): 1 for f in (1, 2, 3)}
    a, b, c = (inject.read_pgm(d / f"cam_{cam}" / f"{f:06d}.pgm")[0] for f in (1, 2, 3))
    assert not np.array_equal(b, c) and not np.array_equal(a, b)  # no byte-equal frames
    diff = (b - c)[100:-100, 100:-100]
    assert 0.8 < diff.std() / math.sqrt(2) < 2.0  # fresh sensor noise of about 1 DN, nothing else
    for u, v in spots_of(simfolder, cam, 1).values():  # the spots of frame 1, not of frame 3
        if 10 < u < a.shape[1] - 10 and 10 < v < a.shape[0] - 10:
            cu, cv = centroid(c, u, v)
            assert np.hypot(cu - u, cv - v) < 0.5
    assert spots_of(d, cam, 3) == spots_of(simfolder, cam, 1)


def test_reflections_beside_every_beacon(simfolder: Path, tmp_path: Path) -> None:
    cam = busy_camera(simfolder)
    d = inject.link_frames(simfolder, tmp_path / "d")
    n = inject.reflections(d, cam, 2, seed=4)
    beacons = {f: spots_of(simfolder, cam, f) for f in (2, 3)}
    assert n == sum(len(b) for b in beacons.values())
    for f in (2, 3):
        ghosts = [
            (float(r["u"]), float(r["v"]), float(r["peak_dn"]))
            for r in score.read_csv(d / "spots.csv")
            if r["camera"] == cam and int(r["frame"]) == f and int(r["beacon_id"]) == -1
        ]
        assert len(ghosts) == len(beacons[f])
        for u, v in beacons[f].values():  # one ghost 3-6 px from each beacon
            dist = min(np.hypot(g[0] - u, g[1] - v) for g in ghosts)
            assert 3.0 - 1e-6 <= dist <= 6.0 + 1e-6
        px0, _ = inject.read_pgm(simfolder / f"cam_{cam}" / f"{f:06d}.pgm")
        px1, _ = inject.read_pgm(d / f"cam_{cam}" / f"{f:06d}.pgm")
        assert (px1 - px0).sum() > 0 and (px1 >= px0).all()  # light added, nothing removed
    assert img(d, cam, 1) == img(simfolder, cam, 1)


def test_swapped_streams_really_swap(folder6: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder6, tmp_path / "d")
    assert inject.swap_streams(d, "x", "y", 3) == 3
    for f in range(6):
        if f >= 3:
            assert img(d, "x", f) == img(folder6, "y", f) and img(d, "y", f) == img(folder6, "x", f)
        else:
            assert img(d, "x", f) == img(folder6, "x", f) and img(d, "y", f) == img(folder6, "y", f)
        assert img(d, "z", f) == img(folder6, "z", f)
    assert (d / "frames.csv").read_bytes() == (folder6 / "frames.csv").read_bytes()


def test_gain_halved_halves_every_pixel(folder: Path, tmp_path: Path) -> None:
    d = inject.link_frames(folder, tmp_path / "d")
    assert inject.scale_gain(d, "y", 1, 0.5) == 2
    for f in range(3):
        px0, _ = inject.read_pgm(folder / "cam_y" / f"{f:06d}.pgm")
        px1, _ = inject.read_pgm(d / "cam_y" / f"{f:06d}.pgm")
        want = np.floor(px0 * 0.5 + 0.5) if f >= 1 else px0
        np.testing.assert_array_equal(px1, want)
    assert px0.max() > 150 and px1.max() <= 0.5 * px0.max() + 0.5  # the spot's peak halved too


def test_two_beacons_moved(folder: Path, tmp_path: Path) -> None:
    rows = inject.read_beacons(folder / "beacons.csv")
    moves = {3: inject.move_vector(rows, 3, 20.0, False), 9: inject.move_vector(rows, 9, 20.0, False)}
    out = inject.moved_beacons_map(folder / "beacons.csv", tmp_path / "b.csv", moves)
    new = {int(r["id"]): r for r in inject.read_beacons(out)}
    for r in rows:
        p0 = np.array([float(r[a]) for a in inject.AXES])
        p1 = np.array([float(new[int(r["id"])][a]) for a in inject.AXES])
        np.testing.assert_allclose(p1 - p0, -moves.get(int(r["id"]), np.zeros(3)), atol=1e-4)
    assert inject.seen_beacons(folder / "spots.csv") == [7]
    with pytest.raises(ValueError):
        inject.moved_beacons_map(folder / "beacons.csv", tmp_path / "c.csv", {99: np.ones(3)})


def test_collision_is_a_velocity_step() -> None:
    from mfns.core.errors import MfnsError
    from mfns.simulate import nav as sim

    scn = sim.module_scenario(40, 18.6, 60, 2)
    ref = sim.module_scenario(40, 18.6, 60, 2)
    t_c = float(scn.t_s[20])
    sim.apply_collision(scn, *sim.parse_collision(f"{t_c},0,100,0,0,0,15"))
    dp = scn.r_wb_w - ref.r_wb_w
    np.testing.assert_allclose(dp[:21], 0.0, atol=1e-9)  # continuous: nothing before or at t_c
    np.testing.assert_allclose(dp[21:, 1], 100.0 * (scn.t_s[21:] - t_c), rtol=1e-9)
    dyaw = (scn.euler_deg[:, 2] - ref.euler_deg[:, 2] + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(dyaw[21:], 15.0 * (scn.t_s[21:] - t_c), atol=1e-6)
    # the velocity (finite differences) jumps by the step within one frame period
    v = np.diff(scn.r_wb_w[:, 1]) * 18.6
    v0 = np.diff(ref.r_wb_w[:, 1]) * 18.6
    assert (v - v0)[19] == pytest.approx(0.0, abs=1e-6) and (v - v0)[21] == pytest.approx(100.0)
    assert scn.info["collision"]["velocity_step_mm_s"] == [0.0, 100.0, 0.0]
    assert "collision" not in ref.info  # without the option nothing changes
    for bad in ("1,2,3", "1,2,3,x", "1,2,3,4,5", "nan,0,0,0"):
        with pytest.raises(MfnsError):
            sim.parse_collision(bad)


def test_blame_names_right_and_wrong_subjects() -> None:
    ev = [
        {"cycle": "1", "seq": "0", "event": "BEACON_MISSING", "subject": "4"},  # before the onset
        {"cycle": "3", "seq": "0", "event": "SELFTEST_CAMERA", "subject": "2"},  # start-up: no blame
        {"cycle": "5", "seq": "1", "event": "BEACON_EXCLUDED", "subject": "19"},
        {"cycle": "6", "seq": "2", "event": "CAMERA_LAG", "subject": "0"},
        {"cycle": "7", "seq": "3", "event": "CAMERAS_DISAGREE", "subject": "2", "arg1": "1"},
        {"cycle": "8", "seq": "4", "event": "BEACON_MISSING", "subject": "4"},
        {"cycle": "9", "seq": "5", "event": "CAMERA_RECOVERED", "subject": "2"},  # ordinary
    ]
    b = score.blame(ev, 3, [("camera", 1)])
    assert b["first"] == {
        "event": "BEACON_EXCLUDED",
        "cycle": 5,
        "delay": 2,
        "label": "beacon 19",
        "right": False,
    }
    assert b["wrong"] == {
        "beacon 19": ["BEACON_EXCLUDED"],
        "camera x": ["CAMERA_LAG"],
        "camera z": ["CAMERAS_DISAGREE"],
        "beacon 4": ["BEACON_MISSING"],
    }
    assert b["wrong_not_in_clean"] is None
    clean = score.baseline_blame([{"cycle": "2", "seq": "0", "event": "BEACON_MISSING", "subject": "4"}])
    b = score.blame(ev, 3, [("camera", 1)], baseline=clean)
    assert "beacon 4" not in b["wrong_not_in_clean"] and "beacon 19" in b["wrong_not_in_clean"]
    assert score.blame(ev, 6, [("camera", 0)])["first"]["right"] is True
    assert score.blame(ev, 10, [("camera", 0)]) == {"first": None, "wrong": {}, "wrong_not_in_clean": None}
    # a motion fault's own reports: MOTION_EXCEEDED or a mode change; a camera blamed is none
    assert score.first_motion_report(ev, 6) is None
    motion = [*ev, {"cycle": "14", "seq": "0", "event": "MOTION_EXCEEDED", "subject": "0"}]
    assert score.first_motion_report(motion, 6) == {"cycle": 14, "delay": 8, "event": "MOTION_EXCEEDED"}
    mode = [{"cycle": "12", "seq": "0", "event": "MODE_CHANGE", "subject": "3"}]
    assert score.first_motion_report(mode, 10) == {"cycle": 12, "delay": 2, "event": "MODE_CHANGE"}
    assert score.first_motion_report(ev[-1:], 0) is None
