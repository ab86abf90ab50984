#!/usr/bin/env bash
# summary.sh FILE: total the suites recorded by suite.sh; exit 1 if any failed.
set -u
f=$1
passed=0; failed=0; bad=0
while read -r status _name rest; do
  p=$(sed -E 's/.*: ([0-9]+) passed, ([0-9]+) failed.*/\1/' <<<"$rest")
  q=$(sed -E 's/.*: ([0-9]+) passed, ([0-9]+) failed.*/\2/' <<<"$rest")
  passed=$((passed + p)); failed=$((failed + q))
  [ "$status" = ok ] || bad=$((bad + 1))
done <"$f"
echo "total: $passed passed, $failed failed"
[ "$bad" -eq 0 ] && [ "$failed" -eq 0 ]
