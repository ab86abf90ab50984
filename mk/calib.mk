# `mfns calib` of the default dataset: time (<= 10 s on 2 cores) and run-to-run identity.
BENCH_TARGETS += bench-calib
.PHONY: bench-calib
bench-calib: venv
	@mk/bench-calib.sh $(PY)
