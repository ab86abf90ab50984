#!/usr/bin/env bash
# deb.sh BOARD BUILD MAKE: the Debian package of the flight program for BOARD
# (make deb; docs/operations.md). The tree is `make install PREFIX=/usr` into a
# staging root; the programs are stripped; Depends are read from the binaries'
# NEEDED libraries through dpkg -S (with the installed version as the minimum);
# /etc/default/mfns-nav is a conffile. dpkg-deb builds it; lintian checks it
# when installed (its report beside the package). Prints the package's path.
set -euo pipefail
board=$1 build=$2 make=$3
case $board in
  sitss-nav) arch=arm64; triplet=aarch64-linux-gnu ;;
  host-sim) arch=$(dpkg --print-architecture); triplet=$(gcc -dumpmachine) ;;
  *) echo "deb: BOARD=$board has no Debian architecture (sitss-nav or host-sim)" >&2; exit 2 ;;
esac
version=$(sed -nE 's/^__version__ = "([0-9]+\.[0-9]+\.[0-9]+)"$/\1/p' host_tools/mfns/__init__.py)
[ -n "$version" ] || { echo "deb: no version in host_tools/mfns/__init__.py" >&2; exit 2; }
stage=$build/deb
root=$stage/root
rm -rf "$stage"
mkdir -p "$root/DEBIAN"
$make --no-print-directory BOARD="$board" install DESTDIR="$PWD/$root" PREFIX=/usr >/dev/null
"$triplet-strip" --strip-unneeded --remove-section=.comment --remove-section=.note "$root/usr/bin/"*

deps=()
for lib in $(for b in "$root"/usr/bin/*; do "$triplet-objdump" -p "$b" | awk '/NEEDED/ {print $2}'; done | sort -u); do
  pkg=
  for dir in /lib/$triplet /usr/lib/$triplet; do
    pkg=$(dpkg -S "$dir/$lib" 2>/dev/null | head -n 1 | cut -d: -f1) && [ -n "$pkg" ] && break
  done
  [ -n "$pkg" ] || { echo "deb: $lib (NEEDED) belongs to no installed $arch package" >&2; exit 1; }
  ver=$(dpkg-query -W -f='${Version}' "$pkg:$arch" 2>/dev/null || dpkg-query -W -f='${Version}' "$pkg")
  deps+=("$pkg (>= ${ver%%-*})")
done
depends=$(printf '%s\n' "${deps[@]}" | sort -u | paste -sd, - | sed 's/,/, /g')

doc=$root/usr/share/doc/mfns-nav
cat > "$doc/copyright" <<C
Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/
Upstream-Name: mfns
Source: the MFNS project repository

Files: *
Copyright: 2024-2026 The MFNS project
License: see the repository
C
printf 'mfns-nav (%s) unstable; urgency=medium\n\n  * Built from the repository by make deb.\n\n -- MFNS project <mfns@example.org>  %s\n' \
  "$version" "$(date -R -u -d "@${SOURCE_DATE_EPOCH:-$(git log -1 --format=%ct 2>/dev/null || date +%s)}")" \
  | gzip -9n > "$doc/changelog.gz"  # a native package: changelog.gz
gzip -9n "$doc"/*.md
# manual pages from each program's own --help (one source), run under the
# board's runner (qemu-aarch64 for arm64)
run=$(sed -nE 's/^RUN[[:space:]]*:=[[:space:]]*(.*)$/\1/p' "boards/$board/board.mk")
man=$root/usr/share/man/man1
mkdir -p "$man"
for prog in mfns-nav mfns-ground; do
  help=$($run "$build/bin/$prog" --help) || { echo "deb: $prog --help failed" >&2; exit 1; }
  {
    printf '.TH %s 1 "" "%s" "MFNS"\n.SH NAME\n%s \\- %s\n.SH SYNOPSIS AND OPTIONS\n.nf\n' \
      "$(echo "$prog" | tr a-z A-Z)" "$version" "$prog" \
      "$([ "$prog" = mfns-nav ] && echo "the MFNS navigation computer's flight program" || echo "the MFNS ground station")"
    printf '%s\n' "$help" | sed -e 's/\\/\\\\/g' -e 's/^\./\\\&./' -e "s/^'/\\\\\&'/"
    printf '.fi\n.SH SEE ALSO\n/usr/share/doc/mfns-nav/operations.md.gz\n'
  } | gzip -9n > "$man/$prog.1.gz"
done
size_kb=$(du -sk --exclude=DEBIAN "$root" | cut -f1)
cat > "$root/DEBIAN/control" <<C
Package: mfns-nav
Version: $version
Architecture: $arch
Maintainer: MFNS project <mfns@example.org>
Section: science
Priority: optional
Installed-Size: $size_kb
Depends: $depends
Description: MFNS navigation computer: three cameras to 6-DOF pose telemetry
 The flight program of the Multiple Field-of-view Navigation System: it reads
 three V4L2 cameras watching LED beacons, identifies the beacons, solves the
 pose with its covariance and sends it over a UART as CCSDS packets, under
 systemd with a watchdog (mfns-nav.service), and the ground station
 mfns-ground that decodes the telemetry and sends commands.
C
printf '%s\n' /etc/default/mfns-nav /etc/mfns/mfns-nav.conf > "$root/DEBIAN/conffiles"
deb=$stage/mfns-nav_${version}_${arch}.deb
dpkg-deb --root-owner-group -Zxz --build "$root" "$deb" >/dev/null
if command -v lintian >/dev/null 2>&1; then
  lintian --tag-display-limit 0 "$deb" > "$stage/lintian.txt" 2>&1 || true
  echo "deb: lintian: $(grep -c '^E:' "$stage/lintian.txt" || true) errors, $(grep -c '^W:' "$stage/lintian.txt" || true) warnings ($stage/lintian.txt)"
fi
echo "deb: $deb ($(stat -c %s "$deb") bytes; Depends: $depends)"
