# Telemetry link (docs/telemetry.md): the decoder fuzzer, and the synthetic
# telemetry generator mfns-tlm-gen built next to mfns-ground.
#
#   make fuzz          runs every FUZZ_TARGETS entry; fuzz-tlm-decoder runs 60 s
#                      (TLM_FUZZ_SECONDS) and keeps its corpus in build/fuzz/
#   make fuzz-brief    10 s of the same fuzzer, part of `make test`
#   make tlm-docs      regenerates everything generated from the dictionaries,
#                      the tables of docs/telemetry.md included (= make contracts,
#                      mk/contracts.mk)

TLM_FUZZ_CC      ?= clang
TLM_FUZZ_SECONDS ?= 60
TLM_FUZZ_BIN     := build/fuzz/fuzz_tlm_decoder
TLM_FUZZ_SRCS    := tests/fuzz/fuzz_tlm_decoder.c $(call tree,firmware/tlm,.c)

FUZZ_TARGETS += fuzz-tlm-decoder
TEST_SUITES  += fuzz-brief
.PHONY: fuzz-tlm-decoder fuzz-brief tlm-docs

tlm-docs: contracts

$(TLM_FUZZ_BIN): $(TLM_FUZZ_SRCS) $(call tree,firmware/tlm,.h)
	@mkdir -p $(@D)
	$(TLM_FUZZ_CC) -std=c11 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
	  -I. $(TLM_FUZZ_SRCS) -o $@

fuzz-tlm-decoder: $(TLM_FUZZ_BIN)
	@mk/fuzz_run.sh fuzz-tlm-decoder $(TLM_FUZZ_BIN) build/fuzz/corpus-tlm $(TLM_FUZZ_SECONDS) 0 4096

# A fresh corpus each time so the brief run does the same work on every machine.
fuzz-brief: $(TLM_FUZZ_BIN)
	@rm -rf build/fuzz/corpus-brief
	@mk/fuzz_run.sh fuzz-brief $(TLM_FUZZ_BIN) build/fuzz/corpus-brief 10 1 4096

# mfns-tlm-gen (ground/tools/mfns_tlm_synth.c): built with `make flight` on Linux boards.
ifeq ($(BOARD_KIND),linux)
TLM_GEN_BIN := $(BUILD)/bin/mfns-tlm-gen
flight: $(TLM_GEN_BIN)
$(TLM_GEN_BIN): $(call obj,ground/tools/mfns_tlm_synth.c) $(BUILD)/libmfns_linux.a $(BUILD)/libmfns_core.a
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $^ $(LIBS) -o $@
endif

# make bench: codec throughput on the host (encode frames/s, decode MB/s).
BENCH_TARGETS += bench-tlm
.PHONY: bench-tlm
build/bench/bench_tlm: tests/bench/bench_tlm.c $(call tree,firmware/tlm,.c) $(call tree,firmware/tlm,.h)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -O2 -I. tests/bench/bench_tlm.c $(call tree,firmware/tlm,.c) -o $@
bench-tlm: build/bench/bench_tlm
	@build/bench/bench_tlm
