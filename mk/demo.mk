# make demo: simulate -> table -> flight program -> FIFO -> ground station -> report.
# It needs only the demo set of mk/deps.sh (no cross compilers, qemu, linters or
# cmocka): the host flight programs, the core library for the host tools, the venv.
# One console line per step: the build's output goes to build/demo-build.log (shown
# when it fails; V=1 shows the commands), the steps' to build/demo/demo.log (mk/demo.sh).
DEMO_BUILD_LOG := build/demo-build.log
demo: deps-demo
ifeq ($(V),1)
	@$(MAKE) --no-print-directory BOARD=host-sim flight lib
else
	@echo "[build] host-sim flight programs and the core library (log: $(DEMO_BUILD_LOG))"
	@mkdir -p build && $(MAKE) --no-print-directory BOARD=host-sim flight lib >$(DEMO_BUILD_LOG) 2>&1 || \
	  { tail -n 40 $(DEMO_BUILD_LOG); echo "demo: the build failed (all of it: $(DEMO_BUILD_LOG))"; exit 1; }
endif
	@mk/demo.sh
