# Pose solver (issue 5): benchmarks.
#   make bench-pose      C timings (refinement warm start, cold start) and the
#                        Python comparison with PoseLib and pycolmap, the
#                        acquisition sweeps (still, a moving robot, four
#                        beacons plus a reflection, one beacon moved)
BENCH_TARGETS += bench-pose

POSE_BENCH := $(BUILD)/bench/bench_pose

$(POSE_BENCH): $(BUILD)/obj/tests/bench/bench_pose.o $(BUILD)/libmfns_testsupport.a $(BUILD)/libmfns_host.a \
               $(BUILD)/libmfns_linux.a $(BUILD)/libmfns_core.a
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $^ $(LIBS) -o $@

.PHONY: bench-pose
bench-pose: $(POSE_BENCH) lib venv
	$(RUN) $(POSE_BENCH)
	$(PY) tests/bench/bench_pose_baselines.py
	$(PY) tests/bench/bench_ident.py
	$(PY) tests/bench/bench_pose_moving.py
	$(PY) tests/bench/bench_pose_reflection.py
	$(PY) tests/bench/bench_moved_beacon.py
