#!/usr/bin/env bash
# install.sh PKG BOARD BUILD ROOT PREFIX: one package's file tree under ROOT
# (issue 44 item 4). `make install` runs it for both packages and mk/deb.sh
# for the package it builds, so `make install` and the packages hold the same
# files by construction (tests/host/test_service.py compares the lists).
#   PKG=flight  mfns-nav, the service unit, its exit recorder, the mfns
#               user (sysusers.d), the configuration, man page, docs and the
#               chrony snippet (docs/operations.md "Time")
#   PKG=ground  mfns-ground, the XTCE dictionaries, the Yamcs set-up and the
#               operator page under PREFIX/share/mfns-ground, man page, docs
# Configuration goes to /etc when PREFIX=/usr, else PREFIX/etc. The man pages
# come from each program itself, run under the board's runner (qemu-aarch64
# for arm64): mfns-nav writes its page from its options' table
# (`--help-man`, firmware/app/nav_opts_table.h), mfns-ground's wraps its --help. Docs are gzipped as Debian ships them.
set -euo pipefail
pkg=$1 board=$2 build=$3 root=$4 prefix=$5
case $prefix in /usr) etc=/etc ;; *) etc=$prefix/etc ;; esac
version=$(sed -nE 's/^__version__ = "([0-9]+\.[0-9]+\.[0-9]+)"$/\1/p' host_tools/mfns/__init__.py)
[ -n "$version" ] || { echo "install: no version in host_tools/mfns/__init__.py" >&2; exit 2; }
svc=boards/sitss-nav/service
run=$(sed -nE 's/^RUN[[:space:]]*:=[[:space:]]*(.*)$/\1/p' "boards/$board/board.mk")

man_page() { # PROG SUMMARY DOCPKG
  local help
  help=$($run "$build/bin/$1" --help) || { echo "install: $1 --help failed" >&2; exit 1; }
  install -d "$root$prefix/share/man/man1"
  {
    printf '.TH %s 1 "" "%s" "MFNS"\n.SH NAME\n%s \\- %s\n.SH SYNOPSIS AND OPTIONS\n.nf\n' \
      "$(echo "$1" | tr a-z A-Z)" "$version" "$1" "$2"
    printf '%s\n' "$help" | sed -e 's/\\/\\\\/g' -e 's/^\./\\\&./' -e "s/^'/\\\\\&'/"
    printf '.fi\n.SH SEE ALSO\n%s/share/doc/%s/\n' "$prefix" "$3"
  } | gzip -9n > "$root$prefix/share/man/man1/$1.1.gz"
}

doc_dir() { # PKG DOCS...
  local d=$root$prefix/share/doc/$1
  shift
  install -d "$d"
  install -m 0644 "$@" "$d/"
  gzip -9nf "$d"/*.md
  cat > "$d/copyright" <<C
Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/
Upstream-Name: mfns
Source: the MFNS project repository

Files: *
Copyright: 2024-2026 The MFNS project
License: see the repository
C
  chmod 0644 "$d/copyright"
  printf '%s (%s) unstable; urgency=medium\n\n  * Built from the repository by make deb.\n\n -- MFNS project <mfns@example.org>  %s\n' \
    "$(basename "$d")" "$version" \
    "$(date -R -u -d "@${SOURCE_DATE_EPOCH:-$(git log -1 --format=%ct 2>/dev/null || date +%s)}")" \
    | gzip -9n > "$d/changelog.gz" # a native package: changelog.gz
}

case $pkg in
flight)
  install -d "$root$prefix/bin" "$root$prefix/lib/mfns-nav" "$root$prefix/lib/systemd/system" \
    "$root$prefix/lib/sysusers.d" "$root$etc/default" "$root$etc/mfns"
  install -m 0755 "$build/bin/mfns-nav" "$root$prefix/bin/"
  install -m 0755 $svc/record-exit "$root$prefix/lib/mfns-nav/record-exit"
  sed -e "s#/usr/bin/#$prefix/bin/#g; s#/usr/lib/mfns-nav/#$prefix/lib/mfns-nav/#g" \
    -e "s#/etc/default/#$etc/default/#g; s#/usr/share/doc/#$prefix/share/doc/#g" \
    -e "s#/etc/mfns/#$etc/mfns/#g" \
    $svc/mfns-nav.service > "$root$prefix/lib/systemd/system/mfns-nav.service"
  chmod 0644 "$root$prefix/lib/systemd/system/mfns-nav.service"
  install -m 0644 $svc/mfns-nav.sysusers "$root$prefix/lib/sysusers.d/mfns-nav.conf"
  install -m 0644 $svc/mfns-nav.default "$root$etc/default/mfns-nav"
  install -m 0644 $svc/mfns-nav.conf "$root$etc/mfns/mfns-nav.conf"
  install -d "$root$prefix/share/man/man1"
  $run "$build/bin/mfns-nav" --help-man | sed -e "s#/usr/share/doc/#$prefix/share/doc/#" | gzip -9n \
    > "$root$prefix/share/man/man1/mfns-nav.1.gz" || { echo "install: mfns-nav --help-man failed" >&2; exit 1; }
  doc_dir mfns-nav docs/operations.md docs/telemetry.md docs/uplink.md docs/cameras.md README.md
  install -d "$root$prefix/share/doc/mfns-nav/examples"
  install -m 0644 $svc/chrony-mfns.conf "$root$prefix/share/doc/mfns-nav/examples/chrony-mfns.conf"
  ;;
ground)
  share=$root$prefix/share/mfns-ground
  install -d "$root$prefix/bin" "$share/yamcs/etc" "$share/yamcs/mdb" "$share/operator"
  install -m 0755 "$build/bin/mfns-ground" "$root$prefix/bin/"
  install -m 0644 ground/yamcs/etc/*.yaml "$share/yamcs/etc/"
  # the dictionaries' one source (contract/), copied
  install -m 0644 contract/mfns_tm.xml contract/mfns_tc.xml \
    contract/mfns_ground.xml "$share/yamcs/mdb/"
  install -m 0644 ground/operator/index.html "$share/operator/"
  man_page mfns-ground "the MFNS ground station" mfns-ground
  doc_dir mfns-ground docs/operators.md docs/telemetry.md docs/uplink.md README.md
  ;;
*) echo "install: PKG=$pkg (flight or ground)" >&2; exit 2 ;;
esac
