#!/usr/bin/env bash
# pkg-check.sh PY: `pip install ./host_tools` (from a copy) into a clean venv, then `mfns --help` and
# `mfns sim calib --small` (and `mfns calib` on it) from outside the repository.
# Offline-capable: the wheels come from build/wheels, filled once from the pinned runtime
# section of host_tools/requirements.txt (pip's cache serves them after `make venv`).
set -euo pipefail
py=$1
wheels=build/wheels
venv=build/pkg-venv
lock=build/pkg-runtime.txt
# the runtime pins and the build backend: the lock's runtime and build-tools sections
awk '/^# --- runtime/{s=1;next} /^# --- build tools/{s=2;next} /^# ---/{s=0} s && /^[A-Za-z]/' \
  host_tools/requirements.txt >"$lock"
mkdir -p "$wheels"
if ! "$py" -m pip download -q --disable-pip-version-check --no-index --find-links "$wheels" \
     -d "$wheels" -r "$lock" >/dev/null 2>&1; then
  "$py" -m pip download -q --disable-pip-version-check --only-binary=:all: -d "$wheels" -r "$lock"
fi
rm -rf "$venv"
"$py" -m venv "$venv"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# a copy of the sources: a non-editable build writes build/ and *.egg-info into its source tree
mkdir "$work/src"
cp -r host_tools/pyproject.toml host_tools/mfns "$work/src/"
find "$work/src" -name __pycache__ -prune -exec rm -rf {} +
"$venv/bin/python" -m pip install -q --disable-pip-version-check --no-index --find-links "$wheels" "$work/src"
pass=0
abs_venv=$(cd "$venv" && pwd)
cd "$work"
"$abs_venv/bin/mfns" --help >help.txt && grep -q "calib" help.txt && pass=$((pass + 1))
"$abs_venv/bin/mfns" sim calib ds --small --quiet && [ -f ds/dataset.json ] && pass=$((pass + 1))
"$abs_venv/bin/mfns" calib ds --quiet -o res.json && [ -f res_camchain.yaml ] && pass=$((pass + 1))
# the installed package must not need anything from the repository or the dev extras
! "$abs_venv/bin/python" -c "import pytest" 2>/dev/null && pass=$((pass + 1))
echo "pkg-check: $pass passed, $((4 - pass)) failed"
[ "$pass" -eq 4 ]
