"""Issue 41 item 5: mfns-nav's options and configuration keys are written once
(firmware/app/nav_opts_table.h). tests/unit/test_nav_opts.c checks the views the
program prints (--help, --help-man) against the table; this checks the views
written by hand beside it -- docs/operations.md's key table and the board's
commented configuration -- against the man page the program writes."""

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _man(bins: Path) -> str:
    res = subprocess.run([str(bins / "mfns-nav"), "--help-man"], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    return res.stdout


def _man_keys(man: str) -> dict[str, str]:
    """key -> the option it stands for, from the man page's CONFIGURATION section."""
    conf = man.split(".SH CONFIGURATION", 1)[1].split(".SH ", 1)[0]
    keys = dict(re.findall(r"^\.B ([a-z_]+)\n.*; the option \\-\\-(\S+)$", conf, flags=re.M))
    return {k: v.replace("\\-", "-") for k, v in keys.items()}


def test_man_page_lists_options_and_keys(bins):
    man = _man(bins)
    assert man.startswith(".TH MFNS-NAV 1 ")
    keys = _man_keys(man)
    assert len(keys) == 15 and keys["uart"] == "serial" and keys["cameras"] == "v4l2"
    section = man.split(".SH OPTIONS", 1)[1].split(".SH ", 1)[0]
    # each tag: .B --name, .BI "--name " META or .BR -v ", " --name
    tags = re.findall(r"^\.TP\n\.B[IR]? (.*)$", section, flags=re.M)
    options = {re.findall(r"\\-\\-((?:[a-z0-9]|\\-)+)", t)[0].replace("\\-", "-") for t in tags}
    assert set(keys.values()) <= options
    assert {"table", "replay", "config", "init-pose", "tlm-tty", "help-man", "verbose"} <= options
    assert len(options) == len(tags) == 38
    help_text = subprocess.run([str(bins / "mfns-nav"), "--help"], capture_output=True, text=True).stdout
    for opt in options:  # --help lists the same options
        assert f"--{opt}" in help_text


def test_operations_md_key_table_is_the_programs(bins):
    keys = _man_keys(_man(bins))
    text = (REPO / "docs/operations.md").read_text()
    documented: dict[str, str] = {}
    for row in re.findall(r"^\| (`[a-z_]+`(?:, `[a-z_]+`)*) \| .* \| (.+) \|$", text, flags=re.M):
        for key in re.findall(r"`([a-z_]+)`", row[0]):
            documented[key] = row[1]
    assert set(documented) == set(keys), "docs/operations.md's key table and mfns-nav --help-man differ"
    for key, opt in keys.items():
        assert f"--{opt}" in documented[key], (key, opt, documented[key])


def test_board_configuration_uses_known_keys(bins):
    keys = _man_keys(_man(bins))
    conf = (REPO / "boards/sitss-nav/service/mfns-nav.conf").read_text()
    used = re.findall(r"^#?([a-z_]+) *=", conf, flags=re.M)
    assert used and set(used) <= set(keys), set(used) - set(keys)
