#!/usr/bin/env python3
"""include_graph.py [--folders] [--check]: the C include graph of the tree, and its circles.

A node is a module: `name.c`, `name.h` and `name_internal.h` of one folder are one node
(the header is the module's contract, the internal header what its own sources share, the
source its body). An edge A -> B is an `#include "..."` in A's files
that names B's header. A circle is a strongly connected set of two or more modules: two
modules that reach each other through includes, which the house forbids (README.md
"Adding a module"). --folders prints the folder-level graph (edges between folders with
their counts); --check exits 1 when any circle exists. Includes are resolved the way the
build resolves them: from the repository root (`#include "firmware/nav/pose/pose.h"`),
or, for a bare name, from the including file's own folder.
"""
import argparse
import re
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # --root moves it (the tests' small trees)
SCAN = ("math", "firmware", "drivers", "ground", "tests/unit/support")
INC = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def files():
    for top in SCAN:
        for p in sorted((ROOT / top).rglob("*")):
            if p.suffix in (".c", ".h", ".cpp") and "build" not in p.parts:
                yield p


def node(p: Path) -> str:
    rel = p.relative_to(ROOT).with_suffix("")
    if rel.name.endswith("_internal"):
        rel = rel.with_name(rel.name[: -len("_internal")])
    return str(rel)


# The search path the build used before includes were written from the root: a bare name
# found only through it is reported (--check fails on it), so the picture of an older tree
# can still be drawn.
LEGACY_PATH = ("math", "firmware/nav", "firmware/tlm", "firmware/app", "drivers/camera",
               "drivers/uart", "ground", "tests/unit/support", "firmware/host")


# Headers the build writes itself (mk/version.mk: build/gen/mfns_version.h, the one -I
# beside the root).
BUILD_GENERATED = ("mfns_version.h",)

# The borders: a module in the first folder never includes one in the second (prefixes).
# The flight core sees no OS, host-only or Linux code, nor the frame policies beside it;
# the host-only core is never a flight module's dependency; drivers know nothing of the
# program that uses them.
BORDERS = (
    (("math/", "firmware/nav/", "firmware/tlm/"),
     ("firmware/app/", "firmware/host/", "firmware/linux/", "firmware/frames/", "drivers/", "ground/", "tests/")),
    # the frame policies (issue 41) are portable like the core and sit beside it: they may
    # use the core, nothing of an OS, a program or the ground; the core never uses them
    (("firmware/frames/",),
     ("firmware/app/", "firmware/host/", "firmware/linux/", "drivers/", "ground/", "tests/")),
    (("math/",), ("firmware/",)),
    (("drivers/",), ("firmware/app/", "ground/", "firmware/host/")),
    # what both programs link lives in firmware/linux/: the ground never reaches into the
    # flight program, nor the flight program into the ground
    (("ground/",), ("firmware/app/",)),
    (("firmware/app/", "firmware/linux/"), ("ground/",)),
    (("firmware/linux/",), ("firmware/app/",)),
)


def resolve(src: Path, name: str):
    """(path, how): how is 'root', 'local' (the including file's folder) or 'search'."""
    if name in BUILD_GENERATED:
        return ROOT / "build" / "gen" / name, "build"
    for cand, how in ((ROOT / name, "root"), (src.parent / name, "local")):
        if cand.is_file():
            return cand, how
    for d in LEGACY_PATH:
        if (ROOT / d / name).is_file():
            return ROOT / d / name, "search"
    return None, None


def graph():
    g = defaultdict(set)
    unresolved = []
    searched = []
    for p in files():
        a = node(p)
        g[a]
        for name in INC.findall(p.read_text(errors="replace")):
            q, how = resolve(p, name)
            if q is None:
                unresolved.append((str(p.relative_to(ROOT)), name))
                continue
            if how == "search":
                searched.append((str(p.relative_to(ROOT)), name))
            if how == "build":
                continue
            b = node(q)
            if b != a:
                g[a].add(b)
    return g, unresolved, searched


def sccs(g):
    """Tarjan's algorithm, iterative (the graph is small but recursion depth is not ours to pick)."""
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in sorted(g):
        if root in index:
            continue
        work = [(root, iter(sorted(g[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(g.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folders", action="store_true", help="print the folder-level graph")
    ap.add_argument("--check", action="store_true", help="exit 1 when a circle exists")
    ap.add_argument("--root", type=Path, help="the tree to read (default: this repository)")
    a = ap.parse_args()
    if a.root is not None:
        global ROOT
        ROOT = a.root.resolve()
    g, unresolved, searched = graph()
    if a.folders:
        fe = defaultdict(int)
        for m, deps in g.items():
            for d in deps:
                fa, fb = str(Path(m).parent), str(Path(d).parent)
                if fa != fb:
                    fe[(fa, fb)] += 1
        for (fa, fb), n in sorted(fe.items()):
            print(f"{fa} -> {fb} ({n})")
    circles = sccs(g)
    crossings = [(m, d) for m, deps in sorted(g.items()) for d in sorted(deps)
                 for src, dst in BORDERS if m.startswith(src) and d.startswith(dst)]
    for m, d in crossings:
        print(f"border crossed: {m} -> {d}")
    # every circle fails, wherever it is (issue 41's app stage broke the last two: the
    # flight program's rooms and the camera driver's front and backends)
    for c in circles:
        print("circle: " + " <-> ".join(c))
    for src, name in unresolved:
        print(f"unresolved: {src}: \"{name}\"")
    for src, name in searched:
        print(f"by search path: {src}: \"{name}\"")
    print(f"{len(g)} modules, {sum(len(v) for v in g.values())} includes, {len(circles)} circles, "
          f"{len(searched)} includes found only by a search path, {len(unresolved)} unresolved, "
          f"{len(crossings)} borders crossed")
    return 1 if a.check and (circles or unresolved or searched or crossings) else 0


if __name__ == "__main__":
    sys.exit(main())
