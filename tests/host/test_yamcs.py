"""A real ground system end to end (docs/uplink.md "Yamcs"): replayed frames -> mfns-nav
-> FIFO -> mfns-ground -> UDP -> Yamcs with the project's XTCE dictionaries; the nav
parameters read back through Yamcs' REST API equal mfns-ground's nav.csv, packet by
packet; commands issued from Yamcs (its UDP TC link -> mfns-ground) reach the flight
program and their CMD_ACCEPTED events come back, to mfns-ground and to Yamcs.

The chain runs in a private network namespace (`unshare -n`, tests/host/yamcs_chain.py)
where that works; skips, with the reason printed, where the Java runtime cannot start.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import pytest

from mfns import ground_yamcs as gy

REPO = Path(__file__).resolve().parents[2]
BIN = REPO / "build" / "host-sim" / "bin"


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def utc(s: str) -> float:
    return datetime.fromisoformat(s.replace("Z", "+00:00")).timestamp()


@pytest.fixture(scope="module")
def chain(tmp_path_factory) -> dict:
    reason = gy.why_not()
    if reason:
        print(f"\nSKIP test_yamcs: {reason}", file=sys.stderr)
        pytest.skip(reason)
    res = subprocess.run(
        ["make", "--no-print-directory", "-j2", "BOARD=host-sim", "flight"],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    d = tmp_path_factory.mktemp("yamcs")
    frames = d / "frames"
    for args in (
        ["sim", "nav", str(frames), "--quiet", "--scenario", "module", "--frames", "60", "--seed", "3"],
        [
            "table",
            "build",
            str(frames / "calib.json"),
            str(frames / "beacons.csv"),
            "-o",
            str(d / "t.mfnstbl"),
        ],
    ):
        r = subprocess.run([sys.executable, "-m", "mfns", *args], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    cmd = [sys.executable, str(REPO / "tests" / "host" / "yamcs_chain.py"), str(BIN), str(d / "t.mfnstbl"),
           str(frames), str(d / "chain")]  # fmt: skip
    env = dict(os.environ)
    unshare = shutil.which("unshare")
    if unshare and subprocess.run([unshare, "-n", "true"], capture_output=True).returncode == 0:
        cmd = [unshare, "-n", *cmd]
        env["MFNS_NETNS"] = "1"
    else:
        print("\nnote: no private network namespace here (unshare -n refused): "
              "Yamcs' UDP link listens on all "
              "interfaces for this test", file=sys.stderr)  # fmt: skip
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    out = d / "chain"
    result = json.loads((out / "result.json").read_text())
    assert "error" not in result, result.get("error")
    return {"res": result, "out": out}


def test_telemetry_through_yamcs_equals_ground_csv(chain):
    res, out = chain["res"], chain["out"]
    assert res["nav_rc"] == 0 and res["ground_rc"] == 0
    nav = rows(out / "ground" / "nav.csv")
    assert len(nav) == 60
    stats = json.loads((out / "ground" / "stats.json").read_text())
    tm = res["links"]["tm_udp"]
    # every packet mfns-ground decoded reached Yamcs, and Yamcs refused none
    assert int(tm["dataInCount"]) == stats["frames_ok"]
    assert tm["extra"]["Invalid datagrams"] == "0"
    p = res["params"]
    cycles = p["nav_cycle"]
    assert [c for _, c in cycles] == list(range(60))  # one nav packet per cycle, in order
    by_time = {name: dict(series) for name, series in p.items() if name.startswith("nav_")}
    worst = {}
    cols = {"nav_x_mm": ("x_mm", 5e-4), "nav_y_mm": ("y_mm", 5e-4), "nav_z_mm": ("z_mm", 5e-4),
            "nav_roll_deg": ("roll_deg", 5e-7), "nav_pitch_deg": ("pitch_deg", 5e-7),
            "nav_yaw_deg": ("yaw_deg", 5e-7), "nav_q_w": ("q_w", 1e-8),
            "nav_cov_x_x": ("cov_x_x", 1e-6)}  # fmt: skip
    for t, cyc in cycles:
        row = nav[cyc]
        assert int(row["cycle"]) == cyc
        assert by_time["nav_status"][t] == row["status"], cyc
        assert by_time["nav_mode"][t] == row["mode"], cyc
        for name, (col, tol) in cols.items():
            y, g = by_time[name][t], float(row[col])
            err = abs(y - g) / (max(1.0, abs(g)) if name == "nav_cov_x_x" else 1.0)
            assert err <= tol, (cyc, name, y, g)
            worst[name] = max(worst.get(name, 0.0), abs(y - g))
    # Yamcs' generation time is the packet's UTC (the flight's time correlation, forwarded
    # by mfns-ground in the CUC field): nav.csv's utc column, to Yamcs' millisecond; a real
    # time (within the hour of the test), no longer the flight clock on 1970-01-01
    for t, cyc in cycles:
        assert abs(utc(t) - utc(nav[cyc]["utc"])) < 1.5e-3
        assert abs(utc(t) - time.time()) < 3600
    print(
        f"\nYamcs: up in {res['startup_s']:.1f} s; {stats['frames_ok']} packets in, 0 invalid; "
        f"{len(cycles)} nav packets read back (REST archive) equal nav.csv: max |diff| "
        + ", ".join(f"{k[4:]} {v:.2g}" for k, v in worst.items())
        + f"; chain {res['chain_s']:.1f} s, whole test {res['total_s']:.1f} s"
    )


def test_commands_from_yamcs_reach_the_flight_program(chain):
    res, out = chain["res"], chain["out"]
    sent = res["sent"]
    assert [s["name"] for s in sent] == ["NOOP", "SET_MODE", "SET_MODE"]
    assert int(res["links"]["tc_udp"]["dataOutCount"]) == 3
    assert len(res["cmdhist"]) == 3
    up = rows(out / "ground" / "commands.csv")
    assert [(r["seq"], r["opcode"], r["source"]) for r in up] == [
        ("0", "NOOP", "udp"), ("1", "SET_MODE", "udp"), ("2", "SET_MODE", "udp")
    ]  # fmt: skip
    ev = [e for e in rows(out / "ground" / "events.csv") if e["event"].startswith("CMD_")]
    assert [(e["event"], e["subject"], e["arg0"], e["arg1"]) for e in ev] == [
        ("CMD_ACCEPTED", "1", "0", "0"),  # NOOP
        ("CMD_ACCEPTED", "3", "1", "4"),  # SET_MODE STANDBY
        ("CMD_ACCEPTED", "3", "2", "1"),  # SET_MODE ACQUIRE
    ]
    nav = rows(out / "ground" / "nav.csv")
    standby = [int(r["cycle"]) for r in nav if r["mode"] == "STANDBY"]
    assert standby and all(r["status"] == "NO_FIX" for r in nav if r["mode"] == "STANDBY")
    assert int(ev[1]["cycle"]) == standby[0] and int(ev[2]["cycle"]) == standby[-1] + 1
    # the events came back to Yamcs too
    codes = [c for _, c in res["params"]["evt_code"]]
    assert codes.count("CMD_ACCEPTED") == 3
    lat = [utc(e["ground_utc"]) - s["t"] for e, s in zip(ev, sent, strict=True)]
    assert all(0 < x < 3.0 for x in lat), lat
    print(
        f"\nYamcs command -> UDP -> mfns-ground -> FIFO -> mfns-nav -> event back at the ground: "
        f"{', '.join(f'{x * 1e3:.0f} ms' for x in lat)}; STANDBY for cycles {standby[0]}..{standby[-1]}"
    )
