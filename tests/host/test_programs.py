"""mfns.programs: the console scripts mfns-nav and mfns-ground run the packaged flight and
ground programs (the wheel's mfns/bin), else the tree's build (issue 43: a pip install flies)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from mfns import programs


def test_unknown_program_is_refused():
    with pytest.raises(ValueError, match="not one of"):
        programs.program_path("mfns-tlm-gen")


def test_the_package_copy_comes_first(tmp_path, monkeypatch):
    pkg, tree = tmp_path / "pkg", tmp_path / "tree"
    for d in (pkg, tree):
        d.mkdir()
        p = d / "mfns-nav"
        p.write_text("#!/bin/sh\necho " + d.name + ' "$@"\n')
        p.chmod(0o755)
    monkeypatch.setattr(programs, "PACKAGE_BIN", pkg)
    monkeypatch.setattr(programs, "TREE_BIN", tree)
    assert programs.program_path("mfns-nav") == pkg / "mfns-nav"
    (pkg / "mfns-nav").chmod(0o644)  # not executable: not a program
    assert programs.program_path("mfns-nav") == tree / "mfns-nav"
    assert programs.program_path("mfns-ground") is None


def test_missing_program_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(programs, "PACKAGE_BIN", tmp_path / "a")
    monkeypatch.setattr(programs, "TREE_BIN", tmp_path / "b")
    assert programs._exec("mfns-ground", []) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no mfns-ground" in err[0] and "make flight" in err[0]


def test_the_script_execs_the_program_with_its_arguments_and_status(tmp_path):
    """A child Python runs the console script's function: the program replaces it (its output,
    its exit status)."""
    d = tmp_path / "bin"
    d.mkdir()
    p = d / "mfns-ground"
    p.write_text('#!/bin/sh\necho "|$*"\nexit 7\n')
    p.chmod(0o755)
    code = (
        "import sys, pathlib, mfns.programs as m; m.PACKAGE_BIN = pathlib.Path(sys.argv[1]); "
        "sys.argv = ['mfns-ground', '--file', 'x y']; sys.exit(m.ground())"
    )
    r = subprocess.run([sys.executable, "-c", code, str(d)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 7
    assert r.stdout.strip() == "|--file x y"
