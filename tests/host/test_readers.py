"""Hostile inputs to the readers of the host tools (issue 17 item 6): each gives one clear
line on stderr and exit status 2, never a traceback, never silent wrong output."""

from __future__ import annotations

import json
import os

import pytest

from mfns.cli import main


@pytest.fixture(scope="module")
def sources(repo_root):
    d = repo_root / "host_tools/mfns/data"
    return d / "paper_calib.json", d / "paper_beacons.csv"


@pytest.fixture(scope="module")
def need_core_lib(core_lib):
    if not core_lib.exists():
        pytest.fail("make lib has not built the C core")


def _run(argv, capsys) -> str:
    capsys.readouterr()
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert rc == 2, (rc, cap.err)
    assert cap.err.count("\n") == 1 and "error: " in cap.err and "Traceback" not in cap.err, cap.err
    return cap.err


def _calib(sources, edit) -> dict:
    doc = json.loads(sources[0].read_text())
    r = edit(doc)  # None: edited in place; "null": the document is JSON null
    return doc if r is None else (None if r == "null" else r)


def _set(path: str, value):
    """edit: doc[path...] = value, path like 'cameras.0.fx'."""

    def edit(doc):
        keys = path.split(".")
        d = doc
        for k in keys[:-1]:
            d = d[int(k)] if isinstance(d, list) else d[k]
        last = keys[-1]
        d[int(last) if isinstance(d, list) else last] = value

    return edit


CALIB_CASES = [
    (_set("cameras.0.fx", "1600"), "camera x fx: expected a number"),
    (_set("cameras.0.fx", [1600]), "camera x fx: expected a number"),
    (_set("cameras.0.fx", True), "camera x fx: expected a number, got true"),  # was fx = 1 px, exit 0
    (_set("cameras.1.fy", None), "camera y fy: expected a number"),
    (_set("cameras.0.image_size", 5), "image_size: expected [width, height]"),
    (_set("cameras.0.image_size", [1280.0, 1024]), "image_size width: expected an integer"),
    (_set("cameras.0.image_size", [True, 1024]), "image_size width: expected an integer"),
    (_set("cameras.2.dist", 0.1), "camera z dist [k1, k2, p1, p2, k3]: expected a list of 5"),
    (_set("cameras.2.dist", [0.1, 0, 0, 0, "0"]), "dist [k1, k2, p1, p2, k3][4]: expected a number"),
    (_set("cameras.0.C_k_b", [[1, 0, 0], [0, 1, 0], [0, 0]]), "C_k_b[2]: expected a list of 3"),
    (_set("cameras.0.r_bk_b", {"x": 1}), "r_bk_b: expected a list of 3"),
    (_set("cameras", ["x", "y", "z"]), "camera 0: expected a JSON object"),
    (_set("cameras", "xyz"), "cameras must be a list of exactly three"),
    (_set("pixel_noise_px", True), "pixel_noise_px: expected a number"),
    (_set("version", 1.5), "version: expected an integer"),
    (_set("version", True), "version: expected an integer"),
    (lambda d: [], "calibration results: expected a JSON object, got a list of 0"),
    (lambda d: "null", "calibration results: expected a JSON object, got null"),
]


@pytest.mark.usefixtures("need_core_lib")
@pytest.mark.parametrize("edit,message", CALIB_CASES)
def test_table_build_refuses_bad_calibration_json(sources, tmp_path, capsys, edit, message):
    calib = tmp_path / "calib.json"
    calib.write_text(json.dumps(_calib(sources, edit)))
    out = tmp_path / "t.mfnstbl"
    err = _run(["table", "build", calib, sources[1], "-o", out], capsys)
    assert message in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    "text,message",
    [
        ("[" * 100_000 + "]" * 100_000, "JSON nested too deeply"),
        ('{"format": "mfns-calib-results", "version": NaN}', "NaN is not a JSON number"),
        ('{"format": "mfns-calib-results", "format": "x"}', "duplicate key 'format'"),
        ("\xff\xfe", "not UTF-8 text"),
        ("", "not valid JSON"),
    ],
)
def test_calibration_json_syntax(sources, tmp_path, capsys, text, message):
    calib = tmp_path / "calib.json"
    calib.write_bytes(text.encode("latin-1") if text.startswith("\xff") else text.encode())
    err = _run(["table", "build", calib, sources[1], "-o", tmp_path / "t"], capsys)
    assert message in err, err


@pytest.mark.usefixtures("need_core_lib")
@pytest.mark.parametrize(
    "csv,message",
    [
        ("", "missing columns"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n", "no beacons"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n3.7,0,0,0,0.4\n", "id: '3.7' is not an integer"),  # was id 3
        ("id,x_mm,y_mm,z_mm,sigma_mm\n3.0,0,0,0,0.4\n", "id: '3.0' is not an integer"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n1,0,0,0\n", "wrong number of fields"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n1,0,0,0,0.4,9\n", "wrong number of fields"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n1,0,nan,0,0.4\n", "y_mm: 'nan' is not finite"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n1,0,0,0,-0.4\n", "sigma_mm must be positive"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n70000,0,0,0,0.4\n", "outside 0..65535"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n1,0,0\x00,0,0.4\n", "NUL"),
        ("id,x_mm,y_mm,z_mm,sigma_mm\n1,0,0,0,0.4\n1,1,1,1,0.4\n", "duplicate beacon ids"),
    ],
)
def test_table_build_refuses_bad_beacon_csv(sources, tmp_path, capsys, csv, message):
    beacons = tmp_path / "beacons.csv"
    beacons.write_text(csv)
    err = _run(["table", "build", sources[0], beacons, "-o", tmp_path / "t"], capsys)
    assert message in err, err


@pytest.mark.usefixtures("need_core_lib")
def test_table_build_refuses_more_beacons_than_the_flight_build_holds(sources, tmp_path, capsys):
    from mfns.table.check import core

    n = core().max_beacons + 1
    beacons = tmp_path / "many.csv"
    beacons.write_text("id,x_mm,y_mm,z_mm,sigma_mm\n" + "".join(f"{i},{i},0,0,0.4\n" for i in range(n)))
    err = _run(["table", "build", sources[0], beacons, "-o", tmp_path / "t"], capsys)
    assert f"{n} beacons, the flight loader takes 1..{n - 1}" in err, err


@pytest.mark.usefixtures("need_core_lib")
@pytest.mark.parametrize(
    "settings,message",
    [
        ({"centroid": 5}, "centroid: expected a JSON object, got 5"),
        ([], "expected a JSON object"),
        (
            {"centroid": {"threshold_dn": True}},
            "centroid.threshold_dn: expected an integer, got true",
        ),  # was 1
        ({"centroid": {"threshold_dn": 2.0}}, "centroid.threshold_dn: expected an integer"),
        ({"centroid": {"threshold_dn": 70000}}, "outside 0..65535"),
        ({"solver": {"huber_k": "3"}}, "solver.huber_k: expected a number"),
        ({"solver": {"huber_k": 1e39}}, "solver.huber_k"),
        ({"solver": {"no_such": 1}}, "unknown key(s) 'no_such'"),
        ({"other": {}}, "unknown key(s) 'other'"),
    ],
)
def test_table_build_refuses_bad_settings(sources, tmp_path, capsys, settings, message):
    s = tmp_path / "s.json"
    s.write_text(json.dumps(settings))
    out = tmp_path / "t"
    err = _run(["table", "build", *sources, "-o", out, "--settings", s], capsys)
    assert message in err, err
    assert not out.exists()


@pytest.mark.usefixtures("need_core_lib")
def test_table_show_does_not_read_a_device_or_a_huge_file(tmp_path, capsys):
    """/dev/zero was read until the OOM killer stopped it (24 GB)."""
    err = _run(["table", "show", "/dev/zero"], capsys)
    assert "not a regular file" in err
    big = tmp_path / "big.mfnstbl"
    with open(big, "wb") as f:
        f.truncate(64 * 1024 * 1024)  # sparse: no disk used
    err = _run(["table", "show", big], capsys)
    assert "larger than the limit" in err
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    assert "not a regular file" in _run(["table", "show", fifo], capsys)
    assert "not found" in _run(["table", "show", tmp_path / "missing"], capsys)
    assert "not a regular file" in _run(["table", "show", tmp_path], capsys)


def test_calibration_json_from_a_device_is_refused(sources, tmp_path, capsys):
    assert "not a regular file" in _run(
        ["table", "build", "/dev/zero", sources[1], "-o", tmp_path / "t"], capsys
    )
    assert "not a regular file" in _run(["sim", "nav", tmp_path / "o", "--rig", "/dev/zero"], capsys)


@pytest.mark.parametrize(
    "nav,message",
    [
        ("", "missing columns"),
        ("t_s,status,roll_deg,pitch_deg,yaw_deg,x_mm,y_mm,z_mm\n0,FIX,0,0,0,0,0\n", "wrong number of fields"),
        ("t_s,status,roll_deg,pitch_deg,yaw_deg,x_mm,y_mm,z_mm\n0,FIX,0,0,0,0,0,inf\n", "not finite"),
        ("t_s,status,roll_deg,pitch_deg,yaw_deg,x_mm,y_mm,z_mm\n0,FIX,0,0,0,0,0,1e999\n", "not finite"),
        ("t_s,status,roll_deg,pitch_deg,yaw_deg,x_mm,y_mm,z_mm\n0,FIX,0,0,0,0,0,x\n", "not a number"),
    ],
)
def test_report_refuses_bad_nav_csv(tmp_path, capsys, nav, message):
    p = tmp_path / "nav.csv"
    p.write_text(nav)
    err = _run(["report", p, "--no-plots", "--out", tmp_path / "o"], capsys)
    assert message in err, err


def test_report_refuses_bad_truth_and_devices(tmp_path, capsys):
    nav = tmp_path / "nav.csv"
    nav.write_text("t_s,status,roll_deg,pitch_deg,yaw_deg,x_mm,y_mm,z_mm\n0,FIX,0,0,0,0,0,0\n")
    truth = tmp_path / "truth.csv"
    truth.write_text("frame,t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n")
    assert "no rows" in _run(["report", nav, "--truth", truth, "--no-plots"], capsys)
    assert "not a regular file" in _run(["report", nav, "--truth", "/dev/zero", "--no-plots"], capsys)
    assert "not a regular file" in _run(["report", "/dev/zero", "--no-plots", "--out", tmp_path], capsys)
    truth.write_text("frame,t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n0,nan,0,0,0,0,0,0\n")
    assert "not finite" in _run(["report", nav, "--truth", truth, "--no-plots"], capsys)


def test_report_time_tolerance_checked(tmp_path, capsys):
    nav = tmp_path / "nav.csv"
    nav.write_text("t_s,status,roll_deg,pitch_deg,yaw_deg,x_mm,y_mm,z_mm\n0,FIX,0,0,0,0,0,0\n")
    for bad in ("nan", "-1", "inf"):
        assert "--time-tolerance" in _run(["report", nav, "--no-plots", "--time-tolerance", bad], capsys)


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--trials", "5"], "--trials"),
        (["--z-min", "nan"], "--z-min"),
        (["--pose-trials", "-1"], "--pose-trials"),
        (["--seed", "-1"], "--seed"),
        (["--trials", "100000000000"], "--trials"),
    ],
)
def test_mc_refuses_bad_arguments(tmp_path, capsys, argv, message):
    assert message in _run(["mc", tmp_path / "o", "--quiet", *argv], capsys)


# --- issue 28 item 5: one reader and one set of checks per input format, every command ----
_EMISSION_HEAD = "id,x_mm,y_mm,z_mm,sigma_mm,axis_x,axis_y,axis_z,half_angle_deg\n"
_EMISSION_ROWS = ["2,100,0,0,0.4,0,0,1,60", "3,0,100,0,0.4,0,0,1,60", "4,0,0,100,0.4,0,0,1,60"]


@pytest.mark.parametrize(
    "row, message",
    [
        ("1,0,0,0,0.4,0,0,1,nan", "half_angle_deg: 'nan' is not finite"),
        ("1,0,0,0,0.4,0,0,0,60", "zero emission axis with half_angle_deg 60"),
    ],
)
def test_emission_columns_refused_alike_by_plan_and_table(
    tmp_path, capsys, sources, need_core_lib, row, message
):
    csv_path = tmp_path / "beacons.csv"
    csv_path.write_text(_EMISSION_HEAD + "\n".join([row, *_EMISSION_ROWS]) + "\n")
    errs = [
        _run(
            ["plan", "analyze", tmp_path / "p", "--beacons", csv_path, "--samples", 3, "--no-ident-margin"],
            capsys,
        ),
        _run(["table", "build", sources[0], csv_path, "-o", tmp_path / "t.tbl"], capsys),
    ]
    for err in errs:
        assert message in err, err
    assert errs[0].split("error: ", 1)[1] == errs[1].split("error: ", 1)[1]  # the same reader's words


def test_zero_axis_that_emits_everywhere_is_accepted(tmp_path):
    from mfns.model.camera import load_beacon_emission, load_beacons

    csv_path = tmp_path / "beacons.csv"
    csv_path.write_text(_EMISSION_HEAD + "\n".join(["1,0,0,0,0.4,0,0,0,180", *_EMISSION_ROWS]) + "\n")
    assert len(load_beacons(csv_path)[0]) == 4
    axes, half = load_beacon_emission(csv_path)
    assert half[0] == 180 and not axes[0].any()


@pytest.mark.parametrize("samples", ["1000000000", "0"])
def test_sample_counts_are_bounded(tmp_path, capsys, samples):
    err = _run(["plan", "analyze", tmp_path / "p", "--samples", samples, "--no-ident-margin"], capsys)
    assert "expected 1..100000 pose samples" in err
    assert not (tmp_path / "p").exists() or not any((tmp_path / "p").iterdir())


@pytest.mark.parametrize("fx", [1e300, 1e-30, 5.0])
def test_absurd_focal_length_is_one_line_without_numpy_warnings(tmp_path, capsys, sources, fx):
    import warnings

    doc = _calib(sources, _set("cameras.0.fx", fx))
    rig = tmp_path / "rig.json"
    rig.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy RuntimeWarning before the error fails here
        for argv in (
            ["table", "build", rig, sources[1], "-o", tmp_path / "t.tbl"],
            ["plan", "analyze", tmp_path / "p", "--rig", rig, "--samples", 3, "--no-ident-margin"],
        ):
            err = _run(argv, capsys)
            assert "camera x fx" in err and "field of view" in err, err
