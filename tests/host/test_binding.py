"""The one binding of the C core (mfns.core.binding): held to the headers field by field by the
generated binding_check_gen.c, which `make lib` compiles (mk/binding.mk). Here: the
committed file is current, it compiles, and a copy of the declarations with two fields of
one size swapped (or one field of the right size but the wrong type, or a function
declared with an argument too few or of another type) does not."""

from __future__ import annotations

import ctypes as ct
import importlib.util
import shutil
import subprocess
import sys

import pytest

from mfns.core import binding, binding_check
from mfns.core.errors import MfnsError

REPO = binding.REPO
CFLAGS = ["-std=c11", "-Wall", "-Wextra", "-Werror", "-Wconversion", "-fsyntax-only"]


def _include_dirs() -> list[str]:
    """The build's include roots: every header is named from the repository root
    (binding.py's `_c_` and PROTOTYPE_HEADERS), so -I. and the generated version header's
    folder are all a compile needs."""
    assert all((REPO / cls._c_[0]).is_file() for cls in binding.STRUCTS)
    assert all((REPO / h).is_file() for h in binding.PROTOTYPE_HEADERS)
    return ["-I.", f"-I{REPO / 'build' / 'gen'}"]


def _compile(text: str, tmp_path) -> subprocess.CompletedProcess:
    src = tmp_path / "check.c"
    src.write_text(text)
    return subprocess.run(
        ["gcc", *CFLAGS, *_include_dirs(), str(src)], cwd=REPO, capture_output=True, text=True, check=False
    )


def _variant(tmp_path, old: str, new: str):
    """A copy of binding.py with one edit, imported as a module of the package."""
    text = (REPO / "host_tools" / "mfns" / "core" / "binding.py").read_text()
    assert text.count(old) == 1, old
    path = tmp_path / "binding_variant.py"
    path.write_text(text.replace(old, new))
    name = f"mfns.core._binding_variant_{abs(hash(new))}"
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc")


def test_the_committed_check_is_current():
    assert binding_check.main(["--check"]) == 0


@needs_gcc
def test_the_binding_compiles_against_the_headers(tmp_path):
    res = _compile(binding_check.generate(binding), tmp_path)
    assert res.returncode == 0, res.stderr


@needs_gcc
@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        # two bools of AcqCycleReport (a struct the old size checks never saw)
        (
            '        ("carry_dropped", ct.c_bool),\n        ("bridge_refused", ct.c_bool),\n',
            '        ("bridge_refused", ct.c_bool),\n        ("carry_dropped", ct.c_bool),\n',
            "AcqCycleReport.bridge_refused: offset",
        ),
        # fx and fy of the intrinsics: same size, same type, same struct size
        (
            '        ("fx", ct.c_float),\n        ("fy", ct.c_float),\n',
            '        ("fy", ct.c_float),\n        ("fx", ct.c_float),\n',
            "Intrinsics.fy: offset",
        ),
    ],
)
def test_two_fields_of_one_size_swapped_fail_the_check(tmp_path, old, new, field):
    mod = _variant(tmp_path, old, new)
    for cls in mod.STRUCTS:  # the copy keeps every size: a size check alone would pass it
        orig = getattr(binding, cls.__name__)
        assert ct.sizeof(cls) == ct.sizeof(orig)
    res = _compile(binding_check.generate(mod), tmp_path)
    assert res.returncode != 0
    assert field in res.stderr, res.stderr[-2000:]


@needs_gcc
@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        # right size and offset, wrong type
        (
            '("residual_rms_px", ct.c_float)',
            '("residual_rms_px", ct.c_uint32)',
            "SolutionC.residual_rms_px: C type is not uint32_t",
        ),
        # (6, 6) declared as (4, 9): same bytes, other dimensions
        ('("cov", (ct.c_float * 6) * 6)', '("cov", (ct.c_float * 9) * 4)', "SolutionC.cov: 4 elements"),
    ],
)
def test_a_field_of_the_right_size_but_the_wrong_type_or_shape_fails(tmp_path, old, new, message):
    res = _compile(binding_check.generate(_variant(tmp_path, old, new)), tmp_path)
    assert res.returncode != 0
    assert message in res.stderr, res.stderr[-2000:]


@needs_gcc
@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        # an argument too few: what crashed the planner when mfns_pose_covariance gained one
        (
            '"mfns_pose_covariance": (ct.c_int, [_P(_H66), _VP, _VP, _VP, ct.c_float, _P(SolutionC)])',
            '"mfns_pose_covariance": (ct.c_int, [_P(_H66), _VP, _VP, ct.c_float, _P(SolutionC)])',
            "too few arguments to function 'mfns_pose_covariance'",
        ),
        # a pointer to another struct
        (
            '"mfns_pose_config_default": (None, [_P(PoseConfig)])',
            '"mfns_pose_config_default": (None, [_P(SolverSettings)])',
            "mfns_pose_config_default",
        ),
        # a wider integer where C takes a uint8_t
        (
            '"tc_opcode_name": (ct.c_char_p, [ct.c_uint8])',
            '"tc_opcode_name": (ct.c_char_p, [ct.c_int])',
            "may change value",
        ),
    ],
)
def test_a_function_declared_otherwise_than_its_prototype_fails(tmp_path, old, new, message):
    res = _compile(binding_check.generate(_variant(tmp_path, old, new)), tmp_path)
    assert res.returncode != 0
    assert message in res.stderr.replace("\u2018", "'").replace("\u2019", "'"), res.stderr[-2000:]


def test_one_loader_with_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("MFNS_CORE_LIB", str(tmp_path / "nowhere.so"))
    with pytest.raises(MfnsError, match="no such library.*make lib"):
        binding.load()
    assert binding.lib_path() == tmp_path / "nowhere.so"
    monkeypatch.delenv("MFNS_CORE_LIB")
    assert binding.lib_path() == binding.DEFAULT_LIB


def test_the_package_library_comes_first(tmp_path, monkeypatch):
    """Issue 28 item 1, lib_path's order: a given path, the package's own library (an installed
    wheel), $MFNS_CORE_LIB, the tree's build."""
    own = tmp_path / "mfns" / "libmfns_core.so"
    own.parent.mkdir()
    own.write_bytes(b"")
    monkeypatch.setattr(binding, "PACKAGE_LIB", own)
    monkeypatch.setenv("MFNS_CORE_LIB", str(tmp_path / "env.so"))
    assert binding.lib_path() == own
    assert binding.lib_path(tmp_path / "given.so") == tmp_path / "given.so"
    own.unlink()
    assert binding.lib_path() == tmp_path / "env.so"


def test_no_module_loads_the_library_on_its_own():
    """ctypes.CDLL appears in binding.py only (host tools and tests)."""
    hits = []
    for folder in ("host_tools", "tests/host", "tests/bench"):
        for p in (REPO / folder).rglob("*.py"):
            if p.name != "binding.py" and "CDLL" + "(" in p.read_text():
                hits.append(str(p.relative_to(REPO)))
    assert not hits, hits
