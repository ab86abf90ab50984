# make soak SOAK_MINUTES=N: the flight program under ASan/UBSan replays the
# module scenario for N minutes (paced at the recorded 18.6 Hz, back and
# forth so the trajectory stays continuous and tracking runs), its RSS
# sampled every few seconds. Passes when RSS after the warm-up stays within
# 1 % of its first post-warm-up sample, the counters agree (program summary,
# housekeeping, decoded telemetry) and there is no sanitizer report.
# Details and figures: mk/soak.py; the log is build/soak/soak.log.
SOAK_MINUTES ?= 30
.PHONY: soak
soak: venv
	@$(MAKE) --no-print-directory BOARD=host-sim SAN=1 flight
	@$(PY) mk/soak.py --minutes $(SOAK_MINUTES) --bin build/host-sim-san/bin --work build/soak
