"""Issue 28 item 3: README's module accuracy is the demo's own output.

mk/readme_accuracy.py (the last step of `make demo`) renders the sentence between README's
demo-accuracy markers from build/demo/module/*/report/summary.json. Here: the rendering from
known summaries, the block's replacement, and, when a demo output is present, that README
says what it printed (drift fails)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("readme_accuracy", REPO / "mk" / "readme_accuracy.py")
ra = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ra)


def _summary(sig_deg, sig_mm):
    axes = [{"axis": a, "sigma": s} for a, s in zip(("roll", "pitch", "yaw"), sig_deg, strict=True)]
    axes += [{"axis": a, "sigma": s} for a, s in zip(("x", "y", "z"), sig_mm, strict=True)]
    return {"kind": "error", "axes": axes}


def _demo(tmp_path):
    for table, deg, mm in (
        ("paper-calibration", (0.047, 0.1, 0.144), (1.01, 2.0, 4.56)),
        ("refined-calibration", (0.023, 0.05, 0.084), (0.78, 1.0, 2.99)),
        ("true-rig", (0.02, 0.03, 0.04), (0.5, 0.6, 0.7)),
    ):
        d = tmp_path / "module" / table / "report"
        d.mkdir(parents=True)
        (d / "summary.json").write_text(json.dumps(_summary(deg, mm)))
    return tmp_path


def test_render_and_replace(tmp_path):
    demo = _demo(tmp_path)
    text = ra.render(demo)
    assert "paper-method calibration 0.047-0.144 deg and 1.01-4.56 mm" in text
    assert "refined calibration 0.023-0.084 deg and 0.78-2.99 mm" in text
    assert "true rig 0.020-0.040 deg and 0.50-0.70 mm" in text
    readme = tmp_path / "README.md"
    readme.write_text(f"a\n{ra.BEGIN}\nold\n{ra.END}\nb\n")
    assert ra.main([str(demo), str(readme), "--check"]) == 1
    assert ra.main([str(demo), str(readme)]) == 0
    assert ra.main([str(demo), str(readme), "--check"]) == 0
    assert readme.read_text() == f"a\n{ra.BEGIN}\n{text}\n{ra.END}\nb\n"


def test_a_summary_without_truth_is_refused(tmp_path):
    demo = _demo(tmp_path)
    p = demo / "module" / "true-rig" / "report" / "summary.json"
    p.write_text(json.dumps({**json.loads(p.read_text()), "kind": "estimate"}))
    with pytest.raises(SystemExit, match="against truth"):
        ra.render(demo)


def test_readme_has_one_block():
    text = (REPO / "README.md").read_text()
    assert text.count(ra.BEGIN) == 1 and text.count(ra.END) == 1


def test_readme_says_what_the_demo_printed():
    demo = REPO / "build" / "demo"
    if not all((demo / "module" / t / "report" / "summary.json").is_file() for t, _ in ra.TABLES):
        pytest.skip("no demo output (make demo) to hold README to")
    assert ra.main([str(demo), str(REPO / "README.md"), "--check"]) == 0, (
        "README's module accuracy differs from build/demo: run make demo (it rewrites the block)"
    )
