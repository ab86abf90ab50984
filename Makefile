# MFNS navigation computer: one Makefile for the flight program, its
# cross-builds, the host tools and every test suite.
#
#   make                      flight program + ground station for BOARD (default host-sim)
#   make BOARD=sitss-nav      cross-build for the aarch64 flight board
#   make size                 flight core for a bare-metal Cortex-M7: text per module,
#                             worst stack depth per entry point (docs/budgets.md)
#   make test                 everything: deps, native, ASan+UBSan, qemu-aarch64, pytest, ...
#   make lint                 cppcheck + clang-tidy (C) and ruff (Python)
#   make bench                benchmarks (speed targets are checked here, not in tests)
#   make demo                 the main job (see README.md); installs only what it needs
#   make faults               fault acceptance: misleading fixes under injected faults
#   make faults-grown         issue 42's grown fault campaign (opt-in; FAULTS_SEEDS='2 3 4 5')
#   make soak SOAK_MINUTES=N  the flight program under sanitizers for N minutes
#
# Sources are discovered by folder, so adding a module or a test needs no edit
# here (README.md "Adding a module"):
#   math/*.c firmware/nav/*.c firmware/nav/filter/*.c
#   firmware/tlm/*.c                                portable core (no OS, no heap): flies
#   firmware/host/*.c                               host-only core (builders, analyses,
#                                                   binding hooks): libmfns_core.so and
#                                                   the unit tests, never a flight image
#   drivers/*/*.c firmware/app/*.c ground/*.c       Linux-only code (firmware/linux/*.c: what
#                                                   both programs link, e.g. the MAC, the drain)
#   tests/unit/test_*.c                             one cmocka binary each
#   tests/unit/support/*.c                          helpers linked into every test
#   mk/*.mk                                         per-topic rules (generated files,
#                                                   benchmarks, fuzzers)

BOARD ?= host-sim
ifeq ($(wildcard boards/$(BOARD)/board.mk),)
$(error unknown BOARD '$(BOARD)': expected one of $(notdir $(wildcard boards/*)))
endif
include boards/$(BOARD)/board.mk

# SAN=1 builds the same code with AddressSanitizer and UndefinedBehaviorSanitizer.
SAN ?=
BUILD := build/$(BOARD)$(if $(SAN),-san)
GEN   := build/gen
VENV  := .venv
PY    := $(VENV)/bin/python

# Quiet rules (the kernel's convention): a rule prints one short line ("  CC    file"); the
# compiler's own messages still show, so a failure is seen where it happens. V=1 prints the
# commands instead; make -s prints neither (make 4 keeps the one-letter flags in MAKEFLAGS'
# first word).
V ?= 0
ifeq ($(V),1)
Q :=
say :=
else ifneq ($(findstring s,$(firstword -$(MAKEFLAGS))),)
Q := @
say :=
else
Q := @
say = @printf '  %-5s %s\n' '$(1)' '$(2)';
endif

WARN := -Wall -Wextra -Werror -Wconversion -Wshadow -Wdouble-promotion \
        -Wstrict-prototypes -Wmissing-prototypes -Wvla -Wformat=2 -Wundef
CSTD := -std=c11
# Every include is written from the repository root (#include "firmware/nav/pose/pose.h"),
# so no name depends on the order of a search path: -I. is the one root (with build/gen
# for the build's own generated version header, mk/version.mk). mk/include_graph.py --check
# (make lint) fails on an include found only through a search path, and on a circle.
INCLUDES := -I.
comma := ,
SAN_FLAGS := $(if $(SAN),-fsanitize=address$(comma)undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
CFLAGS_ALL = $(CSTD) $(WARN) $(BOARD_CFLAGS) $(BOARD_DEFINES) $(INCLUDES) $(SAN_FLAGS) \
             $(EXTRA_CFLAGS) -MMD -MP

# A folder and its family folders one level down (firmware/nav/pose/, firmware/tlm/generated/).
tree = $(sort $(wildcard $(addsuffix /*$(2),$(1)) $(addsuffix /*/*$(2),$(1))))
CORE_DIRS  := math firmware/nav firmware/tlm
CORE_SRCS  := $(call tree,$(CORE_DIRS),.c)
CORE_HDRS  := $(call tree,$(CORE_DIRS),.h)
# The host-only core: code of the core that runs on the ground only (index
# and grid builders, the map analysis, the struct-size hooks of the Python
# binding). Same rules as the core (no OS, no heap) but never in mfns-nav or
# the Cortex-M7 image; its headers are seen only by its own objects, the
# tests and the shared library, so a flight module cannot include them.
HOST_CORE_DIR  := firmware/host
HOST_CORE_SRCS := $(sort $(wildcard $(HOST_CORE_DIR)/*.c))
APP_MAINS  := firmware/app/main.c ground/main.c
# The frame policies (issue 41): which frames a cycle fuses, camera data health, cycle
# timing. Portable like the core (no OS, no heap: `make size` compiles and checks them for
# the Cortex-M7) but applied by the flight program around the navigator, which never calls
# them: beside the core, linked with the Linux programs, outside the core's image.
FRAMES_DIR  := firmware/frames
FRAMES_SRCS := $(sort $(wildcard $(FRAMES_DIR)/*.c))
LINUX_SRCS := $(sort $(filter-out $(APP_MAINS),$(wildcard drivers/*/*.c firmware/app/*.c firmware/linux/*.c ground/*.c ground/generated/*.c) $(FRAMES_SRCS)))
SUPPORT_SRCS := $(sort $(wildcard tests/unit/support/*.c))
TEST_SRCS  := $(sort $(wildcard tests/unit/test_*.c))
TESTS      := $(patsubst tests/unit/%.c,$(BUILD)/tests/%,$(TEST_SRCS))

obj = $(patsubst %.c,$(BUILD)/obj/%.o,$(1))
CORE_OBJS    := $(call obj,$(CORE_SRCS))
HOST_CORE_OBJS := $(call obj,$(HOST_CORE_SRCS))
LINUX_OBJS   := $(call obj,$(LINUX_SRCS))
SUPPORT_OBJS := $(call obj,$(SUPPORT_SRCS))

# Optional libcamera backend: built only where pkg-config finds libcamera
# (the host has it; the arm64 sysroot here does not).
ifeq ($(BOARD_KIND),linux)
HAVE_LIBCAMERA := $(shell $(PKG_CONFIG) --exists libcamera 2>/dev/null && echo 1)
endif
LIBCAMERA_SRCS := $(if $(HAVE_LIBCAMERA),$(wildcard drivers/camera/*.cpp))
LIBCAMERA_OBJS := $(patsubst %.cpp,$(BUILD)/obj/%.o,$(LIBCAMERA_SRCS))
ifneq ($(HAVE_LIBCAMERA),)
CFLAGS_ALL += -DMFNS_HAVE_LIBCAMERA=1
LINK := $(CXX)
LIBCAMERA_LIBS := $(shell $(PKG_CONFIG) --libs libcamera)
else
LINK := $(CC)
endif
# libcrypto (OpenSSL, Debian libssl-dev; libssl-dev:arm64 for sitss-nav) for the
# telecommand MAC (firmware/linux/tc_auth.c). A Linux build without it still builds, but
# its programs load no key: commands then need --tc-insecure (docs/uplink.md).
ifeq ($(BOARD_KIND),linux)
HAVE_LIBCRYPTO := $(shell $(PKG_CONFIG) --exists libcrypto 2>/dev/null && echo 1)
ifneq ($(HAVE_LIBCRYPTO),)
CFLAGS_ALL += -DMFNS_HAVE_LIBCRYPTO=1
CRYPTO_LIBS := $(shell $(PKG_CONFIG) --libs libcrypto)
else
$(warning BOARD=$(BOARD): no libcrypto for this target (libssl-dev$(if $(filter qemu-aarch64,$(RUN)),:arm64)): built without telecommand authentication, --tc-key refused)
endif
endif
# One pkg-config call per library: a missing cmocka (the demo set of mk/deps.sh
# has none) must not drop libserialport from the link of the flight programs.
LIBS = $(shell $(PKG_CONFIG) --libs libserialport 2>/dev/null) $(shell $(PKG_CONFIG) --libs cmocka 2>/dev/null) \
       $(shell $(PKG_CONFIG) --libs libsystemd 2>/dev/null) $(LIBCAMERA_LIBS) $(CRYPTO_LIBS) -lm -lpthread

.PHONY: all flight tests unit test test-all deps deps-demo venv lint size bench fuzz demo clean gen lib help
.DEFAULT_GOAL := all
# Keep test objects: they are intermediate files of the test binaries.
.SECONDARY:

# Per-topic fragments add to GEN_FILES, BENCH_TARGETS, FUZZ_TARGETS, TEST_SUITES.
GEN_FILES :=
BENCH_TARGETS :=
FUZZ_TARGETS :=
TEST_SUITES :=
-include $(sort $(wildcard mk/*.mk))

ifeq ($(BOARD_KIND),linux)
all: flight
PROGRAMS := $(patsubst %,$(BUILD)/bin/%,$(if $(wildcard firmware/app/main.c),mfns-nav) $(if $(wildcard ground/main.c),mfns-ground))
flight: $(PROGRAMS)
	@echo "built $(BOARD): $^"
else
all: size
endif

help:
	@sed -n '1,/^$$/p' Makefile

# --------------------------------------------------------------------------
# Compilation
# (the board's flags are in board.mk: a changed flag rebuilds its objects)
$(BUILD)/obj/%.o: %.c boards/$(BOARD)/board.mk
	@mkdir -p $(@D)
	$(call say,CC,$<)$(CC) $(CFLAGS_ALL) -c $< -o $@


$(BUILD)/obj/%.o: %.cpp
	@mkdir -p $(@D)
	$(call say,CXX,$<)$(CXX) -std=c++17 -Wall -Wextra -Werror $(BOARD_CFLAGS) $(INCLUDES) $(SAN_FLAGS) \
	  $(shell $(PKG_CONFIG) --cflags libcamera) -MMD -MP -c $< -o $@

$(BUILD)/libmfns_core.a: $(CORE_OBJS)
	@mkdir -p $(@D)
	@rm -f $@
	$(call say,AR,$@)$(AR) rcs $@ $^

$(BUILD)/libmfns_host.a: $(HOST_CORE_OBJS)
	@mkdir -p $(@D)
	@rm -f $@
	$(call say,AR,$@)$(AR) rcs $@ $^

$(BUILD)/libmfns_linux.a: $(LINUX_OBJS) $(LIBCAMERA_OBJS)
	@mkdir -p $(@D)
	@rm -f $@
	$(call say,AR,$@)$(AR) rcs $@ $^

$(BUILD)/libmfns_testsupport.a: $(SUPPORT_OBJS)
	@mkdir -p $(@D)
	@rm -f $@
	$(call say,AR,$@)$(AR) rcs $@ $^

LIBS_MFNS := $(BUILD)/libmfns_linux.a $(BUILD)/libmfns_core.a
# The tests and the benchmarks link the host-only core too (before the core:
# it calls into it).
LIBS_HOST := $(BUILD)/libmfns_host.a

$(BUILD)/bin/mfns-nav: $(call obj,firmware/app/main.c) $(LIBS_MFNS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $^ $(LIBS) -o $@

$(BUILD)/bin/mfns-ground: $(call obj,ground/main.c) $(LIBS_MFNS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $^ $(LIBS) -o $@

# The portable core and the host-only core as a shared library for the
# Python host tools (ctypes): host and flight share one implementation of the
# numerics.
lib: build/host-sim/lib/libmfns_core.so
# (the core's headers too: a changed struct must rebuild the library the
# ctypes mirrors check their sizes against)
# CORE_LIB_CC is the library's one recipe: the wheel's build backend runs it too
# (host_tools/setup.py -> mk/pkg.mk pkg-core-lib).
CORE_LIB_CC = gcc $(CSTD) $(WARN) -O2 -fPIC -shared $(INCLUDES) $(CORE_SRCS) $(HOST_CORE_SRCS) -lm
build/host-sim/lib/libmfns_core.so: $(CORE_SRCS) $(HOST_CORE_SRCS) \
                                    $(CORE_HDRS) $(wildcard $(HOST_CORE_DIR)/*.h)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(CORE_LIB_CC) -o $@

# --------------------------------------------------------------------------
# Unit tests: one binary per tests/unit/test_*.c, run from the repo root.
$(BUILD)/tests/%: $(BUILD)/obj/tests/unit/%.o $(BUILD)/libmfns_testsupport.a $(LIBS_HOST) $(LIBS_MFNS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $< $(BUILD)/libmfns_testsupport.a $(LIBS_HOST) $(LIBS_MFNS) $(LIBS) -o $@

tests: $(TESTS) $(GEN_FILES)

SUITE_NAME ?= unit-$(BOARD)$(if $(SAN),-san)
unit: tests
	@MFNS_BUILD=$(BUILD) MFNS_GEN=$(GEN) mk/run-unit.sh "$(SUITE_NAME)" "$(RUN)" $(TESTS)

gen: $(GEN_FILES)

# --------------------------------------------------------------------------
# Dependencies: apt packages (as root) and the Python venv from pinned versions.
# Two sets (mk/deps.sh): `deps` everything the tests need, `deps-demo` only what
# `make demo` needs (host compiler, pkg-config, libserialport, the venv).
deps: build/.deps-ok venv
build/.deps-ok: mk/deps.sh
	@mk/deps.sh test
	@mkdir -p $(@D) && touch $@

deps-demo: build/.deps-demo-ok venv
build/.deps-demo-ok: mk/deps.sh
	@mk/deps.sh demo
	@mkdir -p $(@D) && touch $@

venv: $(VENV)/.stamp
$(VENV)/.stamp: host_tools/requirements.txt host_tools/pyproject.toml
	@mk/venv.sh $(VENV)
	@touch $@

# --------------------------------------------------------------------------
# make test: every suite, one summary line each, non-zero exit on any failure.
# Each suite runs even when an earlier one failed, so one run shows all.
# pytest is one process most of the time (measured: user + sys time about equal
# to the wall time of a serial make test on 2 cores), so the suites that share no
# build folder with it run beside it: the sanitizer build (build/host-sim-san),
# the Cortex-M7 size (build/cortex-m7-core), the fuzzers (build/fuzz) and the
# wheel check (a temporary folder). Everything they and pytest both read (the
# venv, the core library, the generated files, the default table, the host and
# aarch64 flight builds) is built before, one at a time.
test: deps
	@rm -f build/test-summary.txt; mkdir -p build
	@mk/suite.sh "unit-native"       $(MAKE) --no-print-directory BOARD=host-sim unit SUITE_NAME=unit-native
	@mk/suite.sh "unit-qemu-aarch64" $(MAKE) --no-print-directory BOARD=sitss-nav unit SUITE_NAME=unit-qemu-aarch64
	@mk/suite.sh "flight-build"      $(MAKE) --no-print-directory flight-aarch64
	@mkdir -p build/logs; { $(MAKE) --no-print-directory venv lib $(GEN_FILES) $(GEN)/default.mfnstbl \
	  && $(MAKE) --no-print-directory BOARD=host-sim flight; } >build/logs/test-prerequisites.log 2>&1 \
	  || { echo "test: building what pytest and the suites beside it share failed (their results follow):"; \
	       tail -n 30 build/logs/test-prerequisites.log; }
	@mk/suite.sh "pytest"            $(MAKE) --no-print-directory pytest & \
	  { mk/suite.sh "unit-asan-ubsan" $(MAKE) --no-print-directory BOARD=host-sim SAN=1 unit SUITE_NAME=unit-asan-ubsan; \
	    mk/suite.sh "size-cortex-m7"  $(MAKE) --no-print-directory BOARD=cortex-m7-core size; \
	    $(foreach s,$(TEST_SUITES),mk/suite.sh "$(s)" $(MAKE) --no-print-directory $(s) ;) }; \
	  wait
	@mk/summary.sh build/test-summary.txt

# The aarch64 flight build, checked to be what the board runs.
.PHONY: flight-aarch64
flight-aarch64:
	@$(MAKE) --no-print-directory BOARD=sitss-nav flight
	@for b in mfns-nav mfns-ground; do \
	  readelf -h build/sitss-nav/bin/$$b | grep -q 'Machine:.*AArch64' || { echo "$$b is not an AArch64 ELF"; exit 1; }; \
	done
	@echo "flight-build: 2 passed, 0 failed"

.PHONY: pytest
pytest: venv lib $(GEN_FILES)
	@mk/run-pytest.sh $(PY)

# --------------------------------------------------------------------------
# Bare-metal size check of the portable core.
# The flight core only (CORE_SRCS: firmware/host is not in it): text per
# module, the whole image (every function kept, with libm), and the worst
# stack depth per entry point from GCC's call graph (mk/stack.py; the board
# compiles with -fstack-usage -fcallgraph-info=su). docs/budgets.md.
STACK_ALSO := mfns_centroid_detect mfns_acq_cycle_run mfns_pose_track
ifeq ($(BOARD_KIND),baremetal)
# The flight figure is an LTO link (BOARD_LTO): the core compiled a second
# time, to GCC's intermediate code, under $(BUILD)/lto; the objects above stay
# for the per-module table and the per-object stack analysis.
LTO_OBJS := $(patsubst $(BUILD)/obj/%,$(BUILD)/lto/%,$(CORE_OBJS))
$(BUILD)/lto/%.o: %.c boards/$(BOARD)/board.mk
	@mkdir -p $(@D)
	$(call say,CC,$< (lto))$(CC) $(filter-out -fstack-usage -fcallgraph-info=su,$(CFLAGS_ALL)) $(BOARD_LTO) -c $< -o $@

size: $(CORE_OBJS) $(LTO_OBJS) $(BUILD)/obj/boards/cortex-m7-core/entry.o $(call obj,$(FRAMES_SRCS))
	@mk/size.sh "$(SIZE)" "$(NM)" "$(BUILD)" $(CORE_OBJS)
	@echo "frame policies ($(FRAMES_DIR)/: portable, linked by the Linux programs, not part of the core's image):"
	@mk/size.sh "$(SIZE)" "$(NM)" "$(BUILD)" $(call obj,$(FRAMES_SRCS)) $(CORE_OBJS) >$(BUILD)/frames-size.txt
	@grep -E '^($(FRAMES_DIR)/|size:)' $(BUILD)/frames-size.txt
	$(CC) $(BOARD_CFLAGS) $(BOARD_LDFLAGS) -Wl,--no-gc-sections \
	  $(BUILD)/obj/boards/cortex-m7-core/entry.o -Wl,--whole-archive $(CORE_OBJS) -Wl,--no-whole-archive \
	  -lm -Wl,-Map=$(BUILD)/core.map -o $(BUILD)/core.elf
	@$(SIZE) $(BUILD)/core.elf | sed 's/^/image: /'
	@roots=$$(mk/flight_roots.sh "$(NM)" "firmware/app firmware/linux $(FRAMES_DIR)" $(CORE_OBJS)) && \
	  $(CC) $(BOARD_CFLAGS) $(BOARD_LDFLAGS) $$roots $(BUILD)/obj/boards/cortex-m7-core/entry.o $(CORE_OBJS) \
	  -lm -Wl,-Map=$(BUILD)/flight-nolto.map -o $(BUILD)/flight-nolto.elf && \
	  python3 mk/map_text.py --label "flight without LTO" $(BUILD)/flight-nolto.map && \
	  rm -f $(BUILD)/flight.elf.ltrans* && \
	  $(CC) $(BOARD_CFLAGS) $(BOARD_LTO) $(BOARD_LDFLAGS) $$roots $(BUILD)/obj/boards/cortex-m7-core/entry.o $(LTO_OBJS) \
	  -lm -Wl,-Map=$(BUILD)/flight.map -o $(BUILD)/flight.elf && \
	  echo "flight: $$(echo $$roots | wc -w) core functions called by firmware/app, section GC from them, LTO" && \
	  $(SIZE) $(BUILD)/flight.elf | sed 's/^/flight: /'
	@python3 mk/map_text.py $(BUILD)/flight.map
	@python3 mk/stack.py --min 64 $(addprefix --also ,$(STACK_ALSO)) $(CORE_OBJS:.o=.ci)
	@python3 mk/stack.py --label "stack, LTO flight image" --min 64 $(BUILD)/flight.elf.ltrans0.ltrans.ci
else
size:
	@$(MAKE) --no-print-directory BOARD=cortex-m7-core size
endif

# --------------------------------------------------------------------------
lint: venv $(VERSION_H)
	@mk/lint.sh $(PY)

bench: deps $(BENCH_TARGETS)
	@echo "bench: done ($(words $(BENCH_TARGETS)) benchmarks)"

fuzz: deps $(FUZZ_TARGETS)

clean:
	rm -rf build

-include $(shell find $(BUILD) -path '$(BUILD)/deb' -prune -o -name '*.d' -type f -print 2>/dev/null)
