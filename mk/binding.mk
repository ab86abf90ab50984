# The Python binding of the C core (host_tools/mfns/core/binding.py, issue 22) held to the
# headers field by field: binding_check.py generates binding_check_gen.c (_Static_assert on
# every struct's size, every field's offset and type, every constant), committed; here the
# generated file must be current (--check) and must compile with the core's headers and
# flags. Both before the shared library the binding loads, so a binding that disagrees
# with a header fails `make lib` (and every target that needs the library).
BINDING_GEN_PY := host_tools/mfns/core/binding_check.py
BINDING_PY     := host_tools/mfns/core/binding.py host_tools/mfns/core/errors.py
BINDING_C      := host_tools/mfns/generated/binding_check_gen.c
BINDING_STAMP  := build/host-sim/lib/binding-check.stamp

$(BINDING_STAMP): $(BINDING_C) $(BINDING_GEN_PY) $(BINDING_PY) $(CORE_HDRS) $(wildcard $(HOST_CORE_DIR)/*.h)
	@mkdir -p $(@D)
	@python3 $(BINDING_GEN_PY) --check
	gcc $(CSTD) $(WARN) -fsyntax-only $(INCLUDES) $(BINDING_C)
	@touch $@

.PHONY: binding-check
binding-check: $(BINDING_STAMP)
lib: $(BINDING_STAMP)
build/host-sim/lib/libmfns_core.so: $(BINDING_STAMP)
