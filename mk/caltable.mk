# Calibration table (issue 3): the default table of the paper's system and the
# shared test vectors the C tests compare against, generated with the venv
# python from the committed sources (never committed as binaries); the
# undistortion benchmark.

# The table's contract is generated from one definition, caltable_layout.toml, by
# contract/gen_caltable.py (plain python3: it runs before the venv exists) into committed
# files. Every `make` of all, size, lib and tests checks they are not stale: edit the
# definition, run `python3 contract/gen_caltable.py`, commit both.
# Generated: firmware/nav/generated/caltable_layout_gen.h/.c, firmware/nav/generated/nav_defaults_gen.c,
# host_tools/mfns/table/generated/layout_gen.py and the tables of docs/caltable.md.
.PHONY: caltable-gen-check
caltable-gen-check:
	@python3 contract/gen_caltable.py --check
all size lib tests: caltable-gen-check

CALTABLE_SRC := host_tools/mfns/data/paper_calib.json host_tools/mfns/data/paper_beacons.csv
CALTABLE_PY  := $(wildcard host_tools/mfns/table/*.py) host_tools/mfns/commands/table.py \
                host_tools/mfns/model/camera.py host_tools/mfns/analysis/calib_results.py host_tools/mfns/core/validate.py

# the builder checks its output with the flight loader and sizes grids with the
# C interpolation, both through the shared library
$(GEN)/default.mfnstbl: $(CALTABLE_SRC) $(CALTABLE_PY) $(VENV)/.stamp build/host-sim/lib/libmfns_core.so
	@mkdir -p $(@D)
	$(PY) -m mfns table build $(CALTABLE_SRC) -o $@

# caltable_values.txt, caltable_projections.txt, caltable_undistort.txt
$(GEN)/caltable_vectors.stamp: $(GEN)/default.mfnstbl $(CALTABLE_PY) $(VENV)/.stamp build/host-sim/lib/libmfns_core.so
	$(PY) -m mfns table vectors $< $(GEN)
	@touch $@

GEN_FILES += $(GEN)/default.mfnstbl $(GEN)/caltable_vectors.stamp

# make bench: ns per corrected point, iterative inverse (a) vs grid (b).
.PHONY: bench-undistort
BENCH_TARGETS += bench-undistort
bench-undistort: $(BUILD)/bench/bench_undistort $(GEN)/default.mfnstbl
	$(RUN) $(BUILD)/bench/bench_undistort $(GEN)/default.mfnstbl

$(BUILD)/bench/bench_undistort: $(call obj,tests/bench/bench_undistort.c) $(BUILD)/libmfns_linux.a $(BUILD)/libmfns_core.a
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $^ -lm -o $@
