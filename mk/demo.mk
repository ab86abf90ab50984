# make demo: simulate -> table -> flight program -> FIFO -> ground station -> report.
demo: deps
	@$(MAKE) --no-print-directory BOARD=host-sim flight lib
	@mk/demo.sh
