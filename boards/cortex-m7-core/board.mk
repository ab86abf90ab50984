# Board: cortex-m7-core -- not a flight target today but the proof that the
# flight core (math/, firmware/nav/, firmware/tlm/; not firmware/host/, which
# runs on the ground) needs no OS and no heap: it is compiled for a bare-metal
# Cortex-M7 with hard float, sized, and its stack depth bounded (make size).
BOARD_KIND      := baremetal
CC              := arm-none-eabi-gcc
AR              := arm-none-eabi-ar
SIZE            := arm-none-eabi-size
NM              := arm-none-eabi-nm
# -Os: the target is flash-bound (issue 22's goal: 64 KB for the core's own
# code); -O2 costs ~10 KB more (docs/budgets.md). GCC 12's -Oz gives the same.
# -DMFNS_CORE_MESSAGES=0: no console, so no strerror texts (math/core_text.h);
# every code is unchanged, ~5.3 KB less.
# -fno-math-errno: otherwise sqrtf drags newlib's errno path in (+100 B data).
# -fstack-usage -fcallgraph-info=su: each object's frames and calls (.su,
# .ci beside the .o), read by mk/stack.py for the worst stack depth per entry.
# -fno-partial-inlining -fno-tree-tail-merge: two of GCC's -Os passes that
# cost bytes on this code with LTO (162 B less together, measured 2026-12-03;
# no effect on what the code computes).
BOARD_CFLAGS    := -mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard -Os \
                   -fno-partial-inlining -fno-tree-tail-merge \
                   -ffunction-sections -fdata-sections -fno-math-errno \
                   -fstack-usage -fcallgraph-info=su
BOARD_LDFLAGS   := --specs=nano.specs -nostartfiles -T boards/cortex-m7-core/link.ld \
                   -Wl,--gc-sections
# -DMFNS_CORE_OUT_OF_LINE=1: a few small, often-called functions stay out of
# line where LTO would inline them at every call (math/core_inline.h, 932 B).
BOARD_DEFINES   := -DMFNS_BOARD_NAME=\"cortex-m7-core\" -DMFNS_CORE_MESSAGES=0 -DMFNS_CORE_OUT_OF_LINE=1
# The flight image of `make size` is linked with link-time optimisation (the
# core compiled once more to GCC's intermediate code, mk: $(BUILD)/lto), one
# partition so the whole image is optimised as one unit: inlining and constant
# propagation across files, ~2.5 KB less. The stack of that image comes from
# the call graph GCC writes at the link (flight.elf.ltrans0.ltrans.ci).
BOARD_LTO       := -flto -flto-partition=one
