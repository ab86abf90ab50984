# `mfns calib` of the default dataset: time (<= 10 s on 2 cores) and run-to-run identity.
BENCH_TARGETS += bench-calib
.PHONY: bench-calib
bench-calib: venv
	@mk/bench-calib.sh $(PY)

# The estimators' statistics over 40 seeds of simulated corners (tests/bench/bench_calib_seeds.py,
# docs/calibration.md "multi-seed check"); not in `make bench`.
.PHONY: bench-calib-seeds
bench-calib-seeds: venv
	$(PY) tests/bench/bench_calib_seeds.py --seeds 40
