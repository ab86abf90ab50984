# Centroiding benchmark (issue 4): `make bench` runs bench-centroid.
# C benchmark at -O2 (full frame, ROI mode, memcpy), callgrind instruction count
# of one full-frame call, then OpenCV on the same frame and the ratios.
BENCH_TARGETS += bench-centroid

BENCH_CENTROID_DIR := build/bench
BENCH_CENTROID_BIN := $(BENCH_CENTROID_DIR)/bench_centroid
# The centroider's files (centroid_internal.h lists them) and the one default
# set the bench runs with (nav_defaults_gen.c: the flight settings).
BENCH_CENTROID_SRCS := tests/bench/bench_centroid.c $(sort $(wildcard firmware/nav/centroid/*.c)) \
                       firmware/nav/generated/nav_defaults_gen.c math/fixed.c

$(BENCH_CENTROID_BIN): $(BENCH_CENTROID_SRCS) $(wildcard firmware/nav/centroid/*.h) firmware/nav/settings/nav_settings.h \
                       firmware/nav/map/beacon_index.h math/fixed.h math/units.h
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -O2 -g -I. $(BENCH_CENTROID_SRCS) -lm -o $@

.PHONY: bench-centroid
bench-centroid: $(BENCH_CENTROID_BIN) venv
	$(BENCH_CENTROID_BIN) $(BENCH_CENTROID_DIR)
	valgrind --tool=callgrind --toggle-collect=bench_centroid_once \
	  --callgrind-out-file=$(BENCH_CENTROID_DIR)/centroid.callgrind \
	  $(BENCH_CENTROID_BIN) $(BENCH_CENTROID_DIR) --once 2>$(BENCH_CENTROID_DIR)/centroid.callgrind.log
	$(PY) tests/bench/bench_centroid_opencv.py $(BENCH_CENTROID_DIR)
