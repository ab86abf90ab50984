# Host-tools packaging check (issue 14): `pip install ./host_tools` into a clean venv from
# the pinned wheels (build/wheels, offline once filled), then mfns --help / sim calib / calib.
TEST_SUITES += pkg-check
.PHONY: pkg-check
pkg-check: venv
	@mk/pkg-check.sh $(PY)

# `mfns calib` of the default dataset: time (<= 10 s on 2 cores) and run-to-run identity.
BENCH_TARGETS += bench-calib
.PHONY: bench-calib
bench-calib: venv
	@mk/bench-calib.sh $(PY)
