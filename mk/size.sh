#!/usr/bin/env bash
# size.sh SIZE NM BUILD OBJ...: per-module text/data/bss of the portable core
# compiled for the bare-metal Cortex-M7, a total, and a check that the core
# references nothing of an OS or a heap: its undefined symbols must all be
# libm/libgcc/string routines from the allow-list below.
set -euo pipefail
size=$1; nm=$2; build=$3; shift 3
printf '%-28s %8s %8s %8s\n' module text data bss
tt=0; td=0; tb=0
for o in "$@"; do
  read -r t d b _ < <($size "$o" | tail -n 1)
  m=${o#"$build"/obj/}; m=${m%.o}
  printf '%-28s %8d %8d %8d\n' "$m" "$t" "$d" "$b"
  tt=$((tt + t)); td=$((td + d)); tb=$((tb + b))
done
printf '%-28s %8d %8d %8d\n' TOTAL "$tt" "$td" "$tb"
allowed='^(memcpy|memset|memmove|memcmp|strlen|strnlen|strcmp|strncmp|__aeabi_.*|__gnu_.*|(sqrt|sin|cos|tan|atan2|atan|asin|acos|exp|log|log2|log10|pow|floor|ceil|round|fabs|fmin|fmax|fmod|hypot|cbrt|remainder|copysign|trunc|lround|expm1|log1p)f?)$'
defined=$(for o in "$@"; do $nm --defined-only "$o" | awk '{print $3}'; done | sort -u)
undef=$(for o in "$@"; do $nm -u "$o" | awk '{print $2}'; done | sort -u)
bad=$(comm -23 <(echo "$undef") <(echo "$defined") | grep -Ev "$allowed" || true)
if [ -n "$bad" ]; then
  echo "size: the portable core references symbols outside the allow-list (OS, heap or stdio?):"
  echo "$bad" | sed 's/^/  /'
  exit 1
fi
echo "size: core references only libm/string routines (no OS, no heap)"
