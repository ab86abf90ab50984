#!/usr/bin/env bash
# flight_roots.sh NM "APP_DIR..." OBJ...: the core functions the flight program
# calls, as -Wl,-u,NAME linker options: every global function the core objects
# define whose name appears as an identifier in APP_DIR/*.c (the program's folders:
# firmware/app and firmware/linux, the code it shares with the ground). Derived from the
# sources, never listed by hand, so the flight image of `make size` (section
# garbage collection from these roots) follows what firmware/app really calls.
set -euo pipefail
nm=$1; app=$2; shift 2
defs=$(for o in "$@"; do "$nm" --defined-only "$o" | awk '$2 == "T" {print $3}'; done | sort -u)
# shellcheck disable=SC2086
ids=$(for d in $app; do cat "$d"/*.c; done | grep -oE '\b[A-Za-z_][A-Za-z0-9_]*\b' | sort -u)
roots=$(comm -12 <(echo "$defs") <(echo "$ids"))
[ -n "$roots" ] || { echo "flight_roots: no core function is called from $app" >&2; exit 1; }
for r in $roots; do printf -- '-Wl,-u,%s ' "$r"; done
