# Board: sitss-nav -- the aarch64 Linux navigation computer of the free flyer.
# Cross-built with Debian's gcc-aarch64-linux-gnu; arm64 libraries come from
# multiarch (libcmocka-dev:arm64, libserialport-dev:arm64). Tests run under
# qemu-aarch64 (this kernel has no binfmt_misc, so the runner is explicit).
BOARD_KIND      := linux
CC              := aarch64-linux-gnu-gcc
CXX             := aarch64-linux-gnu-g++
AR              := aarch64-linux-gnu-ar
# There is no aarch64 pkg-config wrapper: point pkg-config at the arm64 tree.
PKG_CONFIG      := PKG_CONFIG_LIBDIR=/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig pkg-config
RUN             := qemu-aarch64
BOARD_CFLAGS    := -O2 -g -march=armv8-a
BOARD_LDFLAGS   :=
BOARD_DEFINES   := -DMFNS_BOARD_NAME=\"sitss-nav\" \
                   -DMFNS_BOARD_UART=\"/dev/ttyAMA1\" \
                   -DMFNS_BOARD_BAUD=921600 \
                   -DMFNS_BOARD_CAM_X=\"/dev/video0\" \
                   -DMFNS_BOARD_CAM_Y=\"/dev/video2\" \
                   -DMFNS_BOARD_CAM_Z=\"/dev/video4\"
