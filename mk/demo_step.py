#!/usr/bin/env python3
"""demo_step.py: one step of `make demo` as one console line (mk/demo.sh).

    demo_step.py --n 3 --of 17 --label "module: simulate" --log build/demo/demo.log \
        [--lines FILE --total N] -- COMMAND [ARGS...]

The command's own output (its summaries, messages, progress bars) goes to the log, never to
the console. On the console the step is one line: on a terminal a tqdm bar that moves while
the step runs and stays as the step's line; elsewhere (a CI log) only the final line. The
progress is read from the command's own tqdm counters ("n/total" in its stderr), or with
--lines from the number of lines of FILE against --total (the ground station's nav.csv
during a flight program run); without either the bar shows the elapsed time. A failing step
prints the last lines of the log and exits with the command's code.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

from tqdm import tqdm

COUNTER = re.compile(rb"(\d+)/(\d+)")
TAIL_LINES = 25  # of the log, printed when a step fails
POLL_S = 0.5


def _count_lines(path: Path) -> int:
    try:
        with open(path, "rb") as f:
            return sum(chunk.count(b"\n") for chunk in iter(lambda: f.read(1 << 16), b""))
    except OSError:
        return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--of", type=int, required=True)
    ap.add_argument("--label", required=True)
    ap.add_argument("--log", required=True)
    ap.add_argument("--lines", help="progress: the lines of this file ...")
    ap.add_argument("--total", type=int, default=0, help="... against this many")
    ap.add_argument("cmd", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    cmd = a.cmd[1:] if a.cmd[:1] == ["--"] else a.cmd
    if not cmd:
        ap.error("no command")
    tty = sys.stdout.isatty()
    desc = f"[{a.n:2d}/{a.of}] {a.label}"
    log = open(a.log, "ab")
    start = log.tell()  # this step's part of the log (shown if it fails)
    log.write(f"\n== {desc}\n$ {' '.join(cmd)}\n".encode())
    log.flush()
    bar = tqdm(
        total=a.total or None,
        desc=desc,
        file=sys.stdout,
        disable=not tty,
        leave=True,
        ncols=shutil.get_terminal_size((100, 24)).columns or 100,  # a pty without a size: 0
        bar_format="{desc} |{bar:20}| {n_fmt}/{total_fmt} {elapsed}" if a.total else "{desc} {elapsed}",
    )
    state = {"n": 0, "total": a.total}

    def pump(stream) -> None:
        # the command's output to the log (a progress bar's redrawn line only as it ended);
        # its own "n/total" counters move the bar
        pending = b""
        for chunk in iter(lambda: stream.read1(4096), b""):
            *lines, pending = (pending + chunk).split(b"\n")
            for line in lines:
                log.write(line.rsplit(b"\r", 1)[-1] + b"\n")
            if not a.lines:
                hits = COUNTER.findall(chunk)
                if hits:
                    n, total = (int(x) for x in hits[-1])
                    if 0 < total < 10**7 and n <= total:
                        state["n"], state["total"] = n, total
        if pending:
            log.write(pending.rsplit(b"\r", 1)[-1] + b"\n")

    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=dict(os.environ))
    reader = threading.Thread(target=pump, args=(proc.stdout,), daemon=True)
    reader.start()
    while proc.poll() is None:
        time.sleep(POLL_S)
        if a.lines:
            state["n"] = min(max(_count_lines(Path(a.lines)) - 1, 0), a.total)
        if state["total"]:
            if bar.total != state["total"]:
                bar.total = state["total"]
                bar.bar_format = "{desc} |{bar:20}| {n_fmt}/{total_fmt} {elapsed}"
            bar.n = state["n"]
        bar.refresh()
    reader.join()
    rc = proc.returncode
    if rc == 0 and bar.total:
        bar.n = bar.total
    bar.refresh()
    bar.close()
    log.close()
    dt = time.monotonic() - t0
    if rc != 0:
        print(f"{desc}: FAILED (exit {rc}) after {dt:.0f} s; the end of {a.log}:", file=sys.stderr)
        lines = Path(a.log).read_bytes()[start:].decode(errors="replace").splitlines()
        for line in lines[-TAIL_LINES:]:
            print(f"   {line}", file=sys.stderr)
        return rc
    if not tty:
        print(f"{desc} ({dt:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
