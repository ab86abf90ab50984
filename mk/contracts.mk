# Telemetry and telecommand contracts (docs/telemetry.md "Adding a field"): the C packet
# structs and codecs, numbered codes, ground columns and doc tables are generated from the
# XTCE dictionaries by contract/gen_contracts.py (plain python3, standard library) and committed.
#
#   make contracts         regenerate them after editing a dictionary or the table layout
#                          (contract/README.md: each source, its generator, what it writes)
#   make contracts-check   fail when a committed generated file is stale; a prerequisite of
#                          all, size, lib and tests, so `make` fails on a stale file
#
# Only the check needs python3: without it the check is skipped with a notice (the generated
# files are committed, so a bare cross build such as `make size` still works).

CONTRACTS_SRCS := contract/mfns_tm.xml contract/mfns_tc.xml \
                  host_tools/mfns/tlm/tlm_dict.py contract/gen_contracts.py contract/gen_output.py
CONTRACTS_OUTS := firmware/tlm/generated/tlm_codes_gen.h firmware/nav/generated/nav_codes_gen.h \
                  firmware/tlm/generated/tlm_packets_gen.h firmware/tlm/generated/tlm_packets_gen.c \
                  firmware/tlm/generated/tc_codes_gen.h firmware/tlm/generated/tc_packets_gen.c \
                  ground/generated/ground_cols_gen.c docs/telemetry.md docs/uplink.md
CONTRACTS_STAMP := build/.contracts-ok

.PHONY: contracts contracts-check
contracts:
	python3 contract/gen_contracts.py
	python3 contract/gen_caltable.py

contracts-check: $(CONTRACTS_STAMP)
$(CONTRACTS_STAMP): $(CONTRACTS_SRCS) $(CONTRACTS_OUTS)
	@if command -v python3 >/dev/null 2>&1; then \
	  python3 contract/gen_contracts.py --check; \
	else \
	  echo "contracts-check: no python3, generated contracts not checked"; \
	fi
	@mkdir -p $(@D)
	@touch $@

all size lib tests: contracts-check
