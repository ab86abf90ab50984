# make callgrind (issue 24 item 6, docs/budgets.md "Cycle cost on the target"):
# the instructions of every navigation cycle of mfns-nav on replays of the module
# scenario (valgrind's callgrind, one profile per mfns_nav_cycle call), the worst
# acquisition cycle, and what it means on a Cortex-A53 @ 1.2 GHz and a Cortex-A72
# @ 1.5 GHz. build/callgrind/results.json. About a minute on 2 cores.
.PHONY: callgrind
callgrind:
	@$(MAKE) --no-print-directory BOARD=host-sim flight lib >/dev/null
	@$(PY) mk/callgrind.py $(if $(CALLGRIND_SEEDS),--seeds $(CALLGRIND_SEEDS))

# make latency (docs/budgets.md "Latency"): frame stamp to the nav packet out of
# mfns-nav's transmit queue, over paced replays into a pty (mk/latency.py);
# build/latency/results.json. About 45 s (two 21.5 s replays).
.PHONY: latency
latency:
	@$(MAKE) --no-print-directory BOARD=host-sim flight lib >/dev/null
	@$(PY) mk/latency.py $(if $(LATENCY_SEEDS),--seeds $(LATENCY_SEEDS))
