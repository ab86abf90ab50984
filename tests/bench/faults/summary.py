#!/usr/bin/env python3
"""Summaries of grown fault campaigns (tests/bench/fault_acceptance.py --campaign grown): the
results.json of one or more seeds -> markdown.

    python tests/bench/faults/summary.py build/faults-grown/seed*/results.json [--per-fault]

Per kind of fault (the run name without its camera, frame and amount), over every seed and
both tables: runs, usable %, misleading fixes (in how many runs), worst error against the
protection level and against sigma, reports of the right subject within the campaign's window,
runs whose first blamed subject was wrong. --per-fault: one row per fault of each seed instead,
its nominal and survey-error runs side by side (nominal / survey).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

SURVEY = " + survey error"
KINDS = (
    ("clean", r"^clean"),
    ("knocked mount", r"knocked"),
    ("clock drift, ms per frame", r"clock drifting [\d.]+ ms"),
    ("clock drift, 100 ppm", r"clock drifting [\d.]+ ppm"),
    ("stale after a dropped frame", r"drops frame"),
    ("two alternating buffers", r"alternating buffers"),
    ("frozen scene, fresh noise", r"frozen scene"),
    ("two beacons moved", r"^beacons .* moved"),
    ("reflections beside beacons", r"reflection"),
    ("streams swapped", r"swapped"),
    ("gain halved", r"gain halved"),
    ("collision", r"collision"),
)


def kind_of(name: str) -> str:
    for k, pat in KINDS:
        if re.search(pat, name):
            return k
    return name


def within(r: dict) -> str:
    """yes / late / no / none due / nothing to detect / - for one run (the campaign's verdict)."""
    reps = r.get("reports") or {}
    if not reps:
        return "-"
    win = r.get("report_window_from_cycle")
    if win is None:
        return "none due"
    window = r.get("report_within_cycles", 10)
    verdicts = []
    for label, rep in reps.items():
        if rep is None:
            verdicts.append("nothing" if (r.get("beacon_spots") or {}).get(label) == 0 else "no")
        else:
            verdicts.append("yes" if rep["cycle"] <= win + window else "late")
    if "yes" in verdicts:
        return "yes"
    if set(verdicts) == {"nothing"}:
        return "nothing to detect"
    return "late" if "late" in verdicts else "no"


def first_blamed(r: dict) -> str:
    f = (r.get("blame") or {}).get("first")
    if not r.get("blame"):
        return "-"
    if f is None:
        return "none"
    return f"{f['label']} ({f['event']}){'' if f['right'] else ' WRONG'}"


def report_text(r: dict) -> str:
    reps = r.get("reports") or {}
    out = []
    for label, rep in reps.items():
        t = "-" if rep is None else f"{rep['delay']} {rep['event']}"
        out.append(t if len(reps) == 1 else f"{label}: {t}")
    return "; ".join(out) or "-"


def ratio(r: dict) -> str:
    return "-" if r.get("worst_pl_ratio") is None else f"{r['worst_pl_ratio']:.2f}"


def per_kind(docs: list[dict]) -> list[str]:
    rows: dict[str, dict] = {}
    for d in docs:
        for r in d["runs"]:
            k = rows.setdefault(
                kind_of(r["fault"]),
                {
                    "runs": 0,
                    "cycles": 0,
                    "usable": 0,
                    "mis": 0,
                    "mis_runs": 0,
                    "pl": 0.0,
                    "sig": 0.0,
                    "mm": 0.0,
                }
                | {"yes": 0, "due": 0, "wrong_first": 0, "seeds": set()},
            )
            k["runs"] += 1
            k["seeds"].add(d.get("seed"))
            k["cycles"] += r["cycles"]
            k["usable"] += r["usable"]
            k["mis"] += r["misleading"]
            k["mis_runs"] += int(r["misleading"] > 0)
            k["pl"] = max(k["pl"], r.get("worst_pl_ratio") or 0.0)
            k["sig"] = max(k["sig"], r.get("worst_sigma") or 0.0)
            k["mm"] = max(k["mm"], r.get("worst_mm") or 0.0)
            w = within(r)
            if w not in ("-", "none due", "nothing to detect"):
                k["due"] += 1
                k["yes"] += int(w == "yes")
            f = (r.get("blame") or {}).get("first")
            k["wrong_first"] += int(f is not None and not f["right"])
    out = [
        "| fault kind | seeds | runs | usable | misleading (runs) | worst mm | worst error/PL | worst sigma "
        "| reported with its subject in the window | first blame wrong |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, k in rows.items():
        pct = 100.0 * k["usable"] / k["cycles"] if k["cycles"] else 0.0
        seeds = ",".join(str(s) for s in sorted(x for x in k["seeds"] if x is not None))
        rep = "-" if name == "clean" else f"{k['yes']} of {k['due']}"
        out.append(
            f"| {name} | {seeds} | {k['runs']} | {pct:.1f} % | {k['mis']} ({k['mis_runs']}) | "
            f"{k['mm']:.2f} | "
            f"{k['pl']:.2f} | {k['sig']:.1f} | {rep} | {k['wrong_first'] if name != 'clean' else '-'} |"
        )
    return out


def per_fault(docs: list[dict]) -> list[str]:
    out = [
        "| seed | fault | usable % | misleading | worst error/PL | worst sigma | cycles to report (event) "
        "| in the window | first subject blamed |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for d in docs:
        runs = {r["run"]: r for r in d["runs"]}
        for r in d["runs"]:
            if r["run"].endswith(SURVEY):
                continue
            s = runs.get(r["run"] + SURVEY)
            pair = [x for x in (r, s) if x is not None]

            def both(f, pair=pair) -> str:
                vals = [f(x) for x in pair]
                return vals[0] if len(set(vals)) == 1 else " / ".join(vals)

            out.append(
                f"| {d.get('seed')} | {r['fault']} | "
                + both(lambda x: f"{100.0 * x['usable'] / max(x['cycles'], 1):.0f}")
                + " | "
                + both(lambda x: str(x["misleading"]))
                + " | "
                + both(ratio)
                + " | "
                + both(lambda x: f"{x['worst_sigma']:.1f}")
                + " | "
                + both(report_text)
                + " | "
                + both(within)
                + " | "
                + both(first_blamed)
                + " |"
            )
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", nargs="+", type=Path, help="results.json of grown campaigns")
    ap.add_argument("--per-fault", action="store_true", help="one row per fault of each seed")
    args = ap.parse_args()
    docs = []
    for p in args.results:
        d = json.loads(p.read_text())
        if d.get("campaign") != "grown":
            print(f"summary: {p}: not a grown campaign", file=sys.stderr)
            return 2
        docs.append(d)
    print("\n".join(per_fault(docs) if args.per_fault else per_kind(docs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
