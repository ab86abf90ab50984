"""mfns-nav on the board (issue 24 items 3, 7): the configuration file and its
errors, the start-up self-test events, the table store (a TABLE_LOAD survives a
restart, a corrupt stored table rolls back to the previous one), a missing
camera reported by its identity, and honest exits (docs/operations.md)."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = REPO / "build" / "host-sim" / "bin"


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def replay(tmp_path_factory) -> dict:
    res = subprocess.run(
        ["make", "--no-print-directory", "-j2", "BOARD=host-sim", "flight"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    d = tmp_path_factory.mktemp("app")
    frames = d / "frames"
    cmds = [
        ["sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "12", "--seed", "6"],
        [
            "table",
            "build",
            str(frames / "calib.json"),
            str(frames / "beacons.csv"),
            "-o",
            str(d / "t1.mfnstbl"),
        ],
        [
            "table",
            "build",
            str(frames / "calib.json"),
            str(frames / "beacons.csv"),
            "-o",
            str(d / "t2.mfnstbl"),
            "--pixel-sigma",
            "0.3",
        ],
    ]
    for args in cmds:
        r = subprocess.run([sys.executable, "-m", "mfns", *args], capture_output=True, text=True, check=False)
        assert r.returncode == 0, r.stderr
    return {"dir": d, "frames": frames, "t1": d / "t1.mfnstbl", "t2": d / "t2.mfnstbl"}


def crc_of(table: Path) -> int:
    """The table's identity: the body CRC-32 its header carries at byte 12 (docs/caltable.md)."""
    return int.from_bytes(table.read_bytes()[12:16], "little")


def fly(
    tmp: Path, name: str, args: list[str], check_rc: int | None = 0
) -> tuple[subprocess.CompletedProcess, list]:
    tlm = tmp / f"{name}.bin"
    nav = subprocess.run(
        [str(BIN / "mfns-nav"), *args, "--file", str(tlm)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=tmp,
    )
    if check_rc is not None:
        assert nav.returncode == check_rc, nav.stderr
    out = tmp / f"{name}-g"
    subprocess.run([str(BIN / "mfns-ground"), "--file", str(tlm), "--out", str(out), "-q"], check=False)
    ev = rows(out / "events.csv") if (out / "events.csv").exists() else []
    return nav, ev


def ev_named(ev: list[dict], name: str) -> list[dict]:
    return [e for e in ev if e["event"] == name]


def tc_stream(tmp: Path, cmds: list[str]) -> Path:
    """Unsigned command frames (the flight side runs with --tc-insecure)."""
    src = tmp / "empty.bin"
    src.write_bytes(b"")
    out = tmp / "tc.bin"
    args = [
        str(BIN / "mfns-ground"),
        "--file",
        str(src),
        "--out",
        str(tmp / "g-enc"),
        "--no-status",
        "--tc-file",
        str(out),
    ]
    for c in cmds:
        args += ["--cmd", c]
    r = subprocess.run(args, capture_output=True, text=True, check=False, timeout=30)
    assert r.returncode in (0, 3) and f"uplink: {len(cmds)} commands sent, 0 errors" in r.stderr, r.stderr
    return out


def test_config_file_with_command_line_overrides_and_self_test(replay, tmp_path):
    state = tmp_path / "state"
    state.mkdir()
    conf = tmp_path / "mfns-nav.conf"
    conf.write_text(
        "# a bench configuration\n"
        "cameras = v4l2\n"
        "cam_x = bus_info:platform:vivid-000\n"
        f"table = {replay['t1']}\n"
        f"state_dir = {state}\n"
        "uart = /dev/ttyAMA0\n"
        "budget_units = 4000\n"
    )
    # the line's --replay replaces the file's cameras, its --file the file's uart
    nav, ev = fly(tmp_path, "c", ["--config", str(conf), "--replay", str(replay["frames"]), "-q"])
    assert nav.stderr == ""
    names = [e["event"] for e in ev]
    start = names[: names.index("SELFTEST_DONE") + 1]
    assert start == [
        "BOOT",
        "SELFTEST_TABLE",
        "TABLE_LOADED",
        "CYCLE_BUDGET",
        "SELFTEST_UART",
        "SELFTEST_CLOCK",
        "SELFTEST_CAMERA",
        "SELFTEST_CAMERA",
        "SELFTEST_CAMERA",
        "SELFTEST_DONE",
    ]
    st = {e["event"]: e for e in ev}
    assert st["SELFTEST_TABLE"]["subject"] == "0" and int(st["SELFTEST_TABLE"]["arg1"], 16) == crc_of(
        replay["t1"]
    )
    assert st["CYCLE_BUDGET"]["subject"] == "1" and st["CYCLE_BUDGET"]["arg1"] == "4000"  # the board's budget
    assert st["SELFTEST_UART"]["subject"] == "2"  # a file: no link to check
    clk = int(st["SELFTEST_CLOCK"]["arg0"])
    assert st["SELFTEST_CLOCK"]["subject"] == "0" and clk & 0b101 == 0b101  # UTC set, monotonic advancing
    cams = ev_named(ev, "SELFTEST_CAMERA")
    assert [(c["subject"], c["arg0"]) for c in cams] == [
        ("0", "3"),
        ("1", "3"),
        ("2", "3"),
    ]  # replay: not streamed
    done = st["SELFTEST_DONE"]
    assert done["subject"] == "0" and done["arg0"] == "7" and done["arg1"] == "5"
    # the initial table was copied into the store
    assert (state / "table.mfnstbl").read_bytes() == replay["t1"].read_bytes()
    # the cycle margin (issue 24 item 6): the frame period from the stamps (18.6 Hz), less the longest cycle
    hk = rows(tmp_path / "c-g" / "housekeeping.csv")
    last = hk[-1]
    assert int(last["frame_period_us"]) == pytest.approx(1e6 / 18.6, abs=60)
    assert int(last["cycle_margin_us"]) == int(last["frame_period_us"]) - int(last["cycle_max_us"])
    assert hk[0]["frame_period_us"] == "0" and hk[0]["cycle_margin_us"] == "0"  # before any cycle: unknown


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("cameras = v4l2\nbaud = fast\n", "line 2: key 'baud': wants a number 1200..4000000, got 'fast'"),
        ("cameras = v4l2\n\nstate-dir = /var/lib/mfns\n", "line 3: unknown key 'state-dir'"),
        ("table = a.mfnstbl\n", "line 1: key 'table': wants an absolute path"),
        ("cam_x = a\ncam_x = b\n", "line 2: key 'cam_x' given twice (first on line 1)"),
        ("uart = /dev/ttyAMA0\ntty = /dev/pts/1\n", ":2: key 'tty': excludes 'uart' (line 1)"),
    ],
)
def test_config_errors_name_the_line_and_key(tmp_path, text, needle):
    conf = tmp_path / "bad.conf"
    conf.write_text(text)
    res = subprocess.run(
        [str(BIN / "mfns-nav"), "--config", str(conf)], capture_output=True, text=True, check=False
    )
    assert res.returncode == 2 and needle in res.stderr and str(conf) in res.stderr, res.stderr


def test_table_load_survives_a_restart_and_a_corrupt_store_rolls_back(replay, tmp_path):
    state = tmp_path / "state"
    state.mkdir()
    base = ["--table", str(replay["t1"]), "--replay", str(replay["frames"]), "--state-dir", str(state), "-q"]
    tc = tc_stream(tmp_path, [f"TABLE_LOAD {replay['t2']}"])
    nav, ev = fly(tmp_path, "load", [*base, "--tc-file", str(tc), "--tc-insecure", "--max-cycles", "4"])
    stored = ev_named(ev, "TABLE_STORED")
    assert (
        len(stored) == 1
        and stored[0]["subject"] == "0"
        and int(stored[0]["arg1"], 16) == crc_of(replay["t2"])
    )
    assert (state / "table.mfnstbl").read_bytes() == replay["t2"].read_bytes()
    assert (state / "table.prev.mfnstbl").read_bytes() == replay["t1"].read_bytes()
    assert not (state / "table.tmp").exists()

    # a restart (the same --table on the line) runs the stored table, and says that the
    # --table given (t1) is not the one that runs (issue 45: it was silently overridden)
    nav, ev = fly(tmp_path, "restart", [*base, "--max-cycles", "2"])
    st = ev_named(ev, "SELFTEST_TABLE")[0]
    assert st["subject"] == "0" and int(st["arg1"], 16) == crc_of(replay["t2"])
    assert not ev_named(ev, "TABLE_ROLLBACK")
    ov = ev_named(ev, "TABLE_ARG_OVERRIDDEN")
    assert len(ov) == 1 and int(ov[0]["arg1"], 16) == crc_of(replay["t2"]), ov
    assert int(ov[0]["arg0"]) == replay["t1"].stat().st_size and ov[0]["severity"] == "WARNING"
    assert "differs from the stored table, which runs" in nav.stderr, nav.stderr
    # the --table that is the stored one: nothing to say
    nav, ev = fly(tmp_path, "same", ["--table", str(replay["t2"]), *base[2:], "--max-cycles", "2"])
    assert not ev_named(ev, "TABLE_ARG_OVERRIDDEN") and "differs" not in nav.stderr

    # the stored table corrupted on the medium: the previous one runs, the bad one is kept aside
    data = bytearray((state / "table.mfnstbl").read_bytes())
    data[300] ^= 0xFF
    (state / "table.mfnstbl").write_bytes(bytes(data))
    nav, ev = fly(tmp_path, "rollback", [*base, "--max-cycles", "2"])
    assert "rolled back to the previous one" in nav.stderr
    st = ev_named(ev, "SELFTEST_TABLE")[0]
    rb = ev_named(ev, "TABLE_ROLLBACK")
    assert (
        st["subject"] == "2" and st["severity"] == "WARNING" and int(st["arg1"], 16) == crc_of(replay["t1"])
    )
    assert len(rb) == 1 and int(rb[0]["arg1"], 16) == crc_of(replay["t1"]) and rb[0]["arg0"] != "0"
    assert (state / "table.bad.mfnstbl").read_bytes() == bytes(data)
    assert (state / "table.mfnstbl").read_bytes() == replay["t1"].read_bytes()
    assert ev_named(ev, "SELFTEST_DONE")[0]["subject"] == "1"  # the table check counts as failed

    # nothing validates (store corrupt, no previous, --table corrupt): refused, exit 2, the cause named
    (state / "table.mfnstbl").write_bytes(bytes(data))
    bad = tmp_path / "bad.mfnstbl"
    bad.write_bytes(bytes(data))
    nav, ev = fly(
        tmp_path,
        "none",
        ["--table", str(bad), "--replay", str(replay["frames"]), "--state-dir", str(state)],
        check_rc=2,
    )
    assert "refused" in nav.stderr and "CRC" in nav.stderr, nav.stderr
    assert ev_named(ev, "SELFTEST_TABLE")[0]["subject"] == "1" and ev_named(ev, "TABLE_REFUSED")


def test_missing_cameras_are_reported_by_identity(replay, tmp_path):
    """No V4L2 device here: each identity is reported missing (SELFTEST_CAMERA 1), and with no
    camera at all the program stops with exit 2 (a board with one camera left runs on it)."""
    nav, ev = fly(
        tmp_path,
        "nocam",
        [
            "--table",
            str(replay["t1"]),
            "--v4l2",
            "--cam-x",
            "bus_info:platform:vivid-000",
            "--cam-y",
            "card:cam-y",
            "--cam-z",
            "/dev/v4l/by-path/none",
        ],
        check_rc=2,
    )
    assert "no capture node among /dev/video0..63 has bus_info 'platform:vivid-000'" in nav.stderr
    assert "has card 'cam-y'" in nav.stderr and "/dev/v4l/by-path/none" in nav.stderr
    assert "no camera opened" in nav.stderr
    cams = ev_named(ev, "SELFTEST_CAMERA")
    assert [(c["subject"], c["arg0"], c["severity"]) for c in cams] == [
        ("0", "1", "ERROR"),
        ("1", "1", "ERROR"),
        ("2", "1", "ERROR"),
    ]
    assert ev_named(ev, "SELFTEST_DONE")[0]["subject"] == "3"


@pytest.mark.parametrize("opt", ["--tty", "--serial"])
def test_a_link_that_never_opened_exits_nonzero_with_its_cause(replay, tmp_path, opt):
    """Issue 24 item 7: every telemetry frame lost is a failure, and the message says why."""
    res = subprocess.run(
        [
            str(BIN / "mfns-nav"),
            "--table",
            str(replay["t1"]),
            "--replay",
            str(replay["frames"]),
            opt,
            "/nonexistent/tty",
            "--max-cycles",
            "3",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert res.returncode == 3, res.stderr
    assert "/nonexistent/tty never opened" in res.stderr and "none of" in res.stderr, res.stderr


def test_the_shipped_configuration_is_read(replay, tmp_path):
    """boards/sitss-nav/service/mfns-nav.conf (installed as /etc/mfns/mfns-nav.conf) parses, and
    the unit reads it; on the host its devices are replaced by a replay from the command line."""
    conf = REPO / "boards/sitss-nav/service/mfns-nav.conf"
    unit = (REPO / "boards/sitss-nav/service/mfns-nav.service").read_text()
    assert "--config /etc/mfns/mfns-nav.conf" in unit
    state = tmp_path / "state"
    state.mkdir()
    nav, ev = fly(
        tmp_path,
        "shipped",
        [
            "--config",
            str(conf),
            "--replay",
            str(replay["frames"]),
            "--table",
            str(replay["t1"]),
            "--state-dir",
            str(state),
            "--max-cycles",
            "2",
            "-q",
        ],
    )
    assert ev_named(ev, "SELFTEST_DONE")[0]["subject"] == "0"
    install = subprocess.run(
        [
            "make",
            "--no-print-directory",
            "BOARD=host-sim",
            "install",
            f"DESTDIR={tmp_path / 'root'}",
            "PREFIX=/usr",
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert install.returncode == 0, install.stderr
    assert (tmp_path / "root/etc/mfns/mfns-nav.conf").read_bytes() == conf.read_bytes()


def test_a_missing_table_says_why(replay, tmp_path):
    nav, ev = fly(
        tmp_path, "notable", ["--table", str(tmp_path / "none.mfnstbl"), "--replay", str(replay["frames"])], 2
    )
    assert (
        "none.mfnstbl refused: calibration table file cannot be opened: No such file or directory"
        in nav.stderr
    )
    assert ev_named(ev, "SELFTEST_TABLE")[0]["subject"] == "1" and ev_named(ev, "TABLE_REFUSED")
