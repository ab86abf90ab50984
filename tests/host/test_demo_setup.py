"""`make demo` needs only the demo set of mk/deps.sh; `make test` installs everything.

A newcomer's `make demo` must not pull in cross compilers, qemu, linters or cmocka, and it
must not call them: checked on the dry run of the whole demo (`make -n -B demo`, which
prints every command, including the sub-make's, without running any; V=1, since the quiet
demo sends the build's output to its log).
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
TEST_ONLY = ("aarch64", "arm-none-eabi", "qemu", "cppcheck", "clang", "valgrind", "libcamera", "cmocka")


def package_set(name: str) -> set[str]:
    text = (REPO / "mk" / "deps.sh").read_text()
    m = re.search(rf'^{name}_PKGS="([^"]*)"', text, re.M)
    assert m, f"mk/deps.sh has no {name}_PKGS"
    return set(
        m.group(1).replace("$DEMO_PKGS", " ".join(package_set("DEMO") if name != "DEMO" else [])).split()
    )


def test_demo_set_is_light_and_test_set_has_everything():
    demo, test = package_set("DEMO"), package_set("TEST")
    assert {"build-essential", "pkg-config", "libserialport-dev", "python3-venv"} <= demo
    assert not [p for p in demo if any(t in p for t in TEST_ONLY)], demo
    assert demo < test
    for tool in ("gcc-aarch64-linux-gnu", "qemu-user", "gcc-arm-none-eabi", "clang-tidy", "libcmocka-dev"):
        assert tool in test


def test_make_demo_calls_no_test_tool():
    res = subprocess.run(
        ["make", "-n", "-B", "--no-print-directory", "demo", "V=1"],  # V=1: the build's commands shown
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert "mk/deps.sh demo" in out and "mk/deps.sh test" not in out
    assert "mk/demo.sh" in out and "mfns-nav" in out and "libmfns_core.so" in out
    for line in out.splitlines():
        if line.startswith(("gcc", "g++", "cc ", "ar ")):
            assert not any(t in line for t in ("aarch64", "arm-none-eabi", "clang")), line
    assert "qemu" not in out and "cppcheck" not in out and "clang-tidy" not in out
