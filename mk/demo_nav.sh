#!/usr/bin/env bash
# demo_nav.sh OUT NAME LABEL CALIB NAV_ARGS [TABLE_ARGS]: one run of make demo's step 4-5
# (mk/demo.sh): a calibration table from CALIB (mfns table build), the flight program
# mfns-nav on the replayed frames of OUT/NAME/frames, its telemetry through a FIFO to the
# ground station mfns-ground, live, then the run's report against truth (mfns report:
# OUT/NAME/LABEL/report/summary.md). Everything it prints is for the demo's log.
set -euo pipefail
py=${PY:-.venv/bin/python}
bin=${BIN:-build/host-sim/bin}
out=$1 name=$2 label=$3 calib=$4 nav_args=$5 table_args=${6:-}
d=$out/$name/$label
mkdir -p "$d"
echo "table from $(basename "$calib"), flight program -> FIFO -> ground station"
# shellcheck disable=SC2086
"$py" -m mfns table build "$calib" "$out/$name/frames/beacons.csv" -o "$d/table.mfnstbl" $table_args >"$d/table.log"
fifo=$d/uart.fifo
mkfifo "$fifo"
"$bin/mfns-ground" --tty "$fifo" --out "$d/ground" --record "$d/telemetry.bin" --no-status \
  --max-seconds 600 2>"$d/ground.log" &
gpid=$!
sleep 0.3
init=$(sed -n 2p "$out/$name/frames/truth.csv" | cut -d, -f3-8)
args=${nav_args//@INIT@/$init}
# shellcheck disable=SC2086
"$bin/mfns-nav" --table "$d/table.mfnstbl" --replay "$out/$name/frames" --tlm-tty "$fifo" $args 2>"$d/nav.log"
# the ground station keeps a FIFO open for writers that come and go: stop
# it once the flight program has finished and the last bytes are read
sleep 0.5
kill -INT "$gpid"
wait "$gpid" || true
echo "   $(tail -n 1 "$d/nav.log")"
echo "   $(tail -n 1 "$d/ground.log")"
"$py" -m mfns report "$d/ground" --truth "$out/$name/frames/truth.csv" --out "$d/report" \
  --title "$name / $label" | grep -v '^wrote'
rm -f "$fifo"
