# make image BOARD=sitss-nav: a bootable image of the navigation computer from
# Debian arm64 packages only (boards/sitss-nav/image/build.sh; docs/operations.md
# "The image"): Debian's PREEMPT_RT arm64 kernel with the vivid, virtio and ext4
# modules, a busybox-static initramfs configured on the host, mfns-nav and the
# arm64 libraries it needs, its configuration and table, the supervisor
# mfns-supervise, and a persistent ext4 disk for /var/lib/mfns.
# Output: build/image/{vmlinuz,initrd.cpio.gz,state.img,tc.key,image.txt};
# downloads cached in build/image-cache.
#
# make board-test: boots that image under qemu-system-aarch64 -M virt (three
# vivid cameras, the flight link on a virtio console to a host pty where
# mfns-ground decodes and commands) and checks the service end to end
# (tests/board/test_board.py). Not in `make test` (minutes of TCG): .ci/run
# runs it as its own step. make image-run boots the image by hand (console on
# stdio, the flight link's pty named by qemu).
# (not under build/sitss-nav: the Makefile includes every *.d there, and a root has etc/init.d)
IMAGE_DIR := build/image
IMAGE_SRC := $(shell find boards/sitss-nav/image -type f)
SUPERVISE_CFLAGS := $(CSTD) $(WARN) -O2 -g

.PHONY: image board-test image-run
ifeq ($(BOARD),sitss-nav)
image: $(IMAGE_DIR)/image.txt
$(IMAGE_DIR)/image.txt: $(BUILD)/bin/mfns-nav $(BUILD)/bin/mfns-supervise $(BUILD)/bin/mfns-cam-setup $(BUILD)/bin/mfns-frame-feed $(GEN)/default.mfnstbl \
                        $(IMAGE_DIR)/tables/alt.mfnstbl $(IMAGE_SRC) boards/sitss-nav/service/mfns-nav.default mk/image.mk
	@mk/deps.sh image
	@boards/sitss-nav/image/build.sh $(IMAGE_DIR) $(BUILD)/bin $(GEN)/default.mfnstbl $(IMAGE_DIR)/tables

# A second table for the board test's TABLE_LOAD: the same rig and map, another
# unmodelled pixel error, so another CRC-32 (the image carries it in
# /usr/share/mfns/tables/).
$(IMAGE_DIR)/tables/alt.mfnstbl: $(CALTABLE_SRC) $(VENV)/.stamp build/host-sim/lib/libmfns_core.so
	@mkdir -p $(@D)
	@$(PY) -m mfns table build $(CALTABLE_SRC) --pixel-sigma 0.2 -o $@ >/dev/null

$(BUILD)/bin/mfns-%: boards/sitss-nav/image/mfns-%.c boards/sitss-nav/board.mk
	@mkdir -p $(@D)
	$(CC) $(SUPERVISE_CFLAGS) $< -o $@
else
image:
	@$(MAKE) --no-print-directory BOARD=sitss-nav image
endif

# The board test's frames disk: LED frames rendered by `mfns sim nav` (the
# module scenario: a free flight among wall beacons, several in view per camera),
# 8 per camera, with their truth and the table built from their rig and map
# (module.mfnstbl, which the board test loads with TABLE_LOAD and the host replay
# flies), as an ext4 image the guest plays through the board test's rig (v4l2loopback).
$(IMAGE_DIR)/frames.img: $(VENV)/.stamp build/host-sim/lib/libmfns_core.so mk/image.mk
	@rm -rf $(IMAGE_DIR)/frames && mkdir -p $(IMAGE_DIR)
	@$(PY) -m mfns sim nav -q --scenario module --seed 3 --frames 8 --out $(IMAGE_DIR)/frames
	@$(PY) -m mfns table build $(IMAGE_DIR)/frames/calib.json $(IMAGE_DIR)/frames/beacons.csv \
	  -o $(IMAGE_DIR)/frames/module.mfnstbl >/dev/null
	@rm -f $@ && mke2fs -q -F -t ext4 -L mfns-frames -d $(IMAGE_DIR)/frames $@ 48M

# Without qemu-system-aarch64 (and not root to install it) the test skips and says so.
board-test: venv lib
	@mk/deps.sh image || echo "board-test: the image's host tools are missing (above): the test skips"
	@if command -v qemu-system-aarch64 >/dev/null; then \
	  $(MAKE) --no-print-directory BOARD=host-sim flight && $(MAKE) --no-print-directory BOARD=sitss-nav image \
	  && $(MAKE) --no-print-directory $(IMAGE_DIR)/frames.img; fi
	@nice $(PY) -m pytest -q -rs -p no:cacheprovider tests/board

image-run: image
	@boards/sitss-nav/image/boot.sh $(IMAGE_DIR) build/image-run
