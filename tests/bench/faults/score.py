"""Scoring one flight of the fault campaign against truth (issue 23).

A fix is usable when nav.csv says FIX or DEGRADED. Its pose is what it claims for its own stamp
t_s, and that is what it is scored on: truth at t_s (interpolated). Its stamp is then held to
the frames it came from: camera.csv says which frame (frame_seq) each camera contributed in the
fix's cycle (the cameras of nav.csv's cams_used bit mask when that column is there, else those
OK with identified beacons), and the campaign knows each (camera, frame_seq)'s true capture
time (the original frames.csv, and what the injector put into the image); a fix fused from
frames of different true times is counted (out_of_step_fixes).

Until 7 Dec 2026 (issue 42) a fix was scored against truth at each of its frames' capture times
and the worst kept. That condemned a fix that was right at its stamp because one of its
frames showed an earlier instant: the navigation filter takes a camera whose clock is in doubt
with its time offset eliminated (firmware/nav/filter/filter_bank.h), and its fix of a stale
camera's cycle is right at its stamp (0.4 mm with 1 mm sigma, module seed 5, camera x a period
stale) yet was 4.7 mm (one period of motion) from truth at the stale frame's time. What the old
rule caught still fails here: a snapshot fix that blends two instants is off at its stamp, and
a fix right for frames a period older than its stamp is off at its stamp by that motion (the
old rule let one period pass; the stamp rule below still allows it, the error rule does not).

A usable fix is misleading when, against truth at its stamp:
- its position is more than 20 mm from truth (Euclidean), or its attitude more than 1 deg
  (rotation angle);
- any axis of the error is beyond 5 sigma of its own covariance (ROS order x, y, z, rx, ry, rz
  when nav.csv has cov_* and q_*; else the sigma_* columns and Euler differences), or the NEES
  with the full covariance is beyond the chi-square(6) quantile of the same tail probability;
- or its stamp t_s differs from a contributing frame's capture time by more than one frame
  period.

Protection levels: columns named pl_* (pl_<what>_<unit>; unit mm or deg) are compared with the
true error: what = x/y/z or rx/ry/rz/roll/pitch/yaw the one component, anything else the
position norm (mm) or the rotation angle (deg). A level that is not a finite positive number is
no level (counted apart). Runs without such columns skip this.

Reporting: the first event at or after the fault's onset cycle whose name is not an ordinary
one (start-up, mode, link, commands, and anything coming back: *_RECOVERED, *_HEALTHY,
*_READMITTED, *_ENDED) and whose subject is the faulty camera (camera index) or beacon (id). What an event's
subject holds comes from the TM dictionary's description of it ("subject camera ...",
"subject beacon ..."), else from its name (CAMERA/FRAME: camera; BEACON/LED: beacon); a beacon
subject of 255 (an id above 254) is read from arg1. Names come from events.csv, never numeric
codes.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np

AXES_ROS = ("x", "y", "z", "rx", "ry", "rz")
SUBJECT_SATURATED = 255  # a beacon id above 254 in an event's u8 subject; arg1 then carries it
CAMERAS = "xyz"  # camera index k = bit k of cams_used (docs/telemetry.md)
USABLE = ("FIX", "DEGRADED")
LIMIT_MM = 20.0
LIMIT_DEG = 1.0
LIMIT_SIGMA = 5.0
NEES_5SIGMA = 39.3  # chi-square(6) quantile at the two-sided 5-sigma tail, 5.7e-7
STAMP_TOL_S = 1e-4  # telemetry time is 2^-16 s (15 us) and truncated: well inside this
# Events that are no report of a fault: start-up, mode, link, commands, and a camera coming
# back or ending its replay; and any event whose name says something came back (ORDINARY_ENDS).
ORDINARY_ENDS = ("_RECOVERED", "_HEALTHY", "_READMITTED", "_ENDED")
# Events about a pair of cameras: the subject and the camera in arg1 (one of them is faulty).
PAIR_EVENTS = frozenset({"CAMERAS_DISAGREE"})
ORDINARY = frozenset(
    {
        "BOOT",
        "TABLE_LOADED",
        "TABLE_REFUSED",
        "MODE_CHANGE",
        "TLM_DROPPED",
        "TLM_WRITE_ERROR",
        "CMD_ACCEPTED",
        "CMD_REJECTED",
        "CAMERA_RECOVERED",
        "CAMERA_ENDED",
    }
)


# --------------------------------------------------------------------------- rotations
def rot_from_euler213_deg(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """C_w_b = R3(yaw) R1(roll) R2(pitch), frame rotations (docs/conventions.md)."""
    f, t, p = np.radians([roll, pitch, yaw])
    r1 = np.array([[1, 0, 0], [0, math.cos(f), math.sin(f)], [0, -math.sin(f), math.cos(f)]])
    r2 = np.array([[math.cos(t), 0, -math.sin(t)], [0, 1, 0], [math.sin(t), 0, math.cos(t)]])
    r3 = np.array([[math.cos(p), math.sin(p), 0], [-math.sin(p), math.cos(p), 0], [0, 0, 1]])
    return r3 @ r1 @ r2


def quat_to_m3(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def rot_log(r: np.ndarray) -> np.ndarray:
    c = max(-1.0, min(1.0, 0.5 * (np.trace(r) - 1.0)))
    th = math.acos(c)
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    if th < 1e-6:
        return 0.5 * v
    if math.pi - th < 1e-6:  # 180 deg: the axis from the symmetric part
        k = int(np.argmax(np.diag(r)))
        a = (r[:, k] + np.eye(3)[k]) / math.sqrt(max(2.0 * (1.0 + r[k, k]), 1e-30))
        return th * a
    return th / (2 * math.sin(th)) * v


def rot_exp(v: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(v))
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    if th < 1e-12:
        return np.eye(3) + k
    return np.eye(3) + math.sin(th) / th * k + (1 - math.cos(th)) / (th * th) * (k @ k)


# --------------------------------------------------------------------------- inputs
def read_csv(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


class Truth:
    """truth.csv (frame,t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg) at any time: position
    linear, attitude along the geodesic between the rows around t (clamped at the ends)."""

    def __init__(self, rows: list[dict]):
        rows = sorted(rows, key=lambda r: float(r["t_s"]))
        self.t = np.array([float(r["t_s"]) for r in rows])
        self.pos = np.array([[float(r[a + "_mm"]) for a in "xyz"] for r in rows])
        self.c_w_b = [
            rot_from_euler213_deg(float(r["roll_deg"]), float(r["pitch_deg"]), float(r["yaw_deg"]))
            for r in rows
        ]
        self.euler = np.array([[float(r[a + "_deg"]) for a in ("roll", "pitch", "yaw")] for r in rows])

    @classmethod
    def load(cls, path: Path) -> Truth:
        return cls(read_csv(path))

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(r_wb_w mm, C_w_b, Euler deg) at time t."""
        i = int(np.searchsorted(self.t, t))
        if i <= 0 or i >= len(self.t):
            j = 0 if i <= 0 else len(self.t) - 1
            return self.pos[j], self.c_w_b[j], self.euler[j]
        t0, t1 = self.t[i - 1], self.t[i]
        s = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
        if s < 1e-9:
            return self.pos[i - 1], self.c_w_b[i - 1], self.euler[i - 1]
        if s > 1 - 1e-9:
            return self.pos[i], self.c_w_b[i], self.euler[i]
        c0, c1 = self.c_w_b[i - 1], self.c_w_b[i]
        c = c0 @ rot_exp(s * rot_log(c0.T @ c1))
        e = self.euler[i - 1] + s * ((self.euler[i] - self.euler[i - 1] + 180.0) % 360.0 - 180.0)
        return (1 - s) * self.pos[i - 1] + s * self.pos[i], c, e


def capture_times(frames_csv_rows: list[dict], content: dict | None = None) -> dict[tuple[str, int], float]:
    """(camera, frame) -> the instant its image shows: the original frames.csv time of the frame
    whose content it holds (content: {(camera, frame): source frame} from the injectors)."""
    orig = {(r["camera"], int(r["frame"])): float(r["t_s"]) for r in frames_csv_rows}
    content = content or {}
    return {k: orig.get((k[0], content.get(k, k[1])), t) for k, t in orig.items()}


# --------------------------------------------------------------------------- one fix
def fix_error(row: dict, truth_pos: np.ndarray, c_true: np.ndarray, eul_true: np.ndarray) -> dict:
    """Error of one nav.csv row against one truth pose: pos (mm, 3), att (deg, 3; rotation
    vector about world axes or Euler differences), sigma ratio, NEES (or None)."""
    d_pos = np.array([float(row[a + "_mm"]) - truth_pos[i] for i, a in enumerate("xyz")])
    nees = None
    if "q_w" in row and "cov_x_x" in row:
        c_b_w_est = quat_to_m3(np.array([float(row[k]) for k in ("q_w", "q_x", "q_y", "q_z")]))
        # C_b_w(est) = exp(phi_w) C_b_w(true)
        phi_deg = np.degrees(rot_log(c_b_w_est @ c_true))
        e = np.concatenate([d_pos, phi_deg])
        p = np.zeros((6, 6))
        for i, a in enumerate(AXES_ROS):
            for j in range(i, 6):
                p[i, j] = p[j, i] = float(row[f"cov_{a}_{AXES_ROS[j]}"])
        sig = np.sqrt(np.maximum(np.diag(p), 1e-18))
        try:
            nees = float(e @ np.linalg.solve(p, e))
        except np.linalg.LinAlgError:
            nees = math.inf
        att_deg = float(np.linalg.norm(phi_deg))
    else:
        e_eul = np.array([float(row[a + "_deg"]) for a in ("roll", "pitch", "yaw")]) - eul_true
        e_eul = (e_eul + 180.0) % 360.0 - 180.0
        e = np.concatenate([d_pos, e_eul])
        sig = np.array(
            [float(row[f"sigma_{a}_mm"]) for a in "xyz"]
            + [float(row[f"sigma_{a}_deg"]) for a in ("roll", "pitch", "yaw")]
        )
        c_est = rot_from_euler213_deg(*(float(row[a + "_deg"]) for a in ("roll", "pitch", "yaw")))
        att_deg = float(np.degrees(np.linalg.norm(rot_log(c_est @ c_true.T))))
    return {
        "e": e,
        "pos_mm": float(np.linalg.norm(d_pos)),
        "att_deg": att_deg,
        "sigma": float(np.max(np.abs(e) / np.maximum(sig, 1e-9))),
        "nees": nees,
    }


PL_COMPONENTS = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5, "roll": 3, "pitch": 4, "yaw": 5}


def pl_error(name: str, err: dict) -> float | None:
    """The true error a protection-level column pl_<what>_<unit> bounds, or None if the unit is
    neither mm nor deg."""
    parts = name.split("_")
    unit, what = parts[-1], "_".join(parts[1:-1])
    if unit not in ("mm", "deg"):
        return None
    if what in PL_COMPONENTS and (PL_COMPONENTS[what] < 3) == (unit == "mm"):
        return abs(float(err["e"][PL_COMPONENTS[what]]))
    return err["pos_mm"] if unit == "mm" else err["att_deg"]


def fix_cameras(nav_row: dict, cams: dict[str, dict]) -> list[str]:
    """The cameras whose frames made this fix."""
    if nav_row.get("cams_used", "").strip().isdigit():
        mask = int(nav_row["cams_used"])
        used = [c for k, c in enumerate(CAMERAS) if mask >> k & 1]
        if used:
            return used
    return [
        c
        for c, r in cams.items()
        if r.get("state") == "OK" and int(r.get("beacons_identified", "0") or 0) > 0
    ]


# --------------------------------------------------------------------------- one run
def score_run(
    nav: list[dict],
    camera: list[dict],
    truth: Truth,
    capture: dict[tuple[str, int], float],
    period_s: float,
) -> dict:
    """The scores of one flight (see the module's docstring)."""
    by_cycle: dict[int, dict[str, dict]] = {}
    for r in camera:
        by_cycle.setdefault(int(r["cycle"]), {})[r["camera"]] = r
    pl_cols = [c for c in (nav[0] if nav else {}) if c.startswith("pl_")]
    res = {
        "cycles": len(nav),
        "usable": 0,
        "misleading": 0,
        "misleading_stamp": 0,
        "misleading_error": 0,
        "out_of_step_fixes": 0,
        "worst_mm": 0.0,
        "worst_deg": 0.0,
        "worst_sigma": 0.0,
        "worst_nees": None,
        "worst_stamp_s": 0.0,
        "pl_columns": pl_cols,
        "worst_pl_ratio": None,
        "pl_exceeded": 0,
        "pl_missing": 0,
        "pl_max": {},
        "first_misleading_cycle": None,
    }
    for row in nav:
        if row["status"] not in USABLE:
            continue
        res["usable"] += 1
        cycle = int(row["cycle"])
        t_fix = float(row["t_s"])
        cams = by_cycle.get(cycle, {})
        times = set()
        for c in fix_cameras(row, cams):
            if c in cams and cams[c].get("frame_seq", "").strip().isdigit():
                key = (c, int(cams[c]["frame_seq"]))
                if key in capture:
                    times.add(capture[key])
        if not times:  # nothing to tell: truth at the stamp
            times.add(t_fix)
        if len(times) > 1:
            res["out_of_step_fixes"] += 1
        stamp = max(abs(t_fix - t) for t in times)
        errs = [fix_error(row, *truth.at(t_fix))]
        pos = max(e["pos_mm"] for e in errs)
        att = max(e["att_deg"] for e in errs)
        z = max(e["sigma"] for e in errs)
        nees_l = [e["nees"] for e in errs if e["nees"] is not None]
        nees = max(nees_l) if nees_l else None
        res["worst_mm"] = max(res["worst_mm"], pos)
        res["worst_deg"] = max(res["worst_deg"], att)
        res["worst_sigma"] = max(res["worst_sigma"], z)
        res["worst_stamp_s"] = max(res["worst_stamp_s"], stamp)
        if nees is not None:
            res["worst_nees"] = max(res["worst_nees"] or 0.0, nees)
        bad_err = (
            pos > LIMIT_MM or att > LIMIT_DEG or z > LIMIT_SIGMA or (nees is not None and nees > NEES_5SIGMA)
        )
        bad_stamp = stamp > period_s + STAMP_TOL_S
        exceeded = False
        for col in pl_cols:
            try:
                pl = float(row[col])
            except (TypeError, ValueError):
                pl = math.nan
            true_err = max((pl_error(col, e) or 0.0) for e in errs)
            if not (math.isfinite(pl) and pl > 0.0):
                res["pl_missing"] += 1
                continue
            res["pl_max"][col] = max(res["pl_max"].get(col, 0.0), pl)
            ratio = true_err / pl
            res["worst_pl_ratio"] = max(res["worst_pl_ratio"] or 0.0, ratio)
            exceeded = exceeded or ratio > 1.0
        res["pl_exceeded"] += int(exceeded)
        if bad_err or bad_stamp:
            res["misleading"] += 1
            res["misleading_error"] += int(bad_err)
            res["misleading_stamp"] += int(bad_stamp)
            if res["first_misleading_cycle"] is None:
                res["first_misleading_cycle"] = cycle
    return res


# --------------------------------------------------------------------------- reporting
def dictionary_subjects(mdb: Path | None = None) -> dict[str, str]:
    """Event name -> "camera" or "beacon" where the TM dictionary's description of the event
    code says "subject camera ..." or "subject beacon ..." (mdb: the dictionary file, default
    the mfns package's; empty without the mfns package)."""
    try:
        from mfns.tlm import tlm_dict

        codes = tlm_dict.load(str(mdb) if mdb else None).enums["event_code_t"]
    except Exception:  # the scorer also runs on its own (tests): the names alone then
        return {}
    out = {}
    for label, text in codes.values():
        m = re.match(r"\s*subject\s+(camera|beacon)", text.lower())
        if m:
            out[label] = m.group(1)
    return out


def event_subject_kind(name: str, described: dict[str, str] | None = None) -> str | None:
    """What an event's subject field holds: the dictionary's word for it, else guessed from the
    name (BEACON/LED: a beacon id; CAMERA/FRAME: a camera index)."""
    if described and name in described:
        return described[name]
    if "BEACON" in name or "LED" in name:
        return "beacon"
    if "CAMERA" in name or name.startswith("FRAME"):
        return "camera"
    return None


def onset_cycle(camera: list[dict], first_frame: int) -> int:
    """The first cycle in which some camera's frame_seq reached first_frame (the fault's onset
    as the program saw it); first_frame itself when no row says."""
    cyc = [
        int(r["cycle"])
        for r in camera
        if r.get("frame_seq", "").strip().isdigit() and int(r["frame_seq"]) >= first_frame
    ]
    return min(cyc) if cyc else first_frame


def first_report(
    events: list[dict], kind: str, subject: int, onset: int, described: dict[str, str] | None = None
) -> dict | None:
    """The first event at or after cycle onset about subject (camera index or beacon id) that is
    not ordinary: {"cycle", "delay", "event"} or None. described: dictionary_subjects()."""
    for r in sorted(events, key=lambda r: (int(r["cycle"]), int(r.get("seq", 0) or 0))):
        name = r.get("event", "")
        if name in ORDINARY or name.endswith(ORDINARY_ENDS) or int(r["cycle"]) < onset:
            continue
        if event_subject_kind(name, described) != kind:
            continue
        subj = r.get("subject", "").strip()
        if kind == "camera" and subj in CAMERAS:
            subj = str(CAMERAS.index(subj))
        if kind == "beacon" and subj == str(SUBJECT_SATURATED):  # the id does not fit: arg1 has it
            subj = r.get("arg1", "").strip()
        if subj.lstrip("-").isdigit() and int(subj) == subject:
            return {"cycle": int(r["cycle"]), "delay": int(r["cycle"]) - onset, "event": name}
        # two cameras that disagree (integrity_cameras.h): the event names both, the other in arg1
        other = r.get("arg1", "").strip()
        if name in PAIR_EVENTS and kind == "camera" and other.isdigit() and int(other) == subject:
            return {"cycle": int(r["cycle"]), "delay": int(r["cycle"]) - onset, "event": name}
    return None


# --------------------------------------------------------------------------- subjects blamed
# (issue 42 item 4: which event names the right camera or beacon, and who else was blamed)
MOTION = "motion"  # the subject of a fault of the robot's motion: no camera, no beacon
# A motion fault is reported with its subject by the event that names it (MOTION_EXCEEDED: the
# navigation filter restarted because the robot left the table's motion bound) or by the mode
# leaving tracking (MODE_CHANGE: a re-acquisition). A camera or beacon blamed instead is the
# wrong subject (blame() lists it), not a report.
MOTION_REPORTS = frozenset({"MOTION_EXCEEDED", "MODE_CHANGE"})
# The start-up self-test names cameras too (SELFTEST_CAMERA): no blame.
STARTUP_PREFIX = "SELFTEST_"


def subject_events(events: list[dict], onset: int, described: dict[str, str] | None = None) -> list[dict]:
    """The events at or after cycle onset that blame a camera or a beacon (not ordinary, and
    their subject a camera index or beacon id): {"cycle", "event", "kind", "subject"} in order;
    a pair event (CAMERAS_DISAGREE) gives one entry per camera it names."""
    out = []
    for r in sorted(events, key=lambda r: (int(r["cycle"]), int(r.get("seq", 0) or 0))):
        name = r.get("event", "")
        if name in ORDINARY or name.endswith(ORDINARY_ENDS) or int(r["cycle"]) < onset:
            continue
        if name.startswith(STARTUP_PREFIX):
            continue
        kind = event_subject_kind(name, described)
        if kind not in ("camera", "beacon"):
            continue
        subj = r.get("subject", "").strip()
        if kind == "camera" and subj in CAMERAS:
            subj = str(CAMERAS.index(subj))
        if kind == "beacon" and subj == str(SUBJECT_SATURATED):
            subj = r.get("arg1", "").strip()
        if not subj.lstrip("-").isdigit():
            continue
        out.append({"cycle": int(r["cycle"]), "event": name, "kind": kind, "subject": int(subj)})
        other = r.get("arg1", "").strip()
        if name in PAIR_EVENTS and kind == "camera" and other.isdigit():
            out.append({"cycle": int(r["cycle"]), "event": name, "kind": kind, "subject": int(other)})
    return out


def first_motion_report(events: list[dict], onset: int) -> dict | None:
    """The first MOTION_EXCEEDED or MODE_CHANGE at or after onset (the reports a motion fault,
    which has no camera or beacon subject, can have: MOTION_REPORTS)."""
    for r in sorted(events, key=lambda r: (int(r["cycle"]), int(r.get("seq", 0) or 0))):
        if int(r["cycle"]) >= onset and r.get("event", "") in MOTION_REPORTS:
            return {"cycle": int(r["cycle"]), "delay": int(r["cycle"]) - onset, "event": r["event"]}
    return None


def subject_label(kind: str, subject: int) -> str:
    if kind == "camera" and 0 <= subject < len(CAMERAS):
        return f"camera {CAMERAS[subject]}"
    return f"{kind} {subject}"


def blame(
    events: list[dict],
    onset: int,
    subjects: list[tuple[str, int]],
    described: dict[str, str] | None = None,
    baseline: set[tuple[str, str, int]] | None = None,
) -> dict:
    """Who the events after onset blame, for a fault whose true subjects are `subjects`
    [(kind, id)]: the first subject blamed ({"event", "cycle", "delay", "label", "right"}),
    the wrong-subject blame {label: [event names]} (events naming a camera or beacon that is
    not a subject of the fault) and, with baseline (the (event, kind, subject) triples the
    fault-free run of the same table gave at any time), the wrong blame that run did not give
    (the fault's own wrong blame, not the scenario's background)."""
    truth = {(k, int(i)) for k, i in subjects}
    evs = subject_events(events, onset, described)
    first = None
    if evs:
        e = evs[0]
        first = {
            "event": e["event"],
            "cycle": e["cycle"],
            "delay": e["cycle"] - onset,
            "label": subject_label(e["kind"], e["subject"]),
            "right": (e["kind"], e["subject"]) in truth,
        }
    wrong: dict[str, list[str]] = {}
    excess: dict[str, list[str]] = {}
    for e in evs:
        if (e["kind"], e["subject"]) in truth:
            continue
        label = subject_label(e["kind"], e["subject"])
        if e["event"] not in wrong.setdefault(label, []):
            wrong[label].append(e["event"])
        if baseline is not None and (e["event"], e["kind"], e["subject"]) not in baseline:
            if e["event"] not in excess.setdefault(label, []):
                excess[label].append(e["event"])
    return {"first": first, "wrong": wrong, "wrong_not_in_clean": excess if baseline is not None else None}


def baseline_blame(events: list[dict], described: dict[str, str] | None = None) -> set[tuple[str, str, int]]:
    """The (event, kind, subject) triples a fault-free run's events blame (blame()'s baseline)."""
    return {(e["event"], e["kind"], e["subject"]) for e in subject_events(events, 0, described)}
