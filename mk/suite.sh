#!/usr/bin/env bash
# suite.sh NAME CMD...: run one test suite with its output in build/logs/NAME.log,
# print exactly one summary line for it and record the result for summary.sh.
# The suite's own runner prints "NAME: N passed, M failed" as its last such
# line; a suite that fails without one is reported as failed with its log tail.
set -u
name=$1; shift
mkdir -p build/logs
log=build/logs/$name.log
start=$(date +%s)
"$@" >"$log" 2>&1
rc=$?
secs=$(( $(date +%s) - start ))
line=$(grep -E "^$name: [0-9]+ passed, [0-9]+ failed" "$log" | tail -n 1)
if [ "$rc" -eq 0 ]; then
  [ -n "$line" ] || line="$name: 1 passed, 0 failed"
  echo "$line (${secs}s)"
  echo "ok $name $line" >>build/test-summary.txt
else
  echo "---- $name failed (exit $rc); last lines of $log:"
  tail -n 40 "$log" | sed 's/^/  | /'
  [ -n "$line" ] || line="$name: 0 passed, 1 failed"
  echo "$line (${secs}s)"
  echo "FAIL $name $line" >>build/test-summary.txt
fi
exit 0
