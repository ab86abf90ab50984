"""The house's include rules (issue 41, docs/system.md section 9), checked on every test run:
mk/include_graph.py --check passes on this tree, and on a small tree it fails for each thing
it is there to catch (a circle, a bare include found only by the old search path, a flight
module including the host-only core)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
TOOL = REPO / "mk" / "include_graph.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(TOOL), *args], capture_output=True, text=True, check=False)


def _tree(tmp: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (tmp / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp / name).write_text(text)
    return tmp


def test_this_tree_holds_the_rules():
    res = _run("--check")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "0 circles, 0 includes found only by a search path, 0 unresolved, 0 borders crossed" in res.stdout


def test_a_clean_tree_passes(tmp_path):
    root = _tree(
        tmp_path,
        {
            "math/a.h": "",
            "firmware/nav/pose/pose.h": '#include "math/a.h"\n',
            "firmware/nav/pose/pose.c": (
                '#include "firmware/nav/pose/pose.h"\n#include "firmware/nav/pose/pose_internal.h"\n'
            ),
            "firmware/nav/pose/pose_internal.h": '#include "firmware/nav/pose/pose.h"\n',
        },
    )
    res = _run("--check", "--root", str(root))
    assert res.returncode == 0, res.stdout
    assert "0 circles" in res.stdout  # an internal header belongs to its module


def test_a_circle_in_the_app_or_a_driver_fails(tmp_path):
    """No folder is exempt: the flight program's rooms and the drivers are held to it too."""
    for a, b in (("firmware/app/x", "firmware/app/y"), ("drivers/camera/x", "drivers/camera/y")):
        root = _tree(
            tmp_path / a.split("/")[0] / a.split("/")[1],
            {f"{a}.h": f'#include "{b}.h"\n', f"{b}.h": "", f"{b}.c": f'#include "{a}.h"\n'},
        )
        res = _run("--check", "--root", str(root))
        assert res.returncode == 1, res.stdout
        assert f"circle: {a} <-> {b}" in res.stdout


def test_a_circle_fails(tmp_path):
    root = _tree(
        tmp_path,
        {
            "firmware/nav/a/a.h": '#include "firmware/nav/b/b.h"\n',
            "firmware/nav/b/b.h": "",
            "firmware/nav/b/b.c": '#include "firmware/nav/a/a.h"\n',
        },
    )
    res = _run("--check", "--root", str(root))
    assert res.returncode == 1
    assert "circle: firmware/nav/a/a <-> firmware/nav/b/b" in res.stdout


def test_a_search_path_include_fails(tmp_path):
    root = _tree(tmp_path, {"math/lens.h": "", "firmware/nav/x/x.c": '#include "lens.h"\n'})
    res = _run("--check", "--root", str(root))
    assert res.returncode == 1
    assert 'by search path: firmware/nav/x/x.c: "lens.h"' in res.stdout


def test_the_flight_core_never_includes_the_host_only_core(tmp_path):
    root = _tree(
        tmp_path,
        {"firmware/host/build.h": "", "firmware/nav/x/x.c": '#include "firmware/host/build.h"\n'},
    )
    res = _run("--check", "--root", str(root))
    assert res.returncode == 1
    assert "border crossed: firmware/nav/x/x -> firmware/host/build" in res.stdout


def test_the_frame_policies_sit_beside_the_core_on_both_sides_of_a_border(tmp_path):
    """firmware/frames/ may use the core; the core never uses it, nor it the program."""
    for src, dst in (("firmware/nav/x/x", "firmware/frames/f"), ("firmware/frames/f", "firmware/app/a")):
        root = _tree(tmp_path / src.replace("/", "_"), {f"{dst}.h": "", f"{src}.c": f'#include "{dst}.h"\n'})
        res = _run("--check", "--root", str(root))
        assert res.returncode == 1, res.stdout
        assert f"border crossed: {src} -> {dst}" in res.stdout
    root = _tree(tmp_path / "ok", {"math/m.h": "", "firmware/frames/f.c": '#include "math/m.h"\n'})
    assert _run("--check", "--root", str(root)).returncode == 0
