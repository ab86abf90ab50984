#!/usr/bin/env bash
# deps.sh [demo|test|image]: make sure the Debian packages of one set are installed.
#   demo  what `make demo` needs: the host C compiler, pkg-config, libserialport,
#         libsystemd (the service's notify protocol, firmware/app/nav_service.h)
#         and Python's venv module (the Python packages come from the venv, mk/venv.sh)
#   test  (default) everything `make test` needs: the demo set plus cmocka, the
#         aarch64 and Cortex-M cross compilers, qemu, the linters, clang's fuzzer
#         runtime, valgrind and libcamera
#   image what `make image` and `make board-test` add (mk/image.mk): qemu-system-arm
#         (qemu-system-aarch64), cpio and e2fsprogs (mke2fs -d) on the host; the
#         arm64 packages of the image itself are fetched with apt-get download
# As root it installs what is missing (apt); otherwise it names the missing
# packages and the command to install them, and fails.
set -euo pipefail
set_name=${1:-test}
DEMO_PKGS="build-essential pkg-config libserialport-dev libsystemd-dev libssl-dev linux-libc-dev python3 python3-venv"
# libc6-dev-arm64-cross and libnewlib-arm-none-eabi are only "recommended" by
# the cross compilers: without them the aarch64 build lacks libc headers and
# the Cortex-M build lacks nano.specs, so they are named explicitly.
TEST_PKGS="$DEMO_PKGS libcmocka-dev
 gcc-aarch64-linux-gnu g++-aarch64-linux-gnu libc6-dev-arm64-cross qemu-user
 gcc-arm-none-eabi libnewlib-arm-none-eabi cppcheck clang-tidy clang libclang-rt-14-dev
 valgrind libcamera-dev lintian"
# headless Chromium: the operator view's end-to-end test (tests/host/test_yamcs.py)
TEST_PKGS="$TEST_PKGS chromium"
ARM64_PKGS="libcmocka-dev:arm64 libserialport-dev:arm64 libsystemd-dev:arm64 libssl-dev:arm64"
case $set_name in
  demo) pkgs=$DEMO_PKGS; foreign= ;;
  image) pkgs="qemu-system-arm cpio e2fsprogs qemu-user gcc-aarch64-linux-gnu $ARM64_PKGS"; foreign=arm64 ;;
  test) pkgs="$TEST_PKGS $ARM64_PKGS"; foreign=arm64 ;;
  *) echo "usage: mk/deps.sh [demo|test|image]" >&2; exit 2 ;;
esac

missing=()
for p in $pkgs; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "deps ($set_name): missing Debian packages: ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  echo "deps: run as root, or install them with:" >&2
  echo "  ${foreign:+dpkg --add-architecture $foreign && }apt-get update && apt-get install --no-install-recommends ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
if [ -n "$foreign" ]; then
  dpkg --print-foreign-architectures | grep -qx "$foreign" || dpkg --add-architecture "$foreign"
fi
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "deps ($set_name): installed ${#missing[@]} packages"
