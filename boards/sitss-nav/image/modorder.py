#!/usr/bin/env python3
"""modorder.py MODDIR NAME...: the kernel modules NAME need, in load order.

The Debian kernel package ships no modules.dep (its postinst runs depmod, which
this host does not have and which would run on the target's tree anyway), so
the order is read from each module's own .modinfo section: its `depends=`
line names the modules it needs. Prints one path per line, relative to MODDIR,
dependencies first; fails naming a module that is not in the tree.
"""

import sys
from pathlib import Path


def modinfo_depends(ko: Path) -> list[str]:
    """The depends= entry of a .ko (the strings of its .modinfo section)."""
    data = ko.read_bytes()
    for field in data.split(b"\0"):
        if field.startswith(b"depends="):
            v = field[len(b"depends=") :].decode()
            return [d for d in v.split(",") if d]
    return []


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    root = Path(sys.argv[1])
    index = {p.name[:-3].replace("-", "_"): p for p in root.rglob("*.ko")}
    order: list[Path] = []
    seen: set[str] = set()

    def visit(name: str, chain: tuple[str, ...]) -> None:
        key = name.replace("-", "_")
        if key in seen:
            return
        if key in chain:
            raise SystemExit(f"modorder: dependency cycle {' -> '.join(chain + (key,))}")
        ko = index.get(key)
        if ko is None:
            raise SystemExit(f"modorder: module {name} not in {root} (built in, or not in this kernel?)")
        for dep in modinfo_depends(ko):
            visit(dep, chain + (key,))
        seen.add(key)
        order.append(ko)

    for name in sys.argv[2:]:
        visit(name, ())
    for ko in order:
        print(ko.relative_to(root))
    return 0


if __name__ == "__main__":
    sys.exit(main())
