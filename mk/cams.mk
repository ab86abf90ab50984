# Cameras (issue 6, drivers/camera/): replay throughput benchmark.
# The camera unit tests need no fragment (tests/unit/test_camera_*.c are found
# by folder); this only adds `make bench-camera` to `make bench`.
.PHONY: bench-camera
BENCH_TARGETS += bench-camera
bench-camera: $(BUILD)/bench/bench_camera
	$(RUN) $(BUILD)/bench/bench_camera

$(BUILD)/bench/bench_camera: $(call obj,tests/bench/bench_camera.c) $(BUILD)/libmfns_linux.a $(BUILD)/libmfns_core.a
	@mkdir -p $(@D)
	$(call say,LD,$@)$(LINK) $(BOARD_LDFLAGS) $(SAN_FLAGS) $^ $(LIBCAMERA_LIBS) -lm -o $@
