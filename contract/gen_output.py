"""gen_output.py -- what every generator of contract/ does with its output: write the generated
files that changed, or, with --check, write nothing and fail naming the stale ones (the
check `make` runs, so a stale committed file fails the build). Standard library only.

Generators load it by path (load_gen_output), so it works whether they run as a script or
are imported by a test.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path


def write_or_check(root: Path, files: Mapping[str | Path, str], check: bool, tool: str, hint: str) -> int:
    """files: path (relative to root, or absolute below it) -> text. Returns the exit code:
    0 when written or fresh, 1 when check finds a stale file (listed on stderr with hint)."""
    stale: list[str] = []
    for rel, text in files.items():
        path = Path(rel) if Path(rel).is_absolute() else root / rel
        old = path.read_text(encoding="utf-8") if path.exists() else None
        if old == text:
            continue
        stale.append(str(path.relative_to(root)))
        if not check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    if check and stale:
        print(f"{tool}: stale generated files ({hint}): {' '.join(stale)}", file=sys.stderr)
        return 1
    for rel in stale:
        print(f"{tool}: wrote {rel}")
    return 0
