# drivers/openni2: OpenNI2 depth cameras (C++ API inside, C ABI outside).
# `make check-openni2` streams from OpenNI2's own DummyDevice driver (synthetic
# depth and colour through the real OpenNI2 runtime) and checks the errors.
include drivers/common/common.mk

OPENNI2_PKG := libopenni2
OPENNI2_PLUGIN := $(BUILD)/drivers/mocap-driver-openni2.so
OPENNI2_OBJ := $(BUILD)/drivers/openni2/openni2_plugin.o $(HWDRV_COMMON_OBJ)

$(BUILD)/drivers/openni2/%.o: CPPFLAGS += -Idrivers/common $(shell $(PKG_CONFIG) --cflags $(OPENNI2_PKG))

$(OPENNI2_PLUGIN): $(OPENNI2_OBJ)
	@mkdir -p $(@D)
	$(CXX) $(HWDRV_SO_LDFLAGS) -o $@ $^ $(LDFLAGS) $(shell $(PKG_CONFIG) --libs $(OPENNI2_PKG))

PLUGINS += $(OPENNI2_PLUGIN)

$(HWDRV_TEST_DIR)/test_openni2: tests/drivers/test_openni2.c $(HWDRV_HARNESS_OBJ)
	$(HWDRV_LINK_TEST)

.PHONY: check-openni2
check-openni2: $(OPENNI2_PLUGIN) $(HWDRV_TEST_DIR)/test_openni2
	$(HWDRV_RUN) $(HWDRV_TEST_DIR)/test_openni2
CHECKS += check-openni2
