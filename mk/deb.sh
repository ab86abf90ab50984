#!/usr/bin/env bash
# deb.sh PKG BOARD BUILD: the Debian packages of PKG for BOARD (make deb,
# make deb-ground; docs/operations.md "Install"), and each one's -dbgsym.
#   PKG=flight  mfns-nav (the flight program, its unit, the mfns user; no
#               ground program); TABLE=FILE in the environment: that table,
#               checked by mfns table show, ships as
#               /usr/share/mfns-nav/table.mfnstbl and the packaged
#               configuration's `table` names it (the board's initial table)
#   PKG=ground  mfns-ground (the ground station, the dictionaries, the Yamcs
#               set-up): amd64 for BOARD=host-sim, arm64 for BOARD=sitss-nav
# The tree is mk/install.sh's (as make install's), PREFIX=/usr; the debug
# information is split out before stripping into PKG-dbgsym
# (objcopy --only-keep-debug, /usr/lib/debug/.build-id/xx/yyyy.debug, as
# Debian's dh_strip lays it out); Depends are read from the binaries' NEEDED
# libraries through dpkg -S (the installed version as the minimum). dpkg-deb
# builds them; lintian checks them when installed (its report beside them).
# Prints each package's path.
set -euo pipefail
pkg=$1 board=$2 build=$3
case $board in
  sitss-nav) arch=arm64; triplet=aarch64-linux-gnu ;;
  host-sim) arch=$(dpkg --print-architecture); triplet=$(gcc -dumpmachine) ;;
  *) echo "deb: BOARD=$board has no Debian architecture (sitss-nav or host-sim)" >&2; exit 2 ;;
esac
case $pkg in
  flight) name=mfns-nav ;;
  ground) name=mfns-ground ;;
  *) echo "deb: PKG=$pkg (flight or ground)" >&2; exit 2 ;;
esac
version=$(sed -nE 's/^__version__ = "([0-9]+\.[0-9]+\.[0-9]+)"$/\1/p' host_tools/mfns/__init__.py)
[ -n "$version" ] || { echo "deb: no version in host_tools/mfns/__init__.py" >&2; exit 2; }
stage=$build/deb
root=$stage/$name
dbg=$stage/$name-dbgsym
mkdir -p "$stage"
rm -rf "$root" "$dbg" "$stage/${name}_"*.deb "$stage/${name}-dbgsym_"*.deb
mkdir -p "$root/DEBIAN" "$dbg/DEBIAN"
mk/install.sh "$pkg" "$board" "$build" "$PWD/$root" /usr

if [ "$pkg" = flight ] && [ -n "${TABLE:-}" ]; then
  [ -r "$TABLE" ] || { echo "deb: TABLE=$TABLE cannot be read" >&2; exit 2; }
  py=${PYTHON:-.venv/bin/python}
  [ -x "$py" ] || py=python3
  if ! why=$(PYTHONPATH=host_tools "$py" -m mfns table show "$TABLE" 2>&1 >/dev/null); then
    echo "deb: TABLE=$TABLE refused by mfns table show (not packaged): $why" >&2
    exit 1
  fi
  install -d "$root/usr/share/mfns-nav"
  install -m 0644 "$TABLE" "$root/usr/share/mfns-nav/table.mfnstbl"
  sed -i -E 's#^table = .*#table = /usr/share/mfns-nav/table.mfnstbl#' "$root/etc/mfns/mfns-nav.conf"
  echo "deb: table $TABLE packaged as /usr/share/mfns-nav/table.mfnstbl"
fi

# debug information: split by build id, then strip
ids=()
for b in "$root"/usr/bin/*; do
  id=$(LC_ALL=C "$triplet-readelf" -n "$b" | sed -nE 's/^[[:space:]]*Build ID: ([0-9a-f]+)$/\1/p')
  [ -n "$id" ] || { echo "deb: $b has no build id" >&2; exit 1; }
  d=$dbg/usr/lib/debug/.build-id/${id:0:2}
  mkdir -p "$d"
  "$triplet-objcopy" --only-keep-debug --compress-debug-sections "$b" "$d/${id:2}.debug"
  chmod 0644 "$d/${id:2}.debug"
  "$triplet-strip" --strip-unneeded --remove-section=.comment --remove-section=.note "$b"
  "$triplet-objcopy" --add-gnu-debuglink="$d/${id:2}.debug" "$b"
  ids+=("$id")
done
mkdir -p "$dbg/usr/share/doc"
ln -s "$name" "$dbg/usr/share/doc/$name-dbgsym"  # as dh_strip: the main package's copyright

deps=()
for lib in $(for b in "$root"/usr/bin/*; do "$triplet-objdump" -p "$b" | awk '/NEEDED/ {print $2}'; done | sort -u); do
  p=
  for dir in /lib/$triplet /usr/lib/$triplet; do
    p=$(dpkg -S "$dir/$lib" 2>/dev/null | head -n 1 | cut -d: -f1) && [ -n "$p" ] && break
  done
  [ -n "$p" ] || { echo "deb: $lib (NEEDED) belongs to no installed $arch package" >&2; exit 1; }
  ver=$(dpkg-query -W -f='${Version}' "$p:$arch" 2>/dev/null || dpkg-query -W -f='${Version}' "$p")
  deps+=("$p (>= ${ver%%-*})")
done
depends=$(printf '%s\n' "${deps[@]}" | sort -u | paste -sd, - | sed 's/,/, /g')

size_kb=$(du -sk --exclude=DEBIAN "$root" | cut -f1)
if [ "$pkg" = flight ]; then
  cat > "$root/DEBIAN/control" <<C
Package: mfns-nav
Version: $version
Architecture: $arch
Maintainer: MFNS project <mfns@example.org>
Section: science
Priority: optional
Installed-Size: $size_kb
Depends: $depends, systemd | systemd-standalone-sysusers | systemd-sysusers
Recommends: chrony
Suggests: mfns-ground
Description: MFNS navigation computer: three cameras to 6-DOF pose telemetry
 The flight program of the Multiple Field-of-view Navigation System: it reads
 three V4L2 cameras watching LED beacons, identifies the beacons, solves the
 pose with its covariance and sends it over a UART as CCSDS packets, under
 systemd with a watchdog (mfns-nav.service, a hardened unit running as the
 system user mfns). The ground station is the package mfns-ground.
C
  printf '%s\n' /etc/default/mfns-nav /etc/mfns/mfns-nav.conf > "$root/DEBIAN/conffiles"
  cat > "$root/DEBIAN/postinst" <<'P'
#!/bin/sh
# the service's user (mfns, in video and dialout: /usr/lib/sysusers.d/mfns-nav.conf);
# the state dir /var/lib/mfns is systemd's (StateDirectory=, owned by mfns)
set -e
if [ "$1" = configure ]; then
    systemd-sysusers mfns-nav.conf
fi
P
  chmod 0755 "$root/DEBIAN/postinst"
else
  cat > "$root/DEBIAN/control" <<C
Package: mfns-ground
Version: $version
Architecture: $arch
Maintainer: MFNS project <mfns@example.org>
Section: science
Priority: optional
Installed-Size: $size_kb
Depends: $depends
Description: MFNS ground station: telemetry decoding and signed commands
 The ground side of the Multiple Field-of-view Navigation System: mfns-ground
 decodes the navigation computer's CCSDS telemetry into CSV and JSON lines,
 forwards it to Yamcs and sends signed telecommands; with the XTCE
 dictionaries and the Yamcs instance set-up under /usr/share/mfns-ground.
C
fi
dbg_kb=$(du -sk --exclude=DEBIAN "$dbg" | cut -f1)
cat > "$dbg/DEBIAN/control" <<C
Package: $name-dbgsym
Source: $name
Version: $version
Auto-Built-Package: debug-symbols
Architecture: $arch
Maintainer: MFNS project <mfns@example.org>
Installed-Size: $dbg_kb
Depends: $name (= $version)
Section: debug
Priority: optional
Description: debug symbols for $name
Build-Ids: ${ids[*]}
C
: > "$stage/lintian-$name.txt"
for r in "$root" "$dbg"; do
  p=$(sed -n 's/^Package: //p' "$r/DEBIAN/control")
  deb=$stage/${p}_${version}_${arch}.deb
  dpkg-deb --root-owner-group -Zxz --build "$r" "$deb" >/dev/null
  if command -v lintian >/dev/null 2>&1; then
    lintian --tag-display-limit 0 "$deb" >> "$stage/lintian-$name.txt" 2>&1 || true
  fi
  echo "deb: $deb ($(stat -c %s "$deb") bytes)"
done
[ "$pkg" = flight ] && cp "$stage/lintian-$name.txt" "$stage/lintian.txt"  # the name tests and docs know
if command -v lintian >/dev/null 2>&1; then
  echo "deb: lintian: $(grep -c '^E:' "$stage/lintian-$name.txt" || true) errors, $(grep -c '^W:' "$stage/lintian-$name.txt" || true) warnings ($stage/lintian-$name.txt)"
fi
echo "deb: Depends: $depends"
