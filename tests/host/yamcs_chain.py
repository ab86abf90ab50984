"""The Yamcs chain of tests/host/test_yamcs.py, run inside a private network namespace
(`unshare -n python tests/host/yamcs_chain.py ...`) so Yamcs' UDP link, which listens on
every interface, sees loopback only, and its fixed ports collide with nothing.

  replay frames -> mfns-nav -> FIFO -> mfns-ground -> UDP -> Yamcs (XTCE MDB)
  Yamcs command -> UDP -> mfns-ground -> FIFO -> mfns-nav -> event -> ... -> Yamcs

Writes OUT/result.json: Yamcs' start-up time, its link counters, the nav parameters read
back through the REST API (archive, per packet), the command events, the commands Yamcs
issued and the times; mfns-ground's CSVs are in OUT/ground. The test compares them.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.parse
from pathlib import Path

from mfns import ground_yamcs as gy

NAV_PARAMS = ["nav_cycle", "nav_status", "nav_mode", "nav_x_mm", "nav_y_mm", "nav_z_mm", "nav_roll_deg",
              "nav_pitch_deg", "nav_yaw_deg", "nav_q_w", "nav_cov_x_x"]  # fmt: skip
EVENT_PARAMS = ["evt_code", "evt_subject", "evt_arg0", "evt_arg1"]


def value(v: dict):
    ev = v.get("engValue", {})
    if ev.get("type") == "ENUMERATED":
        return ev.get("stringValue")
    for k in (
        "doubleValue",
        "floatValue",
        "sint64Value",
        "uint64Value",
        "sint32Value",
        "uint32Value",
        "stringValue",
    ):
        if k in ev:
            return (
                float(ev[k])
                if k in ("doubleValue", "floatValue")
                else (ev[k] if k == "stringValue" else int(ev[k]))
            )
    return None


def archive(name: str) -> list[tuple[str, object]]:
    q = urllib.parse.urlencode(
        {
            "start": "1970-01-01T00:00:00Z",
            "stop": "2200-01-01T00:00:00Z",
            "limit": 1000,
            "order": "asc",
            "source": "replay",
        }  # fmt: skip
    )
    out: list[tuple[str, object]] = []
    try:
        r = gy.get(f"/api/archive/{gy.INSTANCE}/parameters/MFNS/{name}?{q}", timeout=30)
    except urllib.error.HTTPError as e:
        raise RuntimeError(f"archive {name}: HTTP {e.code} {e.read()[:200]!r}") from e
    for v in r.get("parameter", []):
        out.append((v["generationTime"], value(v)))
    return out


def main() -> int:
    bins, table, frames, out = (Path(a) for a in sys.argv[1:5])
    out.mkdir(parents=True, exist_ok=True)
    res: dict = {"netns": gy.in_private_netns()}
    if res["netns"]:
        gy.loopback_up()
    t0 = time.monotonic()
    yamcs = gy.start(out / "yamcs-run", out / "yamcs.log")
    nav = ground = None
    try:
        res["startup_s"] = gy.wait_ready(yamcs)
        t_chain = time.monotonic()
        tlm, tc = out / "tlm.fifo", out / "tc.fifo"
        for f in (tlm, tc):
            if f.exists():
                f.unlink()
            os.mkfifo(f)
        nav_log, g_log = open(out / "nav.log", "w"), open(out / "ground.log", "w")
        # a throw-away board key (mode 0600) and a fresh state directory: mfns-ground signs
        # what Yamcs sends (docs/uplink.md 1a), mfns-nav verifies
        key, state = out / "board.key", out / "state"
        if key.exists():
            key.unlink()
        fd = os.open(key, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(f"1 {os.urandom(32).hex()}\n")
        shutil.rmtree(state, ignore_errors=True)
        state.mkdir()
        nav = subprocess.Popen(
            [str(bins / "mfns-nav"), "--table", str(table), "--replay", str(frames), "--realtime",
             "--tty", str(tlm), "--tc-tty", str(tc), "--tc-key", str(key), "--state-dir", str(state)],
            stderr=nav_log,
        )  # fmt: skip
        ground = subprocess.Popen(
            [str(bins / "mfns-ground"), "--tty", str(tlm), "--out", str(out / "ground"), "--no-status",
             "--max-seconds", "60", "--tc-tty", str(tc),
             "--udp-forward", f"127.0.0.1:{gy.TM_PORT}", "--udp-tc", f"127.0.0.1:{gy.TC_PORT}",
             "--tc-key", str(key)],
            stderr=g_log,
        )  # fmt: skip
        time.sleep(0.5)
        sent = []
        for cmd, args in (("NOOP", {}), ("SET_MODE", {"mode": "STANDBY"}), ("SET_MODE", {"mode": "ACQUIRE"})):
            t_issue = time.time()  # before the REST call: Yamcs may release the command before it answers
            r = gy.post(f"/api/processors/{gy.INSTANCE}/realtime/commands/MFNS_TC/{cmd}", {"args": args})
            sent.append(
                {"name": cmd, "args": args, "id": r.get("id"), "binary": r.get("binary"), "t": t_issue}
            )
            time.sleep(0.15)
        res["sent"] = sent
        nav.wait(timeout=120)
        time.sleep(0.7)  # the last telemetry through the ground station and UDP
        ground.send_signal(signal.SIGINT)
        ground.wait(timeout=30)
        res["nav_rc"], res["ground_rc"] = nav.returncode, ground.returncode
        res["chain_s"] = time.monotonic() - t_chain
        time.sleep(1.0)  # Yamcs archives what it received
        res["links"] = {lk["name"]: lk for lk in gy.get(f"/api/links/{gy.INSTANCE}")["links"]}
        res["params"] = {n: archive(n) for n in NAV_PARAMS + EVENT_PARAMS}
        res["realtime_x"] = gy.get(f"/api/processors/{gy.INSTANCE}/realtime/parameters/MFNS/nav_x_mm")
        res["cmdhist"] = gy.get(f"/api/archive/{gy.INSTANCE}/commands?limit=100").get("commands", [])
        res["total_s"] = time.monotonic() - t0
    except Exception as e:  # reported to the test, which fails with it
        res["error"] = f"{type(e).__name__}: {e}"
    finally:
        for p in (nav, ground):
            if p is not None and p.poll() is None:
                p.kill()
        gy.stop(yamcs)
    (out / "result.json").write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
