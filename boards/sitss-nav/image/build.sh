#!/usr/bin/env bash
# build.sh OUT BIN TABLE TABLES: the bootable sitss-nav image (make image BOARD=sitss-nav;
# docs/operations.md "The image"), from Debian arm64 packages only.
#   OUT    output folder (build/image): vmlinuz, initrd.cpio.gz,
#          state.img (the persistent disk's first contents), tc.key (the
#          ground's copy of the board key), tables/, image.txt (what and how big)
#   BIN    the cross-built programs (build/sitss-nav/bin)
#   TABLE  the table the image starts on (build/gen/default.mfnstbl)
#   TABLES a folder of further tables, carried in /usr/share/mfns/tables/ (for
#          TABLE_LOAD; the board test loads one)
# Downloads (apt-get download) are cached in OUT/../image-cache/debs and their
# contents in OUT/../image-cache/x: a second build downloads nothing.
#
# The root is an initramfs configured entirely on the host (this machine has no
# binfmt_misc, so nothing of the target runs here except through an explicit
# qemu-aarch64): busybox-static's applet links are made from its own --list
# (run under qemu-aarch64), the shared libraries the programs need are found
# by reading their NEEDED entries (objdump) recursively and taken from the
# Debian arm64 packages that own them (dpkg -S on the host's multiarch copy
# names the package, apt-get download fetches that exact version), and the
# kernel modules' load order is read from their .modinfo (modorder.py).
set -euo pipefail
out=$1 bin=$2 table=$3 tables=$4
here=$(cd "$(dirname "$0")" && pwd)
cache=$(dirname "$out")/image-cache
debs=$cache/debs x=$cache/x
triplet=aarch64-linux-gnu
t0=$(date +%s.%N)
mkdir -p "$debs" "$x"

# apt-get download PKG into the cache unless a .deb of it is there; echoes its path.
# ARCH: the .deb's architecture (arm64 unless given; all, or the build machine's).
fetch() {
  local pkg=$1 arch=${2:-arm64} name=${1%%[:=]*} f
  f=$( (ls "$debs/${name}_"*_"$arch".deb 2>/dev/null || true) | head -n 1)
  if [ -z "$f" ]; then
    (cd "$debs" && apt-get download -q "$pkg" >/dev/null 2>&1) \
      || { echo "image: apt-get download $pkg failed (apt-get update? dpkg --add-architecture arm64?)" >&2; return 1; }
    f=$(ls "$debs/${name}_"*_"$arch".deb | head -n 1)
  fi
  echo "$f"
}
# dpkg -x a cached .deb once; echoes the folder.
unpack() {
  local deb=$1 d
  d=$x/$(basename "$deb" .deb)
  [ -d "$d" ] || { dpkg -x "$deb" "$d.tmp" && mv "$d.tmp" "$d"; }
  echo "$d"
}

# --- the kernel: Debian's PREEMPT_RT arm64 kernel (docs/operations.md says why)
kpkg=${MFNS_KERNEL_PKG:-}
if [ -z "$kpkg" ]; then
  kpkg=$( (ls "$debs"/linux-image-*-rt-arm64_*_arm64.deb 2>/dev/null || true) | head -n 1 | xargs -r basename | cut -d_ -f1)
  [ -n "$kpkg" ] || kpkg=$(apt-cache depends linux-image-rt-arm64:arm64 2>/dev/null \
                           | sed -nE 's/^ *Depends: (linux-image-[^:]*-rt-arm64)(:arm64)?$/\1/p' | head -n 1)
fi
[ -n "$kpkg" ] || { echo "image: no linux-image-*-rt-arm64 in apt (apt-get update?)" >&2; exit 1; }
kdeb=$(fetch "$kpkg:arm64")
kdir=$(unpack "$kdeb")
kver=$(ls "$kdir/lib/modules" | head -n 1)
bbdir=$(unpack "$(fetch busybox-static:arm64)")

root=$out/root
rm -rf "$root"
mkdir -p "$root"/{bin,sbin,usr/bin,usr/sbin,usr/lib/mfns-nav,usr/share/mfns/tables,etc/mfns,etc/init.d,etc/default} \
         "$root"/{dev,proc,sys,run,tmp,var/lib/mfns,var/log,root,lib/modules/"$kver"}
chmod 1777 "$root/tmp"

# --- busybox and its applet links (the list from the binary itself, under qemu-aarch64)
install -m 0755 "$bbdir/bin/busybox" "$root/bin/busybox"
for a in $(qemu-aarch64 "$root/bin/busybox" --list-full); do
  [ -e "$root/$a" ] || ln -s /bin/busybox "$root/$a"
done
ln -sf /bin/busybox "$root/init"

# --- the programs, the supervisor
install -m 0755 "$bin/mfns-nav" "$root/usr/bin/mfns-nav"
install -m 0755 "$bin/mfns-supervise" "$bin/mfns-cam-setup" "$bin/mfns-frame-feed" "$root/usr/sbin/"
"$triplet-strip" --strip-unneeded "$root/usr/bin/mfns-nav" "$root"/usr/sbin/mfns-*

# --- shared libraries: NEEDED, recursively, from the packages that own them
declare -A have=()
libdirs="/lib/$triplet /usr/lib/$triplet"
# resolve PKGDIR PATH: PATH with its symlinks followed inside the package.
resolve() {
  local p=$2 l
  for _ in 1 2 3 4; do
    [ -L "$1$p" ] || break
    l=$(readlink "$1$p")
    case $l in /*) p=$l ;; *) p=$(dirname "$p")/$l ;; esac
  done
  echo "$p"
}
# copy_file PKGDIR PATH: PATH (a symlink and its target) from the package into the root.
copy_file() {
  local t
  t=$(resolve "$1" "$2")
  mkdir -p "$root$(dirname "$2")" "$root$(dirname "$t")"
  [ "$t" = "$2" ] || cp -P "$1$2" "$root$2"
  cp "$1$t" "$root$t"
}
need_libs() { "$triplet-objdump" -p "$1" | awk '/NEEDED/ {print $2}'; }
queue=($(for b in "$root/usr/bin/mfns-nav" "$root"/usr/sbin/mfns-*; do need_libs "$b"; done | sort -u))
pkgs_used=()
for _ in $(seq 1 64); do  # the closure is a handful of libraries deep
  [ ${#queue[@]} -gt 0 ] || break
  next=()
  for lib in "${queue[@]}"; do
    [ -z "${have[$lib]:-}" ] || continue
    have[$lib]=1
    owner= path=
    for d in $libdirs; do
      if [ -e "$d/$lib" ]; then
        owner=$(dpkg -S "$d/$lib" 2>/dev/null | head -n 1 | cut -d: -f1,2 | sed 's/: .*//') || true
        [ -n "$owner" ] && { path=$d/$lib; break; }
      fi
    done
    [ -n "$owner" ] || { echo "image: $lib (NEEDED) is owned by no installed arm64 package" >&2; exit 1; }
    pkg=${owner%%:*}
    ver=$(dpkg-query -W -f='${Version}' "$pkg:arm64")
    pdir=$(unpack "$(fetch "$pkg:arm64=$ver")")
    pkgs_used+=("$pkg:arm64=$ver")
    [ -e "$pdir$path" ] || [ -L "$pdir$path" ] || { echo "image: $lib not in $pkg's package" >&2; exit 1; }
    copy_file "$pdir" "$path"
    next+=($(need_libs "$pdir$(resolve "$pdir" "$path")"))
  done
  queue=("${next[@]}")
done
# the dynamic loader, at the path the programs name (PT_INTERP)
interp=$("$triplet-readelf" -l "$root/usr/bin/mfns-nav" | sed -nE 's/.*interpreter: ([^]]*)\]/\1/p')
libc6=$(unpack "$(fetch "libc6:arm64=$(dpkg-query -W -f='${Version}' libc6:arm64)")")
copy_file "$libc6" "$interp"
"$triplet-strip" --strip-unneeded "$root"/lib/$triplet/*.so* "$root"/usr/lib/$triplet/*.so* 2>/dev/null || true

# --- kernel modules: vivid (the cameras), virtio-mmio + virtio-blk + ext4 (the
# persistent disk), virtio-console (the flight link), in dependency order
mods=$(python3 "$here/modorder.py" "$kdir/lib/modules/$kver" vivid virtio_mmio virtio_blk crc32c_generic ext4 virtio_console)
: > "$root/etc/modules.order"
for m in $mods; do
  mkdir -p "$root/lib/modules/$kver/$(dirname "$m")"
  cp "$kdir/lib/modules/$kver/$m" "$root/lib/modules/$kver/$m"
  echo "$m" >> "$root/etc/modules.order"
done
cp "$kdir/boot/vmlinuz-$kver" "$out/vmlinuz"

# --- the board test's camera rig (loaded by rcS only when the test's frames disk
# is attached; docs/operations.md "The image"): v4l2loopback, built here from
# Debian's v4l2loopback-dkms source against this kernel's headers package, with
# the host's own kbuild tools (linux-kbuild for the build machine's architecture,
# the kernel's version) and the aarch64 cross compiler.
kpkgver=$(dpkg-deb -f "$kdeb" Version)
kseries=$(echo "$kver" | cut -d. -f1,2)
kb=$(cd "$x" && pwd)/rig-kbuild-$kver  # absolute: the kernel build runs in the headers folder
if [ ! -f "$kb/v4l2loopback.ko" ]; then
  rm -rf "$kb.tmp" && mkdir -p "$kb.tmp"
  for d in "$(fetch "linux-headers-$kver:arm64=$kpkgver")" \
           "$(fetch "linux-headers-${kver%-rt-arm64}-common-rt=$kpkgver" all)" \
           "$(fetch "linux-kbuild-$kseries:$(dpkg --print-architecture)=$kpkgver" "$(dpkg --print-architecture)")" \
           "$(fetch v4l2loopback-dkms all)"; do
    dpkg -x "$d" "$kb.tmp/pkgs"
  done
  hdr=$kb.tmp/pkgs/usr/src/linux-headers-$kver
  # the flavour's Makefile includes the common headers by their installed path
  sed -i "s|/usr/src/linux-headers-|$kb.tmp/pkgs/usr/src/linux-headers-|" "$hdr/Makefile"
  cp "$kb.tmp"/pkgs/usr/src/v4l2loopback-*/*.[ch] "$kb.tmp"/pkgs/usr/src/v4l2loopback-*/Makefile "$kb.tmp/"
  make -s -C "$hdr" M="$kb.tmp" CROSS_COMPILE="$triplet-" modules >"$kb.tmp/build.log" 2>&1 \
    || { tail -n 20 "$kb.tmp/build.log" >&2; echo "image: building v4l2loopback failed" >&2; exit 1; }
  "$triplet-strip" --strip-debug "$kb.tmp/v4l2loopback.ko"
  rm -rf "$kb" && mkdir -p "$kb" && cp "$kb.tmp/v4l2loopback.ko" "$kb/" && rm -rf "$kb.tmp"
fi
mkdir -p "$root/lib/modules/$kver/extra"
cp "$kb/v4l2loopback.ko" "$root/lib/modules/$kver/extra/"

# --- configuration, init, the service
cp -a "$here/rootfs/." "$root/"
chmod 0755 "$root"/etc/init.d/*
echo "$kver" > "$root/etc/kernel-release"
install -m 0644 "$table" "$root/usr/share/mfns/table.mfnstbl"
install -m 0644 "$tables"/*.mfnstbl "$root/usr/share/mfns/tables/"
cp "$here/../service/mfns-nav.default" "$root/etc/default/mfns-nav.debian"  # the Debian unit's, for reference
# The flight program's configuration: a file when the program reads one
# (--config, s-app's /etc/mfns/mfns-nav.conf), else its options.
# (read whole first: grep -q stopping at the first match would end the writer
# with SIGPIPE, which pipefail turns into "no --config")
nav_help=$(qemu-aarch64 "$root/usr/bin/mfns-nav" --help 2>&1 || true)
if grep -q -- '--config' <<<"$nav_help"; then
  install -m 0644 "$here/mfns-nav.conf" "$root/etc/mfns/mfns-nav.conf"
  echo 'MFNS_NAV_ARGS="--config /etc/mfns/mfns-nav.conf"' > "$root/etc/default/mfns-nav"
else
  cp "$here/mfns-nav.args" "$root/etc/default/mfns-nav"
fi
cat "$here/supervise.default" >> "$root/etc/default/mfns-nav"
# the board key: a fresh one per build, never one from the repository; the
# ground's copy beside the image (mode 0600 both)
if [ ! -s "$out/tc.key" ]; then
  (umask 077 && printf '# sitss-nav image key (make image)\n1 %s\n' "$(od -An -tx1 -N32 /dev/urandom | tr -d ' \n')" > "$out/tc.key")
fi
install -m 0600 "$out/tc.key" "$root/etc/mfns/tc.key"

# --- the persistent disk's first contents: an ext4 image made on the host
# (mke2fs -d): the state directory, empty (the program fills its table store)
state=$out/state-root
rm -rf "$state" && mkdir -p "$state"
echo "sitss-nav persistent state (/var/lib/mfns)" > "$state/README"
rm -f "$out/state.img"
mke2fs -q -F -t ext4 -L mfns-state -d "$state" "$out/state.img" 16M

# --- the initramfs (owner root, newc)
(cd "$root" && find . -print0 | LC_ALL=C sort -z | cpio -o -H newc -0 -R 0:0 --quiet) | gzip -6n > "$out/initrd.cpio.gz"

t1=$(date +%s.%N)
{
  echo "kernel: $kpkg ($kver)"
  echo "busybox: $(basename "$bbdir")"
  printf 'libraries from: %s\n' "$(printf '%s\n' "${pkgs_used[@]}" | sort -u | paste -sd' ')"
  echo "modules: $(echo $mods | wc -w) ($(echo "$mods" | xargs -n1 basename | paste -sd' '))"
  echo "board test rig (loaded only with the frames disk): v4l2loopback $(basename "$(ls "$debs"/v4l2loopback-dkms_*.deb)" .deb | cut -d_ -f2), $(stat -c %s "$kb/v4l2loopback.ko") bytes"
  echo "vmlinuz: $(stat -c %s "$out/vmlinuz") bytes"
  echo "initrd.cpio.gz: $(stat -c %s "$out/initrd.cpio.gz") bytes (root $(du -sk "$root" | cut -f1) kB unpacked)"
  echo "state.img: $(stat -c %s "$out/state.img") bytes ($(du -k "$out/state.img" | cut -f1) kB allocated)"
  echo "image: $(( $(stat -c %s "$out/vmlinuz") + $(stat -c %s "$out/initrd.cpio.gz") )) bytes to boot (kernel + initramfs)"
  awk -v a="$t0" -v b="$t1" 'BEGIN { printf "built in %.1f s\n", b - a }'
} > "$out/image.txt"
sed 's/^/image: /' "$out/image.txt"
