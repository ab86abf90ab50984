#!/usr/bin/env python3
"""Worst-case stack depth per entry point of the flight core.

Reads the call-graph files GCC writes with ``-fstack-usage -fcallgraph-info=su``
(one ``.ci`` per object: every function's own frame in bytes and whether it is
static, dynamic or dynamic-bounded, and every call it makes) and prints, for
each entry point, the deepest sum of frames over its call graph::

    stack: ENTRY BYTES [flags]

Entry points are the functions nothing in the core calls (the API the flight
program uses); ``--entry NAME`` (repeatable) prints those only, ``--also NAME``
adds a function the core calls itself (the centroider, under mfns_nav_cycle),
``--min BYTES`` folds the shallow entries into one line. Flags say where
the number is not a bound:

  recursion   a cycle in the call graph (the depth of one trip round it is
              counted; the true depth depends on the recursion's bound)
  dynamic     a frame of run-time size (VLA, alloca) on the path
  indirect    a call through a function pointer the graph cannot resolve
  ext=a,b     calls to functions outside the core (libm, libgcc, string
              routines), whose frames are not in the graph and count as 0

Standard library only (it runs in ``make size`` before the venv exists).
Exit status 1 when --max BYTES is given and an entry exceeds it.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

NODE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"(.*)\}')
EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
FRAME = re.compile(r"\\n(\d+) bytes \(([a-z, ]+)\)")
INDIRECT = "__indirect_call"

# (bytes, flags, external callees, deepest chain) of the deepest path from a function
Result = tuple[int, frozenset[str], frozenset[str], tuple[str, ...]]


class Graph:
    def __init__(self) -> None:
        self.frame: dict[str, int] = {}  # defined function -> own frame (bytes)
        self.kind: dict[str, str] = {}  # static / dynamic / dynamic,bounded
        self.calls: dict[str, list[str]] = {}
        self.public: set[str] = set()  # defined, not file-local

    def read(self, path: Path) -> None:
        for line in path.read_text().splitlines():
            m = NODE.match(line.strip())
            if m:
                title, label, _ = m.groups()
                f = FRAME.search(label)
                if f:  # a function defined in this file
                    self.frame[title] = int(f.group(1))
                    self.kind[title] = f.group(2)
                    self.calls.setdefault(title, [])
                    if ":" not in title:  # file-local ones are "file.c:name"
                        self.public.add(title)
                continue
            m = EDGE.match(line.strip())
            if m:
                self.calls.setdefault(m.group(1), []).append(m.group(2))

    def folded(self, fn: str) -> str | None:
        """In the graph of an LTO link: a call to a copy of a file-local function
        (NAME.lto_priv.N, one per file that defined it, e.g. a static inline of a
        header) whose node is missing because the copies were merged into one; the
        deepest remaining copy, or None."""
        m = re.match(r"(.*\.lto_priv\.)\d+$", fn)
        copies = [t for t in self.frame if m and t.startswith(m.group(1))]
        return max(copies, key=lambda t: self.frame[t]) if copies else None

    def roots(self) -> list[str]:
        called = {t for src, ts in self.calls.items() for t in ts}
        return sorted(f for f in self.public if f not in called)


class Depth:
    """Worst depth of each function, memoised; flags collected per entry."""

    def __init__(self, g: Graph) -> None:
        self.g = g
        self.memo: dict[str, Result] = {}

    def of(self, fn: str, path: tuple[str, ...] = ()) -> Result:
        """(bytes, flags, external callees, deepest chain) of the deepest path from fn."""
        if fn in self.memo:
            return self.memo[fn]
        if fn in path:
            return 0, frozenset({"recursion"}), frozenset(), ()
        if fn == INDIRECT:
            return 0, frozenset({"indirect"}), frozenset(), ()
        if fn not in self.g.frame and self.g.folded(fn):
            return self.of(self.g.folded(fn) or fn, path)
        if fn not in self.g.frame:  # outside the core
            return 0, frozenset(), frozenset({fn}), ()
        flags: set[str] = set()
        ext: set[str] = set()
        if "dynamic" in self.g.kind[fn] and "bounded" not in self.g.kind[fn]:
            flags.add("dynamic")
        deepest, chain = 0, ()
        for callee in self.g.calls.get(fn, []):
            d, fl, ex, ch = self.of(callee, path + (fn,))
            if d > deepest:
                deepest, chain = d, ch
            flags |= fl
            ext |= ex
        own = f"{fn.rsplit(':', 1)[-1]}({self.g.frame[fn]})"
        res = (self.g.frame[fn] + deepest, frozenset(flags), frozenset(ext), (own,) + chain)
        if "recursion" not in flags:  # a cycle's partial result depends on the path
            self.memo[fn] = res
        return res


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ci", nargs="+", type=Path, help=".ci files (gcc -fcallgraph-info=su)")
    ap.add_argument("--entry", action="append", default=[], help="entry to report (default: every root)")
    ap.add_argument("--max", type=int, default=0, help="fail when an entry needs more bytes")
    ap.add_argument("--also", action="append", default=[], help="a function the core calls, reported too")
    ap.add_argument("--min", type=int, default=0, help="list only entries needing at least this many bytes")
    ap.add_argument("--label", default="stack", help="prefix of the printed lines (default: stack)")
    a = ap.parse_args(argv)
    g = Graph()
    for p in a.ci:
        if not p.exists():
            print(f"{a.label}: {p} missing (build with -fstack-usage -fcallgraph-info=su)", file=sys.stderr)
            return 2
        g.read(p)
    entries = a.entry or g.roots()
    unknown = [e for e in entries if e not in g.frame]
    if unknown:
        print(f"{a.label}: not in the core: {', '.join(unknown)}", file=sys.stderr)
        return 2
    d = Depth(g)
    for name in a.also:
        if name not in g.frame:
            print(f"{a.label}: {name} not in the core (renamed?)")
            continue
        n, flags, ext, _ = d.of(name)
        notes = sorted(flags) + ([f"ext={','.join(sorted(ext))}"] if ext else [])
        print(f"{a.label}: {name} {n} [called by the core" + "".join(" " + x for x in notes) + "]")
    worst, worst_fn, worst_chain, rc = 0, "", (), 0
    small, small_max = 0, 0
    for e in sorted(entries, key=lambda x: d.of(x)[0]):
        n, flags, ext, chain = d.of(e)
        if n > worst:
            worst, worst_fn, worst_chain = n, e, chain
        if a.max and n > a.max:
            rc = 1
        if n < a.min and not a.entry:
            small, small_max = small + 1, max(small_max, n)
            continue
        notes = sorted(flags) + ([f"ext={','.join(sorted(ext))}"] if ext else [])
        print(f"{a.label}: {e} {n}" + (f" [{' '.join(notes)}]" if notes else ""))
    if small:
        print(f"{a.label}: ({small} more entry points below {a.min} bytes, the deepest {small_max})")
    print(f"{a.label}: worst {worst_fn} {worst} bytes over {len(entries)} entry points")
    print(f"{a.label}: its deepest chain: {' > '.join(worst_chain)}")
    if rc:
        print(f"{a.label}: an entry point needs more than {a.max} bytes")
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
