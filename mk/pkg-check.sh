#!/usr/bin/env bash
# pkg-check.sh PY TABLE: the host tools as a user installs them (issues 14 and 28).
#   1. build the wheel from the tree (`pip wheel ./host_tools`, its own build backend compiles
#      the C core into it: host_tools/setup.py) and check the build left nothing in the tree;
#   2. install it into a clean venv in a temporary folder, offline from the pinned wheels
#      (build/wheels, filled once from the lock's runtime and build-tools sections);
#   3. from that folder (no repository beside it) run every subcommand: `--help` of each,
#      `mfns table build` (byte-identical to the tree's TABLE), `mfns table show`, `mfns mc`
#      (its default flight solver: the wheel's library), `mfns sim calib` + `mfns calib`,
#      `mfns sim nav` + `mfns report` (+ its refusal of another run's truth), `mfns compare`
#      (meaning column filled), `mfns plan`, mfns.ground.ground_yamcs' run folder and the
#      operator view's page (mfns.ground.ground_yamcs_view);
#   4. a user's whole chain from the wheel alone (issue 43): the wheel's own flight and ground
#      programs (console scripts mfns-nav, mfns-ground: mfns/bin, built by the Makefile's
#      targets during the wheel build) fly a simulated module run (sim -> table -> fly ->
#      ground -> report) with small frame counts, then `mfns plan analyze` on its map.
# Prints the wheel's size and the install time.
set -uo pipefail
py=$1
table=$(cd "$(dirname "$2")" && pwd)/$(basename "$2")
repo=$(pwd)
wheels=build/wheels
lock=build/pkg-runtime.txt
awk '/^# --- runtime/{s=1;next} /^# --- build tools/{s=2;next} /^# ---/{s=0} s && /^[A-Za-z]/' \
  host_tools/requirements.txt >"$lock"
mkdir -p "$wheels"
if ! "$py" -m pip download -q --disable-pip-version-check --no-index --find-links "$wheels" \
     -d "$wheels" -r "$lock" >/dev/null 2>&1; then
  "$py" -m pip download -q --disable-pip-version-check --only-binary=:all: -d "$wheels" -r "$lock" || exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
pass=0 fail=0
check() { # name, command...: one line per check
  local name=$1; shift
  if "$@" >"$work/last.log" 2>&1; then
    pass=$((pass + 1)); echo "  ok   $name"
  else
    fail=$((fail + 1)); echo "  FAIL $name"; tail -n 5 "$work/last.log" | sed 's/^/       /'
  fi
}

before=$(git status --porcelain --ignored host_tools | grep -v __pycache__)
t0=$(date +%s.%N)
check "wheel: pip wheel ./host_tools" "$py" -m pip wheel -q --disable-pip-version-check --no-deps \
  --no-index --find-links "$wheels" -w "$work/dist" ./host_tools
t1=$(date +%s.%N)
after=$(git status --porcelain --ignored host_tools | grep -v __pycache__)
check "no build debris in host_tools/" test "$before" = "$after"
whl=$(ls "$work"/dist/mfns-*.whl 2>/dev/null | head -n 1)
check "the wheel carries mfns/libmfns_core.so" sh -c "unzip -l '$whl' | grep -q ' mfns/libmfns_core.so$'"
check "the wheel carries mfns/bin/mfns-nav and mfns-ground" sh -c "
  unzip -l '$whl' | grep -q ' mfns/bin/mfns-nav$' && unzip -l '$whl' | grep -q ' mfns/bin/mfns-ground$'"

"$py" -m venv "$work/venv"
v=$work/venv/bin
t2=$(date +%s.%N)
check "install the wheel into a clean venv (offline)" "$v/python" -m pip install -q --disable-pip-version-check \
  --no-index --find-links "$wheels" "$whl"
t3=$(date +%s.%N)

cd "$work" || exit 1
mkdir run && cd run || exit 1
check "mfns --help" "$v/mfns" --help
for c in calib compare mc plan report sim table "sim calib" "sim nav" "table build" "table show" \
         "plan analyze" "plan optimize" "plan size"; do
  # shellcheck disable=SC2086
  check "mfns $c --help" "$v/mfns" $c --help
done
check "mfns-nav --help, mfns-ground --help (the wheel's programs)" sh -c "
  '$v/mfns-nav' --help >/dev/null && '$v/mfns-ground' --help >/dev/null"
check "the programs are the package's own" "$v/python" -c "
import mfns.programs as p
for n in p.PROGRAMS:
    assert p.program_path(n) == p.PACKAGE_BIN / n, p.program_path(n)"
check "the core library is the package's own" "$v/python" -c \
  "import mfns.core.binding as b, pathlib; p = b.lib_path(); assert p == b.PACKAGE_LIB and p.is_file(), p; b.load()"
data=$("$v/python" -c "import mfns.data, pathlib; print(pathlib.Path(mfns.data.__file__).parent)")
check "mfns table build" "$v/mfns" table build "$data/paper_calib.json" "$data/paper_beacons.csv" -o t.mfnstbl -q
check "table byte-identical to the tree's $(basename "$table")" cmp t.mfnstbl "$table"
check "mfns table show" sh -c "'$v/mfns' table show t.mfnstbl | grep -q ."
check "mfns mc (flight solver: the wheel's library)" "$v/mfns" mc mc --trials 200 --pose-trials 3 -q
check "mfns sim calib --small" "$v/mfns" sim calib ds --small -q
check "mfns calib" sh -c "'$v/mfns' calib ds -q -o res.json && test -f res_camchain.yaml && test -f res.json"
check "mfns plan analyze" "$v/mfns" plan analyze plan --beacons "$data/paper_beacons.csv" --samples 20 --no-ident-margin -q
check "mfns sim nav (turntable, 12 frames)" "$v/mfns" sim nav demo/turntable/frames --scenario turntable --frames 12 --seed 1 -q
check "mfns sim nav (module, 8 frames)" "$v/mfns" sim nav other --scenario module --frames 8 --seed 2 -q
# the flight program and the ground station make nav.csv (docs/telemetry.md: --file replays a recording);
# the turntable is an accuracy bench: its table is monitor-only (docs/pose.md "Integrity"), as in make demo
d=demo/turntable/true-rig
mkdir -p "$d"
check "input: mfns-nav + mfns-ground on the frames" sh -c "
  printf '{\"integrity\": {\"monitor_only\": 1}}' > $d/bench.json &&
  '$v/mfns' table build demo/turntable/frames/calib.json demo/turntable/frames/beacons.csv -o $d/table.mfnstbl -q --settings $d/bench.json &&
  '$v/mfns-nav' --table $d/table.mfnstbl --replay demo/turntable/frames --tlm-file $d/telemetry.bin 2>$d/nav.log &&
  '$v/mfns-ground' --file $d/telemetry.bin --out $d/ground -q"
check "mfns report" "$v/mfns" report "$d/ground" --truth demo/turntable/frames/truth.csv --out "$d/report" --no-plots
check "mfns report refuses another run's truth (exit 2, one line)" sh -c "
  '$v/mfns' report '$d/ground' --truth other/truth.csv --out bad --no-plots >out.txt 2>err.txt; rc=\$?;
  test \$rc -eq 2 && test \$(wc -l <err.txt) -eq 1 && test ! -e bad"
check "mfns compare (meaning column filled)" sh -c "
  '$v/mfns' compare demo -o report.md -q && grep -q '| meaning |' report.md &&
  rows=\$(grep -E '^\| true-rig \| (NO_FIX|DEGRADED) \|' report.md) && test -n \"\$rows\" &&
  ! printf '%s\n' \"\$rows\" | grep -qE '\| *\|\$'"
# the whole chain a user runs, from the wheel alone: a module with its own map, flown by the
# wheel's flight program with the flight's defaults (integrity enforced), reported, planned
m=fly
check "chain: mfns sim nav (module, 24 frames)" "$v/mfns" sim nav $m/frames --scenario module --frames 24 --seed 3 -q
check "chain: mfns table build (the module's workspace)" "$v/mfns" table build $m/frames/calib.json \
  $m/frames/beacons.csv -o $m/table.mfnstbl -q --workspace $m/frames/scenario.json
check "chain: mfns-nav (the wheel's) flies the frames" sh -c "
  '$v/mfns-nav' --table $m/table.mfnstbl --replay $m/frames --tlm-file $m/telemetry.bin 2>$m/nav.log"
check "chain: mfns-ground (the wheel's) decodes the telemetry" sh -c "
  '$v/mfns-ground' --file $m/telemetry.bin --out $m/ground -q && test \$(wc -l <$m/ground/nav.csv) -eq 25"
check "chain: mfns report (fixes against truth)" sh -c "
  '$v/mfns' report $m/ground --truth $m/frames/truth.csv --out $m/report --no-plots >$m/report.txt &&
  grep -qE '^[0-9]+ of 24 solutions used' $m/report.txt && ! grep -qE '^0 of 24' $m/report.txt"
# issue 43: a turntable truth of the same length and rate passes the span and count checks
check "chain: mfns report refuses a turntable's truth (same time base) for the module's run" sh -c "
  '$v/mfns' sim nav $m/tt --scenario turntable --frames 24 --seed 3 -q &&
  { '$v/mfns' report $m/ground --truth $m/tt/truth.csv --out $m/bad --no-plots 2>$m/err.txt; test \$? -eq 2; } &&
  test \$(wc -l <$m/err.txt) -eq 1 && grep -q 'gross errors' $m/err.txt && test ! -e $m/bad"
check "chain: mfns plan analyze (the module's map)" "$v/mfns" plan analyze $m/plan --workspace module \
  --beacons $m/frames/beacons.csv --samples 20 --no-ident-margin -q
check "mfns.ground.ground_yamcs: run folder without the repository" "$v/python" -c "
import pathlib, mfns.ground.ground_yamcs as g
r = g.prepare(pathlib.Path('yamcs-run'))
assert (r / 'etc' / 'yamcs.mfns.yaml').is_file() and (r / 'mdb' / 'mfns_tm.xml').is_file()
import mfns.data, mfns.tlm.tlm_dict as t
assert all('contract' not in str(mfns.data.dictionary(n)) and mfns.data.dictionary(n).is_file()
           for n in ('mfns_tm.xml', 'mfns_tc.xml', 'mfns_ground.xml')), 'dictionaries not in the wheel'
assert 'fixobs' in t.load().packets
assert 'ground' not in str(g.ETC), g.ETC"
check "mfns.ground.ground_yamcs_view: the operator's page without the repository" "$v/python" -c "
import mfns.ground.ground_yamcs_view as v
assert v.PAGE.is_file() and 'ground' not in str(v.PAGE), v.PAGE"
check "the installed package needs no dev extras" sh -c "! '$v/python' -c 'import pytest' 2>/dev/null"

size=$(stat -c %s "$whl" 2>/dev/null || echo 0)
printf 'pkg-check: wheel %s (%d kB), built in %.1f s, installed in %.1f s\n' \
  "$(basename "$whl")" $((size / 1024)) "$(echo "$t1 - $t0" | bc)" "$(echo "$t3 - $t2" | bc)"
echo "pkg-check: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
