# make faults: issue 17's fault acceptance as a measurement (not a timed
# test): the module scenario flown with injected faults (hostile replay rows,
# a camera dying, a CRC-valid odd table, 5,000 spurious spots), each also with
# the table's beacons displaced by their survey sigma; counts the usable
# fixes more than 20 mm or 5 sigma (own covariance) from truth and fails if
# there is one. About 10 min on 2 cores. Script: tests/bench/fault_acceptance.py.
.PHONY: faults
faults: venv
	@$(MAKE) --no-print-directory BOARD=host-sim flight
	@$(PY) tests/bench/fault_acceptance.py --work build/faults
