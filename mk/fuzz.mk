# Fuzzers of every reader (issue 17): the calibration-table loader, the
# replay PGM reader, the frames.csv parser and the scenario.json check, each
# a libFuzzer target in tests/fuzz/fuzz_<name>.c with its seed corpus in
# tests/fuzz/corpus/<name>/ (the table fuzzer is also seeded with the
# generated default table, build/gen/default.mfnstbl).
#
#   make fuzz FUZZ_SECONDS=N   every FUZZ_TARGETS entry for N s each (default 60),
#                              corpus kept in build/fuzz/corpus-<name>/
#   make fuzz-readers-brief    FUZZ_BRIEF_SECONDS (4) s of each, part of `make test`
#
# A crash or sanitizer report fails the recipe; the reproducer is written to
# build/fuzz/crash-* (rerun: build/fuzz/fuzz_<name> build/fuzz/crash-...).

FUZZ_CC            ?= clang-14
FUZZ_SECONDS       ?= 60
FUZZ_BRIEF_SECONDS ?= 4
TLM_FUZZ_SECONDS   ?= $(FUZZ_SECONDS)
FUZZ_FLAGS := -std=c11 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -D_DEFAULT_SOURCE

READER_FUZZERS := caltable replay_pgm replay_csv replay_scenario nav_conf nav_upload
fuzz_srcs_caltable        := $(CORE_SRCS)
fuzz_srcs_replay_pgm      := drivers/camera/replay_pgm.c
fuzz_srcs_replay_csv      := drivers/camera/replay_index.c
fuzz_srcs_replay_scenario := drivers/camera/replay_scenario.c
fuzz_srcs_nav_conf        := firmware/app/nav_conf.c
fuzz_srcs_nav_upload      := $(CORE_SRCS) firmware/app/nav_upload.c
fuzz_maxlen_caltable      := 262144
fuzz_maxlen_replay_pgm    := 4096
fuzz_maxlen_replay_csv    := 8192
fuzz_maxlen_replay_scenario := 8192
fuzz_maxlen_nav_conf      := 20000
fuzz_maxlen_nav_upload    := 8192

FUZZ_TARGETS += $(addprefix fuzz-,$(READER_FUZZERS))
TEST_SUITES  += fuzz-readers-brief
.PHONY: $(addprefix fuzz-,$(READER_FUZZERS)) fuzz-readers-brief

build/fuzz/fuzz_%: tests/fuzz/fuzz_%.c $(CORE_SRCS) $(CORE_HDRS) $(wildcard drivers/camera/replay_*.[ch] firmware/app/nav_conf.[ch] firmware/app/nav_upload.[ch])
	@mkdir -p $(@D)
	$(FUZZ_CC) $(FUZZ_FLAGS) $(INCLUDES) $< $(fuzz_srcs_$*) -lm -o $@

# $(1) name, $(2) corpus dir, $(3) seconds, $(4) seed (mk/fuzz_run.sh prints the verdict);
# the caltable fuzzer also starts from the default table, at even and odd alignment.
define reader_run_fuzz
	@mkdir -p $(2)
	@if [ "$(1)" = caltable ] && [ -f $(GEN)/default.mfnstbl ]; then cp $(GEN)/default.mfnstbl $(2)/default-even; \
	  { printf '\001'; cat $(GEN)/default.mfnstbl; } > $(2)/default-odd; fi
	@mk/fuzz_run.sh fuzz-$(1) build/fuzz/fuzz_$(1) $(2) $(3) $(4) $(fuzz_maxlen_$(1)) tests/fuzz/corpus/$(1)
endef

$(foreach f,$(READER_FUZZERS),$(eval fuzz-$(f): build/fuzz/fuzz_$(f) $(if $(filter caltable,$(f)),$(GEN)/default.mfnstbl) ; \
	$$(call reader_run_fuzz,$(f),build/fuzz/corpus-$(f),$(FUZZ_SECONDS),0)))

# Fresh corpora from the committed seeds, so the brief run does the same work everywhere.
fuzz-readers-brief: $(addprefix build/fuzz/fuzz_,$(READER_FUZZERS)) $(GEN)/default.mfnstbl
	@rm -rf build/fuzz/brief-*
	$(call reader_run_fuzz,caltable,build/fuzz/brief-caltable,$(FUZZ_BRIEF_SECONDS),1)
	$(call reader_run_fuzz,replay_pgm,build/fuzz/brief-replay_pgm,$(FUZZ_BRIEF_SECONDS),1)
	$(call reader_run_fuzz,replay_csv,build/fuzz/brief-replay_csv,$(FUZZ_BRIEF_SECONDS),1)
	$(call reader_run_fuzz,replay_scenario,build/fuzz/brief-replay_scenario,$(FUZZ_BRIEF_SECONDS),1)
	$(call reader_run_fuzz,nav_conf,build/fuzz/brief-nav_conf,$(FUZZ_BRIEF_SECONDS),1)
	$(call reader_run_fuzz,nav_upload,build/fuzz/brief-nav_upload,$(FUZZ_BRIEF_SECONDS),1)
	@echo "fuzz-readers-brief: $(words $(READER_FUZZERS)) passed, 0 failed"
