# drivers/libcamera: cameras through libcamera (C++17 inside, C ABI outside).
# `make check-libcamera` checks that it loads, probes, and explains a missing
# camera; no camera that libcamera drives exists here (see docs/DRIVERS.md).
include drivers/common/common.mk

LIBCAMERA_PKG := libcamera
LIBCAMERA_PLUGIN := $(BUILD)/drivers/mocap-driver-libcamera.so
LIBCAMERA_OBJ := $(BUILD)/drivers/libcamera/libcamera_plugin.o $(HWDRV_COMMON_OBJ)

$(BUILD)/drivers/libcamera/%.o: CPPFLAGS += -Idrivers/common $(shell $(PKG_CONFIG) --cflags $(LIBCAMERA_PKG))

$(LIBCAMERA_PLUGIN): $(LIBCAMERA_OBJ)
	@mkdir -p $(@D)
	$(CXX) $(HWDRV_SO_LDFLAGS) -o $@ $^ $(LDFLAGS) $(shell $(PKG_CONFIG) --libs $(LIBCAMERA_PKG))

PLUGINS += $(LIBCAMERA_PLUGIN)

$(HWDRV_TEST_DIR)/test_libcamera: tests/drivers/test_libcamera.c $(HWDRV_HARNESS_OBJ)
	$(HWDRV_LINK_TEST)

.PHONY: check-libcamera
check-libcamera: $(LIBCAMERA_PLUGIN) $(HWDRV_TEST_DIR)/test_libcamera
	$(HWDRV_RUN) $(HWDRV_TEST_DIR)/test_libcamera
CHECKS += check-libcamera
