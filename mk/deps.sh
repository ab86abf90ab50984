#!/usr/bin/env bash
# deps.sh: make sure the Debian packages the build and the tests need are
# installed. As root it installs what is missing (apt); otherwise it names the
# missing packages and the command to install them, and fails.
set -euo pipefail
# libc6-dev-arm64-cross and libnewlib-arm-none-eabi are only "recommended" by
# the cross compilers: without them the aarch64 build lacks libc headers and
# the Cortex-M build lacks nano.specs, so they are named explicitly.
HOST_PKGS="build-essential pkg-config libcmocka-dev libserialport-dev linux-libc-dev
 gcc-aarch64-linux-gnu g++-aarch64-linux-gnu libc6-dev-arm64-cross qemu-user
 gcc-arm-none-eabi libnewlib-arm-none-eabi cppcheck clang-tidy clang libclang-rt-14-dev
 valgrind libcamera-dev"
ARM64_PKGS="libcmocka-dev:arm64 libserialport-dev:arm64"

missing=()
for p in $HOST_PKGS $ARM64_PKGS; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "deps: missing Debian packages: ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  echo "deps: run as root, or install them with:" >&2
  echo "  dpkg --add-architecture arm64 && apt-get update && apt-get install --no-install-recommends ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
dpkg --print-foreign-architectures | grep -qx arm64 || dpkg --add-architecture arm64
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "deps: installed ${#missing[@]} packages"
