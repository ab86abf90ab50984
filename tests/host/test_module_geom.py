"""The module's geometry (mfns.simulate.module_geom): one definition for `mfns sim nav
--scenario module` and `mfns plan --workspace/--surfaces module`; the demo's by default
(unchanged), other sizes scale the walls, the path and the workspace together."""

from __future__ import annotations

import hashlib
import json
from types import SimpleNamespace

import numpy as np
import pytest

from mfns import cli
from mfns.core.errors import MfnsError
from mfns.plan import run as plan_run
from mfns.plan import surfaces, workspace
from mfns.simulate import module_geom, nav
from mfns.simulate.module_geom import DEMO_MODULE, EDGE_MARGIN_MM, ModuleGeometry

SMALL = ModuleGeometry((3000.0, 2000.0, 2000.0))


def _digest(scn) -> str:
    v = np.concatenate([scn.beacons.ravel(), scn.r_wb_w.ravel(), scn.euler_deg.ravel()])
    return hashlib.sha256(np.round(v, 6).tobytes()).hexdigest()


def test_the_default_is_the_demo_module_unchanged():
    assert np.array_equal(DEMO_MODULE.half, [2000.0, 1000.0, 1000.0])
    assert np.array_equal(DEMO_MODULE.pos_amp_mm, [800.0, 300.0, 300.0])
    assert DEMO_MODULE.turn_width_mm == 250.0 and DEMO_MODULE.is_demo and DEMO_MODULE.cli_args() == []
    assert np.array_equal(nav.MODULE_HALF, DEMO_MODULE.half)
    assert np.array_equal(nav.module_workspace()[1], [800.0, 300.0, 300.0])
    # the scenario of seed 2, as the code before the geometry was parametric drew it
    # (digest taken from commit 566a866's mfns.simulate.nav)
    scn = nav.module_scenario(6, 1.0, 60, 2)
    assert _digest(scn) == "791c302cd574f2c137dfe0a3c76998c4bea9c84b7899a4a06019f88493088278"
    assert scn.info["module_size_mm"] == [4000.0, 2000.0, 2000.0]
    assert scn.info["table_workspace_mm"] == [-800.0, -300.0, -300.0, 800.0, 300.0, 300.0]
    # the demo's size given explicitly is the same module
    same = nav.module_scenario(6, 1.0, 60, 2, geom=module_geom.parse("4000,2000,2000", None))
    assert _digest(same) == _digest(scn) and same.info == scn.info


def test_another_size_scales_walls_path_and_workspace():
    assert np.array_equal(SMALL.pos_amp_mm, [600.0, 300.0, 300.0])  # the demo's path, scaled
    assert SMALL.turn_width_mm == pytest.approx(187.5)
    scn = nav.module_scenario(200, 2.0, 30, 4, geom=SMALL)
    half = SMALL.half
    # every beacon on a wall of the smaller module, clear of its edges
    on = np.isclose(np.abs(scn.beacons), half).sum(axis=1)
    assert np.all(on == 1) and len(scn.beacons) == 30
    inner = np.where(np.isclose(np.abs(scn.beacons), half), 0.0, np.abs(scn.beacons))
    assert np.all(inner <= half - EDGE_MARGIN_MM + 1e-9)
    assert np.any(np.isclose(np.abs(scn.beacons[:, 0]), 1500.0))  # end walls at +-1.5 m
    # the path stays in the scaled box, and crosses most of it
    amp = SMALL.pos_amp_mm
    assert np.all(np.abs(scn.r_wb_w) <= amp + 1e-9)
    assert np.all(np.abs(scn.r_wb_w).max(axis=0) > 0.8 * amp)
    assert scn.info["module_size_mm"] == [3000.0, 2000.0, 2000.0]
    assert scn.info["table_workspace_mm"] == [-600.0, -300.0, -300.0, 600.0, 300.0, 300.0]
    assert scn.info["trajectory"]["pos_amp_mm"] == [600.0, 300.0, 300.0]
    # the LEDs of a map given in that module face off its own walls
    nrm = nav.wall_normals(scn.beacons, half)
    assert np.allclose(nrm, scn.beacon_normals)


def test_the_planner_reads_the_same_module():
    # workspace module: the path's box; surfaces module: the walls less the edge strip
    ws = workspace.module(400, np.random.default_rng(1), SMALL)
    assert np.all(np.abs(ws.r_wb_w) <= SMALL.pos_amp_mm + 1e-9)
    assert np.all(np.abs(ws.r_wb_w).max(axis=0) > 0.9 * SMALL.pos_amp_mm)
    walls, keep = surfaces.load("module", SMALL)
    assert len(walls) == 6 and keep == []
    cand, _ = surfaces.candidates(walls, 100.0, [])
    assert np.all(np.abs(cand) <= SMALL.half + 1e-9)
    assert np.isclose(np.abs(cand[:, 0]).max(), 1500.0)
    assert np.abs(cand[:, 1:]).max() == pytest.approx(1000.0)
    demo, _ = surfaces.candidates(surfaces.load("module")[0], 100.0, [])
    assert np.isclose(np.abs(demo[:, 0]).max(), 2000.0) and len(cand) < len(demo)
    # the command's arguments pick it; options that shape nothing are refused
    args = SimpleNamespace(
        workspace="module", surfaces="module", module_size="3000,2000,2000", module_path_amp=None
    )
    assert plan_run.module_of(args) == SMALL
    args = SimpleNamespace(workspace="box", surfaces="paper-frame", module_size="3000,2000,2000")
    with pytest.raises(MfnsError, match="--module-size"):
        plan_run.module_of(args)


@pytest.mark.parametrize(
    ("size", "amp", "message"),
    [
        ("3000,2000", None, "--module-size"),
        ("3000,2000,nan", None, "--module-size"),
        ("300,2000,2000", None, "module size"),
        ("3000,2000,2000", "1300,300,300", "within 300 mm of a wall"),
        ("3000,2000,2000", "-1,0,0", "path amplitude"),
    ],
)
def test_bad_geometry_is_named(size, amp, message):
    with pytest.raises(MfnsError, match=message):
        module_geom.parse(size, amp)


def test_given_amplitude_travels_to_the_fly_check():
    g = module_geom.parse("3000,2000,2500", "500,200,250")
    assert np.array_equal(g.pos_amp_mm, [500.0, 200.0, 250.0])
    assert g.cli_args() == ["--module-size", "3000,2000,2500", "--module-path-amp", "500,200,250"]
    assert module_geom.parse(*g.cli_args()[1::2]) == g
    assert json.loads(json.dumps(g.to_doc()))["size_mm"] == [3000.0, 2000.0, 2500.0]


def test_cli_options_have_help_and_refuse_misuse(tmp_path, capsys):
    # in-process: the parser and the error path of `mfns` (a subprocess each costs seconds)
    for cmd in (["sim", "nav"], ["plan", "optimize"], ["plan", "analyze"], ["plan", "size"]):
        with pytest.raises(SystemExit) as ex:
            cli.main([*cmd, "--help"])
        out = capsys.readouterr().out
        assert ex.value.code == 0 and "--module-size" in out and "--module-path-amp" in out
    rc = cli.main(["sim", "nav", str(tmp_path / "t"), "--frames", "1", "--module-size", "3000,2000,2000"])
    assert rc == 2 and "--scenario module" in capsys.readouterr().err  # the turntable has no module
    rc = cli.main(
        ["sim", "nav", str(tmp_path / "m"), "--scenario", "module", "--frames", "1", "--module-size", "1,2"]
    )
    assert rc == 2 and "--module-size '1,2'" in capsys.readouterr().err
    assert not (tmp_path / "t").exists() and not (tmp_path / "m").exists()  # refused before writing
