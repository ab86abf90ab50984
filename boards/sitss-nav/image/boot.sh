#!/usr/bin/env bash
# boot.sh IMAGE_DIR RUN_DIR [FRAMES_IMG]: boot the sitss-nav image under qemu-system-aarch64
# -M virt (TCG, nice'd) -- make image-run, and tests/board (docs/operations.md
# "The image").
#   console      the first PL011 (ttyAMA0) on stdio: kernel messages, the
#                system log's copy of the supervisor's lines, a maintenance shell
#   flight link  a virtio console (the guest's /dev/hvc0) on a host pty, which
#                qemu names on its output: "char device redirected to
#                /dev/pts/N (label uart)"; mfns-ground --tty /dev/pts/N --uplink
#   state        RUN_DIR/state.img (a copy of IMAGE_DIR/state.img on first boot)
#                as a virtio disk: /var/lib/mfns, kept across boots
#   cameras      three vivid instances, loaded by the image's rcS
#   frames       FRAMES_IMG (optional third argument): the board test's disk of
#                rendered frames (label mfns-frames); rcS then plays them through the
#                board test's rig (three v4l2loopback devices, one trigger) in place of vivid
# QEMU_EXTRA adds options (e.g. QEMU_EXTRA='-smp 2').
set -euo pipefail
img=$1 run=$2 frames=${3:-}
mkdir -p "$run"
[ -f "$run/state.img" ] || cp "$img/state.img" "$run/state.img"
exec nice qemu-system-aarch64 -M virt -cpu cortex-a53 -m 512 -smp 1 \
  -display none -monitor none -nic none \
  -kernel "$img/vmlinuz" -initrd "$img/initrd.cpio.gz" \
  -append "console=ttyAMA0 quiet loglevel=4 panic=5" \
  -chardev stdio,id=con,signal=off -serial chardev:con \
  -device virtio-serial-device -chardev pty,id=uart -device virtconsole,chardev=uart \
  -drive if=none,id=state,format=raw,file="$run/state.img" -device virtio-blk-device,drive=state \
  ${frames:+-drive if=none,id=frames,format=raw,readonly=on,file="$frames" -device virtio-blk-device,drive=frames} \
  ${QEMU_EXTRA:-}
