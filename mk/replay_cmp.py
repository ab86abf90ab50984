"""replay_cmp.py A B: every cell of the ground station's CSV files under A (any depth:
mk/replay_ident.sh's output, or two `make demo` folders) equal in B, but the wall-clock
ones (cycle times, CPU load, frame period and margin, UTC stamps, the kernel's
time error and offset, the clock self-test's value), which differ between two runs of the
same binary. Cells are matched by column name: a column only one side has (a field a
change added to a packet) is named once and not compared. Exit 1 on any difference."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

WALL = (
    "cycle_p",
    "cycle_max",
    "cycle_margin",
    "cpu_load",
    "utc",
    "frame_period",
    "time_error",
    "time_offset",
)


def main() -> int:
    a, b = (Path(p) for p in sys.argv[1:3])
    files = cells = bad = 0
    for fa in sorted(a.rglob("ground/*.csv")):
        fb = b / fa.relative_to(a)
        files += 1
        ra = list(csv.reader(fa.open()))
        rb = list(csv.reader(fb.open())) if fb.exists() else []
        if len(ra) != len(rb):
            print(f"{fa.relative_to(a)}: {len(ra)} vs {len(rb)} rows")
            bad += 1
            continue
        ha, hb = ra[0], rb[0]
        only = sorted(set(ha) ^ set(hb))
        if only:
            print(f"{fa.relative_to(a)}: columns on one side only, not compared: {' '.join(only)}")
        common = [h for h in ha if h in hb and not any(w in h.lower() for w in WALL)]
        ia, ib = {h: i for i, h in enumerate(ha)}, {h: i for i, h in enumerate(hb)}
        for i, (x, y) in enumerate(zip(ra[1:], rb[1:], strict=True)):
            for h in common:
                if h == "arg1" and "SELFTEST_CLOCK" in x:
                    continue
                u = x[ia[h]] if ia[h] < len(x) else ""
                v = y[ib[h]] if ib[h] < len(y) else ""
                cells += 1
                if u != v:
                    bad += 1
                    if bad <= 15:
                        print(f"{fa.relative_to(a)} row {i + 1} {h}: {u} vs {v}")
    print(f"replay_cmp: {files} files, {cells} cells compared, {bad} differ")
    return 1 if bad or files == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
