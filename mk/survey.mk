# Self-survey (issue 29, docs/self_survey.md section 4): the slow checks, not in `make test`
# (the fast ones are tests/host/test_map_refine.py and test_fixlog_flight.py).
# Script: tests/bench/bench_survey.py (its survey runs `mfns map demo` per seed, each seed a task
# of a local Dask cluster: docs/studies.md). BENCH_SURVEY_ARGS: e.g. '--seeds 2,3,5,7 --serial',
# '--scheduler tcp://HOST:8786'.
#   make bench-survey          the map target on seeds 2, 3, 5: 24 min of survey flight at 1 Hz
#                              each (about 2 min per seed on 2 cores: 5 min 22 s for the three,
#                              3 Dec 2026), figures in
#                              build/bench/survey/survey.md
#   make bench-survey-monitor  the in-flight monitor end to end: a beacon moved 5, 3, 2, 1 mm along
#                              its wall, camera y turned 0.1 and 0.3 deg (build/bench/monitor/)
BENCH_SURVEY_ARGS ?=
.PHONY: bench-survey bench-survey-monitor
bench-survey: venv
	@$(MAKE) --no-print-directory BOARD=host-sim flight
	$(PY) tests/bench/bench_survey.py survey build/bench/survey $(BENCH_SURVEY_ARGS)

bench-survey-monitor: venv
	@$(MAKE) --no-print-directory BOARD=host-sim flight
	$(PY) tests/bench/bench_survey.py monitor build/bench/monitor
