"""The moving-robot acquisition bench (tests/bench/bench_pose_moving.py, issue 27) at its
--quick size: it runs, prints the table of right fixes within K cycles, and no fix is
wrong. (The full sizes and their targets run in make bench-pose.)"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("box", [[], ["--map-workspace"]], ids=["robot-workspace", "map-workspace"])
def test_quick_moving_bench_prints_its_table_and_no_wrong_fix(box):
    res = subprocess.run(
        [sys.executable, str(REPO / "tests" / "bench" / "bench_pose_moving.py"), "--quick", *box],
        cwd=REPO,
        check=False,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    assert ("(the map default)" in res.stdout) == bool(box), res.stdout
    rows = [ln for ln in res.stdout.splitlines() if ln.startswith("| x1 | 18.6 Hz |")]
    assert len(rows) == 1, res.stdout
    cells = [c.strip() for c in rows[0].split("|")]
    within = [float(re.sub(r"\s*%$", "", c)) for c in cells[3:7]]
    assert within == sorted(within)  # within 1 <= 5 <= 20 <= 40 cycles
    assert within[-1] >= 90.0  # 40 starts: a regression shows, not the 99 % target's statistics
    assert cells[7] == "0"  # wrong fixes
