"""`mfns table build/show`, the table format's writer/reader, and the correction grid."""

from __future__ import annotations

import ctypes
import json
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from mfns.cli import main
from mfns.core.binding import UndistGrid
from mfns.core.binding import load as load_core
from mfns.table.builder import build_table
from mfns.table.check import TableRefused, check_table, core
from mfns.table.format import VERSION, decode, encode
from mfns.table.grid import MAX_GRID_ERROR_PX, build_grid, grid_error, record_camera, size_grid
from mfns.table.settings import load_settings

pytestmark = pytest.mark.usefixtures("need_core_lib")


@pytest.fixture(scope="module")
def need_core_lib(core_lib):
    if not core_lib.exists():
        pytest.fail("make lib has not built the C core: tables are checked by the flight loader")


@pytest.fixture(scope="module")
def sources(repo_root):
    d = repo_root / "host_tools/mfns/data"
    return d / "paper_calib.json", d / "paper_beacons.csv"


@pytest.fixture(scope="module")
def built(tmp_path_factory, sources):
    out = tmp_path_factory.mktemp("table") / "t.mfnstbl"
    assert main(["table", "build", str(sources[0]), str(sources[1]), "-o", str(out)]) == 0
    return out


def _refix_crc(data: bytearray) -> bytearray:
    data[12:16] = struct.pack("<I", zlib.crc32(bytes(data[16:])))
    return data


def test_build_then_show_round_trip(built, sources, capsys):
    data = built.read_bytes()
    t = decode(data)
    doc = json.loads(sources[0].read_text())
    assert t.size_bytes == len(data)
    for rec, cam in zip(t.cameras, doc["cameras"], strict=True):
        assert rec.fx == np.float32(cam["fx"])
        assert rec.cy == np.float32(cam["cy"])
        np.testing.assert_array_equal(rec.dist, np.float32(cam["dist"]))
        np.testing.assert_array_equal(rec.C_k_b, np.float32(cam["C_k_b"]))
        np.testing.assert_array_equal(rec.r_bk_b, np.float32(cam["r_bk_b"]))
        # sized for the lens: the coarsest grid within the requirement
        assert 2 < rec.grid.nx * rec.grid.ny <= core().max_grid_nodes
    assert list(t.beacon_ids) == list(range(10))
    assert t.beacon_pos[9, 2] == np.float32(562.5394)
    default_centroid, default_solver = load_settings(None)
    assert t.centroid == pytest.approx(default_centroid)
    assert t.solver == pytest.approx(default_solver, rel=1e-6)
    # writer and reader are exact inverses
    assert encode(t) == data
    capsys.readouterr()
    assert main(["table", "show", str(built)]) == 0
    out = capsys.readouterr().out
    assert "(verified by the flight loader: calibration table ok)" in out and "camera z (id 2)" in out
    assert "C_k_b Euler 2-1-3 (roll pitch yaw) deg: -0.1076 -0.7211 1.1690" in out
    assert "9    -122.5798    -44.9064    562.5394 mm  sigma 0.3963 mm" in out


def test_build_prints_grid_error(sources, tmp_path, capsys):
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(sources[0]), str(sources[1]), "-o", str(out), "--grid", "101x81"]) == 0
    text = capsys.readouterr().out
    line = [x for x in text.splitlines() if x.startswith("grid worst-case error: ")]
    assert len(line) == 1, text
    worst = float(line[0].split()[-2])
    assert 0.003 < worst < MAX_GRID_ERROR_PX  # a dense grid: the measurement is real, not a constant
    assert decode(out.read_bytes()).cameras[0].grid.nx == 101
    # no --workspace: the builder says the default box is one and what a robot's own buys
    assert "the workspace is the default" in text and "give --workspace" in text


def test_build_refuses_a_grid_too_coarse_with_the_figure(sources, tmp_path, capsys):
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(sources[0]), str(sources[1]), "-o", str(out), "--grid", "41x33"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "grid 41x33 leaves 0.03" in err and "above 0.01 px" in err, err
    assert not out.exists()


def test_default_table_from_the_build_matches(built, gen_dir):
    gen = gen_dir / "default.mfnstbl"
    if not gen.exists():
        pytest.skip("make gen has not built the default table")
    assert gen.read_bytes() == built.read_bytes()  # deterministic, and made from the committed sources


@pytest.mark.parametrize(
    "patch,code,field",
    [
        (lambda d: d[:100], 2, "the end of the 100 bytes"),
        (lambda d: d[:10], 2, "the end of the 10 bytes"),
        (lambda d: b"XFTB" + d[4:], 3, "header magic"),
        (lambda d: d[:4] + struct.pack("<H", VERSION + 1) + d[6:], 4, "header version"),
        (lambda d: d[:200] + bytes([d[200] ^ 1]) + d[201:], 8, "header crc32"),
        (lambda d: _refix_crc(bytearray(d[:16] + struct.pack("<H", 2) + d[18:])), 9, "camera_count"),
        (lambda d: _refix_crc(bytearray(d[:84] + struct.pack("<f", -1.0) + d[88:])), 18, "camera x fx"),
        (lambda d: _refix_crc(bytearray(d[:124] + struct.pack("<f", 0.5) + d[128:])), 21, "camera x C_k_b"),
        # the camera record's reserved field: refused by the flight loader, accepted by the old reader
        (lambda d: _refix_crc(bytearray(d[:82] + struct.pack("<H", 1) + d[84:])), 11, "camera x reserved"),
        (
            lambda d: _refix_crc(bytearray(d[:200] + struct.pack("<i", 12345) + d[204:])),
            26,
            "camera x grid node (i=1, j=0)",
        ),
    ],
)
def test_show_reports_the_flight_loaders_verdict(built, tmp_path, capsys, patch, code, field):
    bad = tmp_path / "bad.mfnstbl"
    data = bytes(patch(built.read_bytes()))
    bad.write_bytes(data)
    capsys.readouterr()
    assert main(["table", "show", str(bad)]) == 2
    err = capsys.readouterr().err
    st = core().load(data)
    assert st.code == code
    assert err.count("\n") == 1 and f"(status {code}, byte offset {st.offset}: " in err and field in err, err
    assert st.message in err


def test_show_and_flight_loader_agree_on_trailing_bytes(built, tmp_path, capsys):
    """The flight program loads a file with bytes after total_size (mfns_caltable_load_file):
    `mfns table show` says so instead of refusing what the navigation computer uses."""
    longer = tmp_path / "longer.mfnstbl"
    longer.write_bytes(built.read_bytes() + b"\0\0\0\0")
    assert core().load(longer.read_bytes()).ok
    capsys.readouterr()
    assert main(["table", "show", str(longer)]) == 0
    assert "4 bytes after the table's total size (ignored by the loader)" in capsys.readouterr().out


def test_build_accepts_every_value_the_flight_loader_accepts(sources, tmp_path, capsys):
    """min_rcond = 0.999 is the loader's upper bound (binary32 0.999): the builder used to
    refuse its own output."""
    settings = tmp_path / "s.json"
    settings.write_text(json.dumps({"solver": {"min_rcond": 0.999}}))
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", *map(str, sources), "-o", str(out), "--settings", str(settings)]) == 0
    assert decode(out.read_bytes()).solver["min_rcond"] == pytest.approx(0.999)
    assert main(["table", "show", str(out)]) == 0


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--grid", "93"], "expected NXxNY"),
        (["--grid", "200x100"], "MFNS_MAX_GRID_NODES"),
        (["--grid", "99999999x2"], "expected NXxNY"),
        (["--grid", "3x3"], "outside 1..255 px"),
    ],
)
def test_build_cli_errors(sources, tmp_path, capsys, extra, message):
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(sources[0]), str(sources[1]), "-o", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not out.exists()


def test_build_input_errors(sources, tmp_path, capsys):
    out = str(tmp_path / "t.mfnstbl")
    assert main(["table", "build", str(tmp_path / "missing.json"), str(sources[1]), "-o", out]) == 2
    dup = tmp_path / "dup.csv"
    dup.write_text("id,x_mm,y_mm,z_mm,sigma_mm\n1,0,0,0,0.4\n1,1,1,1,0.4\n")
    assert main(["table", "build", str(sources[0]), str(dup), "-o", out]) == 2
    assert "duplicate beacon ids" in capsys.readouterr().err
    settings = tmp_path / "s.json"
    settings.write_text(json.dumps({"solver": {"huber_k": 0.0}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 2
    err = capsys.readouterr().err  # the flight loader's verdict on the table, with the field named
    assert "solver setting out of range" in err and "solver.huber_k" in err and "nothing written" in err, err
    settings.write_text(json.dumps({"solver": {"no_such": 1}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 2
    settings.write_text(json.dumps({"centroid": {"min_area_px": 5}, "solver": {"max_iterations": 7}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 0
    t = decode((tmp_path / "t.mfnstbl").read_bytes())
    assert t.centroid["min_area_px"] == 5 and t.solver["max_iterations"] == 7
    # the integrity settings (docs/caltable.md "Integrity settings")
    settings.write_text(json.dumps({"integrity": {"alert_limit_pos_mm": 50, "require_camera_monitor": 1}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 0
    t = decode((tmp_path / "t.mfnstbl").read_bytes())
    assert t.integrity["alert_limit_pos_mm"] == 50 and t.integrity["require_camera_monitor"] == 1
    assert t.integrity["p_fa"] == pytest.approx(1e-5) and t.integrity["hold_cycles"] == 19
    settings.write_text(json.dumps({"integrity": {"p_fa": 0.7}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 2
    err = capsys.readouterr().err
    assert "integrity settings out of range" in err and "integrity.p_fa" in err, err
    # the motion bound (docs/caltable.md "Motion bound"): defaults unless given, written
    # as given, shown, and refused by the flight loader with the field named
    t = decode((tmp_path / "t.mfnstbl").read_bytes())
    assert t.version == 6 and t.motion["accel_bound_mm_s2"] == 100.0 and t.motion["gate_reject_run"] == 3
    settings.write_text(
        json.dumps({"motion": {"accel_bound_mm_s2": 60, "bound_time_s": 0.5, "max_coast_s": 0.4}})
    )
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 0
    t = decode((tmp_path / "t.mfnstbl").read_bytes())
    assert t.motion["accel_bound_mm_s2"] == 60 and t.motion["max_coast_s"] == pytest.approx(0.4)
    assert t.motion["alpha_bound_rad_s2"] == 0.25 and t.integrity["p_fa"] == pytest.approx(1e-5)
    capsys.readouterr()
    assert main(["table", "show", out]) == 0
    assert "motion: accel_bound_mm_s2=60" in capsys.readouterr().out
    settings.write_text(json.dumps({"motion": {"max_coast_s": 0.3}}))  # beyond bound_time_s 0.2
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 2
    err = capsys.readouterr().err
    assert "motion bound out of range" in err and "motion.max_coast_s" in err, err
    settings.write_text(json.dumps({"motion": {"gate_reject_run": 1.5}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 2
    settings.write_text(json.dumps({"motion": {"no_such": 1}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 2


def test_grid_error_below_requirement_and_shrinks_with_spacing(sources):
    table, errors = build_table(*sources)[:2]
    assert all(e.max_px <= MAX_GRID_ERROR_PX for e in errors)
    cam = record_camera(table.cameras[1])
    coarse = grid_error(cam, build_grid(cam, 47, 38), sample_px=3.3).max_px
    fine = grid_error(cam, build_grid(cam, 93, 75), sample_px=3.3).max_px
    # bilinear error ~ h^2: halving the spacing divides it by ~4
    assert 3.0 < coarse / fine < 5.0


def _lens(sources, k: int, dist) -> object:
    from mfns.table.builder import _record

    doc = json.loads(sources[0].read_text())
    e = dict(doc["cameras"][k], dist=list(dist))
    return record_camera(_record(k, e))


def test_grid_sized_for_the_lens(sources):
    """A weaker lens gets a coarser grid, a stronger one a denser grid, each the coarsest
    within the requirement (the next coarser candidate misses it)."""
    weak = _lens(sources, 2, [-0.05, 0.0, 0.0, 0.0, 0.0])
    paper = _lens(sources, 1, json.loads(sources[0].read_text())["cameras"][1]["dist"])
    gw, ew = size_grid(weak, core().max_grid_nodes)
    gp, ep = size_grid(paper, core().max_grid_nodes)
    assert ew.max_px <= MAX_GRID_ERROR_PX and ep.max_px <= MAX_GRID_ERROR_PX
    assert gw.nx * gw.ny < gp.nx * gp.ny <= core().max_grid_nodes
    coarser = build_grid(paper, gp.nx - 1, round((gp.nx - 2) * 1024 / 1280) + 1)
    assert grid_error(paper, coarser).max_px > MAX_GRID_ERROR_PX


def test_builder_sizes_the_grid_of_a_strong_lens(sources, tmp_path, capsys):
    """k1 = -0.21 (a stronger lens than the paper's): 0.02 px from the old fixed 93 x 75
    grid; the builder picks the density it needs (15,429 nodes, within the loader's
    16,384) and keeps it within 0.01 px."""
    doc = json.loads(sources[0].read_text())
    doc["cameras"][1]["dist"][0] = -0.21
    calib = tmp_path / "strong.json"
    calib.write_text(json.dumps(doc))
    out = tmp_path / "t.mfnstbl"
    assert (
        main(["table", "build", str(calib), str(sources[1]), "-o", str(out), "--certify-samples", "5"]) == 0
    )
    text = capsys.readouterr().out
    line = next(x for x in text.splitlines() if x.startswith("camera y: grid"))
    nx, ny = (int(v) for v in line.split()[3].split("x"))
    assert 93 * 75 < nx * ny <= core().max_grid_nodes
    assert float(line.split("worst-case error ")[1].split()[0]) <= MAX_GRID_ERROR_PX


def test_builder_refuses_a_lens_it_cannot_correct_with_the_figure(sources, tmp_path, capsys):
    """k1 = -0.35: beyond what the loader's node limit can correct to 0.01 px: refused
    with the figure, nothing written."""
    doc = json.loads(sources[0].read_text())
    doc["cameras"][1]["dist"][0] = -0.35
    calib = tmp_path / "strong.json"
    calib.write_text(json.dumps(doc))
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(calib), str(sources[1]), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "camera y: the lens cannot be corrected to 0.01 px" in err, err
    worst = float(err.split(" leaves ")[1].split()[0])
    assert worst > 0.01
    assert not out.exists()


def test_grid_error_is_measured_with_the_c_interpolation(sources, core_lib):
    """grid_error evaluates with mfns_undistort_grid_px itself: one call per point through
    ctypes agrees with the batch evaluation bit for bit, and points outside are refused."""
    lib = load_core(core_lib)
    table = build_table(*sources)[0]
    g = table.cameras[0].grid
    nodes = np.ascontiguousarray(g.nodes, dtype=np.int32)
    cg = UndistGrid(g.nx, g.ny, g.origin_u_q8, g.origin_v_q8, g.step_u_q8, g.step_v_q8,
              nodes.ctypes.data_as(ctypes.POINTER(ctypes.c_int32 * 2)))  # fmt: skip
    f = lib.mfns_undistort_grid_px
    rng = np.random.default_rng(3)
    uq = rng.integers(-3000, 1300 * 256, 500)
    vq = rng.integers(-3000, 1040 * 256, 500)
    got, inside = core().eval_grid(g, uq, vq)
    a, b = ctypes.c_int32(), ctypes.c_int32()
    for k in range(len(uq)):
        st = f(ctypes.byref(cg), int(uq[k]), int(vq[k]), ctypes.byref(a), ctypes.byref(b))
        assert (st == 0) == bool(inside[k])
        if st == 0:
            assert (a.value, b.value) == tuple(got[k])
        else:
            assert st == 4  # MFNS_UNDIST_OUTSIDE
    assert (~inside).sum() > 0 and inside.sum() > 400


def test_build_checks_its_output_with_the_flight_loader(sources, tmp_path, capsys, monkeypatch):
    """A table the loader would refuse is never written (the builder's own bytes are loaded)."""
    import mfns.table.format as fmt

    real = fmt.encode
    monkeypatch.setattr(
        "mfns.commands.table.encode",
        lambda t: bytes(_refix_crc(bytearray(real(t)[:82] + b"\1\0" + real(t)[84:]))),
    )
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", *map(str, sources), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "refused by the flight loader" in err and "camera x reserved" in err and "nothing written" in err
    assert not out.exists()
    with pytest.raises(TableRefused):
        check_table(b"MFTB")


def test_pixel_sigma_override(tmp_path, repo_root):
    from mfns.cli import main
    from mfns.table.format import decode

    data = repo_root / "host_tools/mfns/data"
    out = tmp_path / "t.mfnstbl"
    assert (
        main(
            [
                "table",
                "build",
                str(data / "paper_calib.json"),
                str(data / "paper_beacons.csv"),
                "-o",
                str(out),
                "--pixel-sigma",
                "0.75",
            ]
        )
        == 0
    )
    assert abs(decode(out.read_bytes()).pixel_sigma_px - 0.75) < 1e-6
    assert (
        main(
            [
                "table",
                "build",
                str(data / "paper_calib.json"),
                str(data / "paper_beacons.csv"),
                "-o",
                str(out),
                "--pixel-sigma",
                "-1",
            ]
        )
        == 2
    )


def _calib_with_cov(src, tmp_path, names, matrix):
    doc = json.loads(src.read_text())
    for cam in doc["cameras"]:
        cam.pop("sigma", None)  # the reader holds sigma to the covariance's diagonal
    doc["covariance"] = {"parameters": names, "matrix": np.asarray(matrix).tolist()}
    p = tmp_path / "calib_cov.json"
    p.write_text(json.dumps(doc))
    return p


def _cov_names_and_matrix(seed=3):
    """A covariance over every camera's 15 parameters in a shuffled camera order (z, x, y) plus
    one the table does not carry (x.skew), correlated, positive definite."""
    from mfns.table.format import CALIB_PARAM_NAMES

    names = [f"{c}.{p}" for c in ("z", "x", "y") for p in CALIB_PARAM_NAMES] + ["x.skew"]
    rng = np.random.default_rng(seed)
    per = [1.0, 1.0, 0.5, 0.5, 1e-3, 1e-3, 1e-4, 1e-4, 1e-3, 3e-4, 3e-4, 3e-4, 0.3, 0.3, 0.3]
    sd = np.array(per * 3 + [0.1])
    b = rng.uniform(-0.5, 0.5, (len(names), 3)) * sd[:, None]
    return names, b @ b.T + np.diag(0.5 * sd**2)


def test_a_covariance_lacking_a_carried_parameter_is_refused_as_docs_caltable_says(sources, tmp_path, capsys):
    """docs/caltable.md "Calibration covariance": a parameter the table carries but the JSON
    does not list is refused (it once said "zero variance", which the builder never did)."""
    names, m = _cov_names_and_matrix()
    drop = names.index("y.k3")
    keep = [i for i in range(len(names)) if i != drop]
    calib = _calib_with_cov(sources[0], tmp_path, [names[i] for i in keep], m[np.ix_(keep, keep)])
    assert main(["table", "build", str(calib), str(sources[1]), "-o", str(tmp_path / "t.mfnstbl"), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith("covariance parameters: missing y.k3"), err
    doc = (Path(__file__).resolve().parents[2] / "docs" / "caltable.md").read_text()
    assert '("covariance parameters: missing y.k3"' in doc


def test_build_carries_the_calibration_covariance(sources, tmp_path, capsys):
    from mfns.table.format import CALIB_PARAM_NAMES, CALIB_PARAMS

    names, m = _cov_names_and_matrix()
    calib = _calib_with_cov(sources[0], tmp_path, names, m)
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(calib), str(sources[1]), "-o", str(out), "-q"]) == 0
    err = capsys.readouterr().err
    assert "x.skew" in err and "marginalised out" in err  # dropped: its marginal is the rest
    data = out.read_bytes()
    assert check_table(data).ok
    t = decode(data)
    assert t.version == VERSION == 6 and t.calib_cov.shape == (CALIB_PARAMS, CALIB_PARAMS)
    slot = {
        f"{c}.{p}": k * len(CALIB_PARAM_NAMES) + i
        for k, c in enumerate("xyz")
        for i, p in enumerate(CALIB_PARAM_NAMES)
    }
    for a, na in enumerate(names[:-1]):
        for b, nb in enumerate(names[:-1]):
            assert t.calib_cov[slot[na], slot[nb]] == np.float32(m[a, b])
    assert t.calib_cov[slot["y.fx"], slot["z.r_z"]] != 0.0  # cross-camera correlations kept
    assert encode(t) == data
    # the size grows by the section: 4 + 4 * 45 * 46 / 2 bytes over a table without it
    plain = tmp_path / "plain.mfnstbl"
    assert main(["table", "build", *map(str, sources), "-o", str(plain), "-q"]) == 0
    assert len(data) - plain.stat().st_size == 4 * CALIB_PARAMS * (CALIB_PARAMS + 1) // 2
    capsys.readouterr()
    assert main(["table", "show", str(out)]) == 0
    text = capsys.readouterr().out
    assert "calibration covariance: 45 parameters" in text
    assert f"x: fx {np.sqrt(np.float32(m[15, 15])):.3g}" in text
    assert main(["table", "show", str(plain)]) == 0
    assert "calibration covariance: none (unknown: no calibration term" in capsys.readouterr().out


def test_build_refuses_an_indefinite_covariance(sources, tmp_path, capsys):
    names, m = _cov_names_and_matrix()
    m[0, 1] = m[1, 0] = 1.5 * np.sqrt(m[0, 0] * m[1, 1])  # correlation above 1: not PSD
    calib = _calib_with_cov(sources[0], tmp_path, names, m)
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(calib), str(sources[1]), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not positive semi-definite" in err, err
    assert not out.exists()


def test_build_covariance_input_errors(sources, tmp_path, capsys):
    """The document's covariance is checked by its reader (mfns.analysis.calib_results): one line."""
    names, m = _cov_names_and_matrix()
    calib = _calib_with_cov(sources[0], tmp_path, names[:-2], m[:-2, :-2])  # y.r_z missing
    assert main(["table", "build", str(calib), str(sources[1]), "-o", str(tmp_path / "t"), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "covariance parameters: missing y.r_z" in err, err


def test_show_names_the_covariance_element_refused(sources, tmp_path, capsys):
    names, m = _cov_names_and_matrix()
    calib = _calib_with_cov(sources[0], tmp_path, names, m)
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(calib), str(sources[1]), "-o", str(out), "-q"]) == 0
    data = bytearray(out.read_bytes())
    t = decode(bytes(data))
    # the section starts after the beacon records; element (x.fx, x.fx) is its first float
    at = 16 + 60 + sum(116 + 8 * c.grid.nx * c.grid.ny for c in t.cameras) + 20 * len(t.beacon_ids)
    assert struct.unpack_from("<H", data, at)[0] == 45
    data[at + 4 : at + 8] = struct.pack("<f", -1.0)
    bad = tmp_path / "bad.mfnstbl"
    bad.write_bytes(bytes(_refix_crc(data)))
    capsys.readouterr()
    assert main(["table", "show", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"byte offset {at + 4}: calibration covariance (x.fx, x.fx))" in err, err
    data[at : at + 2] = struct.pack("<H", 7)
    bad.write_bytes(bytes(_refix_crc(data)))
    assert main(["table", "show", str(bad)]) == 2
    assert f"byte offset {at}: calibration covariance parameter count)" in capsys.readouterr().err


def _datum_doc(sources, tmp_path, cov=None, drop=0):
    """A map_datum.json for the paper's beacons (relative sigma 0.02 mm + 0.001 * index)."""
    from mfns.map import datum_file
    from mfns.model.camera import load_beacons

    ids, pos, _ = load_beacons(sources[1])
    if cov is None:
        sd = np.array([0.05, 0.06, 0.04, 5e-5, 4e-5, 6e-5])
        cov = np.diag(sd**2)
        cov[0, 5] = cov[5, 0] = 0.5 * sd[0] * sd[5]
    rel = 0.02 + 0.001 * np.arange(len(ids))
    path = tmp_path / "map_datum.json"
    datum_file.write(path, ids[drop:], rel[drop:], pos.mean(axis=0), cov, source="test")
    return path, ids, rel, pos.mean(axis=0), cov


def test_build_carries_the_map_datum(sources, tmp_path, capsys):
    """--map-datum: the table's beacons carry the relative sigmas and its map datum section
    the shared 6 x 6 (docs/caltable.md "Map datum covariance"), written and read as the flight
    loader reads it; without it the section is empty and the CSV's sigma stands."""
    from mfns.table.format import MAP_DATUM_PARAMS

    path, ids, rel, centre, cov = _datum_doc(sources, tmp_path)
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", *map(str, sources), "-o", str(out), "--map-datum", str(path), "-q"]) == 0
    data = out.read_bytes()
    assert check_table(data).ok
    t = decode(data)
    assert t.version == VERSION == 6
    np.testing.assert_array_equal(t.beacon_ids, ids)
    np.testing.assert_array_equal(t.beacon_sigma, np.round(rel, 4).astype(np.float32))
    np.testing.assert_array_equal(t.map_datum.c_w_mm, np.round(centre, 4).astype(np.float32))
    np.testing.assert_array_equal(t.map_datum.cov, np.asarray(cov, dtype=np.float32))
    assert encode(t) == data
    plain = tmp_path / "plain.mfnstbl"
    assert main(["table", "build", *map(str, sources), "-o", str(plain), "-q"]) == 0
    assert len(data) - plain.stat().st_size == 4 * MAP_DATUM_PARAMS * (MAP_DATUM_PARAMS + 1) // 2
    assert decode(plain.read_bytes()).map_datum is None
    capsys.readouterr()
    assert main(["table", "show", str(out)]) == 0
    text = capsys.readouterr().out
    assert "map datum: shift 1-sigma 0.05 0.06 0.04 mm" in text, text
    assert main(["table", "show", str(plain)]) == 0
    assert "map datum: none" in capsys.readouterr().out


def test_build_refuses_a_bad_map_datum(sources, tmp_path, capsys):
    """An indefinite datum is the flight loader's refusal (nothing written); a file that
    names other beacons than the map, or is malformed, is refused in one line."""
    import json

    cov = np.diag([0.05**2, 0.05**2, 0.05**2, 1e-9, 1e-9, 1e-9])
    cov[0, 1] = cov[1, 0] = 1.2 * 0.05**2  # correlation above 1
    path, *_ = _datum_doc(sources, tmp_path, cov=cov)
    out = tmp_path / "t.mfnstbl"
    args = ["table", "build", *map(str, sources), "-o", str(out), "-q", "--map-datum", str(path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and "map datum: covariance not positive semi-definite" in err, err
    assert not out.exists()
    path, *_ = _datum_doc(sources, tmp_path, drop=1)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and "not the map's datum: it lacks beacons 0" in err, err
    doc = json.loads(_datum_doc(sources, tmp_path)[0].read_text())
    for key, value, message in [
        ("cov", [[0.0] * 6] * 5, "cov: expected a list of 6"),
        ("c_w_mm", [0.0, 2e7, 0.0], "c_w_mm: a coordinate beyond"),
        ("format", "other", "format 'other'"),
        ("sigma_relative_mm", {**doc["sigma_relative_mm"], "1": 0.0}, "sigma_relative_mm[1]: 0 below (0"),
    ]:
        path.write_text(json.dumps({**doc, key: value}))
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.count("error:") == 1 and message in err, (message, err)
    assert not out.exists()


def test_version_2_tables_are_refused_as_old(built):
    data = built.read_bytes()
    old = data[:4] + struct.pack("<H", 2) + data[6:]
    st = core().load(old)
    assert not st.ok and st.offset == 4 and "rebuild it with mfns table build" in st.message


# ---- the one definition (contract/caltable_layout.toml) and what is generated from it


def _generator(repo_root):
    import importlib.util

    spec = importlib.util.spec_from_file_location("gen_caltable", repo_root / "contract" / "gen_caltable.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_generated_files_are_fresh(repo_root):
    """What `make` checks: every file generated from the definition matches it."""
    import subprocess
    import sys

    r = subprocess.run(
        [sys.executable, "contract/gen_caltable.py", "--check"], cwd=repo_root, capture_output=True
    )
    assert r.returncode == 0, r.stderr.decode()


def test_generator_refuses_an_inconsistent_definition(repo_root):
    import tomllib

    gen = _generator(repo_root)
    doc = tomllib.loads((repo_root / gen.SRC).read_text())
    doc["record"]["beacon"]["size"] = 24  # the fields fill 20 bytes
    with pytest.raises(gen.LayoutError, match="record beacon: fields sum to 20 bytes"):
        gen.Layout(doc)
    doc = tomllib.loads((repo_root / gen.SRC).read_text())
    doc["status"][3]["value"] = 7  # codes are explicit and contiguous
    with pytest.raises(gen.LayoutError, match="explicit and contiguous"):
        gen.Layout(doc)
    doc = tomllib.loads((repo_root / gen.SRC).read_text())
    doc["record"]["globals"]["field"][2]["default"] = 11.0  # pixel sigma's range is (0, 10]
    with pytest.raises(gen.LayoutError, match="outside its range"):
        gen.Layout(doc)


def test_c_and_python_share_the_generated_defaults_and_statuses():
    """The C core's defaults (nav_defaults_gen.c) and messages (caltable_layout_gen.c), through
    the shared library, are the builder's (layout_gen.py): both generated from one definition."""
    from mfns.core.flight import Flight
    from mfns.table.generated import layout_gen
    from mfns.table.settings import defaults

    assert Flight().default_settings() == defaults()
    lib = core().lib
    for code, (_, message) in layout_gen.STATUS.items():
        assert lib.mfns_caltable_strerror(code).decode() == message


def test_a_map_datum_that_leaves_no_usable_fix_is_warned_about():
    """Issue 45: the flight adds the datum to the fault-free covariance of every protection
    level, so a datum whose sigma times K_ff (= Q^-1(P_md / 2), 3.29 at the default P_md 1e-3)
    exceeds an alert limit leaves no usable fix: the build says so (the table is still built:
    a bench may want it)."""
    import numpy as np

    from mfns.table.builder import datum_unusable
    from mfns.table.format import MapDatum

    pos = np.array([[0.0, 0, 0], [1000, 0, 0], [0, 1000, 0]])
    tight = MapDatum(np.zeros(3), np.diag([1.0, 1, 1, 1e-8, 1e-8, 1e-8]))
    assert datum_unusable(tight, None, pos) == []
    # 7 mm: below the 20 mm limit itself, but 3.29 x 7 = 23 mm of PL floor: warned
    wide = MapDatum(np.zeros(3), np.diag([7.0**2, 1, 1, 1e-8, 1e-8, 1e-8]))
    lines = datum_unusable(wide, None, pos)
    assert len(lines) == 1 and "world x" in lines[0] and "20 mm" in lines[0], lines
    assert "K_ff 3.29" in lines[0], lines
    assert datum_unusable(wide, {"alert_limit_pos_mm": 30.0}, pos) == []  # the table's own limit counts
    assert datum_unusable(MapDatum(np.zeros(3), np.diag([5.0**2, 1, 1, 1e-8, 1e-8, 1e-8])), None, pos) == []
    turn = MapDatum(np.zeros(3), np.diag([1.0, 1, 1, 1e-8, 1e-8, np.radians(0.4) ** 2]))
    lines = datum_unusable(turn, None, pos)
    assert len(lines) == 1 and "about z" in lines[0] and "1 deg" in lines[0]
