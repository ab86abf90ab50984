#!/usr/bin/env bash
# bench-calib.sh PY: time `mfns calib` on the default simulated dataset (target <= 10 s on
# 2 cores) and check that two runs write byte-identical files.
set -euo pipefail
py=$1
dir=build/bench-calib
if [ ! -f "$dir/ds/dataset.json" ]; then
  rm -rf "$dir/ds"
  "$py" -m mfns sim calib "$dir/ds" --quiet
fi
for run in 1 2; do
  rm -rf "$dir/out$run"
  start=$(date +%s.%N)
  "$py" -m mfns calib "$dir/ds" --quiet -o "$dir/out$run/res.json" --report "$dir/out$run/report.txt"
  end=$(date +%s.%N)
  echo "bench-calib: run $run $(echo "$end - $start" | bc) s ($(grep 'corner detection' "$dir/out$run/report.txt"))"
done
for f in "$dir"/out1/*; do
  b=$(basename "$f")
  [ "$b" = report.txt ] && continue
  cmp -s "$f" "$dir/out2/$b" || { echo "bench-calib: $b differs between runs"; exit 1; }
done
echo "bench-calib: the two runs' outputs are byte-identical"
