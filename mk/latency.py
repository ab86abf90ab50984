#!/usr/bin/env python3
"""make latency (docs/budgets.md "Latency"): camera-to-telemetry latency of
mfns-nav on the development host -- from a frame's stamp to its cycle's nav
packet leaving the transmit queue (written to the link) -- over a paced replay
(--realtime: frames come at their recorded 18.6 Hz) into a pseudo-terminal
that a reader here keeps drained, as a ground station would. The program
measures it (nav_app_note_latency) and prints median, p99 and max with
--verbose; this script runs it on the module scenario of each seed and writes
build/latency/results.json."""

from __future__ import annotations

import argparse
import json
import os
import pty
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

from sim_case import module_case

REPO = Path(__file__).resolve().parents[1]
BIN = REPO / "build" / "host-sim" / "bin"
LINE = re.compile(
    r"latency, frame stamp to nav packet out of the queue: median ([\d.]+) ms, p99 ([\d.]+) ms, "
    r"max ([\d.]+) ms \((\d+) cycles\)"
)


def fly(out: Path, seed: int, frames: int) -> dict:
    d = out / f"seed{seed}"
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    table = module_case(d, seed, frames)
    master, slave = pty.openpty()
    got = bytearray()
    stop = threading.Event()

    def reader() -> None:  # the ground side: keeps the pty drained
        while not stop.is_set():
            try:
                b = os.read(master, 65536)
            except OSError:
                return
            if not b:
                return
            got.extend(b)

    th = threading.Thread(target=reader, daemon=True)
    th.start()
    nav = subprocess.run(
        [
            str(BIN / "mfns-nav"),
            "--table",
            str(table),
            "--replay",
            str(d / "frames"),
            "--realtime",
            "--tty",
            os.ttyname(slave),
            "-v",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    stop.set()
    os.close(slave)
    os.close(master)
    m = LINE.search(nav.stderr)
    if nav.returncode != 0 or m is None:
        sys.exit(f"latency: mfns-nav exited {nav.returncode} without a latency line: {nav.stderr[-1500:]}")
    return {
        "seed": seed,
        "frames": frames,
        "median_ms": float(m.group(1)),
        "p99_ms": float(m.group(2)),
        "max_ms": float(m.group(3)),
        "cycles": int(m.group(4)),
        "bytes_read": len(got),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="2,5")
    ap.add_argument("--frames", type=int, default=400, help="frames per run (400: 21.5 s at 18.6 Hz)")
    ap.add_argument("--out", type=Path, default=REPO / "build" / "latency")
    a = ap.parse_args()
    os.environ["PYTHONPATH"] = str(REPO / "host_tools") + os.pathsep + os.environ.get("PYTHONPATH", "")
    a.out.mkdir(parents=True, exist_ok=True)
    runs = [fly(a.out, int(s), a.frames) for s in a.seeds.split(",")]
    (a.out / "results.json").write_text(json.dumps({"runs": runs}, indent=1) + "\n")
    for r in runs:
        print(
            f"latency: seed {r['seed']}: {r['cycles']} cycles paced at 18.6 Hz into a pty: "
            f"median {r['median_ms']:.2f} ms, p99 {r['p99_ms']:.2f} ms, max {r['max_ms']:.2f} ms "
            "(percentiles +-2.5 %, cycle_stats.h)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
