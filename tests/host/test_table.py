"""`mfns table build/show`, the table format's writer/reader, and the correction grid."""

from __future__ import annotations

import ctypes
import json
import struct
import zlib

import numpy as np
import pytest

from mfns.cli import main
from mfns.errors import MfnsError
from mfns.table.builder import build_table
from mfns.table.format import decode, encode, validate
from mfns.table.grid import build_grid, eval_grid, grid_error, record_camera
from mfns.table.settings import DEFAULT_CENTROID, DEFAULT_SOLVER


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
        assert (rec.grid.nx, rec.grid.ny) == (93, 75)
    assert list(t.beacon_ids) == list(range(10))
    assert t.beacon_pos[9, 2] == np.float32(562.5394)
    assert t.centroid == pytest.approx(DEFAULT_CENTROID)
    assert t.solver == pytest.approx(DEFAULT_SOLVER, rel=1e-6)
    # writer and reader are exact inverses
    assert encode(t) == data
    capsys.readouterr()
    assert main(["table", "show", str(built)]) == 0
    out = capsys.readouterr().out
    assert "(verified)" in out and "camera z (id 2)" in out
    assert "C_k_b Euler 2-1-3 (roll pitch yaw) deg: -0.1076 -0.7211 1.1690" in out
    assert "9    -122.5798    -44.9064    562.5394 mm  sigma 0.3963 mm" in out


def test_build_prints_grid_error(sources, tmp_path, capsys):
    out = tmp_path / "t.mfnstbl"
    assert main(["table", "build", str(sources[0]), str(sources[1]), "-o", str(out), "--grid", "41x33"]) == 0
    text = capsys.readouterr().out
    worst = float(text.strip().splitlines()[-1].split()[-2])
    assert "grid worst-case error" in text
    assert 0.01 < worst < 0.2  # a coarse grid: the measurement is real, not a constant
    assert decode(out.read_bytes()).cameras[0].grid.nx == 41


def test_default_table_from_the_build_matches(built, gen_dir):
    gen = gen_dir / "default.mfnstbl"
    if not gen.exists():
        pytest.skip("make gen has not built the default table")
    assert gen.read_bytes() == built.read_bytes()  # deterministic, and made from the committed sources


@pytest.mark.parametrize(
    "patch,message",
    [
        (lambda d: d[:100], "truncated"),
        (lambda d: d[:10], "truncated"),
        (lambda d: b"XFTB" + d[4:], "bad magic"),
        (lambda d: d[:4] + struct.pack("<H", 2) + d[6:], "newer than this reader"),
        (lambda d: d[:200] + bytes([d[200] ^ 1]) + d[201:], "CRC-32 mismatch"),
        (lambda d: d + b"\0\0\0\0", "trailing bytes"),
        (lambda d: _refix_crc(bytearray(d[:16] + struct.pack("<H", 2) + d[18:])), "camera count"),
        (lambda d: _refix_crc(bytearray(d[:84] + struct.pack("<f", -1.0) + d[88:])), "focal length"),
        (lambda d: _refix_crc(bytearray(d[:124] + struct.pack("<f", 0.5) + d[128:])), "not a rotation"),
        (
            lambda d: _refix_crc(bytearray(d[:200] + struct.pack("<i", 12345) + d[204:])),
            "disagrees with the lens",
        ),
    ],
)
def test_show_refuses_bad_tables(built, tmp_path, capsys, patch, message):
    bad = tmp_path / "bad.mfnstbl"
    bad.write_bytes(bytes(patch(built.read_bytes())))
    capsys.readouterr()
    assert main(["table", "show", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--grid", "93"], "expected NXxNY"),
        (["--grid", "200x100"], "MFNS_MAX_GRID_NODES"),
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
    assert "huber_k" in capsys.readouterr().err
    settings.write_text(json.dumps({"solver": {"no_such": 1}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 2
    settings.write_text(json.dumps({"centroid": {"min_area_px": 5}, "solver": {"max_iterations": 7}}))
    assert main(["table", "build", *map(str, sources), "-o", out, "--settings", str(settings)]) == 0
    t = decode((tmp_path / "t.mfnstbl").read_bytes())
    assert t.centroid["min_area_px"] == 5 and t.solver["max_iterations"] == 7


def test_grid_error_below_requirement_and_shrinks_with_spacing(sources):
    table, errors = build_table(*sources)
    assert all(e.max_px <= 0.01 for e in errors)
    cam = record_camera(table.cameras[1])
    coarse = grid_error(cam, build_grid(cam, 47, 38), sample_px=3.3).max_px
    fine = grid_error(cam, build_grid(cam, 93, 75), sample_px=3.3).max_px
    # bilinear error ~ h^2: halving the spacing divides it by ~4
    assert 3.0 < coarse / fine < 5.0


def test_validate_refuses_what_the_flight_loader_refuses(sources):
    table, _ = build_table(*sources)
    table.solver = dict(table.solver, min_rcond=1.5)
    with pytest.raises(MfnsError, match="min_rcond"):
        validate(decode(encode(table)))


def test_grid_emulation_is_bit_exact_with_c(sources, core_lib):
    """The Python evaluation (used for the printed worst-case error) is what the C core computes."""
    if not core_lib.exists():
        pytest.skip("make lib has not built the C core")
    lib = ctypes.CDLL(str(core_lib))

    class Grid(ctypes.Structure):
        _fields_ = [
            ("nx", ctypes.c_uint16),
            ("ny", ctypes.c_uint16),
            ("origin_u_q8", ctypes.c_int32),
            ("origin_v_q8", ctypes.c_int32),
            ("step_u_q8", ctypes.c_int32),
            ("step_v_q8", ctypes.c_int32),
            ("node", ctypes.POINTER(ctypes.c_int32)),
        ]

    table, _ = build_table(*sources)
    g = table.cameras[0].grid
    nodes = np.ascontiguousarray(g.nodes, dtype=np.int32)
    cg = Grid(g.nx, g.ny, g.origin_u_q8, g.origin_v_q8, g.step_u_q8, g.step_v_q8,
              nodes.ctypes.data_as(ctypes.POINTER(ctypes.c_int32)))  # fmt: skip
    f = lib.mfns_undistort_grid_px
    f.argtypes = [ctypes.POINTER(Grid), ctypes.c_int32, ctypes.c_int32]
    f.argtypes += [ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_int32)]
    f.restype = ctypes.c_int
    rng = np.random.default_rng(3)
    uq = rng.integers(-200, 1280 * 256, 500)
    vq = rng.integers(-200, 1024 * 256, 500)
    want, inside = eval_grid(g, uq, vq)
    a, b = ctypes.c_int32(), ctypes.c_int32()
    for k in range(len(uq)):
        st = f(ctypes.byref(cg), int(uq[k]), int(vq[k]), ctypes.byref(a), ctypes.byref(b))
        if inside[k]:
            assert st == 0 and (a.value, b.value) == tuple(want[k])
        else:
            assert st == 4  # MFNS_UNDIST_OUTSIDE
    assert (~inside).sum() > 0 and inside.sum() > 400


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
