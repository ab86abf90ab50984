# make install / make deb (issues 24 item 4, 44 items 1, 4): the flight program
# and the ground station as a Debian board and the operators' machines install
# them (docs/operations.md).
#   make install [BOARD=...] [DESTDIR=] [PREFIX=/usr/local]
#       install-flight and install-ground: the trees of the two packages
#       (mk/install.sh: programs, unit, sysusers.d, configuration under
#       /etc when PREFIX=/usr else PREFIX/etc, man pages, docs, dictionaries
#       and the Yamcs set-up), unstripped;
#   make deb BOARD=sitss-nav [TABLE=FILE]
#       mfns-nav_V_arm64.deb (the flight program, no ground program) and its
#       mfns-nav-dbgsym, built with dpkg-deb from install-flight's tree
#       (PREFIX=/usr), TABLE=FILE: that calibration table in the package as
#       the board's initial table (mk/deb.sh);
#   make deb-ground BOARD=host-sim|sitss-nav
#       mfns-ground_V_amd64.deb / _arm64.deb and its -dbgsym.
# Depends are read from the binaries' NEEDED libraries through dpkg -S; lintian
# checks each package when it is installed.
PREFIX ?= /usr/local
DESTDIR ?=
TABLE ?=

.PHONY: install install-flight install-ground deb deb-ground
install: install-flight install-ground

install-flight: flight
	@mk/install.sh flight "$(BOARD)" "$(BUILD)" "$(DESTDIR)" "$(PREFIX)"
	@echo "installed mfns-nav into $(DESTDIR)$(PREFIX)"

install-ground: flight
	@mk/install.sh ground "$(BOARD)" "$(BUILD)" "$(DESTDIR)" "$(PREFIX)"
	@echo "installed mfns-ground into $(DESTDIR)$(PREFIX)"

deb: flight
	@TABLE="$(TABLE)" mk/deb.sh flight "$(BOARD)" "$(BUILD)"

deb-ground: flight
	@mk/deb.sh ground "$(BOARD)" "$(BUILD)"
