# drivers/gstreamer: files, RTSP and any gst-launch description as cameras,
# through GStreamer's appsink.  `make check-gstreamer` runs its tests.
include drivers/common/common.mk

GST_PKGS := gstreamer-1.0 gstreamer-app-1.0 gstreamer-video-1.0 gstreamer-pbutils-1.0
GST_PLUGIN := $(BUILD)/drivers/mocap-driver-gstreamer.so
GST_OBJ := $(addprefix $(BUILD)/drivers/gstreamer/,gst_plugin.o gst_pipe.o gst_frames.o gst_errors.o gst_probe.o) \
	$(HWDRV_COMMON_OBJ)

$(BUILD)/drivers/gstreamer/%.o: CPPFLAGS += -Idrivers/common $(shell $(PKG_CONFIG) --cflags $(GST_PKGS))

# GStreamer cannot be unloaded (its threads and type registry outlive any
# pipeline): -z nodelete keeps the plugin mapped after dlclose.
$(GST_PLUGIN): $(GST_OBJ) $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_SO_LDFLAGS) -Wl,-z,nodelete -o $@ $(GST_OBJ) $(LDFLAGS) $(CORE_LIB) \
		$(shell $(PKG_CONFIG) --libs $(GST_PKGS))

PLUGINS += $(GST_PLUGIN)

DEB_PACKAGES += libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev libgstrtspserver-1.0-dev \
	gstreamer1.0-plugins-base gstreamer1.0-plugins-good gstreamer1.0-plugins-bad gstreamer1.0-libav \
	gstreamer1.0-plugins-ugly gstreamer1.0-tools

# Tests: files made from the demo frames (test_gstreamer) and a loopback
# RTSP server (test_gstreamer_rtsp, with the server program it starts);
# probe() and modes() with a device provider of its own (test_gstreamer_probe).
GST_TEST_CFLAGS := $(shell $(PKG_CONFIG) --cflags gstreamer-1.0)
GST_TEST_LIBS := $(shell $(PKG_CONFIG) --libs gstreamer-1.0)
GST_TESTS := $(HWDRV_TEST_DIR)/test_gstreamer $(HWDRV_TEST_DIR)/test_gstreamer_rtsp $(HWDRV_TEST_DIR)/test_gstreamer_probe
GST_RTSP_SERVE := $(HWDRV_TEST_DIR)/gst_rtsp_serve

$(GST_TESTS): $(HWDRV_TEST_DIR)/%: tests/drivers/%.c $(HWDRV_HARNESS_OBJ)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_TEST_CPPFLAGS) $(GST_TEST_CFLAGS) $(CFLAGS) -MMD -MP $< $(HWDRV_HARNESS_OBJ) -o $@ \
		$(LDFLAGS) -ldl -lm $(GST_TEST_LIBS)

$(GST_RTSP_SERVE): tests/drivers/gst_rtsp_serve.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(shell $(PKG_CONFIG) --cflags gstreamer-rtsp-server-1.0) $(CFLAGS) -MMD -MP $< -o $@ \
		$(LDFLAGS) $(shell $(PKG_CONFIG) --libs gstreamer-rtsp-server-1.0)

# mocapd on the demo clip made into MKVs, against the files driver.
GST_DAEMON_TEST := tests/drivers/test_gstreamer_daemon.sh

# GStreamer keeps its registry, types and thread pools for the life of the
# process: those allocations are suppressed (tests/drivers/gstreamer.supp).
.PHONY: check-gstreamer
check-gstreamer: $(GST_PLUGIN) $(FILES_PLUGIN) $(GST_TESTS) $(GST_RTSP_SERVE) $(MOCAPD)
	MOCAP_DRIVER_DIR=$(BUILD)/drivers MOCAP_BUILD=$(BUILD) \
	LSAN_OPTIONS=suppressions=$(CURDIR)/tests/drivers/gstreamer.supp:print_suppressions=0 \
	tests/run-tests.sh $(BUILD) $(GST_TESTS) $(GST_DAEMON_TEST)
CHECKS += check-gstreamer

# The capture cost of a 1280x720 30 fps H.264 file against gst-launch
# decoding it to a fakesink (docs/BENCHMARKS_SYSTEM.md, "GStreamer driver").
GST_BENCH_CLIP := $(BUILD)/bench/gst-720p30.mp4
$(HWDRV_TEST_DIR)/bench_gstreamer: tests/drivers/bench_gstreamer.c $(HWDRV_HARNESS_OBJ)
	$(HWDRV_LINK_TEST)

$(GST_BENCH_CLIP):
	@mkdir -p $(@D)
	gst-launch-1.0 -q videotestsrc pattern=smpte horizontal-speed=8 num-buffers=600 ! \
		video/x-raw,format=I420,width=1280,height=720,framerate=30/1 ! x264enc speed-preset=veryfast bitrate=6000 ! \
		mp4mux ! filesink location=$@

.PHONY: bench-gstreamer
bench-gstreamer: $(GST_PLUGIN) $(HWDRV_TEST_DIR)/bench_gstreamer $(GST_BENCH_CLIP)
	@echo "gst-launch-1.0, decoding to fakesink:"
	@/usr/bin/time -f "  %e s wall, %U s user + %S s system" gst-launch-1.0 -q \
		uridecodebin uri=file://$(CURDIR)/$(GST_BENCH_CLIP) ! fakesink sync=false
	@echo "the driver delivering RGB24 frames:"
	@MOCAP_DRIVER_DIR=$(BUILD)/drivers $(HWDRV_TEST_DIR)/bench_gstreamer $(GST_BENCH_CLIP) rgb24
	@echo "the driver delivering YUYV frames:"
	@MOCAP_DRIVER_DIR=$(BUILD)/drivers $(HWDRV_TEST_DIR)/bench_gstreamer $(GST_BENCH_CLIP) yuyv
BENCHES += bench-gstreamer
