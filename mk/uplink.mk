# Telecommand uplink and the Yamcs ground system (docs/uplink.md).
#
#   make fuzz-tc-decoder     the TC deframer/decoder + flight command handler
#                            fuzzer, FUZZ_SECONDS (60) s, corpus in build/fuzz/corpus-tc/
#   make fuzz-tc-brief       the same for FUZZ_BRIEF_SECONDS (4) s from the committed
#                            seeds (tests/fuzz/corpus/tc_decoder/), part of `make test`
#   make ground-yamcs        Yamcs with the project's MDB (contract/) and config
#                            (ground/yamcs/), HTTP on 127.0.0.1:8090, in a private
#                            network namespace where `unshare -n` works
#   make ground-view         the operator's view (ground/operator/) of a running Yamcs,
#                            http://127.0.0.1:8095/ (docs/operators.md); run it in Yamcs'
#                            namespace: nsenter --net=/proc/PID/ns/net make ground-view

TC_FUZZ_BIN  := build/fuzz/fuzz_tc_decoder
TC_FUZZ_SRCS := tests/fuzz/fuzz_tc_decoder.c $(call tree,firmware/tlm,.c) firmware/app/nav_cmd_dispatch.c

FUZZ_TARGETS += fuzz-tc-decoder
TEST_SUITES  += fuzz-tc-brief
.PHONY: fuzz-tc-decoder fuzz-tc-brief ground-yamcs ground-view

$(TC_FUZZ_BIN): $(TC_FUZZ_SRCS) $(call tree,firmware/tlm,.h) firmware/app/nav_cmd_dispatch.h
	@mkdir -p $(@D)
	$(FUZZ_CC) $(FUZZ_FLAGS) -I. $(TC_FUZZ_SRCS) -o $@

fuzz-tc-decoder: $(TC_FUZZ_BIN)
	@mk/fuzz_run.sh fuzz-tc-decoder $(TC_FUZZ_BIN) build/fuzz/corpus-tc $(FUZZ_SECONDS) 0 4096 tests/fuzz/corpus/tc_decoder

fuzz-tc-brief: $(TC_FUZZ_BIN)
	@rm -rf build/fuzz/brief-tc
	@mk/fuzz_run.sh fuzz-tc-brief $(TC_FUZZ_BIN) build/fuzz/brief-tc $(FUZZ_BRIEF_SECONDS) 1 4096 tests/fuzz/corpus/tc_decoder

# Authenticated commands (docs/uplink.md 1a): the security header + MAC check + dispatch
# fuzzer, and mfns-ground's command inputs (grammar, UDP/Unix datagram intake, signing).
#   make fuzz-tc-auth fuzz-uplink-grammar   FUZZ_SECONDS (60) s each, corpora in build/fuzz/
TC_AUTH_FUZZERS := tc_auth uplink_grammar
fuzz_srcs_tc_auth := tests/fuzz/fuzz_tc_auth.c $(call tree,firmware/tlm,.c) firmware/app/nav_cmd_dispatch.c \
                     firmware/linux/tc_auth.c ground/tc_sign.c
fuzz_srcs_uplink_grammar := tests/fuzz/fuzz_uplink_grammar.c $(CORE_SRCS) \
                     firmware/linux/tc_auth.c firmware/linux/txq_drain.c ground/uplink.c ground/uplink_auth.c ground/tc_sign.c \
                     ground/upload.c \
                     ground/udp_forward.c ground/tcp_forward.c $(sort $(wildcard drivers/uart/*.c))
FUZZ_TARGETS += $(addprefix fuzz-,$(subst _,-,$(TC_AUTH_FUZZERS)))
.PHONY: fuzz-tc-auth fuzz-uplink-grammar

define auth_fuzz_bin
build/fuzz/fuzz_$(1): $$(fuzz_srcs_$(1)) $$(call tree,firmware/tlm,.h) $$(wildcard firmware/app/*.h firmware/linux/*.h ground/*.h)
	@mkdir -p $$(@D)
	$$(FUZZ_CC) $$(FUZZ_FLAGS) -DMFNS_HAVE_LIBCRYPTO=1 $$(INCLUDES) $$(fuzz_srcs_$(1)) \
	  $$(shell pkg-config --libs libserialport) -lcrypto -lm -o $$@
endef
$(foreach f,$(TC_AUTH_FUZZERS),$(eval $(call auth_fuzz_bin,$(f))))

fuzz-tc-auth: build/fuzz/fuzz_tc_auth
	@mk/fuzz_run.sh fuzz-tc_auth build/fuzz/fuzz_tc_auth build/fuzz/corpus-tc_auth $(FUZZ_SECONDS) 0 512 tests/fuzz/corpus/tc_auth
fuzz-uplink-grammar: build/fuzz/fuzz_uplink_grammar
	@mk/fuzz_run.sh fuzz-uplink_grammar build/fuzz/fuzz_uplink_grammar build/fuzz/corpus-uplink_grammar $(FUZZ_SECONDS) 0 512 tests/fuzz/corpus/uplink_grammar

# Yamcs' runtime in the venv (ground/requirements.txt): for `make test` and ground-yamcs only.
.PHONY: ground-venv
ground-venv: $(VENV)/.stamp-ground
$(VENV)/.stamp-ground: ground/requirements.txt $(VENV)/.stamp
	$(PY) -m pip install -q --disable-pip-version-check -r ground/requirements.txt
	@touch $@
deps: ground-venv
pytest: ground-venv

# The server in the foreground (Ctrl-C stops it), inside a private network namespace when
# `unshare -n` works (root): only loopback there, so its UDP links reach nothing else. Join
# the namespace to feed it: nsenter --net=/proc/PID/ns/net mfns-ground ... (printed).
YAMCS_RUN ?= build/yamcs
ground-yamcs: ground-venv
	@mkdir -p $(YAMCS_RUN)
	@if command -v unshare >/dev/null 2>&1 && unshare -n true 2>/dev/null; then \
	  MFNS_NETNS=1 exec unshare -n $(VENV)/bin/mfns ground yamcs $(YAMCS_RUN); \
	else \
	  echo "ground-yamcs: no private network namespace (unshare -n refused): Yamcs' UDP link listens on all interfaces"; \
	  exec $(VENV)/bin/mfns ground yamcs $(YAMCS_RUN); \
	fi

# The operator's view over Yamcs (host_tools/mfns/ground/ground_yamcs_view.py): in the foreground, Ctrl-C stops it.
GROUND_VIEW_PORT ?= 8095
ground-view: ground-venv
	exec $(VENV)/bin/mfns ground view --port $(GROUND_VIEW_PORT)

# The picture of the live Foxglove stream in docs/robotics.md, regenerated: a flown module run
# served by `mfns live` and drawn by its --snapshot client (tests/host/test_live_view.py).
.PHONY: live-view-shot
live-view-shot: $(VENV)/.stamp
	MFNS_LIVE_SHOT=docs/img/live-view.png $(PY) -m pytest -q tests/host/test_live_view.py -k snapshot_draws
