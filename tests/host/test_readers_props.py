"""Property-based tests (Hypothesis) of the host tools' readers: random and mutated inputs
give either a valid result or the clear error (MfnsError, one line), never another
exception. Accepted results are checked too (types, finiteness), so a reader that lets a
bad value through fails as well as one that crashes."""

from __future__ import annotations

import copy
import json
import math
import struct
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mfns.analysis import calib_results, report
from mfns.core.errors import MfnsError
from mfns.model.camera import load_beacons
from mfns.table.settings import load_settings

PROFILE = settings(
    max_examples=150,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)

json_scalars = st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.text(max_size=8)
json_scalars |= st.floats(allow_nan=False, allow_infinity=False)
json_values = st.recursive(
    json_scalars,
    lambda kids: st.lists(kids, max_size=6) | st.dictionaries(st.text(max_size=6), kids, max_size=6),
    max_leaves=20,
)


def one_clear_line(exc: MfnsError) -> None:
    msg = str(exc)
    assert msg and "\n" not in msg and "Traceback" not in msg, msg


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("props")


@pytest.fixture(scope="module")
def calib_doc(repo_root):
    return json.loads((repo_root / "host_tools/mfns/data/paper_calib.json").read_text())


# ---- JSON mutations --------------------------------------------------------------------
def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, (*prefix, i))


def _mutate(doc, choice: int, value, delete: bool):
    doc = copy.deepcopy(doc)
    paths = list(_paths(doc))
    path = paths[choice % len(paths)]
    if not path:
        return value
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    if delete:
        del parent[path[-1]]
    else:
        parent[path[-1]] = value
    return doc


mutations = st.lists(st.tuples(st.integers(0, 10_000), json_values, st.booleans()), min_size=1, max_size=3)


def _assert_valid_calibration(doc) -> None:
    for cam in doc["cameras"]:
        w, h = cam["image_size"]
        assert type(w) is int and type(h) is int and w > 0 and h > 0
        for k in ("fx", "fy", "cx", "cy", "skew"):
            assert not isinstance(cam[k], bool) and math.isfinite(cam[k])
        assert cam["fx"] > 0 and cam["fy"] > 0
        for k, n in (("dist", 5), ("r_bk_b", 3)):
            assert len(cam[k]) == n and all(not isinstance(x, bool) and math.isfinite(x) for x in cam[k])
        assert np.asarray(cam["C_k_b"], dtype=float).shape == (3, 3)


@PROFILE
@given(muts=mutations)
def test_calibration_json_mutated(work, calib_doc, muts):
    doc = calib_doc
    for choice, value, delete in muts:
        doc = _mutate(doc, choice, value, delete)
    path = work / "calib.json"
    path.write_text(json.dumps(doc))
    try:
        out = calib_results.load(path)
    except MfnsError as exc:
        one_clear_line(exc)
        return
    _assert_valid_calibration(out)


@pytest.fixture(scope="module")
def calib_doc_cov(calib_doc):
    """The paper's rig with a covariance (docs/calib-results.md) agreeing with its sigma."""
    doc = copy.deepcopy(calib_doc)
    names, var = [], []
    for cam in doc["cameras"]:
        names += [f"{cam['name']}.{p}" for p in calib_results.COVARIANCE_PARAMETERS]
        var += [0.25] * 4 + [1e-6] * 5 + [1e-8] * 3 + [s**2 for s in cam["sigma"]["r_bk_b"]]
    m = np.diag(var)
    m[0, 1] = m[1, 0] = 0.1  # one correlation
    doc["covariance"] = {"parameters": names, "matrix": m.tolist()}
    calib_results.validate(doc)
    return doc


@PROFILE
@given(muts=mutations)
def test_calibration_json_with_covariance_mutated(work, calib_doc_cov, muts):
    doc = calib_doc_cov
    for choice, value, delete in muts:
        doc = _mutate(doc, choice, value, delete)
    path = work / "calib_cov.json"
    path.write_text(json.dumps(doc))
    try:
        out = calib_results.load(path)
    except MfnsError as exc:
        one_clear_line(exc)
        return
    _assert_valid_calibration(out)
    cov = calib_results.covariance(out)
    if cov is not None:
        names, m = cov
        assert m.shape == (len(names), len(names)) and np.all(np.isfinite(m))
        assert np.all(np.diag(m) >= 0.0) and np.allclose(m, m.T, rtol=0.0, atol=1e-6)


@PROFILE
@given(text=st.text(max_size=200) | st.binary(max_size=200).map(lambda b: b.decode("latin-1")))
def test_calibration_json_random_text(work, text):
    path = work / "calib_text.json"
    path.write_bytes(
        text.encode("utf-8", "surrogatepass") if text.isascii() else text.encode("latin-1", "replace")
    )
    with pytest.raises(MfnsError) as exc:
        calib_results.load(path)
    one_clear_line(exc.value)


@PROFILE
@given(doc=json_values, muts=mutations)
def test_settings_json(work, doc, muts):
    base = {"centroid": {"threshold_dn": 0, "min_area_px": 3}, "solver": {"huber_k": 3.0, "min_rcond": 1e-7}}
    for choice, value, delete in muts:
        base = _mutate(base, choice, value, delete)
    for candidate in (doc, base):
        path = work / "settings.json"
        path.write_text(json.dumps(candidate))
        try:
            centroid, solver = load_settings(path)
        except MfnsError as exc:
            one_clear_line(exc)
            continue
        for k, v in {**centroid, **solver}.items():
            assert not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v), (k, v)


@PROFILE
@given(doc=json_values, box=st.lists(json_scalars, min_size=0, max_size=8))
def test_workspace_json(work, doc, box):
    """`mfns table build --workspace FILE.json` (mapindex.workspace_arg): any JSON, or one
    whose table_workspace_mm is any list, gives a box of finite numbers with lo < hi or
    the one clear line."""
    from mfns.table.mapindex import workspace_arg

    for candidate in (doc, {"table_workspace_mm": box}):
        path = work / "plan.json"
        path.write_text(json.dumps(candidate))
        try:
            lo, hi = workspace_arg(str(path))
        except MfnsError as exc:
            one_clear_line(exc)
            continue
        assert lo.shape == hi.shape == (3,) and np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))
        assert np.all(lo < hi)


@PROFILE
@given(doc=json_values, muts=mutations)
def test_map_datum_json(work, doc, muts):
    """`mfns table build --map-datum` (mfns.map.datum_file.load): any JSON, or a good
    map_datum.json mutated, gives a 6 x 6 finite symmetric covariance, a finite centre and
    a positive finite sigma for exactly the map's beacons, or the one clear line (PSD is
    the flight loader's check, on the bytes the builder writes)."""
    from mfns.map import datum_file

    ids = np.array([0, 1, 5])
    good = work / "good_datum.json"
    datum_file.write(good, ids, [0.03, 0.04, 0.05], [10.0, -20.0, 30.0], np.diag([0.05**2] * 3 + [1e-9] * 3))
    base = json.loads(good.read_text())
    for choice, value, delete in muts:
        base = _mutate(base, choice, value, delete)
    for candidate in (doc, base):
        path = work / "map_datum.json"
        path.write_text(json.dumps(candidate))
        try:
            d, sig = datum_file.load(path, ids)
        except MfnsError as exc:
            one_clear_line(exc)
            continue
        assert d.cov.shape == (6, 6) and np.all(np.isfinite(d.cov)) and np.allclose(d.cov, d.cov.T)
        assert d.c_w_mm.shape == (3,) and np.all(np.isfinite(d.c_w_mm))
        assert sig.shape == (3,) and np.all(np.isfinite(sig)) and np.all(sig > 0)


# ---- CSV -------------------------------------------------------------------------------
csv_cells = st.sampled_from(
    ["1", "0", "-2", "3.7", "1e3", "nan", "inf", "", " ", "x", '"', "0.4", "65536", "\0"]
)
csv_cells |= st.text(alphabet='0123456789.-+eE,"\n\r x', max_size=6)


@st.composite
def beacon_csvs(draw):
    header = draw(
        st.sampled_from(["id,x_mm,y_mm,z_mm,sigma_mm", "id,x_mm,y_mm,z_mm", "x_mm,id,z_mm,y_mm,sigma_mm"])
    )
    rows = draw(st.lists(st.lists(csv_cells, min_size=3, max_size=7), max_size=8))
    good = draw(
        st.lists(st.tuples(st.integers(0, 70000), st.floats(-1e4, 1e4), st.floats(-1, 1)), max_size=5)
    )
    lines = [header] + [",".join(r) for r in rows] + [f"{i},{x},{x},{x},{s}" for i, x, s in good]
    draw(st.randoms()).shuffle(lines)
    return "\n".join(lines)


@PROFILE
@given(text=beacon_csvs())
def test_beacon_csv(work, text):
    path = work / "beacons.csv"
    path.write_text(text)
    try:
        ids, pos, sig = load_beacons(path)
    except MfnsError as exc:
        one_clear_line(exc)
        return
    assert len(ids) >= 1 and len(set(ids.tolist())) == len(ids)
    assert ids.dtype.kind == "i" and np.all((ids >= 0) & (ids <= 65535))
    assert pos.shape == (len(ids), 3) and np.all(np.isfinite(pos))
    assert np.all(np.isfinite(sig)) and np.all(sig > 0)


@st.composite
def nav_csvs(draw):
    cols = ["t_s", "status", "roll_deg", "pitch_deg", "yaw_deg", "x_mm", "y_mm", "z_mm"]
    if draw(st.booleans()):
        cols = draw(st.permutations(cols))
    if draw(st.integers(0, 9)) == 0:
        cols = cols[:-1]
    rows = draw(
        st.lists(st.lists(csv_cells | st.sampled_from(["FIX", "0.5"]), min_size=6, max_size=9), max_size=6)
    )
    return "\n".join([",".join(cols)] + [",".join(r) for r in rows])


@PROFILE
@given(text=nav_csvs())
def test_nav_and_truth_csv(work, text):
    path = work / "nav.csv"
    path.write_text(text)
    try:
        nav = report.load_nav(path)
    except MfnsError as exc:
        one_clear_line(exc)
    else:
        assert all(np.all(np.isfinite(v)) for v in [nav.t_s, *nav.values.values()])
    truth = work / "truth.csv"
    truth.write_text(text.replace("status", "frame", 1))
    try:
        t = report.load_truth(truth)
    except MfnsError as exc:
        one_clear_line(exc)
    else:
        assert len(t.t_s) > 0 and np.all(np.diff(t.t_s) >= 0)


@PROFILE
@given(text=st.text(alphabet='[]{}",:0123456789.-eEtruefalsnNI \\', max_size=300))
def test_parse_json_never_raises_anything_else(text):
    from mfns.core import validate as V

    try:
        V.parse_json(text, "doc")
    except MfnsError as exc:
        one_clear_line(exc)


# ---- the binary table (the flight loader through ctypes) -------------------------------
@pytest.fixture(scope="module")
def good_table(repo_root, core_lib):
    if not core_lib.exists():
        pytest.fail("make lib has not built the C core")
    from mfns.table.builder import build_table
    from mfns.table.format import encode

    d = repo_root / "host_tools/mfns/data"
    return encode(build_table(d / "paper_calib.json", d / "paper_beacons.csv")[0])


@st.composite
def table_mutations(draw, size: int):
    edits = draw(st.lists(st.tuples(st.integers(0, size + 8), st.integers(0, 255)), max_size=4))
    cut = draw(st.none() | st.integers(0, size + 16))
    tail = draw(st.binary(max_size=12))
    fix_crc = draw(st.booleans())
    small = draw(st.booleans())  # edits near the settings and camera headers, where the checks are
    return edits, cut, tail, fix_crc, small


@settings(
    max_examples=300,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_table_reader_mutated(good_table, data):
    from mfns.table.check import TableRefused, field_at, read_table

    edits, cut, tail, fix_crc, small = data.draw(table_mutations(len(good_table)))
    b = bytearray(good_table)
    for off, val in edits:
        off = off % 400 if small else off
        if off < len(b):
            b[off] = val
    if cut is not None:
        b = b[:cut]
    b += tail
    if fix_crc and len(b) >= 16:
        total = struct.unpack_from("<I", b, 8)[0]
        if 16 <= total <= len(b):
            b[12:16] = struct.pack("<I", zlib.crc32(bytes(b[16:total])))
    try:
        t = read_table(bytes(b))
    except TableRefused as exc:
        one_clear_line(exc)
        assert exc.status.code != 0 and field_at(bytes(b), exc.status.offset)
        return
    # accepted by the flight loader: the display parser reads every field
    assert len(t.cameras) == 3 and len(t.beacon_ids) >= 1
    assert all(np.all(np.isfinite(c.dist)) and c.grid.nx >= 2 for c in t.cameras)


@pytest.fixture(scope="module")
def good_table_obj(repo_root, core_lib):
    if not core_lib.exists():
        pytest.fail("make lib has not built the C core")
    from mfns.table.builder import build_table

    d = repo_root / "host_tools/mfns/data"
    return build_table(d / "paper_calib.json", d / "paper_beacons.csv")[0]


u16 = st.integers(0, 65535)
f32s = st.floats(allow_nan=False, allow_infinity=False, width=32) | st.sampled_from(
    [0.0, 0.999, 1.0, 1e-7, 100.0]
)


@settings(max_examples=200, deadline=None, database=None)
@given(data=st.data())
def test_settings_through_the_flight_loader(good_table_obj, data):
    """Any settings of the right types: the loader accepts the table or refuses it naming
    a settings field; what it accepts reads back as written (binary32)."""
    import dataclasses

    from mfns.table.check import TableRefused, read_table
    from mfns.table.format import CENTROID_F32, CENTROID_U16, SOLVER_F32, SOLVER_U16, encode
    from mfns.table.settings import load_settings

    centroid, solver = load_settings(None)  # the defaults
    for keys_, dst, strat in (
        (CENTROID_U16, centroid, u16),
        (CENTROID_F32, centroid, f32s),
        (SOLVER_U16, solver, u16),
        (SOLVER_F32, solver, f32s),
    ):
        for k in data.draw(st.lists(st.sampled_from(keys_), max_size=3)):
            dst[k] = data.draw(strat)
    raw = encode(dataclasses.replace(good_table_obj, centroid=centroid, solver=solver))
    try:
        t = read_table(raw)
    except TableRefused as exc:
        one_clear_line(exc)
        assert exc.field.startswith(("centroid.", "solver.")), exc.field
        return
    for k, v in {**centroid, **solver}.items():
        assert {**t.centroid, **t.solver}[k] == np.float32(v), k
