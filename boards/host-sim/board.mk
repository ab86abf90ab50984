# Board: host-sim -- the developer's x86-64 (or any) Linux host. The flight
# program runs here against the replay camera and pseudo-terminal UARTs.
BOARD_KIND      := linux
CC              := gcc
CXX             := g++
AR              := ar
PKG_CONFIG      := pkg-config
# Tests run directly.
RUN             :=
BOARD_CFLAGS    := -O2 -g
BOARD_LDFLAGS   :=
# Settings compiled into the flight program (see boards/README.md).
BOARD_DEFINES   := -DMFNS_BOARD_NAME=\"host-sim\" \
                   -DMFNS_BOARD_UART=\"/dev/null\" \
                   -DMFNS_BOARD_BAUD=921600 \
                   -DMFNS_BOARD_CAM_X=\"/dev/video0\" \
                   -DMFNS_BOARD_CAM_Y=\"/dev/video1\" \
                   -DMFNS_BOARD_CAM_Z=\"/dev/video2\"
