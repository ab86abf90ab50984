"""mk/demo_step.py: one console line per `make demo` step, the step's output in the log.

Issue 28 item 4 (a quiet demo): a step's own output (summaries, progress bars) goes to the
demo's log, the console gets one line; a failing step shows its own part of the log and
exits with the command's code.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
STEP = REPO / "mk" / "demo_step.py"

# a command with a tqdm bar on stderr and a summary on stdout, like mfns sim calib
TALKER = (
    "import sys\n"
    "from tqdm import tqdm\n"
    "for _ in tqdm(range(5), desc='rendering', file=sys.stderr, mininterval=0): pass\n"
    "print('summary line 1'); print('summary line 2')\n"
)


def _step(tmp_path, *cmd, n=1, lines=None, total=0):
    log = tmp_path / "demo.log"
    args = [sys.executable, str(STEP), "--n", str(n), "--of", "3", "--label", "a step", "--log", str(log)]
    if lines:
        args += ["--lines", str(lines), "--total", str(total)]
    res = subprocess.run([*args, "--", *cmd], capture_output=True, text=True, check=False)
    return res, log


def test_a_step_is_one_console_line_and_its_output_goes_to_the_log(tmp_path):
    res, log = _step(tmp_path, sys.executable, "-c", TALKER)
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines() == [res.stdout.strip()] and res.stdout.startswith("[ 1/3] a step (")
    assert res.stderr == ""
    text = log.read_text()
    assert "summary line 1\nsummary line 2\n" in text and "== [ 1/3] a step" in text
    bars = [ln for ln in text.splitlines() if ln.startswith("rendering")]
    assert len(bars) == 1 and "5/5" in bars[0] and "\r" not in text  # the bar as it ended, once


def test_a_failing_step_shows_its_part_of_the_log_and_its_exit_code(tmp_path):
    _step(tmp_path, sys.executable, "-c", "print('earlier step')")
    res, log = _step(
        tmp_path,
        sys.executable,
        "-c",
        "import sys; print('what went wrong', file=sys.stderr); sys.exit(3)",
        n=2,
    )
    assert res.returncode == 3
    assert "[ 2/3] a step: FAILED (exit 3)" in res.stderr and "what went wrong" in res.stderr
    assert "earlier step" not in res.stderr  # only this step's part
    assert "earlier step" in log.read_text()


def test_progress_from_a_growing_file(tmp_path):
    """--lines FILE --total N: the flight program's run, counted by the ground's nav.csv lines."""
    f = tmp_path / "nav.csv"
    writer = (
        "import time\n"
        f"with open({str(f)!r}, 'w') as o:\n"
        "    for i in range(4):\n"
        "        o.write('x\\n'); o.flush(); time.sleep(0.3)\n"
    )
    res, _log = _step(tmp_path, sys.executable, "-c", writer, lines=f, total=3)
    assert res.returncode == 0 and res.stdout.startswith("[ 1/3] a step (")
