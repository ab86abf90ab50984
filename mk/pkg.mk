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

# pkg-check: build the wheel from the tree (no debris left in it), install it into a clean
# venv in a temporary folder from the pinned wheels (build/wheels, offline once filled) and
# run every subcommand there, outside the repository (mk/pkg-check.sh says what each checks).
TEST_SUITES += pkg-check
.PHONY: pkg-check
pkg-check: venv $(GEN)/default.mfnstbl
	@$(MAKE) --no-print-directory -s BOARD=host-sim flight
	@mk/pkg-check.sh $(PY) $(GEN)/default.mfnstbl
