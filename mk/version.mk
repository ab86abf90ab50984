# The one version string (host_tools/mfns/__init__.py) as a C header for the
# programs' --version and the BOOT event: generated, never copied by hand.
VERSION_H := $(GEN)/mfns_version.h
INCLUDES += -I$(GEN)
.PHONY: version-header
version-header: $(VERSION_H)
$(VERSION_H): host_tools/mfns/__init__.py mk/version.sh
	@mk/version.sh $< $@
$(call obj,firmware/app/nav_app.c firmware/app/nav_opts.c ground/ground.c ground/tools/mfns_tlm_synth.c): $(VERSION_H)
