#!/usr/bin/env bash
# venv.sh DIR: create the host tools' Python venv from the pinned requirements
# and install the mfns package (editable) into it.
set -euo pipefail
venv=$1
py=${MFNS_PYTHON:-python3}
if [ ! -x "$venv/bin/python" ]; then
  "$py" -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --disable-pip-version-check -r host_tools/requirements.txt
"$venv/bin/python" -m pip install -q --disable-pip-version-check --no-deps --no-build-isolation -e host_tools
echo "venv: $venv ready ($("$venv/bin/python" --version))"
