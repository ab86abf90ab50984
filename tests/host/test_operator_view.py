"""Issue 46: the operator's view never misleads, in headless Chromium (screenshots in
build/operator-states/).

The view's server (mfns.ground.ground_yamcs_view.State and its HTTP handler) and the page
(ground/operator/index.html) run for real; Yamcs is replaced by a stand-in client that delivers
the parameter values, alarms and command history a Yamcs server would (the same yamcs-client
shapes: ParameterValue-like objects, alarms, command history entries), so each failure state is
reached on demand: NO_FIX after a fix, a commanded STANDBY, a stopped flight (stale data) and
a command the flight rejected. tests/host/test_yamcs.py runs the same page over a real Yamcs.
"""

from __future__ import annotations

import html
import re
import shutil
import subprocess
import threading
from datetime import UTC, datetime
from http.server import ThreadingHTTPServer
from pathlib import Path
from types import SimpleNamespace

import pytest

pytest.importorskip("yamcs.client")  # ground_yamcs imports it (ground/requirements.txt)

from mfns.ground import ground_yamcs_view as gv  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SHOTS = REPO / "build" / "operator-states"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium (mk/deps.sh test installs it)")


class FakeProc:
    def __init__(self):
        self.alarms: list = []

    def create_parameter_subscription(self, params, on_data, abort_on_invalid):
        self.params, self.on_data = params, on_data
        return SimpleNamespace(cancel=lambda: None)

    def list_alarms(self):
        return list(self.alarms)


class FakeArchive:
    def __init__(self):
        self.commands: list = []

    def list_command_history(self, descending, page_size):
        return list(self.commands)


class FakeClient:
    def __init__(self):
        self.proc, self.archive = FakeProc(), FakeArchive()

    def get_processor(self, instance, name):
        return self.proc

    def get_archive(self, instance):
        return self.archive


def pv(name, value, monitoring=None):
    return SimpleNamespace(
        name=name, eng_value=value, generation_time=datetime.now(UTC), monitoring_result=monitoring
    )


def nav_packet(status, mode, cycle, reason="OK", pose=None):
    pose = pose or {}
    vals = {
        "cycle": cycle,
        "status": status,
        "reason": reason,
        "mode": mode,
        "beacons_used": 0,
        "cams_used": 0,
    }
    for k in gv.NAV:
        if k not in vals:
            vals[k] = pose.get(k, 0.0)  # a NO_FIX packet carries zeros, as the wire does
    return SimpleNamespace(parameters=[pv(f"/MFNS/nav_{k}", v) for k, v in vals.items()])


def cam_packet(name, state):
    vals = {"camera": name, "state": state, "blobs": 3, "beacons_identified": 3, "cycle": 1}
    return SimpleNamespace(parameters=[pv(f"/MFNS/cam_{k}", v) for k, v in vals.items()])


class Clock:
    def __init__(self):
        self.t = 1000.0

    def __call__(self):
        return self.t


@pytest.fixture()
def view(tmp_path):
    client = FakeClient()
    state = gv.State(client)
    state.clock = Clock()
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), gv.handler(state, gv.PAGE))
    t = threading.Thread(target=httpd.serve_forever, daemon=True)
    t.start()
    yield SimpleNamespace(
        client=client, state=state, url=f"http://127.0.0.1:{httpd.server_address[1]}/", tmp=tmp_path
    )
    httpd.shutdown()


def browse(v, name: str) -> dict[str, str]:
    """Chromium's DOM after the page polled: {element id: text}, and a screenshot."""
    common = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        f"--user-data-dir={v.tmp / 'chromium-profile'}",
        "--virtual-time-budget=2000",
        "--window-size=1280,900",
    ]
    r = subprocess.run([*common, "--dump-dom", v.url], capture_output=True, text=True, timeout=90)
    assert r.returncode == 0, r.stderr[-500:]
    SHOTS.mkdir(parents=True, exist_ok=True)
    shot = SHOTS / f"{name}.png"
    s = subprocess.run([*common, f"--screenshot={shot}", v.url], capture_output=True, text=True, timeout=90)
    assert s.returncode == 0 and shot.stat().st_size > 10_000
    ids = dict(re.findall(r'id="([^"]+)"[^>]*>([^<]*)<', r.stdout))
    return {"ids": ids, "html": r.stdout}


FIX_POSE = {
    "x_mm": 512.25,
    "y_mm": -40.5,
    "z_mm": 1210.0,
    "roll_deg": 1.5,
    "pitch_deg": -2.25,
    "yaw_deg": 91.0,
}


def test_no_fix_after_a_fix_shows_no_pose_and_the_last_fix(view):
    view.client.proc.on_data(nav_packet("FIX", "TRACK", 41, pose=dict(FIX_POSE, sigma_x_mm=0.2)))
    view.client.proc.on_data(nav_packet("NO_FIX", "TRACK", 42, reason="TOO_FEW_BEACONS"))
    d = browse(view, "no_fix")
    ids, html = d["ids"], d["html"]
    for k in ("x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg"):
        assert ids[f"nav-{k}"] == "no fix", k  # never 0.000
    assert "0.000" not in "".join(ids[f"nav-{k}"] for k in gv.NAV if f"nav-{k}" in ids)
    assert ids["nav-status"] == "NO_FIX" and ids["fix-cycle"] == "41" and ids["fix-x_mm"] == "512.250"
    assert ids["fix-age"] == "1 cycles ago" and ids["freshness"].startswith("LIVE")
    assert re.search(r'class="n NO_FIX" id="nav-x_mm"|id="nav-x_mm" class="n NO_FIX"', html)


def test_commanded_standby_is_no_fix_by_design_and_says_so(view):
    view.client.proc.on_data(nav_packet("NO_FIX", "STANDBY", 7, reason="NONE"))  # the wire's reason
    ids = browse(view, "standby")["ids"]
    assert ids["nav-mode"] == "STANDBY" and ids["nav-status"] == "NO_FIX"
    assert ids["nav-reason"] == "commanded STANDBY: the navigator does not run"
    assert ids["nav-x_mm"] == "no fix" and ids["fix-cycle"] == "–"  # no fix ever: nothing to show


def test_stale_data_after_the_flight_stops(view):
    view.client.proc.on_data(nav_packet("FIX", "TRACK", 100, pose=FIX_POSE))
    for c in "xyz":
        view.client.proc.on_data(cam_packet(c, "OK"))
    view.client.proc.alarms = [
        SimpleNamespace(
            name="/MFNS_GROUND/nofix_run_cycles",
            severity="WARNING",
            is_acknowledged=False,
            is_ok=True,
            trigger_time=datetime.now(UTC),
            violation_count=3,
        )
    ]
    fresh = browse(view, "live")["ids"]
    assert (
        fresh["freshness"].startswith("LIVE")
        and fresh["nav-mode"] == "TRACK"
        and fresh["cam-x-state"] == "OK"
    )
    assert fresh["nav-x_mm"] == "512.250"
    view.state.clock.t += 104.0  # 1 min 44 s without a packet (issue 46's observation)
    d = browse(view, "stale")
    ids, html = d["ids"], d["html"]
    assert ids["freshness"].startswith("STALE: no navigation packet for 104 s (limit 3 s)")
    assert ids["nav-mode"] == "TRACK (stale)" and ids["nav-status"] == "FIX (stale)"
    assert all(ids[f"cam-{c}-state"] == "OK (stale)" for c in "xyz")
    assert ids["nav-x_mm"] == "stale"  # the pose is not the present one; the last fix keeps it
    assert ids["fix-x_mm"] == "512.250"
    assert 'data-state="no fresh data"' in html and "back in limits" not in html


def test_alarm_state_follows_the_value_the_view_shows(view):
    """Yamcs' alarm may say is_ok while the value this view shows is out of limits: the row
    follows the value (issue 46: "back in limits" during a 37-cycle no-fix run)."""
    pkt = nav_packet("NO_FIX", "TRACK", 80, reason="TOO_FEW_BEACONS")
    pkt.parameters.append(pv("/MFNS_GROUND/nofix_run_cycles", 37, monitoring="WARNING"))
    view.client.proc.on_data(pkt)
    view.client.proc.alarms = [
        SimpleNamespace(
            name="/MFNS_GROUND/nofix_run_cycles",
            severity="WARNING",
            is_acknowledged=False,
            is_ok=True,
            trigger_time=datetime.now(UTC),
            violation_count=28,
        )
    ]
    d = browse(view, "alarm_no_fix_run")
    assert 'data-state="in alarm"' in d["html"] and "back in limits" not in d["html"]
    assert d["ids"]["nofix-run"] == "37 cycles"


def _ack(status):
    return SimpleNamespace(status=status, time=datetime.now(UTC), message=None)


def _cmd(name, acks, success, reason=None):
    return SimpleNamespace(
        name=f"/MFNS_TC/{name}",
        assignments={"mode": "TRACK"} if name == "SET_MODE" else {},
        acknowledgments={k: _ack(v) for k, v in acks.items()},
        attributes={} if reason is None else {gv.FAILED_RETURN: reason},
        is_complete=lambda: True,
        is_success=lambda: success,
    )


def test_a_rejected_command_in_operators_words(view):
    view.client.proc.on_data(nav_packet("FIX", "TRACK", 5, pose=FIX_POSE))
    view.client.archive.commands = [
        _cmd(
            "TABLE_LOAD",
            {
                "Acknowledge_Sent": "OK",
                "Verifier_Accepted": "OK",
                "Verifier_Complete": "CANCELLED",
                "Verifier_Failed": "OK",
            },
            False,
            reason="TABLE",
        ),
        _cmd(
            "SET_MODE",
            {
                "Acknowledge_Sent": "OK",
                "Verifier_Accepted": "OK",
                "Verifier_Complete": "OK",
                "Verifier_Failed": "CANCELLED",
            },
            True,
        ),
    ]
    d = browse(view, "rejected_command")
    html = d["html"]
    rows = re.findall(r'<tr class="command" data-name="([^"]+)" data-verdict="([^"]+)">(.*?)</tr>', html)
    assert [(n, v) for n, v, _ in rows] == [("TABLE_LOAD", "FAILED"), ("SET_MODE", "SUCCESS")]
    text = [re.sub(r"<[^>]+>", "", body) for _, _, body in rows]
    assert "sent · accepted by the flight · REJECTED by the flight" in text[0]
    assert "REJECTED" in text[0] and "rejected by the flight: TABLE" in text[0]
    assert "sent · accepted by the flight · executed" in text[1] and "done" in text[1]
    for raw in ("Failed OK", "Failed CANCELLED", "Complete CANCELLED"):
        assert raw not in html


def evt_packet(cycle, code, severity, subject, arg0, arg1):
    vals = {
        "cycle": cycle,
        "code": code,
        "severity": severity,
        "subject": subject,
        "arg0": arg0,
        "arg1": arg1,
    }
    return SimpleNamespace(parameters=[pv(f"/MFNS/evt_{k}", v) for k, v in vals.items()])


def test_events_by_name_with_decoded_arguments_and_repeats_counted(view):
    """Names and arguments an operator reads (camera names, modes, beacons, commands and
    rejection codes, table loader statuses by name, from mfns_tm.xml's AncillaryData and the
    C core), and a flood aggregated into one line with its count."""
    p = view.client.proc
    p.on_data(nav_packet("FIX", "TRACK", 1, pose=FIX_POSE))
    p.on_data(evt_packet(1, "TABLE_REFUSED", "ERROR", 0, 30, 0))
    p.on_data(evt_packet(2, "MODE_CHANGE", "INFO", 0, 2, 4))
    p.on_data(evt_packet(3, "CMD_REJECTED", "WARNING", 3, 7, 5))
    for c in range(10, 250):  # one warning per cycle for 240 cycles: one line x 240
        p.on_data(evt_packet(c, "CAMERA_LAG", "WARNING", 1, 1500, 420))
    p.on_data(evt_packet(260, "BEACON_MISSING", "WARNING", 12, 20, 12))
    d = browse(view, "events")
    rows = re.findall(r'<tr class="event" data-code="([^"]+)" data-count="(\d+)">(.*?)</tr>', d["html"])
    text = {code: (int(n), html.unescape(re.sub(r"<[^>]+>", " ", body))) for code, n, body in rows}
    assert [code for code, _, _ in rows] == [
        "BEACON_MISSING",
        "CAMERA_LAG",
        "CMD_REJECTED",
        "MODE_CHANGE",
        "TABLE_REFUSED",
    ]
    assert (
        text["CAMERA_LAG"][0] == 240
        and "cycles 10–249" in text["CAMERA_LAG"][1]
        and "× 240" in text["CAMERA_LAG"][1]
    )
    assert "CAMERA_LAG camera y" in text["CAMERA_LAG"][1]
    assert "MODE_CHANGE TRACK -> STANDBY" in text["MODE_CHANGE"][1]
    assert "CMD_REJECTED SET_MODE" in text["CMD_REJECTED"][1]
    assert "calibration table file cannot be opened" in text["TABLE_REFUSED"][1]  # 30, by the core's name
    assert "BEACON_MISSING beacon 12" in text["BEACON_MISSING"][1]
