# Shared by the hardware driver fragments (drivers/{v4l2,usb,aravis,libcamera,
# openni2}/module.mk): helper objects, plugin link flags, the test harness,
# and the command that runs a driver test through tests/run-tests.sh.
ifndef HWDRV_COMMON_MK
HWDRV_COMMON_MK := 1

HWDRV_COMMON_OBJ := $(BUILD)/drivers/common/drv_common.o
# Plugins export only mdrv_entry and must resolve every symbol.
HWDRV_SO_LDFLAGS := -shared -Wl,--version-script=drivers/common/plugin.map -Wl,-z,defs
HWDRV_TEST_DIR := $(BUILD)/tests/drivers
HWDRV_HARNESS_OBJ := $(BUILD)/tests/drivers/drv_harness.o
HWDRV_TEST_CPPFLAGS := $(CPPFLAGS) -Itests -Itests/drivers -Idrivers/common -Idrivers/v4l2
# Library code (glib, OpenNI2) allocates once per process; see the file.
HWDRV_RUN = MOCAP_DRIVER_DIR=$(BUILD)/drivers MOCAP_BUILD=$(BUILD) \
	LSAN_OPTIONS=suppressions=$(CURDIR)/tests/drivers/lsan.supp:print_suppressions=0 \
	tests/run-tests.sh $(BUILD)

# Recipe of a driver test program: its source (first prerequisite) + the
# harness.  Each fragment names its tests in explicit rules, so that the
# top Makefile's $(BUILD)/tests/% pattern does not take them.
define HWDRV_LINK_TEST
	@mkdir -p $(@D)
	$(CC) $(HWDRV_TEST_CPPFLAGS) $(CFLAGS) -MMD -MP $< $(HWDRV_HARNESS_OBJ) -o $@ $(LDFLAGS) -ldl
endef
endif
