# make faults: the fault campaign of issues 17 and 23, a measurement (not a timed test).
# The module scenario (mfns sim nav --scenario module --seed 2, 120 frames) is flown by
# mfns-nav with each fault injected, each twice (the table of the rendered map, and the map
# displaced by its survey sigma): clean; hostile replay rows; camera y dying; a CRC-valid odd
# table (2 DN); 5,000 spurious spots; each camera frozen and x+y frozen; each camera's clock
# stepping -1 s and +5 s; each camera's frames one and two periods stale; the most seen beacon
# moved 5, 20, 50 mm off and along its wall; its LED dead: 28 faults, 56 runs.
# A fix is misleading when usable (FIX/DEGRADED) and > 20 mm or > 1 deg from truth at its
# frames' capture time, beyond 5 sigma (or NEES) of its own covariance, or stamped more than
# one frame period from that capture time. Prints the table (usable, misleading, worst errors,
# worst error / protection level where nav.csv has pl_* columns, cycles from onset to the first
# report of the faulty camera or beacon in events.csv: CAMERA_* health and exclusion events,
# CAMERA_LAG from the time-offset monitor, BEACON_EXCLUDED / BEACON_MISSING / BEACON_REJECTED
# with the beacon's id), writes build/faults/results.json, and
# fails if any fix is misleading. About 3 min on 2 cores (2 Dec 2026; most of it the 16
# tables `mfns table build` makes, ~13 s each; mfns-nav is ~0.1 s a run); the work folder
# keeps each run's telemetry and CSVs (~25 MB), images are hard links or deleted after use.
# Script: tests/bench/fault_acceptance.py (injectors tests/bench/faults/inject.py, scoring
# tests/bench/faults/score.py; tested by tests/host/test_fault_campaign.py).
# FAULTS_ARGS: e.g. FAULTS_ARGS='--only frozen --only stale -j 1', or '--seed 5' (another module
# scenario than the demo's: check on data the campaign was not built on).
FAULTS_ARGS ?=
.PHONY: faults
faults: venv lib
	@$(MAKE) --no-print-directory BOARD=host-sim flight
	@$(PY) tests/bench/fault_acceptance.py --work build/faults $(FAULTS_ARGS)
