# ipc/: the wire protocol (proto), the server library the daemon links
# (srv_server), the client library libmocap (shared, with soname and
# pkg-config file), mocapctl, the IPC tests, the fuzzer and the benchmark.
#
# For the daemon: link $(BUILD)/libmocapipc.a before $(CORE_LIB)
# (srv_server uses mc_error, mc_math and mc_pose from the core).  Use the
# literal path in daemon/module.mk: it is included before this file, so
# IPC_SERVER_LIB is not defined yet when its prerequisites are read.
#
# libmocap uses only header-only core helpers (base/mc_time.h,
# base/mc_thread.h), so libmocap.so links nothing of the core and exports
# only mocap_* (ipc/libmocap.map).

IPC_SERVER_LIB := $(BUILD)/libmocapipc.a
IPC_CLIENT_LIB := $(BUILD)/libmocap.a
IPC_SO_VERSION := 1.2.0
IPC_SO := $(BUILD)/lib/libmocap.so.$(IPC_SO_VERSION)
IPC_PC := $(BUILD)/lib/pkgconfig/mocap.pc
IPC_TESTPUB := $(BUILD)/ipc/mocap-testpub
IPC_EXAMPLES := $(patsubst examples/%.c,$(BUILD)/examples/%,$(wildcard examples/*.c))
IPC_TESTS := $(patsubst tests/%.c,$(BUILD)/tests/%,$(wildcard tests/test_ipc*.c))
# What every program linked with $(IPC_LINK) must depend on: serial make
# builds prerequisites in order, so a library missing here is not built yet.
IPC_LINK_DEPS := $(IPC_SERVER_LIB) $(IPC_CLIENT_LIB) $(CORE_LIB)
IPC_LINK := $(IPC_LINK_DEPS) $(CORE_LIBS)

LIBS += $(IPC_SERVER_LIB) $(IPC_CLIENT_LIB) $(IPC_SO) $(IPC_PC)
BINS += $(BUILD)/bin/mocapctl
CHECKS += check-ipc-python fuzz-ipc
BENCHES += bench-ipc

# The server is ipc/server/*.c (ipc/server/internal.h says which file does
# what), the client library ipc/client/*.c; both share the protocol codec:
# ipc/proto_encode.c, ipc/proto_decode.c, and ipc/proto.c for the type
# names and TCP framing that both use.
IPC_PROTO_SRC := ipc/proto.c ipc/proto_encode.c ipc/proto_decode.c
IPC_PROTO_OBJ := $(patsubst %.c,$(BUILD)/%.o,$(IPC_PROTO_SRC))
IPC_SERVER_OBJ := $(patsubst %.c,$(BUILD)/%.o,$(wildcard ipc/server/*.c))
IPC_CLIENT_OBJ := $(patsubst %.c,$(BUILD)/%.o,$(wildcard ipc/client/*.c))

$(IPC_SERVER_LIB): $(IPC_PROTO_OBJ) $(IPC_SERVER_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(IPC_CLIENT_LIB): $(IPC_PROTO_OBJ) $(IPC_CLIENT_OBJ)
	@rm -f $@
	ar rcs $@ $^

# Only the mocap_ symbols are exported (ipc/libmocap.map).
$(IPC_SO): $(IPC_PROTO_OBJ) $(IPC_CLIENT_OBJ) ipc/libmocap.map
	@mkdir -p $(@D)
	$(CC) -shared -Wl,-soname,libmocap.so.1 -Wl,--version-script=ipc/libmocap.map -Wl,--no-undefined \
		-o $@ $(filter %.o,$^) $(LDFLAGS) -lm
	ln -sf libmocap.so.$(IPC_SO_VERSION) $(BUILD)/lib/libmocap.so.1
	ln -sf libmocap.so.1 $(BUILD)/lib/libmocap.so

# Written on every build, so that it always carries the PREFIX in use.
.PHONY: $(IPC_PC)
$(IPC_PC):
	@mkdir -p $(@D)
	@printf '%s\n' 'prefix=$(PREFIX)' 'libdir=$(LIBDIR)' 'includedir=$${prefix}/include' '' \
		'Name: mocap' 'Description: client library of mocapd, the motion-capture daemon' \
		'Version: $(IPC_SO_VERSION)' 'Libs: -L$${libdir} -lmocap' 'Libs.private: -pthread -lm' \
		'Cflags: -I$${includedir}' > $@

# `record list` reads take.json files (record/, literal path: included later).
$(BUILD)/bin/mocapctl: ipc/mocapctl.c $(IPC_CLIENT_LIB) $(BUILD)/libmocaprecord.a $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Irecord $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(IPC_CLIENT_LIB) $(BUILD)/libmocaprecord.a \
		$(CORE_LIB) -ljansson -lz -lm

$(IPC_TESTPUB): ipc/mocap-testpub.c $(IPC_LINK_DEPS)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(IPC_LINK)

# The examples link the shared library, as an application would.
$(IPC_EXAMPLES): $(BUILD)/examples/%: examples/%.c $(IPC_SO)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) -L$(BUILD)/lib -lmocap -Wl,-rpath,'$$ORIGIN/../lib'

all: $(IPC_TESTPUB) $(IPC_EXAMPLES)

# The IPC tests link the server and client libraries as well as the core.
$(IPC_TESTS): $(BUILD)/tests/%: tests/%.c $(IPC_LINK_DEPS)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(IPC_LINK)

# The Python client (python/, the `mocap` package) with pytest, against the
# test publisher, mocapctl and the examples (python/conftest.py), and
# installed with pip into a temporary venv.  Debian's interpreter: its
# python3-pytest, python3-venv and python3-pip (make deps).
IPC_PYTHON ?= /usr/bin/python3
.PHONY: check-ipc-python fuzz-ipc bench-ipc install-ipc
check-ipc-python: $(IPC_TESTPUB) $(BUILD)/bin/mocapctl $(IPC_EXAMPLES)
	@if $(IPC_PYTHON) -c 'import pytest' 2>/dev/null; then \
		MOCAP_TESTPUB=$(abspath $(IPC_TESTPUB)) MOCAPCTL=$(abspath $(BUILD)/bin/mocapctl) \
		MOCAP_EXAMPLES=$(abspath $(BUILD)/examples) PYTHONDONTWRITEBYTECODE=1 \
		$(IPC_PYTHON) -m pytest -q -p no:cacheprovider python/; \
	else echo "SKIP check-ipc-python: no pytest for $(IPC_PYTHON) (make deps: python3-pytest)"; fi

# libFuzzer on the protocol decoder the server runs on every datagram, with
# ASan+UBSan and leak detection.  FUZZ_SECONDS=60 as in CI.
FUZZ_CC ?= clang
FUZZ_SECONDS ?= 60
IPC_FUZZ := $(BUILD)/fuzz/fuzz_ipc
$(IPC_FUZZ): tests/fuzz/fuzz_ipc.c $(IPC_PROTO_SRC) ipc/proto.h core/base/mc_le.h
	@mkdir -p $(@D)
	$(FUZZ_CC) -std=c11 -D_GNU_SOURCE -Iipc -Icore -g -O1 -fsanitize=fuzzer,address,undefined \
		-fno-sanitize-recover=undefined tests/fuzz/fuzz_ipc.c $(IPC_PROTO_SRC) -o $@ -lm

$(BUILD)/fuzz/fuzz_ipc_seeds: tests/fuzz/fuzz_ipc_seeds.c $(IPC_PROTO_SRC) ipc/proto.h core/base/mc_le.h
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) tests/fuzz/fuzz_ipc_seeds.c $(IPC_PROTO_SRC) -o $@ $(LDFLAGS) -lm

fuzz-ipc: $(IPC_FUZZ) $(BUILD)/fuzz/fuzz_ipc_seeds
	@rm -rf $(BUILD)/fuzz/seeds && mkdir -p $(BUILD)/fuzz/seeds $(BUILD)/fuzz/corpus
	$(BUILD)/fuzz/fuzz_ipc_seeds $(BUILD)/fuzz/seeds
	ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
		$(IPC_FUZZ) -max_total_time=$(FUZZ_SECONDS) -max_len=65536 -print_final_stats=1 \
		-artifact_prefix=$(BUILD)/fuzz/ $(BUILD)/fuzz/corpus $(BUILD)/fuzz/seeds 2>$(BUILD)/fuzz/fuzz_ipc.log \
		|| { tail -n 60 $(BUILD)/fuzz/fuzz_ipc.log; exit 1; }
	@grep -E '^(Done|stat::number_of_executed_units)' $(BUILD)/fuzz/fuzz_ipc.log || true

$(BUILD)/tests/bench_ipc: tests/bench_ipc.c $(IPC_LINK_DEPS)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(IPC_LINK)

$(BUILD)/tests/bench_predict: tests/bench_predict.c $(IPC_LINK_DEPS)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(IPC_LINK)

# Twice: with the default scheduler, then with SCHED_FIFO (where allowed),
# which shows the IPC path without the load of other processes.  Then the
# prediction error on the evaluation clips' ground truth (DATA_DIR).
BENCHES += bench-predict
.PHONY: bench-predict
bench-ipc: $(BUILD)/tests/bench_ipc
	$(BUILD)/tests/bench_ipc
	$(BUILD)/tests/bench_ipc --rt || [ $$? -eq 77 ]

bench-predict: $(BUILD)/tests/bench_predict
	@clips="$$(ls -d $(DATA_DIR)/ego/*/ $(DATA_DIR)/outside/*/ 2>/dev/null)"; \
	if [ -n "$$clips" ]; then $(BUILD)/tests/bench_predict $$clips; \
	else echo "bench-predict: no clips in $(DATA_DIR)/ego or $(DATA_DIR)/outside, skipped"; fi

# Installs what the top-level install does not know about: the shared
# library, its header and pkg-config file.
install: install-ipc
install-ipc: $(IPC_SO) $(IPC_PC)
	install -d $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(PREFIX)/include
	install -m 755 $(IPC_SO) $(DESTDIR)$(LIBDIR)/
	ln -sf libmocap.so.$(IPC_SO_VERSION) $(DESTDIR)$(LIBDIR)/libmocap.so.1
	ln -sf libmocap.so.1 $(DESTDIR)$(LIBDIR)/libmocap.so
	install -m 644 ipc/mocap.h $(DESTDIR)$(PREFIX)/include/
	install -m 644 $(IPC_PC) $(DESTDIR)$(LIBDIR)/pkgconfig/
	install -d $(DESTDIR)$(DATADIR)/bash-completion/completions
	install -m 644 ipc/mocapctl.bash-completion $(DESTDIR)$(DATADIR)/bash-completion/completions/mocapctl

.PHONY: uninstall-ipc
uninstall: uninstall-ipc
uninstall-ipc:
	rm -f $(DESTDIR)$(LIBDIR)/libmocap.so.$(IPC_SO_VERSION) $(DESTDIR)$(LIBDIR)/libmocap.so.1 \
		$(DESTDIR)$(LIBDIR)/libmocap.so $(DESTDIR)$(PREFIX)/include/mocap.h $(DESTDIR)$(LIBDIR)/pkgconfig/mocap.pc \
		$(DESTDIR)$(DATADIR)/bash-completion/completions/mocapctl
