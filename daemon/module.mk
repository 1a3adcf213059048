# mocapd: the daemon, its fault-injection test driver, its tests and the demo.
#
# daemon/*.c except main.c form $(BUILD)/daemon/libmocapd.a, so that the
# tests/test_daemon_*.c programs can test the modules one by one; mocapd is
# main.c linked against it.

DAEMON_PKGS := inih libsystemd
DAEMON_CFLAGS := $(shell $(PKG_CONFIG) --cflags $(DAEMON_PKGS) 2>/dev/null)
DAEMON_LIBS := $(shell $(PKG_CONFIG) --libs $(DAEMON_PKGS) 2>/dev/null) -ldl
DAEMON_SRC := $(filter-out daemon/main.c,$(wildcard daemon/*.c))
# The project's one version: the programs' --version, the .deb packages
# (debian/changelog), the Python package (python/mocap/__init__.py) and libmocap's
# IPC_SO_VERSION (ipc/module.mk) agree (tests/cli-test.sh checks).
MOCAPD_VERSION := 1.2.0
DAEMON_OBJ := $(DAEMON_SRC:%.c=$(BUILD)/%.o)
DAEMON_LIB := $(BUILD)/daemon/libmocapd.a
MOCAPD := $(BUILD)/bin/mocapd

# The fault-injection driver (tests only; never installed) and variants of
# it that the plugin loader must refuse.
FAULTY_DIR := $(BUILD)/tests/faulty
FAULTY_SO := $(FAULTY_DIR)/mocap-driver-faulty.so
FAULTY_BAD := $(FAULTY_DIR)/bad/mocap-driver-badabi.so $(FAULTY_DIR)/bad/mocap-driver-noentry.so \
	$(FAULTY_DIR)/bad/mocap-driver-oldabi.so
FAULTY_LIBS := $(shell $(PKG_CONFIG) --libs libturbojpeg 2>/dev/null)

# The socket server library of ipc/module.mk (included after this file, so
# named by its path here).
IPC_SERVER_A := $(BUILD)/libmocapipc.a
# The detector runtime of detect/module.mk (also included later: its
# library by path in prerequisites, $(DETECT_LIBS) only in recipes).
DAEMON_DETECT_A := $(BUILD)/libmocapdetect.a
# The take files of record/module.mk (the recorder writes them).
DAEMON_RECORD_A := $(BUILD)/libmocaprecord.a
DAEMON_LINK = $(DAEMON_RECORD_A) $(DAEMON_DETECT_A) $(CORE_LIB) $(CORE_LIBS) $(DETECT_LIBS) $(DAEMON_LIBS) -lz

# mocapd links the tracker (core) and the socket server (ipc); it is built
# once both are in the tree.
ifneq ($(and $(wildcard ipc/module.mk),$(wildcard core/track/mc_tracker.c)),)
BINS += $(MOCAPD)
DAEMON_TEST_NEEDS := $(MOCAPD)
endif

$(BUILD)/daemon/%.o: CPPFLAGS += -Idaemon -Idetect -Irecord $(DAEMON_CFLAGS) -DMOCAPD_VERSION='"$(MOCAPD_VERSION)"'
# the default plugin_dir follows LIBDIR (the top-level Makefile's install paths)
$(BUILD)/daemon/config_keys.o $(BUILD)/daemon/main.o: $(INSTALL_PATHS_H)

$(DAEMON_LIB): $(DAEMON_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(MOCAPD): $(BUILD)/daemon/main.o $(DAEMON_LIB) $(IPC_SERVER_A) $(DAEMON_DETECT_A) $(DAEMON_RECORD_A) $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $< -o $@ $(LDFLAGS) $(DAEMON_LIB) $(IPC_SERVER_A) $(DAEMON_LINK)

$(FAULTY_SO): tests/drivers/faulty/faulty.c drivers/mdrv.h
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -shared $< -o $@ $(LDFLAGS) $(FAULTY_LIBS)

$(FAULTY_DIR)/bad/mocap-driver-badabi.so: tests/drivers/faulty/faulty.c drivers/mdrv.h
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -DFAULTY_ABI_VERSION=999 -DFAULTY_NAME='"badabi"' -shared $< -o $@ $(LDFLAGS) $(FAULTY_LIBS)

# An ABI 3 plugin (before frame_count): still loaded, frame_count not read.
$(FAULTY_DIR)/bad/mocap-driver-oldabi.so: tests/drivers/faulty/faulty.c drivers/mdrv.h
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -DFAULTY_ABI_VERSION=3 -DFAULTY_NAME='"oldabi"' -shared $< -o $@ $(LDFLAGS) $(FAULTY_LIBS)

$(FAULTY_DIR)/bad/mocap-driver-noentry.so: tests/drivers/faulty/faulty.c drivers/mdrv.h
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -DFAULTY_NO_ENTRY -shared $< -o $@ $(LDFLAGS) $(FAULTY_LIBS)

# The keypoint test (and the filter test, which reads the pose block) is
# also a client of the socket: it links libmocap
# (literal path: ipc/module.mk is included after this file).
# The detector tests run mocapd with the test models of detect/tests/data;
# the actor test with the shipped detector.
DAEMON_CLIENT_TESTS := $(BUILD)/tests/test_daemon_keypoints $(BUILD)/tests/test_daemon_detector $(BUILD)/tests/test_daemon_actor \
	$(BUILD)/tests/test_daemon_network $(BUILD)/tests/test_daemon_latency $(BUILD)/tests/test_daemon_filter
$(DAEMON_CLIENT_TESTS): $(BUILD)/tests/%: tests/%.c $(DAEMON_LIB) $(DAEMON_DETECT_A) $(DAEMON_RECORD_A) $(CORE_LIB) \
		$(BUILD)/libmocap.a \
		| $(DAEMON_TEST_NEEDS)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Idaemon -Idetect -Irecord $(DAEMON_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(DAEMON_LIB) \
		$(BUILD)/libmocap.a $(DAEMON_LINK)

# Daemon tests link the daemon library; the integration tests run mocapd
# and the fault driver, so those are built first.
$(BUILD)/tests/test_daemon_%: tests/test_daemon_%.c $(DAEMON_LIB) $(DAEMON_DETECT_A) $(DAEMON_RECORD_A) $(CORE_LIB) \
		| $(DAEMON_TEST_NEEDS) $(FAULTY_SO) $(FAULTY_BAD)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Idaemon -Idetect -Irecord $(DAEMON_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(DAEMON_LIB) \
		$(DAEMON_LINK)

# ---- capture-to-publish latency, stage by stage (docs/BENCHMARKS.md)
BENCH_LATENCY_SECONDS ?= 60
BENCHES += bench-latency
.PHONY: bench-latency
bench-latency: $(MOCAPD) $(BUILD)/bin/mocapctl
	tests/bench/latency.sh $(BUILD) $(BENCH_LATENCY_SECONDS)

# ---- the demo: mocapd on the bundled clip, no hardware (README's first command)
.PHONY: demo
demo: all
	daemon/demo.sh $(if $(V),-v) $(BUILD)

# The demo's output: short, ending with the table and the overlay page.
CHECKS += check-demo
.PHONY: check-demo
check-demo: all
	MOCAP_BUILD=$(BUILD) tests/run-tests.sh $(BUILD) tests/demo-test.sh

# ---- install: the service files and the example config (the binaries and
# plugins are installed by the top-level rule).  Units, sysusers, tmpfiles
# and udev rules go under $(PREFIX)/lib, which systemd and udev search for
# /usr and /usr/local alike; the config goes to $(SYSCONFDIR)/mocapd and is
# never overwritten.
MOCAPD_UNITDIR ?= $(PREFIX)/lib/systemd/system
MOCAPD_DOCDIR ?= $(PREFIX)/share/doc/mocapd

.PHONY: install-daemon
install: install-daemon
install-daemon:
	install -d $(DESTDIR)$(MOCAPD_UNITDIR) $(DESTDIR)$(PREFIX)/lib/sysusers.d \
		$(DESTDIR)$(PREFIX)/lib/tmpfiles.d $(DESTDIR)$(PREFIX)/lib/udev/rules.d \
		$(DESTDIR)$(SYSCONFDIR)/mocapd $(DESTDIR)$(MOCAPD_DOCDIR)
	sed -e 's|@BINDIR@|$(PREFIX)/bin|g' -e 's|@SYSCONFDIR@|$(SYSCONFDIR)|g' \
		-e 's|@DOCDIR@|$(MOCAPD_DOCDIR)|g' systemd/mocapd.service.in > $(DESTDIR)$(MOCAPD_UNITDIR)/mocapd.service
	chmod 644 $(DESTDIR)$(MOCAPD_UNITDIR)/mocapd.service
	install -m 644 systemd/mocapd.socket $(DESTDIR)$(MOCAPD_UNITDIR)/mocapd.socket
	install -m 644 systemd/mocapd.sysusers $(DESTDIR)$(PREFIX)/lib/sysusers.d/mocapd.conf
	install -m 644 systemd/mocapd.tmpfiles $(DESTDIR)$(PREFIX)/lib/tmpfiles.d/mocapd.conf
	install -m 644 systemd/70-mocapd.rules $(DESTDIR)$(PREFIX)/lib/udev/rules.d/70-mocapd.rules
	install -m 644 docs/CONFIG.md docs/SYSTEMD.md $(DESTDIR)$(MOCAPD_DOCDIR)/
	[ -e $(DESTDIR)$(SYSCONFDIR)/mocapd/mocapd.conf ] || \
		sed -e 's|@DATADIR@|$(DATADIR)/mocapd|g' -e 's|@PLUGINDIR@|$(LIBDIR)/mocapd/drivers|g' config/mocapd.conf > $(DESTDIR)$(SYSCONFDIR)/mocapd/mocapd.conf

.PHONY: uninstall-daemon
uninstall: uninstall-daemon
uninstall-daemon:
	rm -f $(DESTDIR)$(MOCAPD_UNITDIR)/mocapd.service $(DESTDIR)$(MOCAPD_UNITDIR)/mocapd.socket \
		$(DESTDIR)$(PREFIX)/lib/sysusers.d/mocapd.conf $(DESTDIR)$(PREFIX)/lib/tmpfiles.d/mocapd.conf \
		$(DESTDIR)$(PREFIX)/lib/udev/rules.d/70-mocapd.rules
	rm -rf $(DESTDIR)$(MOCAPD_DOCDIR)
