#!/usr/bin/env bash
# run-pytest.sh PY: pytest over tests/host, summarised as "pytest: N passed, M failed".
set -u
py=$1
out=$(mktemp)
"$py" -m pytest -q -p no:cacheprovider tests/host 2>&1 | tee "$out"
rc=${PIPESTATUS[0]}
last=$(grep -E "(passed|failed|error)" "$out" | tail -n 1)
p=$(grep -oE '[0-9]+ passed' <<<"$last" | grep -oE '[0-9]+'); p=${p:-0}
f=$(grep -oE '[0-9]+ failed' <<<"$last" | grep -oE '[0-9]+'); f=${f:-0}
e=$(grep -oE '[0-9]+ error' <<<"$last" | grep -oE '[0-9]+'); e=${e:-0}
rm -f "$out"
echo "pytest: $p passed, $((f + e)) failed"
# exit 5 = no tests collected: that is a failure here, a suite must test something
[ "$rc" -eq 0 ]
