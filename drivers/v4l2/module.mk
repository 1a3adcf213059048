# drivers/v4l2: V4L2 capture plugin.  `make check-v4l2` runs the host-side
# test (config errors, no device) and the vivid test inside a qemu VM.
include drivers/common/common.mk

V4L2_PLUGIN := $(BUILD)/drivers/mocap-driver-v4l2.so
$(BUILD)/drivers/v4l2/%.o: CPPFLAGS += -Idrivers/common
# The V4L2 core and sysfs helpers are shared with the usb plugin.
V4L2_CORE_OBJ := $(BUILD)/drivers/v4l2/drv_v4l2.o $(BUILD)/drivers/v4l2/drv_v4l2_modes.o \
	$(BUILD)/drivers/v4l2/drv_sysfs.o $(HWDRV_COMMON_OBJ)
V4L2_OBJ := $(BUILD)/drivers/v4l2/v4l2_plugin.o $(V4L2_CORE_OBJ)

$(V4L2_PLUGIN): $(V4L2_OBJ)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_SO_LDFLAGS) -o $@ $^ $(LDFLAGS) -lm

PLUGINS += $(V4L2_PLUGIN)

$(HWDRV_TEST_DIR)/test_v4l2: tests/drivers/test_v4l2.c $(HWDRV_HARNESS_OBJ)
	$(HWDRV_LINK_TEST)

# The VM test program runs inside the guest; it loads the same plugin.
$(HWDRV_TEST_DIR)/test_v4l2_vivid: tests/drivers/test_v4l2_vivid.c $(HWDRV_HARNESS_OBJ)
	$(HWDRV_LINK_TEST)

# A software UVC camera for the VM (tests/vm/uvc-test.sh), and the test that
# drives the v4l2 and usb plugins against it.
$(BUILD)/tests/vm/uvc_gadget: tests/vm/uvc_gadget.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(shell $(PKG_CONFIG) --libs libturbojpeg)

$(HWDRV_TEST_DIR)/test_uvc_vm: tests/drivers/test_uvc_vm.c $(HWDRV_HARNESS_OBJ)
	$(HWDRV_LINK_TEST)

UVC_VM_DEPS := $(BUILD)/tests/vm/uvc_gadget $(HWDRV_TEST_DIR)/test_uvc_vm $(V4L2_PLUGIN) \
	$(BUILD)/drivers/mocap-driver-usb.so

# mocapd --probe against the fake GigE camera and vivid in the VM, and its
# pasted [camera] sections through --check (README.md, "First real camera").
.PHONY: check-probe
check-probe: $(V4L2_PLUGIN) $(BUILD)/bin/mocapd
	$(HWDRV_RUN) tests/vm/probe-test.sh
CHECKS += check-probe

.PHONY: check-v4l2 check-uvc
check-v4l2: $(V4L2_PLUGIN) $(HWDRV_TEST_DIR)/test_v4l2 $(HWDRV_TEST_DIR)/test_v4l2_vivid
	$(HWDRV_RUN) $(HWDRV_TEST_DIR)/test_v4l2 tests/vm/vivid-test.sh
check-uvc: $(UVC_VM_DEPS)
	$(HWDRV_RUN) tests/vm/uvc-test.sh
CHECKS += check-v4l2 check-uvc
