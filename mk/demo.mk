# make demo: simulate -> table -> flight program -> FIFO -> ground station -> report.
# It needs only the demo set of mk/deps.sh (no cross compilers, qemu, linters or
# cmocka): the host flight programs, the core library for the host tools, the venv.
demo: deps-demo
	@$(MAKE) --no-print-directory BOARD=host-sim flight lib
	@mk/demo.sh
