# tests/soak: the soak test of mocapd (issue 20): two sim cameras and a
# fault-injecting one, watching, slow, killed and churning clients, status
# and reloads, for SOAK_S seconds; per-minute RSS, fds, threads and frame
# counts, then a verdict (tests/soak/soak.c says which).
#
#   make soak          SOAK_S=3600 by default; not part of CI
#   make soak-check    the same program for 2 minutes, then the gstreamer
#                      case for 30 s (soak_gst.c: an RTSP camera whose
#                      server is killed and restarted, a video file that
#                      ends); part of make check
#   make soak-gst      the gstreamer case alone, SOAK_GST_S=300 by default
#
# Run from the repository root (it plays tests/data/sim/walk_131_01_4s.bvh).

SOAK_S ?= 3600
SOAK := $(BUILD)/tests/soak/soak
SOAK_DEPS := $(BUILD)/bin/mocapd $(BUILD)/drivers/mocap-driver-sim.so $(BUILD)/tests/faulty/mocap-driver-faulty.so

SOAK_GST_S ?= 300
SOAK_GST := $(BUILD)/tests/soak/soak_gst
SOAK_GST_DEPS := $(BUILD)/bin/mocapd $(GST_PLUGIN) $(GST_RTSP_SERVE)

CHECKS += soak-check
all: $(SOAK) $(SOAK_GST)

$(SOAK) $(SOAK_GST): $(BUILD)/tests/soak/%: tests/soak/%.c tests/soak/soak_util.h tests/drivers/gst_rtsp_spawn.h $(BUILD)/libmocap.a
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(BUILD)/libmocap.a -lm

.PHONY: soak soak-check soak-gst
soak: $(SOAK) $(SOAK_DEPS)
	$(SOAK) $(SOAK_S)

# 2 minutes; RSS growth measured after the first 30 s.  Then the gstreamer
# case for 30 s (exit 77, GStreamer or an element missing, is a skip).
soak-check: $(SOAK) $(SOAK_DEPS) $(SOAK_GST) $(SOAK_GST_DEPS)
	$(SOAK) 120
	$(SOAK_GST) 30 || [ $$? = 77 ]

soak-gst: $(SOAK_GST) $(SOAK_GST_DEPS)
	$(SOAK_GST) $(SOAK_GST_S)
