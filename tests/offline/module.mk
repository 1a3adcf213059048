# mocapd's offline mode ([daemon] offline, mocapd --offline) on the demo
# clip: the image folders (files driver) and, where GStreamer is installed,
# the same frames as two MKVs (gstreamer driver, pace = asap); every frame
# set tracked (tests/offline/test_offline.sh).
.PHONY: check-offline
check-offline: $(MOCAPD) $(PLUGINS)
	MOCAP_BUILD=$(BUILD) tests/run-tests.sh $(BUILD) tests/offline/test_offline.sh
CHECKS += check-offline
