# make install / make deb (issue 24 item 4): the flight program as a Debian board
# installs it (docs/operations.md).
#   make install [BOARD=...] [DESTDIR=] [PREFIX=/usr/local]
#       the programs, the service unit and its exit recorder, the default
#       configuration (/etc/default/mfns-nav when PREFIX=/usr, else
#       PREFIX/etc/default) and the documentation;
#   make deb BOARD=sitss-nav
#       an arm64 (the board's architecture) .deb built with dpkg-deb from that
#       tree (PREFIX=/usr), its Depends read from the binaries' NEEDED libraries
#       through dpkg -S (mk/deb.sh), checked with lintian when it is installed.
PREFIX ?= /usr/local
DESTDIR ?=
SYSCONFDIR := $(if $(filter /usr,$(PREFIX)),/etc,$(PREFIX)/etc)
SVC := boards/sitss-nav/service
DOCS_INSTALL := docs/operations.md docs/telemetry.md docs/uplink.md docs/cameras.md README.md

.PHONY: install deb
install: flight
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/mfns-nav $(DESTDIR)$(PREFIX)/lib/systemd/system \
	  $(DESTDIR)$(SYSCONFDIR)/default $(DESTDIR)$(SYSCONFDIR)/mfns $(DESTDIR)$(PREFIX)/share/doc/mfns-nav
	install -m 0755 $(BUILD)/bin/mfns-nav $(BUILD)/bin/mfns-ground $(DESTDIR)$(PREFIX)/bin/
	install -m 0755 $(SVC)/record-exit $(DESTDIR)$(PREFIX)/lib/mfns-nav/record-exit
	sed -e 's#/usr/bin/#$(PREFIX)/bin/#g; s#/usr/lib/mfns-nav/#$(PREFIX)/lib/mfns-nav/#g' \
	  -e 's#/etc/default/#$(SYSCONFDIR)/default/#g; s#/usr/share/doc/#$(PREFIX)/share/doc/#g' \
	  -e 's#/etc/mfns/#$(SYSCONFDIR)/mfns/#g' \
	  $(SVC)/mfns-nav.service > $(DESTDIR)$(PREFIX)/lib/systemd/system/mfns-nav.service
	chmod 0644 $(DESTDIR)$(PREFIX)/lib/systemd/system/mfns-nav.service
	install -m 0644 $(SVC)/mfns-nav.default $(DESTDIR)$(SYSCONFDIR)/default/mfns-nav
	install -m 0644 $(SVC)/mfns-nav.conf $(DESTDIR)$(SYSCONFDIR)/mfns/mfns-nav.conf
	install -m 0644 $(DOCS_INSTALL) $(DESTDIR)$(PREFIX)/share/doc/mfns-nav/
	@echo "installed into $(DESTDIR)$(PREFIX) (configuration $(DESTDIR)$(SYSCONFDIR)/default/mfns-nav)"

deb: flight
	@mk/deb.sh "$(BOARD)" "$(BUILD)" "$(MAKE)"
