#!/usr/bin/env bash
# filter_avail.sh OUT [FRAMES]: availability and bounds of the navigation
# filter (issue 42, docs/pose.md "Navigation filter") on the clean module runs
# (seeds 2-5, 120 frames) and the paper's turntable run: each replay flown by
# this tree's host-sim flight program with the filter off and on
# (--nav-filter 54), decoded by the ground station, then compared with the
# simulator's truth by mk/filter_avail.py (usable cycles, worst |error| and
# |error| / PL per axis, usable fixes beyond their PL). FRAMES (default
# build/favail-frames) keeps the simulated frames between runs.
set -euo pipefail
out=$(mkdir -p "$1" && cd "$1" && pwd)
frames=${2:-build/favail-frames}
py=${PY:-.venv/bin/python}
make --no-print-directory BOARD=host-sim flight >/dev/null
bin=build/host-sim/bin
cases=("module2|--scenario module --frames 120 --seed 2"
       "module3|--scenario module --frames 120 --seed 3"
       "module4|--scenario module --frames 120 --seed 4"
       "module5|--scenario module --frames 120 --seed 5"
       "turn1|--scenario turntable --frames 60 --yaw-span 120 --seed 1")
for c in "${cases[@]}"; do
  IFS='|' read -r name simargs <<<"$c"
  if [ ! -f "$frames/$name/truth.csv" ]; then
    rm -rf "${frames:?}/$name"
    mkdir -p "$frames"
    # shellcheck disable=SC2086
    "$py" -m mfns sim nav $simargs -q --out "$frames/$name"
  fi
  for mode in off on; do
    d=$out/$name-$mode
    rm -rf "$d"
    mkdir -p "$d"
    "$py" -m mfns table build "$frames/$name/calib.json" "$frames/$name/beacons.csv" -q -o "$d/table.mfnstbl" 2>/dev/null
    extra=()
    [ "$mode" = on ] && extra=(--nav-filter 54)
    "$bin/mfns-nav" --table "$d/table.mfnstbl" --replay "$frames/$name" --file "$d/tlm.bin" -q \
      --budget-units 20000 "${extra[@]}" 2>"$d/nav.log" || echo "filter_avail: mfns-nav exit $? in $name $mode"
    "$bin/mfns-ground" --file "$d/tlm.bin" --out "$d/ground" -q 2>"$d/ground.log"
  done
done
"$py" mk/filter_avail.py "$out" "$frames"
