#!/usr/bin/env python3
"""map_text.py [--label LABEL] MAP: text + rodata of a GNU ld map, split into
the core's own code (every input that is not an archive member: the core's
objects, or with LTO the link-time partition GCC wrote them into) and the
libraries' (members of libm.a, libgcc.a, libc_nano.a). Prints one LABEL line
(default `flight`) and the 64 KB goal of issue 22 against the core's own."""

from __future__ import annotations

import re
import sys

GOAL = 65536


def main() -> int:
    args = sys.argv[1:]
    label = "flight"
    if len(args) == 3 and args[0] == "--label":
        label, args = args[1], args[2:]
    if len(args) != 1:
        print("usage: map_text.py [--label LABEL] MAP", file=sys.stderr)
        return 2
    path = args[0]
    text = open(path, encoding="utf-8").read().split("Linker script and memory map", 1)[-1]
    lines = text.splitlines()
    own = lib = 0
    for i, line in enumerate(lines):
        m = re.match(r"^ (\.text\S*|\.rodata\S*)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S+)", line)
        if m:
            size, src = int(m.group(3), 16), m.group(4)
        elif re.match(r"^ (\.text\S*|\.rodata\S*)\s*$", line) and i + 1 < len(lines):
            n = re.match(r"^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S+)", lines[i + 1])
            if not n:
                continue
            size, src = int(n.group(2), 16), n.group(3)
        else:
            continue
        if re.search(r"\.a\([^)]*\)$", src):  # an archive member: libm, libgcc, libc
            lib += size
        else:
            own += size
    verdict = "met" if own <= GOAL else f"NOT met ({own - GOAL} B over)"
    print(
        f"{label}: {own} B of the core's own code and constants + {lib} B of libm/libgcc/libc; "
        f"goal {GOAL} B for the core's own: {verdict}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
