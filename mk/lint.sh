#!/usr/bin/env bash
# lint.sh PY: cppcheck and clang-tidy over the C code, ruff and mypy (the whole mfns package,
# [tool.mypy] in host_tools/pyproject.toml) over the Python.
# Exits non-zero on any finding; prints "lint: clean" otherwise.
set -uo pipefail
py=$1
rc=0
mkdir -p build
csrc=$(git ls-files -co --exclude-standard -- '*.c' '*.h' | grep -v '^build/' | sort)
inc="-I. -Ibuild/gen"
# shellcheck disable=SC2086
if ! cppcheck --quiet --error-exitcode=1 --std=c11 --enable=warning,portability,performance \
     --inline-suppr --suppress=missingIncludeSystem $inc -D__GNUC__ $csrc; then
  echo "lint: cppcheck found problems"; rc=1
fi
csrc_only=$(echo "$csrc" | grep '\.c$')
# shellcheck disable=SC2086
if ! clang-tidy --quiet $csrc_only -- -std=c11 -D_DEFAULT_SOURCE $inc 2>/dev/null >build/clang-tidy.log; then
  cat build/clang-tidy.log; echo "lint: clang-tidy found problems"; rc=1
elif grep -qE "(warning|error):" build/clang-tidy.log; then
  cat build/clang-tidy.log; echo "lint: clang-tidy found problems"; rc=1
fi
if ! python3 mk/include_graph.py --check >build/include-graph.log; then
  cat build/include-graph.log; echo "lint: the include graph has a circle, a crossed border or a search-path include"; rc=1
fi
if ! "$py" -m ruff check --quiet host_tools tests/host; then
  echo "lint: ruff found problems"; rc=1
fi
if ! "$py" -m ruff format --check --quiet host_tools tests/host; then
  echo "lint: ruff format would reformat files (run: $py -m ruff format host_tools tests/host)"; rc=1
fi
if ! "$py" -m mypy --config-file host_tools/pyproject.toml --cache-dir build/mypy host_tools/mfns; then
  echo "lint: mypy found type errors (run: $py -m mypy --config-file host_tools/pyproject.toml host_tools/mfns)"; rc=1
fi
[ "$rc" -eq 0 ] && echo "lint: clean"
exit "$rc"
