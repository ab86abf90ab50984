# The host tools as users install them (issues 14, 28): the wheel and its check.
#
# pkg-core-lib: the C core for the wheel. host_tools/setup.py (the wheel's build step) runs
#   make -s -C <repo> pkg-core-lib PKG_CORE_LIB=<its build dir>/mfns/libmfns_core.so PYTHON=<its python>
# so the wheel's library is built by the Makefile's one recipe (CORE_LIB_CC, the sources
# of CORE_DIRS and HOST_CORE_DIR) after the binding check of mk/binding.mk, and nothing is
# written into the tree (no stamp, no object: one gcc call straight to PKG_CORE_LIB).
PYTHON ?= python3
.PHONY: pkg-core-lib
pkg-core-lib:
	@test -n "$(PKG_CORE_LIB)" || { echo "pkg-core-lib: set PKG_CORE_LIB=<output path>" >&2; exit 2; }
	@$(PYTHON) $(BINDING_GEN_PY) --check
	@gcc $(CSTD) $(WARN) -fsyntax-only $(INCLUDES) $(BINDING_C)
	@mkdir -p $(dir $(PKG_CORE_LIB))
	@$(CORE_LIB_CC) -o $(PKG_CORE_LIB)

# pkg-programs: the host builds of the flight and ground programs for the wheel (mfns/bin/,
#   run by the console scripts mfns-nav and mfns-ground, mfns/programs.py). setup.py runs
#   make -s -C <repo> pkg-programs PKG_BIN_DIR=<its build dir>/mfns/bin PKG_BUILD_DIR=<a temporary folder>
# The programs are the Makefile's own targets ($(BUILD)/bin/mfns-nav, mfns-ground: the same
# recipes and flags as `make flight`) built with BUILD pointed at the temporary folder, so
# the tree's build/ is not touched; they link the system's shared libraries the flight build
# links (libcamera, libserialport, libcrypto: mk/deps.sh), as the tree's build does.
PKG_PROGRAMS := mfns-nav mfns-ground
.PHONY: pkg-programs
pkg-programs:
	@test -n "$(PKG_BIN_DIR)" -a -n "$(PKG_BUILD_DIR)" || { echo "pkg-programs: set PKG_BIN_DIR and PKG_BUILD_DIR" >&2; exit 2; }
	@$(MAKE) --no-print-directory -s BOARD=host-sim BUILD=$(PKG_BUILD_DIR) $(addprefix $(PKG_BUILD_DIR)/bin/,$(PKG_PROGRAMS))
	@mkdir -p $(PKG_BIN_DIR)
	@for b in $(PKG_PROGRAMS); do install -m 0755 $(PKG_BUILD_DIR)/bin/$$b $(PKG_BIN_DIR)/$$b || exit 1; done

# pkg-check: build the wheel from the tree (no debris left in it), install it into a clean
# venv in a temporary folder from the pinned wheels (build/wheels, offline once filled) and
# run every subcommand there, outside the repository, and a user's whole chain with the wheel's
# own flight and ground programs (mk/pkg-check.sh says what each checks).
TEST_SUITES += pkg-check
.PHONY: pkg-check
pkg-check: venv $(GEN)/default.mfnstbl
	@mk/pkg-check.sh $(PY) $(GEN)/default.mfnstbl
