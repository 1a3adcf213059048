# detect/: the 2D joint detector's runtime (libmocapdetect.a: ONNX heatmap
# network through OpenCV's DNN module, C++ behind detect/mc_detector.h),
# mocap-detect (a separate process that detects on the daemon's camera rings
# and sends KEYPOINTS back), its benchmark and its tests.  See
# docs/DETECT_RUNTIME.md.
#
# For other programs (mocap-bench, mocapd): add -Idetect to their CPPFLAGS,
# depend on the literal path $(BUILD)/libmocapdetect.a (modules included
# before this file, such as daemon/, do not see DETECT_LIB yet when their
# prerequisites are read) and link
#     $(BUILD)/libmocapdetect.a $(CORE_LIB) $(CORE_LIBS) $(DETECT_LIBS)
# (the detector uses mc_error from the core).

DETECT_LIB := $(BUILD)/libmocapdetect.a
# Only the OpenCV modules the runtime uses, from opencv4's flags.
DETECT_CV_CFLAGS := $(shell $(PKG_CONFIG) --cflags opencv4 2>/dev/null)
DETECT_CV_LIBS := $(filter -L% -lopencv_dnn -lopencv_imgproc -lopencv_core,$(shell $(PKG_CONFIG) --libs opencv4 2>/dev/null))
DETECT_LIBS := $(DETECT_CV_LIBS) $(shell $(PKG_CONFIG) --libs jansson 2>/dev/null) -lstdc++ -lm
DETECT_OBJ := $(BUILD)/detect/mc_detector.o $(BUILD)/detect/mc_detector_movenet.o $(BUILD)/detect/mc_detector_decode.o \
	$(BUILD)/detect/mc_movenet.o
MOCAP_DETECT := $(BUILD)/bin/mocap-detect
DETECT_BENCH := $(BUILD)/detect/bench_detect
DETECT_TESTS := $(patsubst detect/tests/%.c,$(BUILD)/detect/tests/%,$(wildcard detect/tests/test_*.c))
# What a program linked with the detector and the client library needs.
DETECT_LINK_DEPS := $(DETECT_LIB) $(BUILD)/libmocap.a $(CORE_LIB)

# Where mocap-detect looks for the model when --model is not given: the
# installed models, then config/models of the working directory.
DETECT_MODEL_DIR := $(DATADIR)/mocapd/models
DETECT_UNITDIR ?= $(PREFIX)/lib/systemd/system
DETECT_DOCDIR ?= $(PREFIX)/share/doc/mocapd

LIBS += $(DETECT_LIB)
BINS += $(if $(wildcard detect/mocap-detect.c),$(MOCAP_DETECT))
# The tests join the top-level list, so that `make check` runs them with the
# others through tests/run-tests.sh, and `make check-san` under ASan+UBSan.
TESTS += $(DETECT_TESTS)
BENCHES += bench-detect

$(BUILD)/detect/mc_detector.o $(BUILD)/detect/mc_detector_movenet.o: CPPFLAGS += -Idetect $(DETECT_CV_CFLAGS)
$(BUILD)/detect/mc_detector_decode.o $(BUILD)/detect/mc_movenet.o: CPPFLAGS += -Idetect

$(DETECT_LIB): $(DETECT_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(MOCAP_DETECT): detect/mocap-detect.c $(DETECT_LINK_DEPS) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Idetect $(CFLAGS) -MMD -MP $< -o $@ \
		$(LDFLAGS) $(DETECT_LIB) $(BUILD)/libmocap.a $(CORE_LIB) $(CORE_LIBS) $(DETECT_LIBS)

$(DETECT_BENCH): detect/bench_detect.c $(DETECT_LIB) $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Idetect $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(DETECT_LIB) $(CORE_LIB) $(CORE_LIBS) $(DETECT_LIBS)

# The tests use the project's test helpers (tests/test_util.h, and the
# daemon harness tests/daemon/harness.h for the end-to-end test).
$(BUILD)/detect/tests/test_detector $(BUILD)/detect/tests/test_detector_shipped $(BUILD)/detect/tests/test_detector_movenet: \
		$(BUILD)/detect/tests/%: \
		detect/tests/%.c $(DETECT_LIB) $(CORE_LIB)
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Idetect -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(DETECT_LIB) $(CORE_LIB) $(CORE_LIBS) $(DETECT_LIBS)

# The unit's test runs systemd-analyze verify on it (ExecStart must exist).
$(BUILD)/detect/tests/test_detect_unit: detect/tests/test_detect_unit.c | $(MOCAP_DETECT)
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS)

# The end-to-end test runs mocapd (files driver) and mocap-detect.
$(BUILD)/detect/tests/test_mocap_detect: detect/tests/test_mocap_detect.c $(DETECT_LINK_DEPS) \
		| $(MOCAP_DETECT) $(BUILD)/bin/mocapd $(BUILD)/drivers/mocap-driver-files.so
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Idetect -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(DETECT_LIB) $(BUILD)/libmocap.a \
		$(CORE_LIB) $(CORE_LIBS) $(DETECT_LIBS)

# ms per view over 200 runs of the shipped model (config/models/*ego*.onnx),
# else of a stand-in exported to $(BUILD)/detect when torch is there.
.PHONY: bench-detect install-detect
bench-detect: $(DETECT_BENCH)
	@m=$$(ls config/models/*ego*.onnx 2>/dev/null | head -n 1); \
	if [ -z "$$m" ] && [ -x /usr/bin/python3 ] && /usr/bin/python3 -c 'import torch' 2>/dev/null; then \
		/usr/bin/python3 detect/tests/data/make_models.py --standin $(BUILD)/detect >/dev/null 2>&1 && \
		m=$(BUILD)/detect/standin_ego.onnx; fi; \
	if [ -n "$$m" ]; then $(DETECT_BENCH) --model $$m; \
	else echo "bench-detect: no config/models/*ego*.onnx and no torch for a stand-in, skipped"; fi

# The unit (with the binary's path filled in) and the detectors: the shipped
# ones, and MoveNet Thunder when `make models-movenet` made it (their
# sidecars go with config/models/*.json).  mocap-detect itself is in BINS.
install: install-detect
install-detect:
	install -d $(DESTDIR)$(DETECT_UNITDIR) $(DESTDIR)$(DETECT_MODEL_DIR) $(DESTDIR)$(DETECT_DOCDIR)
	sed -e 's|@BINDIR@|$(PREFIX)/bin|g' -e 's|@DOCDIR@|$(DETECT_DOCDIR)|g' systemd/mocap-detect.service \
		> $(DESTDIR)$(DETECT_UNITDIR)/mocap-detect.service
	chmod 644 $(DESTDIR)$(DETECT_UNITDIR)/mocap-detect.service
	install -m 644 docs/DETECT_RUNTIME.md $(DESTDIR)$(DETECT_DOCDIR)/
	for m in config/models/*_detector.onnx config/models/movenet_*.onnx; do [ -e "$$m" ] || continue; \
		install -m 644 "$$m" $(DESTDIR)$(DETECT_MODEL_DIR)/; done

.PHONY: uninstall-detect
uninstall: uninstall-detect
uninstall-detect:
	rm -f $(DESTDIR)$(DETECT_UNITDIR)/mocap-detect.service
	rm -rf $(DESTDIR)$(DETECT_DOCDIR)
