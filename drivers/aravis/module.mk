# drivers/aravis: GigE Vision / USB3 Vision plugin (Aravis 0.8), tested in
# `make check-aravis` against arv-fake-gv-camera-0.8 on loopback.
include drivers/common/common.mk

ARAVIS_PKG := aravis-0.8
ARAVIS_PLUGIN := $(BUILD)/drivers/mocap-driver-aravis.so
ARAVIS_OBJ := $(BUILD)/drivers/aravis/aravis_plugin.o $(HWDRV_COMMON_OBJ)

$(BUILD)/drivers/aravis/%.o: CPPFLAGS += -Idrivers/common $(shell $(PKG_CONFIG) --cflags $(ARAVIS_PKG))

$(ARAVIS_PLUGIN): $(ARAVIS_OBJ)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_SO_LDFLAGS) -o $@ $^ $(LDFLAGS) $(shell $(PKG_CONFIG) --libs $(ARAVIS_PKG))

PLUGINS += $(ARAVIS_PLUGIN)

$(HWDRV_TEST_DIR)/test_aravis: tests/drivers/test_aravis.c $(HWDRV_HARNESS_OBJ)
	$(HWDRV_LINK_TEST)

.PHONY: check-aravis
check-aravis: $(ARAVIS_PLUGIN) $(HWDRV_TEST_DIR)/test_aravis
	$(HWDRV_RUN) $(HWDRV_TEST_DIR)/test_aravis
CHECKS += check-aravis
