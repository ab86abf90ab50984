# Host-tools packaging check (issue 14): `pip install ./host_tools` into a clean venv from
# the pinned wheels (build/wheels, offline once filled), then mfns --help / sim calib / calib.
TEST_SUITES += pkg-check
.PHONY: pkg-check
pkg-check: venv
	@mk/pkg-check.sh $(PY)
