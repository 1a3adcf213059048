# drivers/usb: USB cameras by vendor/product/serial with hotplug (libusb),
# delegating to the V4L2 code of drivers/v4l2.  `make check-usb` tests the
# sysfs mapping on a fake sysfs tree and the plugin with no camera present.
include drivers/common/common.mk

USB_PKG := libusb-1.0
USB_PLUGIN := $(BUILD)/drivers/mocap-driver-usb.so
USB_OBJ := $(BUILD)/drivers/usb/usb_plugin.o $(BUILD)/drivers/v4l2/drv_v4l2.o $(BUILD)/drivers/v4l2/drv_v4l2_modes.o \
	$(BUILD)/drivers/v4l2/drv_sysfs.o \
	$(HWDRV_COMMON_OBJ)

$(BUILD)/drivers/usb/%.o: CPPFLAGS += -Idrivers/common -Idrivers/v4l2 $(shell $(PKG_CONFIG) --cflags $(USB_PKG))

$(USB_PLUGIN): $(USB_OBJ)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_SO_LDFLAGS) -o $@ $^ $(LDFLAGS) $(shell $(PKG_CONFIG) --libs $(USB_PKG)) -lm

PLUGINS += $(USB_PLUGIN)

# The test also links the sysfs code itself, to run it on a fake tree.
$(HWDRV_TEST_DIR)/test_usb: tests/drivers/test_usb.c $(HWDRV_HARNESS_OBJ) $(BUILD)/drivers/v4l2/drv_sysfs.o
	@mkdir -p $(@D)
	$(CC) $(HWDRV_TEST_CPPFLAGS) $(CFLAGS) -MMD -MP $< $(HWDRV_HARNESS_OBJ) $(BUILD)/drivers/v4l2/drv_sysfs.o \
		-o $@ $(LDFLAGS) -ldl

.PHONY: check-usb
check-usb: $(USB_PLUGIN) $(HWDRV_TEST_DIR)/test_usb
	$(HWDRV_RUN) $(HWDRV_TEST_DIR)/test_usb
CHECKS += check-usb
