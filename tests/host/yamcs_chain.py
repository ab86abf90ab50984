"""The Yamcs chain of tests/host/test_yamcs.py, run inside a private network namespace
(`unshare -n python tests/host/yamcs_chain.py ...`) so Yamcs' UDP link, which listens on
every interface, sees loopback only, and its fixed ports collide with nothing.

  replay frames -> mfns-nav -> FIFO -> mfns-ground -> UDP -> Yamcs (XTCE MDB)
  Yamcs command -> UDP -> mfns-ground -> FIFO -> mfns-nav -> event -> ... -> Yamcs verifiers
  Yamcs -> yamcs-client -> the operator view (mfns.ground.ground_yamcs_view) -> headless Chromium

Everything is read back through yamcs-client. Writes OUT/result.json: Yamcs' start-up time,
its link counters, the nav parameters of the archive (per packet), the commands issued and
their command history (verifier states and times), the events and alarms Yamcs raised, the
operator view's DOM values taken during and after the replay, and the times; mfns-ground's
CSVs are in OUT/ground. The test compares them. Screenshots go to SHOTS (argument 5).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from datetime import UTC, datetime
from html.parser import HTMLParser
from pathlib import Path

from yamcs.client.core.exceptions import TimeoutError as YamcsTimeout

from mfns.ground import ground_yamcs as gy
from mfns.ground import ground_yamcs_view as view
from mfns.tlm import tlm_dict

NAV_PARAMS = [
    "nav_cycle",
    "nav_status",
    "nav_mode",
    "nav_pl_pos_mm",
    "nav_sigma_x_mm",
    "nav_x_mm",
    "nav_y_mm",
    "nav_z_mm",
    "nav_roll_deg",
    "nav_pitch_deg",
    "nav_yaw_deg",
    "nav_q_w",
    "nav_cov_x_x",
]
EVENT_PARAMS = ["evt_code", "evt_subject", "evt_arg0", "evt_arg1"]
# the pose's validity in Yamcs itself (issue 46): the pose parameters are read only from a
# packet that carries a pose (mfns_tm.xml nav_pose), and expire (processor.yaml
# expirationTolerance x the containers' DefaultRateInStream) when no fresh one comes
VALIDITY_PARAMS = ["/MFNS/nav_status", "/MFNS/nav_x_mm", "/MFNS/nav_sigma_x_mm", "/MFNS/nav_pl_pos_mm"]
VIEW_PORT = 8095
CPU_LOAD_INJECTED_PCT = 90.0  # above the 80 % the ground dictionary warns at
WORKSPACE_INJECTED = "LOST_OUTSIDE"  # workspace_t: CRITICAL in mfns_tm.xml


def iso(t) -> str | None:
    return view.iso(t)


def archive_values(arch, name: str) -> list[tuple[str, object]]:
    start, stop = datetime(1970, 1, 1, tzinfo=UTC), datetime(2200, 1, 1, tzinfo=UTC)
    return [
        (iso(v.generation_time), view.plain(v.eng_value))
        for v in arch.list_parameter_values(f"/MFNS/{name}", start=start, stop=stop, source="replay")
    ]


class Dom(HTMLParser):
    """Text of every element with an id, and the data-* of alarm and command rows."""

    def __init__(self) -> None:
        super().__init__()
        self.text: dict[str, str] = {}
        self.rows: list[dict] = []
        self._stack: list[str | None] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "tr" and a.get("class") in ("alarm", "command"):
            self.rows.append({k: v for k, v in a.items()})
        self._stack.append(a.get("id"))
        if a.get("id"):
            self.text[a["id"]] = ""

    def handle_endtag(self, tag):
        if self._stack:
            self._stack.pop()

    def handle_data(self, data):
        for i in self._stack:
            if i:
                self.text[i] += data


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def browse(out: Path, name: str, shot: Path | None) -> dict:
    """Headless Chromium loads the view: its DOM (after the page's own polling ran) and,
    when asked, a screenshot."""
    exe = chromium()
    # nice 19: Chromium's start-up must not starve Yamcs, whose UDP link drops what its socket
    # buffer cannot hold while the server waits for the CPU (2 shared cores)
    common = [
        "nice",
        "-n",
        "19",
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        f"--user-data-dir={out / 'chromium-profile'}",
        "--virtual-time-budget=3000",
        "--window-size=1280,900",
    ]
    url = f"http://127.0.0.1:{VIEW_PORT}/"
    t0 = time.time()
    r = subprocess.run([*common, "--dump-dom", url], capture_output=True, text=True, timeout=90)
    (out / f"view-{name}.html").write_text(r.stdout)
    d = Dom()
    d.feed(r.stdout)
    res = {"rc": r.returncode, "t": t0, "text": d.text, "rows": d.rows, "stderr": r.stderr[-800:]}
    if shot is not None:
        shot.parent.mkdir(parents=True, exist_ok=True)
        s = subprocess.run([*common, f"--screenshot={shot}", url], capture_output=True, text=True, timeout=90)
        res["shot"] = str(shot) if s.returncode == 0 and shot.exists() else None
    return res


def archive_settled(client, arch, timeout_s: float) -> tuple[int, float]:
    """The archive's packet count once it equals what the TM links received and stays so for
    one more poll (Yamcs archives asynchronously), waiting at most timeout_s: (count, seconds)."""
    t0 = time.monotonic()
    last = -1
    while True:
        n_in = sum(lk.in_count for lk in client.list_links(gy.INSTANCE) if lk.name.startswith("tm_"))
        n = sum(1 for _ in arch.list_packets(page_size=1000))
        if (n == n_in and n == last) or time.monotonic() - t0 > timeout_s:
            return n, time.monotonic() - t0
        last = n
        time.sleep(0.3)


def cpu_packet(arch) -> bytes:
    """The last housekeeping packet of this run, its CPU load field set to
    CPU_LOAD_INJECTED_PCT, its workspace state to LOST_OUTSIDE and its time to now: the
    flight cannot be made busy, or its robot be carried out of the table's box, on demand
    in this chain (the flight's own LOST_OUTSIDE: test_e2e_nav.py); the packet is otherwise
    the flight's own."""
    pkts = list(arch.list_packets(name="/MFNS/housekeeping", descending=True, page_size=1))
    pkt = bytearray(next(iter(pkts)).binary)
    d = tlm_dict.load()
    f = next(f for f in d.packets["housekeeping"].fields if f.param == "hk_cpu_load_pct")
    hdr = max(h.offset + h.size for h in d.header)  # primary header + CUC time
    raw = round(CPU_LOAD_INJECTED_PCT / f.coefficient)
    pkt[hdr + f.offset : hdr + f.offset + f.size] = raw.to_bytes(f.size, "big")
    w = next(f for f in d.packets["housekeeping"].fields if f.param == "hk_workspace")
    code = next(v for v, lab in d.labels("workspace_t").items() if lab == WORKSPACE_INJECTED)
    pkt[hdr + w.offset : hdr + w.offset + w.size] = code.to_bytes(w.size, "big")
    now = time.time()
    pkt[6:12] = int(now).to_bytes(4, "big") + int((now % 1) * 65536).to_bytes(2, "big")
    return bytes(pkt)


class Deliveries:
    """Every value Yamcs' realtime processor delivers of VALIDITY_PARAMS, expirations included
    (update_on_expiration): (receipt time, name, value, acquisition status, generation time,
    validity ms)."""

    def __init__(self, proc) -> None:
        self.lock = threading.Lock()
        self.rows: list[tuple] = []
        self.sub = proc.create_parameter_subscription(
            VALIDITY_PARAMS, on_data=self._on_data, abort_on_invalid=False, update_on_expiration=True
        )

    def _on_data(self, data) -> None:
        now = time.time()
        with self.lock:
            for p in data.parameters:
                self.rows.append(
                    (
                        now,
                        p.name,
                        view.plain(p.eng_value),
                        p.validity_status,
                        iso(p.generation_time),
                        p.validity_duration.total_seconds() * 1e3 if p.validity_duration else None,
                    )
                )


def main() -> int:
    bins, table, table2, frames, out, shots = (Path(a) for a in sys.argv[1:7])
    out.mkdir(parents=True, exist_ok=True)
    res: dict = {"netns": gy.in_private_netns(), "chromium": chromium()}
    if res["netns"]:
        gy.loopback_up()
    t0 = time.monotonic()
    yamcs = gy.start(out / "yamcs-run", out / "yamcs.log")
    nav = ground = None
    stop_view = threading.Event()
    try:
        res["startup_s"] = gy.wait_ready(yamcs)
        client = gy.client()
        proc = client.get_processor(gy.INSTANCE, "realtime")
        arch = client.get_archive(gy.INSTANCE)
        ready = threading.Event()
        vt = threading.Thread(target=view.serve, args=(VIEW_PORT, ready, stop_view), daemon=True)
        vt.start()
        ready.wait(30)
        conn = proc.create_command_connection()
        deliveries = Deliveries(proc)
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
        ground = subprocess.Popen(
            [
                str(bins / "mfns-ground"),
                "--tty",
                str(tlm),
                "--out",
                str(out / "ground"),
                "--no-status",
                "--max-seconds",
                "60",
                "--tc-tty",
                str(tc),
                "--tcp-forward",  # lossless: Yamcs' tm_tcp link connects to it
                f"127.0.0.1:{gy.TM_TCP_PORT}",
                "--udp-tc",
                f"127.0.0.1:{gy.TC_PORT}",
                "--tc-key",
                str(key),
                "--tc-state",  # the ground gives the board its epochs (docs/uplink.md 1a)
                str(out / "ground-uplink.state"),
            ],
            stderr=g_log,
        )
        # the ground station listens first and Yamcs' TCP link connects to it, then the flight
        # program starts: every packet it sends has its way to the archive
        res["tcp_connect_s"] = gy.connect_tcp_link()
        nav = subprocess.Popen(
            [
                str(bins / "mfns-nav"),
                "--table",
                str(table),
                "--replay",
                str(frames),
                "--realtime",
                "--tty",
                str(tlm),
                "--tc-tty",
                str(tc),
                "--tc-key",
                str(key),
                "--state-dir",
                str(state),
            ],
            stderr=nav_log,
        )
        t_nav = time.monotonic()
        truth = (frames / "truth.csv").read_text().splitlines()
        hint = dict(zip(truth[0].split(","), (float(x) for x in truth[21].split(",")), strict=True))
        plan = [
            (0.8, "NOOP", {}),
            # a second NOOP released the moment the first one's answer is Yamcs' latest event:
            # only its own answer (its sequence count) may verify it
            (0.9, "NOOP_AFTER_ANSWER", {}),
            (
                1.4,
                "SET_POSE_HINT",
                {k: round(hint[k], 3) for k in ("x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg")},
            ),
            (1.8, "TABLE_LOAD", {"path": "/nonexistent/table.mfnstbl"}),  # the flight refuses it
            (2.2, "SET_MODE", {"mode": "STANDBY"}),
            # 3.2 s in STANDBY: a no-fix run of 10 or more packets on its own (STANDBY's NO_FIX
            # packets come about 4 a second: 7 in 1.8 s measured), whatever the availability
            # around it (the run used to lean on PL_EXCEEDS_AL fixes before and after it)
            (5.4, "SET_MODE", {"mode": "ACQUIRE"}),
            (6.0, "VIEW", {}),  # the operator view while the robot flies (Chromium in the background)
            (7.2, "TABLE_LOAD", {"path": str(table2)}),  # another table: its CRC changes
        ]
        sent = []
        browser = None
        for at, cmd, args in sorted(plan, key=lambda p: p[0]):
            time.sleep(max(0.0, at - (time.monotonic() - t_nav)))
            if cmd == "VIEW":

                def during() -> None:
                    res["view_during"] = browse(out, "during", shots / "operator-view-during.png")

                browser = threading.Thread(target=during)
                browser.start()
                continue
            extra = {}
            if cmd == "NOOP_AFTER_ANSWER":  # right after the first NOOP was verified by its answer
                cmd = "NOOP"
            t_issue = time.time()  # before the call: Yamcs may release the command before it answers
            ic = conn.issue(f"/MFNS_TC/{cmd}", args=args)
            sent.append({"name": cmd, "args": args, "id": ic.id, "t": t_issue, **extra})
            # one command at a time, as an operator sends them: the next is released after this
            # one's verification ended (Yamcs 5.12.8 drops the rest of a packet's processing when
            # a finished verifier unsubscribes while that packet is processed, docs/operators.md)
            try:
                ic.await_complete(timeout=12.0)
            except (TimeoutError, YamcsTimeout):  # yamcs-client's own is not the builtin one
                sent[-1]["not_complete"] = True
            time.sleep(0.3)
        res["sent"] = sent
        nav.wait(timeout=120)
        res["nav_end"] = time.time()
        if browser is not None:
            browser.join(timeout=120)
        time.sleep(0.7)  # the last telemetry through the ground station and UDP
        ground.send_signal(signal.SIGINT)
        ground.wait(timeout=30)
        res["ground_end"] = time.time()
        # the last values, asked of the processor once no packet came for longer than their
        # validity: each must say EXPIRED (a display of it is not the present)
        time.sleep(1.5)
        res["after_stop"] = {
            p.name: {
                "value": view.plain(p.eng_value),
                "status": p.validity_status,
                "time": iso(p.generation_time),
            }
            for p in proc.get_parameter_values(VALIDITY_PARAMS)
            if p is not None
        }
        res["after_stop_t"] = time.time()
        res["nav_rc"], res["ground_rc"] = nav.returncode, ground.returncode
        res["chain_s"] = time.monotonic() - t_chain
        time.sleep(1.0)  # Yamcs archives what it received
        # the CPU alarm: two housekeeping reports in a row with a high load (the alarm wants
        # two: one report of the start-up cycle alone is not a sustained load), to the TM link
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for _ in range(2):
                s.sendto(cpu_packet(arch), ("127.0.0.1", gy.TM_PORT))
                time.sleep(0.3)
        time.sleep(1.0)
        res["view_after"] = browse(out, "after", shots / "operator-view.png")
        # a command whose answer is lost: the ground station is gone, the flight never sees it,
        # while the answers of the two NOOPs before are in Yamcs: its verifiers must time out
        lost = proc.issue_command("/MFNS_TC/NOOP")
        res["lost"] = {"name": "NOOP", "id": lost.id, "t": time.time()}
        res["links"] = {
            lk.name: {"in": lk.in_count, "out": lk.out_count, "status": lk.status}
            for lk in client.list_links(gy.INSTANCE)
        }
        res["packets_archived"], res["archive_settle_s"] = archive_settled(client, arch, 20.0)
        res["params"] = {n: archive_values(arch, n) for n in NAV_PARAMS + EVENT_PARAMS}
        with deliveries.lock:
            res["deliveries"] = list(deliveries.rows)
        t_lost = time.monotonic()
        while time.monotonic() - t_lost < 20.0:  # its verifiers' window is 10 s
            acks = {c.id: c.acknowledgments for c in arch.list_command_history()}.get(lost.id, {})
            if all(
                n in acks and acks[n].status != "PENDING"
                for n in ("Verifier_Accepted", "Verifier_Complete", "Verifier_Failed")
            ):
                break
            time.sleep(0.5)
        res["cmdhist"] = []
        for c in arch.list_command_history():
            res["cmdhist"].append(
                {
                    "id": c.id,
                    "name": c.name,
                    "args": {k: view.plain(v) for k, v in c.assignments.items()},
                    "binary": c.binary.hex() if c.binary else None,
                    "complete": c.is_complete(),
                    "success": c.is_success(),
                    "error": c.error,
                    "attrs": {k: view.plain(v) for k, v in getattr(c, "attributes", {}).items()},
                    "acks": {
                        n: {"status": a.status, "time": iso(a.time), "message": a.message}
                        for n, a in c.acknowledgments.items()
                    },
                }
            )
        res["events"] = [
            {
                "source": e.source,
                "type": e.event_type,
                "severity": e.severity,
                "message": e.message,
                "time": iso(e.generation_time),
            }
            for e in arch.list_events(source="MFNS")
        ]
        res["alarms"] = [
            {
                "name": a.name,
                "severity": a.severity,
                "ok": a.is_ok,
                "acknowledged": a.is_acknowledged,
                "trigger_time": iso(a.trigger_time),
                "violations": a.violation_count,
            }
            for a in proc.list_alarms()
        ]
        res["ground_params"] = {
            p.name: (view.plain(p.eng_value), p.monitoring_result)
            for p in proc.get_parameter_values(
                [
                    "/MFNS_GROUND/cpu_margin_pct",
                    "/MFNS_GROUND/nofix_run_cycles",
                    "/MFNS_GROUND/table_crc_changed",
                    "/MFNS_GROUND/cmd_rejected",
                ]
            )
            if p is not None
        }
        start, stop = datetime(1970, 1, 1, tzinfo=UTC), datetime(2200, 1, 1, tzinfo=UTC)
        res["ground_history"] = {
            n: [
                (iso(v.generation_time), view.plain(v.eng_value), v.monitoring_result)
                for v in arch.list_parameter_values(n, start=start, stop=stop)
            ]
            for n in (
                "/MFNS_GROUND/cmd_rejected",
                "/MFNS_GROUND/cpu_margin_pct",
                "/MFNS_GROUND/table_crc_changed",
                "/MFNS_GROUND/nofix_run_cycles",
            )
        }
        res["total_s"] = time.monotonic() - t0
    except Exception as e:  # reported to the test, which fails with it
        import traceback

        res["error"] = f"{type(e).__name__}: {e}\n{traceback.format_exc()[-2000:]}"
    finally:
        stop_view.set()
        if "conn" in locals():
            conn.cancel()
        if "deliveries" in locals():
            deliveries.sub.cancel()
        if "vt" in locals():
            vt.join(timeout=5)  # its subscription closed before the server goes
        for p in (nav, ground):
            if p is not None and p.poll() is None:
                p.kill()
        gy.stop(yamcs)
    (out / "result.json").write_text(json.dumps(res, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
