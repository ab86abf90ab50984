"""One command-line grammar (README "Command-line grammar") across every program.

Every program and every `mfns` subcommand answers --version (with the one version string,
host_tools/mfns/__init__.py) and --help; -q/--quiet and -v/--verbose exist everywhere; the
transports are spelled --serial/--tty/--file in all three C programs, and the older
spellings still work.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from mfns import __version__
from mfns.cli import build_parser, main

REPO = Path(__file__).resolve().parents[2]
PROGRAMS = ("mfns-nav", "mfns-ground", "mfns-tlm-gen")


def command_paths(parser: argparse.ArgumentParser, prefix=()) -> list[tuple[str, ...]]:
    """Every command of the mfns tree: (), ("calib",), ("sim", "nav"), ..."""
    out = [prefix]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out += command_paths(sub, (*prefix, name))
    return out


PATHS = command_paths(build_parser())


def test_the_tree_has_the_known_commands():
    names = {" ".join(p) for p in PATHS}
    assert {"", "calib", "compare", "mc", "report", "sim", "sim calib", "sim nav", "table build"} <= names
    # issue 41: the programs that ran as `python -m mfns.X` are subcommands
    assert {"map demo", "table vectors", "table gridstudy"} <= names


@pytest.mark.parametrize("path", PATHS, ids=lambda p: " ".join(p) or "mfns")
def test_every_mfns_command_answers_version_and_help(path, capsys):
    with pytest.raises(SystemExit) as exc:
        main([*path, "--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == " ".join(("mfns", *path, __version__))
    with pytest.raises(SystemExit) as exc:
        main([*path, "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--version", "-q, --quiet", "-v, --verbose", "-h, --help"):
        assert opt in text, f"mfns {' '.join(path)} --help lacks {opt}"


def test_bad_usage_exits_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["report", "--no-such-option"])
    assert exc.value.code == 2


def test_quiet_means_nothing_on_stdout(tmp_path, capsys):
    data = REPO / "host_tools" / "mfns" / "data"
    args = [
        "table",
        "build",
        str(data / "paper_calib.json"),
        str(data / "paper_beacons.csv"),
        "--certify-samples",
        "5",
    ]
    assert main([*args, "-o", str(tmp_path / "a.tbl")]) == 0
    assert "wrote" in capsys.readouterr().out
    assert main([*args, "-o", str(tmp_path / "b.tbl"), "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    assert (tmp_path / "b.tbl").read_bytes() == (tmp_path / "a.tbl").read_bytes()


def test_version_string_has_one_source(tmp_path):
    pyproject = (REPO / "host_tools" / "pyproject.toml").read_text()
    assert 'dynamic = ["version"]' in pyproject and 'attr = "mfns.__version__"' in pyproject
    header = tmp_path / "v.h"
    subprocess.run(
        ["bash", "mk/version.sh", "host_tools/mfns/__init__.py", str(header)], cwd=REPO, check=True
    )
    assert f'#define MFNS_VERSION_STR "{__version__}"' in header.read_text()


def run(bins: Path, prog: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(bins / prog), *args], check=False, capture_output=True, text=True, timeout=30)


@pytest.mark.parametrize("prog", PROGRAMS)
def test_every_program_answers_version_and_help(bins, prog):
    res = run(bins, prog, "--version")
    assert res.returncode == 0, res.stderr
    assert res.stdout.split()[:2] == [prog, __version__]
    for flag in ("--help", "-h"):
        res = run(bins, prog, flag)
        assert res.returncode == 0 and res.stdout.startswith(f"usage: {prog}")
        for opt in ("--quiet", "--verbose", "--version", "--tty"):
            assert opt in res.stdout, f"{prog} --help lacks {opt}"
    res = run(bins, prog, "--no-such-option", "1")
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr


def test_module_entry_point_version_matches_programs(bins):
    res = subprocess.run(
        [sys.executable, "-m", "mfns", "--version"], capture_output=True, text=True, check=True
    )
    assert res.stdout.split() == ["mfns", __version__]


def test_transport_spellings_and_their_old_aliases(bins, tmp_path):
    # mfns-nav: --serial/--tty/--file and --tlm-*: two of them are one telemetry output too many.
    for a, b in (("--tty", "--tlm-file"), ("--tlm-tty", "--file"), ("--serial", "--tlm-serial")):
        res = run(bins, "mfns-nav", "--table", "t", "--replay", "r", a, "x", b, "y")
        assert res.returncode == 2 and "one telemetry output" in res.stderr, (a, b, res.stderr)
    # mfns-ground: --serial and the old --port are the same source.
    res = run(bins, "mfns-ground", "--serial", "/nonexistent/a", "--port", "/nonexistent/b")
    assert res.returncode == 2 and "exactly one of --serial, --tty, --file" in res.stderr
    # A source that cannot be opened is a failure of the job: exit 1.
    res = run(
        bins, "mfns-ground", "--file", str(tmp_path / "missing.bin"), "--out", str(tmp_path / "g"), "-q"
    )
    assert res.returncode == 1
    # mfns-tlm-gen: --file and the old --out write the same stream.
    new, old = tmp_path / "new.bin", tmp_path / "old.bin"
    assert run(bins, "mfns-tlm-gen", "--cycles", "5", "--file", str(new)).returncode == 0
    assert run(bins, "mfns-tlm-gen", "--cycles", "5", "--out", str(old)).returncode == 0
    assert new.read_bytes() == old.read_bytes() and len(new.read_bytes()) > 100
    res = run(bins, "mfns-tlm-gen", "--cycles", "many")
    assert res.returncode == 2 and "bad value" in res.stderr


def test_ground_quiet_prints_no_counters(bins, tmp_path):
    stream = tmp_path / "s.bin"
    assert run(bins, "mfns-tlm-gen", "--cycles", "20", "--file", str(stream)).returncode == 0
    loud = run(bins, "mfns-ground", "--file", str(stream), "--out", str(tmp_path / "a"))
    quiet = run(bins, "mfns-ground", "--file", str(stream), "--out", str(tmp_path / "b"), "--quiet")
    assert loud.returncode == 0 and quiet.returncode == 0
    assert "frames_ok" in loud.stderr and quiet.stderr == ""

    def rows(d):  # without utc, time_source, ground_utc: receipt times differ between runs
        return [ln.rsplit(",", 3)[0] for ln in (tmp_path / d / "nav.csv").read_text().splitlines()]

    assert rows("a") == rows("b") and len(rows("a")) == 21


def test_output_folder_is_out_everywhere(tmp_path, capsys):
    """An output folder is `--out DIR` in every command; the commands that make a folder
    also take it as their positional OUT (the same folder either way)."""
    args = ["mc", "--trials", "20", "--pose-trials", "0", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert main([*args, str(tmp_path / "b")]) == 0
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == sorted(
        p.name for p in (tmp_path / "b").iterdir()
    )
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "output folder is missing" in err
    assert main([*args, str(tmp_path / "c"), "--out", str(tmp_path / "d")]) == 2
    folder_commands = (["sim", "calib"], ["sim", "nav"], ["mc"], ["plan", "analyze"], ["plan", "optimize"])
    for cmd in (*folder_commands, ["map", "refine"], ["map", "demo"]):
        with pytest.raises(SystemExit):
            main([*cmd, "--help"])
        assert "--out" in capsys.readouterr().out, cmd


def _parsers(parser: argparse.ArgumentParser, prefix=()):
    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, (*prefix, name))


def test_every_option_of_every_command_has_help_text():
    """Issue 43: every option and operand of every `mfns` command says what it is (--help), and
    every subcommand has a one-line help in its parent's list."""
    missing = []
    for path, parser in _parsers(build_parser()):
        where = " ".join(("mfns", *path))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                listed = {a.dest for a in action._choices_actions if a.help and a.help.strip()}
                missing += [f"{where} {n} (no help in the list)" for n in action.choices if n not in listed]
                continue
            if action.help is argparse.SUPPRESS:
                continue
            if not (action.help or "").strip():
                missing.append(f"{where} {'/'.join(action.option_strings) or action.dest}")
    assert not missing, "options without help text: " + ", ".join(missing)


@pytest.mark.parametrize(
    "argv",
    [
        ["calib", "--nope"],
        ["report", "--nope"],
        ["report", "x", "--nope=1"],
        ["sim", "nav", "--nope"],
        ["plan", "analyze", "--nope"],
        ["map", "demo", "--nope"],
        ["table", "vectors", "--nope"],
        ["table", "gridstudy", "--nope"],
    ],
    ids=" ".join,
)
def test_an_unknown_option_is_named(argv, capsys):
    """`mfns calib --nope` names --nope (argparse alone reports the missing DATASET first)."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "--nope" in err[-1] and "unrecognized arguments" in err[-1], err


def test_negative_values_and_abbreviations_are_not_unknown(capsys):
    with pytest.raises(SystemExit):
        main(["report", "--time-tol", "-1", "--no-pl"])  # the missing operand is the error
    err = capsys.readouterr().err
    assert "unrecognized" not in err and "required" in err, err


def test_no_module_of_the_package_is_a_program_of_its_own():
    """Issue 41: every program is an `mfns` subcommand (or a bench under tests/bench/): no module
    of the package carries a `__main__` block but the CLI's own (cli.py, __main__.py) and
    core/binding_check.py, the build-time generator `make lib` runs with the system python3
    before the venv and the package exist (mk/binding.mk)."""
    pkg = REPO / "host_tools" / "mfns"
    allowed = {"cli.py", "__main__.py", "core/binding_check.py"}
    found = sorted(
        str(p.relative_to(pkg))
        for p in pkg.rglob("*.py")
        if '__name__ == "__main__"' in p.read_text() or "__name__ == '__main__'" in p.read_text()
    )
    assert found and set(found) <= allowed, f"modules that are programs of their own: {set(found) - allowed}"


@pytest.mark.parametrize(
    "bench, bad", [("bench_survey.py", ["survey", "OUT", "--nope"]), ("bench_calib_seeds.py", ["--nope"])]
)
def test_the_benches_that_were_package_programs_answer_help(bench, bad):
    """The two former `python -m mfns.*` programs that became benches (tests/bench/) answer --help
    and name a bad option with exit 2."""
    script = REPO / "tests" / "bench" / bench
    res = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, check=False)
    assert res.returncode == 0 and "usage:" in res.stdout, res.stderr
    res = subprocess.run([sys.executable, str(script), *bad], capture_output=True, text=True, check=False)
    assert res.returncode == 2 and "--nope" in res.stderr, res.stderr
