#!/usr/bin/env python3
"""readme_accuracy.py DEMO_DIR README: write the demo's module accuracy into README.md.

The last step of `make demo` (mk/demo.sh). README's sentence on the module run's navigation
accuracy sits between the markers `<!-- demo-accuracy -->` and `<!-- /demo-accuracy -->`;
this script renders it from what the demo itself wrote, DEMO_DIR/module/TABLE/report/
summary.json (`mfns report`: the 1-sigma of the error per axis against truth), so README
says what the demo printed. `--check` renders without writing and exits 1 when README
differs (tests/host/test_readme_accuracy.py runs it when a demo output is present).
Standard library only.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

BEGIN, END = "<!-- demo-accuracy -->", "<!-- /demo-accuracy -->"
TABLES = (
    ("paper-calibration", "the paper-method calibration"),
    ("refined-calibration", "the refined calibration"),
    ("true-rig", "the true rig"),
)
ANGLES, POSITIONS = ("roll", "pitch", "yaw"), ("x", "y", "z")


def sigma_range(summary: dict, axes: tuple[str, ...]) -> tuple[float, float]:
    """(min, max) over `axes` of the 1-sigma error; ValueError when one is missing."""
    by_axis = {a["axis"]: a.get("sigma") for a in summary.get("axes", [])}
    vals = [by_axis.get(a) for a in axes]
    if summary.get("kind") != "error" or any(v is None for v in vals):
        raise ValueError(f"no error 1-sigma for {', '.join(axes)} (a report against truth is needed)")
    return min(vals), max(vals)


def render(demo: Path) -> str:
    """The sentence, from DEMO_DIR/module/*/report/summary.json."""
    parts = []
    for table, name in TABLES:
        path = demo / "module" / table / "report" / "summary.json"
        try:
            summary = json.loads(path.read_text())
            a0, a1 = sigma_range(summary, ANGLES)
            p0, p1 = sigma_range(summary, POSITIONS)
        except (OSError, ValueError) as exc:
            raise SystemExit(f"readme_accuracy: {path}: {exc}") from None
        parts.append(f"{name} {a0:.3f}-{a1:.3f} deg and {p0:.2f}-{p1:.2f} mm")
    return (
        "In the module run the navigation error (1 sigma per axis, the demo's own "
        "`module/*/report/summary.json`, written here by `make demo`) is: " + "; ".join(parts) + "."
    )


def replace_block(text: str, sentence: str) -> str:
    pattern = re.compile(re.escape(BEGIN) + r".*?" + re.escape(END), re.S)
    if len(pattern.findall(text)) != 1:
        raise SystemExit(f"readme_accuracy: README needs exactly one {BEGIN} ... {END} block")
    return pattern.sub(lambda _m: f"{BEGIN}\n{sentence}\n{END}", text)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("demo", type=Path)
    ap.add_argument("readme", type=Path)
    ap.add_argument("--check", action="store_true", help="exit 1 when README differs; write nothing")
    args = ap.parse_args(argv)
    text = args.readme.read_text()
    new = replace_block(text, render(args.demo))
    if args.check:
        if new != text:
            print(
                f"readme_accuracy: {args.readme} differs from the demo's output in {args.demo}",
                file=sys.stderr,
            )
            return 1
        return 0
    if new != text:
        args.readme.write_text(new)
        print(f"   {args.readme}: module accuracy updated from {args.demo}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
