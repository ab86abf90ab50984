#!/usr/bin/env bash
# replay_ident.sh OUT [FRAMES]: the bit-identity check of a change that must not
# change what the flight program computes (docs/budgets.md, issue 22's size work).
# Builds this tree's host-sim flight program, flies four fixed replays (module
# seeds 2 with the survey error, 3, 7 with spurious blobs: acquisition through
# the P3P solver, then tracking; the turntable) with tables from `mfns table
# build` and a fixed acquisition budget (the default is measured at start-up,
# so it differs between runs), and decodes them with the ground station into
# OUT/<case>/ground/*.csv. FRAMES (default build/replay-frames) keeps the
# simulated frames between runs. Run it before and after a change, then
#   mk/replay_cmp.py OUT_BEFORE OUT_AFTER
# which compares every cell but the wall-clock ones.
set -euo pipefail
out=$(mkdir -p "$1" && cd "$1" && pwd)
frames=${2:-build/replay-frames}
py=${PY:-.venv/bin/python}
make --no-print-directory BOARD=host-sim flight >/dev/null
bin=build/host-sim/bin
cases=("module2|--scenario module --frames 40 --seed 2 --survey-error"
       "module3|--scenario module --frames 40 --seed 3"
       "module7|--scenario module --frames 40 --seed 7 --spurious-rate 0.5"
       "turn1|--scenario turntable --frames 60 --yaw-span 120 --seed 1 --survey-error")
for c in "${cases[@]}"; do
  IFS='|' read -r name simargs <<<"$c"
  if [ ! -f "$frames/$name/truth.csv" ]; then
    rm -rf "${frames:?}/$name"
    mkdir -p "$frames"
    # shellcheck disable=SC2086
    "$py" -m mfns sim nav $simargs -q --out "$frames/$name"
  fi
  d=$out/$name
  rm -rf "$d"
  mkdir -p "$d"
  "$py" -m mfns table build "$frames/$name/calib.json" "$frames/$name/beacons.csv" -q -o "$d/table.mfnstbl" 2>/dev/null
  "$bin/mfns-nav" --table "$d/table.mfnstbl" --replay "$frames/$name" --file "$d/tlm.bin" -q \
    --budget-units 20000 2>"$d/nav.log" || echo "replay_ident: mfns-nav exit $? in $name (see $d/nav.log)"
  "$bin/mfns-ground" --file "$d/tlm.bin" --out "$d/ground" -q 2>"$d/ground.log"
done
echo "replay_ident: $out"
