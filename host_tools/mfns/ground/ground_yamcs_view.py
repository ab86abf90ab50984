"""The operator's view (docs/operators.md "The view"): a small local web page over Yamcs.

``mfns ground view [--port 8095]`` (``make ground-view``) serves
ground/operator/index.html and ``/state.json``, a snapshot this process keeps from Yamcs
through ``yamcs-client``: a WebSocket parameter subscription (the navigation solution, the
camera packets, housekeeping, the ground's alarm parameters), the realtime processor's
active alarms and the command history of the archive (REST). The page polls the snapshot
twice a second and draws it; it holds no logic of its own beyond formatting.

Why a page of our own and not a Yamcs display: the values an operator needs are few and
must be checked against nav.csv by a test in a real browser; a page with stable element ids
and no build step is testable with headless Chromium's --dump-dom, where Yamcs' web
application (an Angular app) renders displays only after its own start-up and routing. The
camera states come one camera per packet on one parameter (cam_state), so the view keeps
the latest per camera, which a plain parameter display could not.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from datetime import UTC, datetime
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from mfns.core.csv_formats import POSE_COLUMNS, SIGMA_COLUMNS
from mfns.ground import ground_yamcs as gy
from mfns.tlm import tlm_dict

# The page: the repository's ground/operator/index.html, or the copy an installed
# wheel carries (host_tools/setup.py puts it in mfns/data).
_TREE_PAGE = Path(__file__).resolve().parents[3] / "ground" / "operator" / "index.html"
_WHEEL_PAGE = Path(__file__).resolve().parents[1] / "data" / "operator.html"
PAGE = _TREE_PAGE if _TREE_PAGE.is_file() else _WHEEL_PAGE
NAV = [
    "cycle",
    "status",
    "reason",
    "mode",
    "beacons_used",
    "cams_used",
    *POSE_COLUMNS,
    *SIGMA_COLUMNS,
    "pl_pos_mm",
    "pl_att_deg",
]
CAM = ["camera", "state", "blobs", "beacons_identified", "cycle"]
HK = [
    "cycle",
    "cpu_load_pct",
    "n_cycles",
    "n_fix",
    "n_degraded",
    "n_no_fix",
    "n_cmd_accepted",
    "n_cmd_rejected",
    "table_crc32",
    "time_quality",
    "workspace",
]
GROUND = ["nofix_run_cycles", "cpu_margin_pct", "table_crc_changed", "cmd_rejected"]
EVT = ["cycle", "code", "severity", "subject", "arg0", "arg1"]
PARAMS = (
    [f"/MFNS/nav_{n}" for n in NAV]
    + [f"/MFNS/evt_{n}" for n in EVT]
    + [f"/MFNS/cam_{n}" for n in CAM]
    + [f"/MFNS/hk_{n}" for n in HK]
    + [f"/MFNS_GROUND/{n}" for n in GROUND]
)
N_COMMANDS = 8  # the last commands shown
N_EVENTS = 12  # the last event lines shown (a line aggregates repeats)
# An event of the same code and subject as the line on top within this many cycles (about
# 1 s at 18 Hz) adds to its count instead of a new line: a flood reads as one line "x 240".
EVENT_REPEAT_CYCLES = 20
# No navigation packet for this long and the view says STALE (mode, status, cameras and the
# alarms' "back in limits" are then the last known, not the present). The flight sends one
# navigation packet per cycle (about 18 Hz, docs/telemetry.md), so 3 s is some 50 missed
# packets: never a hiccup of the link, always a flight, link or ground that stopped.
STALE_AFTER_S = 3.0

# The verification stages of a command in an operator's words (docs/operators.md "Commands"):
# (stage, Yamcs ack status) -> what it means; None = nothing to say (e.g. the failure check
# CANCELLED because the command completed: it did not fail).
STAGES = ("Acknowledge_Sent", "Verifier_Accepted", "Verifier_Complete", "Verifier_Failed")
STAGE_WORDS = {
    ("Acknowledge_Sent", "OK"): ("sent", "OK"),
    ("Acknowledge_Sent", "NOK"): ("not sent", "FAILED"),
    ("Verifier_Accepted", "OK"): ("accepted by the flight", "OK"),
    ("Verifier_Accepted", "PENDING"): ("awaiting acceptance", "PENDING"),
    ("Verifier_Accepted", "TIMEOUT"): ("no acceptance seen (timeout)", "TIMEOUT"),
    ("Verifier_Accepted", "NOK"): ("not accepted", "FAILED"),
    ("Verifier_Accepted", "CANCELLED"): None,
    ("Verifier_Complete", "OK"): ("executed", "OK"),
    ("Verifier_Complete", "PENDING"): ("awaiting execution", "PENDING"),
    ("Verifier_Complete", "TIMEOUT"): ("no execution seen (timeout)", "TIMEOUT"),
    ("Verifier_Complete", "NOK"): ("not executed", "FAILED"),
    ("Verifier_Complete", "CANCELLED"): None,
    ("Verifier_Failed", "OK"): ("REJECTED by the flight", "FAILED"),
    ("Verifier_Failed", "NOK"): None,
    ("Verifier_Failed", "PENDING"): None,
    ("Verifier_Failed", "TIMEOUT"): None,
    ("Verifier_Failed", "CANCELLED"): None,
}


def stage_words(acks: dict) -> list[dict]:
    """The command's verification as the operator reads it: one {stage, text, cls} per stage
    that says something (Yamcs' raw "Failed OK" is "REJECTED by the flight"; the failure
    check CANCELLED after a completion is left out: nothing failed)."""
    out = []
    for k in STAGES:
        a = acks.get(k)
        if a is None:
            continue
        w = STAGE_WORDS.get((k, a["status"]), (f"{k.partition('_')[2].lower()} {a['status']}", a["status"]))
        if w is not None:
            out.append({"stage": k, "text": w[0], "cls": w[1]})
    return out


FAILED_RETURN = "Verifier_Failed_Return"  # command history: what the Failed verifier returned
USABLE = tlm_dict.usable_status_names()  # a pose the flight's integrity checks passed (docs/pose.md)


def iso(t) -> str | None:
    return t.astimezone(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z") if t else None


def plain(v):
    """A JSON-able engineering value (enumerations are their labels already)."""
    if isinstance(v, (int, float, str, bool)) or v is None:
        return v
    return str(v)


class State:
    """What the page shows, kept from a Yamcs parameter subscription and read on request."""

    def __init__(self, client) -> None:
        self.client = client
        self.proc = client.get_processor(gy.INSTANCE, "realtime")
        self.archive = client.get_archive(gy.INSTANCE)
        self.lock = threading.Lock()
        self.nav: dict = {}
        self.hk: dict = {}
        self.ground: dict = {}
        self.cams: dict[str, dict] = {}
        self.last_fix: dict = {}  # the navigation packet of the latest FIX or DEGRADED cycle
        self.n_deliveries = 0
        self.clock = time.monotonic  # receipt times (a test may move it)
        self.rx_nav: float | None = None  # when the latest navigation packet arrived
        self.monitoring: dict[str, str | None] = {}  # parameter -> its latest value's monitoring result
        self.events: list[dict] = []  # newest first, repeats aggregated (add_event)
        self.sub = self.proc.create_parameter_subscription(
            PARAMS, on_data=self._on_data, abort_on_invalid=False
        )

    def _on_data(self, data) -> None:
        vals = {p.name: p for p in data.parameters}
        with self.lock:
            self.n_deliveries += 1
            if "/MFNS/nav_status" in vals:
                self.rx_nav = self.clock()
            for name, p in vals.items():
                self.monitoring[name] = p.monitoring_result
            if "/MFNS/evt_code" in vals:  # one event packet: its values belong to that event
                self.add_event(
                    {n: plain(vals[f"/MFNS/evt_{n}"].eng_value) for n in EVT if f"/MFNS/evt_{n}" in vals}
                )
            cam = vals.get("/MFNS/cam_camera")
            if cam is not None:  # one camera's packet: its values belong to that camera only
                d = self.cams.setdefault(str(cam.eng_value), {})
                for n in CAM:
                    if f"/MFNS/cam_{n}" in vals:
                        d[n] = plain(vals[f"/MFNS/cam_{n}"].eng_value)
                d["time"] = iso(cam.generation_time)
            for name, p in vals.items():
                space, _, short = name[1:].partition("/")
                if space == "MFNS" and short.startswith("nav_"):
                    self.nav[short[4:]] = plain(p.eng_value)
                    self.nav["time"] = iso(p.generation_time)
                elif space == "MFNS" and short.startswith("hk_"):
                    self.hk[short[3:]] = plain(p.eng_value)
                    self.hk["time"] = iso(p.generation_time)
                elif space in ("MFNS_GROUND", "MFNS_TC"):
                    self.ground[short] = {"value": plain(p.eng_value), "alarm": p.monitoring_result}
            status = vals.get("/MFNS/nav_status")
            if status is not None and str(status.eng_value) in USABLE:  # a navigation packet with a pose
                self.last_fix = dict(self.nav)

    def add_event(self, e: dict) -> None:
        """A flight event as the operator reads it (names, decoded arguments: tlm_dict.event_text),
        aggregated with the line on top when it repeats it (same code and subject within
        EVENT_REPEAT_CYCLES cycles): the line then counts and spans the repeats."""
        code, subject = str(e.get("code")), int(e.get("subject", 0))
        cycle = int(e.get("cycle", 0))
        top = self.events[0] if self.events else None
        if (
            top is not None
            and (top["code"], top["subject"]) == (code, subject)
            and 0 <= cycle - top["last_cycle"] <= EVENT_REPEAT_CYCLES
        ):
            top["count"] += 1
            top["last_cycle"] = cycle
            top["text"] = tlm_dict.event_text(code, subject, int(e.get("arg0", 0)), int(e.get("arg1", 0)))
            return
        self.events.insert(
            0,
            {
                "code": code,
                "subject": subject,
                "severity": str(e.get("severity")),
                "first_cycle": cycle,
                "last_cycle": cycle,
                "count": 1,
                "text": tlm_dict.event_text(code, subject, int(e.get("arg0", 0)), int(e.get("arg1", 0))),
            },
        )
        del self.events[N_EVENTS:]

    def alarms(self, stale: bool) -> list[dict]:
        """Yamcs' active alarms, each with its present state as the view states it: from the
        latest value this view received of that parameter when it has one (the same value the
        rest of the page shows), else from Yamcs' alarm; never "back in limits" on stale data."""
        out = []
        with self.lock:
            mon = dict(self.monitoring)
        for a in self.proc.list_alarms():
            current = mon.get(a.name, "unknown")
            if current == "unknown":
                in_limits = bool(a.is_ok)
            else:
                in_limits = current in (None, "IN_LIMITS")
            if stale:
                state = "no fresh data"
            else:
                state = "back in limits" if in_limits else "in alarm"
            out.append(
                {
                    "name": a.name,
                    "severity": a.severity,
                    "acknowledged": a.is_acknowledged,
                    "ok": in_limits,
                    "state": state,
                    "trigger_time": iso(a.trigger_time),
                    "violations": a.violation_count,
                }
            )
        return out

    def commands(self) -> list[dict]:
        out = []
        for c in self.archive.list_command_history(descending=True, page_size=N_COMMANDS):
            acks = {
                name: {"status": a.status, "time": iso(a.time), "message": a.message}
                for name, a in c.acknowledgments.items()
            }
            # the flight's reason, by name: the Failed verifier returns it (mfns_tc.xml
            # ReturnParmRef, mfns_ground.xml event_cmd_rejected) into the command's own history
            reason = c.attributes.get(FAILED_RETURN)
            timed_out = any(a["status"] == "TIMEOUT" for a in acks.values())
            out.append(
                {
                    "name": c.name.rpartition("/")[2],
                    "args": {k: plain(v) for k, v in c.assignments.items()},
                    "acks": acks,
                    "stages": stage_words(acks),
                    "complete": c.is_complete(),
                    "success": c.is_success(),
                    "timed_out": timed_out and not c.is_complete(),
                    "reason": None if reason is None else str(reason),
                }
            )
            if len(out) == N_COMMANDS:
                break
        return out

    def snapshot(self) -> dict:
        with self.lock:
            snap: dict[str, Any] = {  # the page's JSON: values of every kind
                "nav": dict(self.nav),
                "last_fix": dict(self.last_fix),
                "hk": dict(self.hk),
                "cams": {k: dict(v) for k, v in self.cams.items()},
                "ground": dict(self.ground),
                "deliveries": self.n_deliveries,
                "events": [dict(e) for e in self.events],
            }
            age = None if self.rx_nav is None else self.clock() - self.rx_nav
        hk = snap["hk"]
        if hk.get("n_cycles"):  # cycles with a usable pose (FIX or DEGRADED) since the board started
            snap["fix_rate_pct"] = 100.0 * (hk["n_fix"] + hk["n_degraded"]) / hk["n_cycles"]
        # freshness: "waiting" before the first navigation packet, "stale" once none came for
        # STALE_AFTER_S; the page then marks every last-known value as such
        snap["nav_age_s"] = age
        snap["stale_after_s"] = STALE_AFTER_S
        snap["freshness"] = "waiting" if age is None else ("stale" if age > STALE_AFTER_S else "live")
        snap["pose_valid"] = snap["freshness"] == "live" and str(snap["nav"].get("status")) in USABLE
        snap["alarms"] = self.alarms(snap["freshness"] != "live")
        snap["commands"] = self.commands()
        snap["now"] = datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")
        return snap


def handler(state: State, page: Path):
    class H(BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802 (http.server's name)
            if self.path in ("/", "/index.html"):
                if not page.is_file():  # neither the tree's page nor the wheel's copy
                    self.send_error(404, f"{page} not found: reinstall mfns (pip install ./host_tools)")
                    return
                body, ctype = page.read_bytes(), "text/html; charset=utf-8"
            elif self.path.startswith("/state.json"):
                try:
                    body, ctype = json.dumps(state.snapshot()).encode(), "application/json"
                except Exception as e:  # Yamcs gone: say so to the page, keep serving
                    body, ctype = (
                        json.dumps({"error": f"{type(e).__name__}: {e}"}).encode(),
                        "application/json",
                    )
            else:
                self.send_error(404)
                return
            self.send_response(200)
            self.send_header("Content-Type", ctype)
            self.send_header("Cache-Control", "no-store")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, fmt, *args):  # quiet: the operator's terminal is not a web log
            pass

    return H


def serve(port: int, ready: threading.Event | None = None, stop: threading.Event | None = None) -> int:
    state = State(gy.client())
    httpd = ThreadingHTTPServer(("127.0.0.1", port), handler(state, PAGE))
    t = threading.Thread(target=httpd.serve_forever, daemon=True)
    t.start()
    print(f"operator view: http://127.0.0.1:{port}/ (Yamcs {gy.HTTP}, instance {gy.INSTANCE})", flush=True)
    if ready is not None:
        ready.set()
    try:
        while stop is None or not stop.is_set():
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        httpd.shutdown()
        state.sub.cancel()
    return 0


def run(port: int) -> int:
    """`mfns ground view` (commands/ground.py): serve, with a clear error for a busy port or no Yamcs."""
    try:
        return serve(port)
    except OSError as e:
        print(f"ground-view: cannot serve on 127.0.0.1:{port}: {e}", file=sys.stderr)
        return 2
    except Exception as e:  # yamcs-client: no server there
        print(
            f"ground-view: Yamcs at {gy.HTTP} not reachable ({type(e).__name__}: {e}); start it with "
            "`make ground-yamcs`",
            file=sys.stderr,
        )
        return 2
