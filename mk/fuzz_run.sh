#!/usr/bin/env bash
# fuzz_run.sh NAME BIN CORPUS SECONDS SEED MAX_LEN [SEED_DIR]: one libFuzzer run of every
# fuzz target (mk/fuzz.mk, mk/telemetry.mk, mk/uplink.mk). Copies the committed seeds of
# SEED_DIR into CORPUS (never over a file already there), runs BIN for SECONDS from CORPUS and
# prints "NAME: 1 passed, 0 failed (N executions in S s, cov: C)"; on a crash or a sanitizer
# report it prints the log's tail and "NAME: 0 passed, 1 failed" and exits 1.
set -uo pipefail
name=$1 bin=$2 corpus=$3 secs=$4 seed=$5 maxlen=$6 seeds=${7:-}
mkdir -p "$corpus"
if [ -n "$seeds" ] && [ -d "$seeds" ]; then cp -n "$seeds"/* "$corpus"/ 2>/dev/null || true; fi
log=build/fuzz/$name.log
if "$bin" -max_total_time="$secs" -seed="$seed" -max_len="$maxlen" -print_final_stats=1 \
     -rss_limit_mb=1024 -artifact_prefix="build/fuzz/$name-" "$corpus" >"$log" 2>&1; then
  execs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+)/\1/p' "$log" | tail -n 1)
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -n 1)
  echo "$name: 1 passed, 0 failed (${execs:-?} executions in $secs s, ${cov:-cov: ?})"
else
  tail -n 40 "$log"
  echo "$name: 0 passed, 1 failed"
  exit 1
fi
