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
    # the pose of frame 0, from frame 0, stamped at frame 2's time: right pose, wrong time
    r = one(nav_row(2, 2 * PERIOD, 0), 0)
    assert r["misleading"] == 1 and r["misleading_stamp"] == 1
    assert r["worst_mm"] < 1e-6 and r["worst_stamp_s"] == pytest.approx(2 * PERIOD)
    # one period late is allowed (a frame that is exactly one period stale)
    assert one(nav_row(1, PERIOD, 0), 0)["misleading_stamp"] == 0


def test_scorer_uses_the_worst_of_frames_fused_out_of_step() -> None:
    row = nav_row(1, PERIOD, 1, cams_used=3)
    cams = cam_rows(1, 1) + [
        {"cycle": "1", "camera": "y", "state": "OK", "beacons_identified": "3", "frame_seq": "1"}
    ]
    cap = {("x", 1): PERIOD, ("y", 1): 0.0}  # y's image of frame 1 shows frame 0
    r = score.score_run([row], cams, truth(), cap, PERIOD)
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
