# Navigation filter (issue 42, firmware/nav/filter/): benchmark.
#   make bench-filter    time of the filter bank per cycle (3 frames + evaluate)
#                        on the paper's rig, 13 and 15 hypotheses (docs/budgets.md)
BENCH_TARGETS += bench-filter

FILTER_BENCH := $(BUILD)/bench/bench_filter

$(FILTER_BENCH): $(BUILD)/obj/tests/bench/bench_filter.o $(BUILD)/libmfns_testsupport.a $(BUILD)/libmfns_host.a \
                 $(BUILD)/libmfns_linux.a $(BUILD)/libmfns_core.a
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $^ $(LIBS) -o $@

.PHONY: bench-filter
bench-filter: $(FILTER_BENCH)
	$(RUN) $(FILTER_BENCH)
