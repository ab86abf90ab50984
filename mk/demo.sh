#!/usr/bin/env bash
# demo.sh: the main job, end to end on simulated data (make demo).
#   1. simulate the navigation experiment (mfns sim nav): the paper's
#      turntable run and a space-station module with a dense beacon map;
#   2. build each scenario's calibration table (mfns table build);
#   3. run the flight program mfns-nav on the replayed frames, sending
#      telemetry through a FIFO to the ground station mfns-ground, live;
#   4. report the navigation errors against truth (mfns report: Table 5 and
#      Fig. 11 style).
# Output in build/demo/<scenario>/. Prints the summary tables.
set -euo pipefail
py=${PY:-.venv/bin/python}
bin=${BIN:-build/host-sim/bin}
out=build/demo
mkdir -p "$out"

run_scenario() {
  local name=$1; shift
  local d=$out/$name
  rm -rf "$d"; mkdir -p "$d"
  echo "== $name: simulate ($*)"
  "$py" -m mfns sim nav "$d/frames" "$@" --quiet
  echo "== $name: calibration table"
  "$py" -m mfns table build "$d/frames/calib.json" "$d/frames/beacons.csv" -o "$d/table.mfnstbl" | tail -n 1
  echo "== $name: flight program -> FIFO -> ground station"
  local fifo=$d/uart.fifo
  mkfifo "$fifo"
  "$bin/mfns-ground" --tty "$fifo" --out "$d/ground" --record "$d/telemetry.bin" --no-status \
    --max-seconds 600 2>"$d/ground.log" &
  local gpid=$!
  sleep 0.3
  local init args
  init=$(sed -n 2p "$d/frames/truth.csv" | cut -d, -f3-8)
  args=${NAV_ARGS//@INIT@/$init}
  # shellcheck disable=SC2086
  "$bin/mfns-nav" --table "$d/table.mfnstbl" --replay "$d/frames" --tlm-tty "$fifo" $args 2>"$d/nav.log"
  # the ground station keeps a FIFO open for writers that come and go: stop
  # it once the flight program has finished and the last bytes are read
  sleep 0.5
  kill -INT "$gpid"
  wait "$gpid" || true
  tail -n 1 "$d/nav.log"
  tail -n 1 "$d/ground.log"
  echo "== $name: report against truth"
  "$py" -m mfns report "$d/ground" --truth "$d/frames/truth.csv" --out "$d/report" | grep -v '^wrote'
  rm -f "$fifo"
}

# The paper's run: the robot starts from no knowledge (acquisition).
NAV_ARGS="" run_scenario turntable --scenario turntable --frames 200 --yaw-span 120 --seed 1
# The module: 60 beacons. The robot leaves a known docking pose (the first
# truth row, as the ground would command it), then tracks on its own.
NAV_ARGS="--init-pose=@INIT@" run_scenario module --scenario module --frames 120 --seed 2
echo "demo: outputs in $out/*/ (report/*.png, report/summary.md, ground/*.csv)"
