#!/usr/bin/env bash
# run-unit.sh SUITE RUNNER TEST...: run each cmocka test binary (under RUNNER,
# e.g. qemu-aarch64, when non-empty) from the repo root, and count the tests
# from cmocka's own lines. Prints "SUITE: N passed, M failed".
set -u
suite=$1; runner=$2; shift 2
passed=0; failed=0; broken=0
for t in "$@"; do
  out=$(mktemp)
  # shellcheck disable=SC2086
  $runner "$t" >"$out" 2>&1
  rc=$?
  run=$(sed -nE 's/^\[==========\] ([0-9]+) test\(s\) run\./\1/p' "$out" | tail -n 1)
  fl=$(sed -nE 's/^\[  FAILED  \] ([0-9]+) test\(s\), listed below:/\1/p' "$out" | tail -n 1)
  run=${run:-0}; fl=${fl:-0}
  if [ "$rc" -ne 0 ] && [ "$fl" -eq 0 ]; then
    # crashed or aborted (sanitizer report, signal): count the binary as failed
    fl=1; broken=$((broken + 1))
  fi
  if [ "$rc" -ne 0 ] || [ "$fl" -ne 0 ]; then
    echo "== $(basename "$t"): FAILED (exit $rc)"; cat "$out"
  else
    echo "== $(basename "$t"): $run passed"
  fi
  passed=$((passed + run - (fl > run ? run : fl))); failed=$((failed + fl))
  rm -f "$out"
done
echo "$suite: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
