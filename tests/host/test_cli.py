"""The mfns command itself: discovery, --help, one-line errors."""

import subprocess
import sys

from mfns.cli import build_parser, main


def test_help_lists_every_registered_command(capsys):
    parser = build_parser()
    with __import__("pytest").raises(SystemExit) as exc:
        parser.parse_args(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "usage: mfns" in out


def test_no_command_is_usage_error():
    assert main([]) == 2


def test_module_entry_point_runs():
    res = subprocess.run(
        [sys.executable, "-m", "mfns", "--version"], check=False, capture_output=True, text=True
    )
    assert res.returncode == 0
    assert res.stdout.startswith("mfns ")
