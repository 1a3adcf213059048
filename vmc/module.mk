# vmc/: mocap-vmc, mocapd's skeletons over the VMC protocol (OSC over UDP,
# liblo) for VR and VTuber software; docs/VMC.md.  The bone mapping
# (vmc_map) and the settings (vmc_config) are plain C tested without a
# network; the end-to-end test runs mocapd or mocap-testpub, mocap-vmc and
# a liblo receiver.

VMC_LIB := $(BUILD)/libmocapvmc.a
VMC_OBJ := $(BUILD)/vmc/vmc_map.o $(BUILD)/vmc/vmc_config.o
MOCAP_VMC := $(BUILD)/bin/mocap-vmc
VMC_TESTS := $(patsubst vmc/tests/%.c,$(BUILD)/vmc/tests/%,$(wildcard vmc/tests/test_*.c))
VMC_LO_CFLAGS := $(shell $(PKG_CONFIG) --cflags liblo 2>/dev/null)
VMC_LO_LIBS := $(or $(shell $(PKG_CONFIG) --libs liblo 2>/dev/null),-llo)
# The map and the settings use the core's math and errors, and inih.
VMC_LINK := $(VMC_LIB) $(BUILD)/libmocap.a $(CORE_LIB) $(CORE_LIBS) -linih
VMC_LINK_DEPS := $(VMC_LIB) $(BUILD)/libmocap.a $(CORE_LIB)
VMC_UNITDIR ?= $(PREFIX)/lib/systemd/system
VMC_DOCDIR ?= $(PREFIX)/share/doc/mocapd

VMC_BENCH := $(BUILD)/vmc/bench_vmc

LIBS += $(VMC_LIB)
BINS += $(MOCAP_VMC)
TESTS += $(VMC_TESTS)
BENCHES += bench-vmc
all: $(VMC_BENCH)

$(BUILD)/vmc/%.o: CPPFLAGS += -Ivmc -Iipc

$(VMC_LIB): $(VMC_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(MOCAP_VMC): vmc/mocap-vmc.c $(VMC_LINK_DEPS) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Ivmc -Iipc $(VMC_LO_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(VMC_LINK) $(VMC_LO_LIBS)

# Unit tests: the map and the settings.  The end-to-end test also needs
# liblo (its receiver), the daemon harness and the programs it runs.
$(BUILD)/vmc/tests/test_vmc_map: vmc/tests/test_vmc_map.c $(VMC_LINK_DEPS)
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Ivmc -Iipc -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(VMC_LINK)

$(BUILD)/vmc/tests/test_mocap_vmc: vmc/tests/test_mocap_vmc.c $(VMC_LINK_DEPS) \
		| $(MOCAP_VMC) $(BUILD)/bin/mocapd $(BUILD)/drivers/mocap-driver-files.so $(BUILD)/ipc/mocap-testpub
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Ivmc -Iipc -Itests $(VMC_LO_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(VMC_LINK) \
		$(VMC_LO_LIBS)

$(BUILD)/vmc/tests/test_vmc_unit: vmc/tests/test_vmc_unit.c | $(MOCAP_VMC)
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS)

# Publish-to-datagram latency on loopback (mocap-testpub, mocap-vmc, a UDP
# socket here), the socket's own beside it; docs/BENCHMARKS.md.
$(VMC_BENCH): vmc/bench_vmc.c $(VMC_LINK_DEPS) | $(MOCAP_VMC) $(BUILD)/ipc/mocap-testpub
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Iipc -Itests $(VMC_LO_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(VMC_LINK) $(VMC_LO_LIBS)

.PHONY: bench-vmc
bench-vmc: $(VMC_BENCH)
	$(VMC_BENCH)

# The unit (with the binary's path filled in), the example config and the
# page.  mocap-vmc itself is in BINS.
.PHONY: install-vmc uninstall-vmc
install: install-vmc
install-vmc:
	install -d $(DESTDIR)$(VMC_UNITDIR) $(DESTDIR)$(VMC_DOCDIR) $(DESTDIR)$(SYSCONFDIR)/mocapd
	sed -e 's|@BINDIR@|$(PREFIX)/bin|g' -e 's|@DOCDIR@|$(VMC_DOCDIR)|g' -e 's|@SYSCONFDIR@|$(SYSCONFDIR)|g' \
		systemd/mocap-vmc.service > $(DESTDIR)$(VMC_UNITDIR)/mocap-vmc.service
	chmod 644 $(DESTDIR)$(VMC_UNITDIR)/mocap-vmc.service
	install -m 644 docs/VMC.md $(DESTDIR)$(VMC_DOCDIR)/
	[ -e $(DESTDIR)$(SYSCONFDIR)/mocapd/vmc.conf ] || install -m 644 config/vmc.conf $(DESTDIR)$(SYSCONFDIR)/mocapd/

uninstall: uninstall-vmc
uninstall-vmc:
	rm -f $(DESTDIR)$(VMC_UNITDIR)/mocap-vmc.service $(DESTDIR)$(VMC_DOCDIR)/VMC.md
