# record/: the take format (take.h: append-only record files with CRCs,
# take.json), written by mocapd's recorder (daemon/recorder.c) and read by
# mocap-export; docs/RECORDING.md.

RECORD_LIB := $(BUILD)/libmocaprecord.a
RECORD_OBJ := $(BUILD)/record/take.o $(BUILD)/record/take_info.o $(BUILD)/record/take_bvh.o
MOCAP_EXPORT := $(BUILD)/bin/mocap-export
MOCAP_TRACK := $(BUILD)/bin/mocap-track
RECORD_TESTS := $(patsubst record/tests/%.c,$(BUILD)/record/tests/%,$(wildcard record/tests/test_*.c))
RECORD_LINK := $(RECORD_LIB) $(CORE_LIB) $(CORE_LIBS) -lz
# mocap-export writes Matroska through libavformat (Debian's FFmpeg libraries).
RECORD_AV_CFLAGS := $(shell $(PKG_CONFIG) --cflags libavformat libavcodec libavutil 2>/dev/null)
RECORD_AV_LIBS := $(or $(shell $(PKG_CONFIG) --libs libavformat libavcodec libavutil 2>/dev/null),-lavformat -lavcodec -lavutil)

LIBS += $(RECORD_LIB)
BINS += $(MOCAP_EXPORT) $(MOCAP_TRACK)
TESTS += $(RECORD_TESTS)

$(BUILD)/record/%.o: CPPFLAGS += -Irecord

$(RECORD_LIB): $(RECORD_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(MOCAP_EXPORT): record/mocap-export.c $(RECORD_LIB) $(CORE_LIB) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Irecord $(RECORD_AV_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(RECORD_LINK) $(RECORD_AV_LIBS)

# mocap-track runs the tracker (the core, OpenCL), and with --detector the
# 2D joint detector (OpenCV DNN).
$(MOCAP_TRACK): record/mocap-track.c $(RECORD_LIB) $(DETECT_LIB) $(CORE_LIB) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Irecord -Idetect $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(DETECT_LIB) $(RECORD_LINK) \
		$(DETECT_LIBS)

# The format's unit test; the end-to-end test runs mocapd on the bundled
# clip, records, kills it, and exports (daemon harness, libmocap).
$(BUILD)/record/tests/test_take: record/tests/test_take.c $(RECORD_LIB) $(CORE_LIB)
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Irecord -Itests $(RECORD_AV_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(RECORD_LINK) \
		$(RECORD_AV_LIBS)

# Damaged and crafted takes against mocap-track, mocap-export and the take
# driver (issue 34).
$(BUILD)/record/tests/test_take_hostile: record/tests/test_take_hostile.c $(RECORD_LIB) $(CORE_LIB) \
		| $(MOCAP_EXPORT) $(MOCAP_TRACK) $(BUILD)/drivers/mocap-driver-take.so
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Irecord -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(RECORD_LINK) -ldl

$(BUILD)/record/tests/test_recording: record/tests/test_recording.c $(RECORD_LIB) $(BUILD)/libmocap.a $(CORE_LIB) \
		| $(MOCAP_EXPORT) $(MOCAP_TRACK) $(BUILD)/bin/mocapd $(BUILD)/bin/mocapctl $(BUILD)/drivers/mocap-driver-files.so \
		$(BUILD)/drivers/mocap-driver-take.so
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Irecord -Iipc -Itests $(RECORD_AV_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(RECORD_LIB) \
		$(BUILD)/libmocap.a $(CORE_LIB) $(CORE_LIBS) -lz $(RECORD_AV_LIBS)

# The recorder's cost with two test cameras (tests/bench/record.sh):
# RECORD_SIZE (1280x1024), RECORD_FPS (60), RECORD_FORMAT (yuyv), RECORD_SYNC_MS (100),
# RECORD_SECONDS (5), RECORD_DIR (a temporary folder).
BENCHES += bench-record
.PHONY: bench-record
bench-record: $(BUILD)/bin/mocapd $(BUILD)/bin/mocapctl $(BUILD)/tests/faulty/mocap-driver-faulty.so
	tests/bench/record.sh $(BUILD)
