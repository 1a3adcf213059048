# drivers/files: plays folders of numbered image files as cameras.
# Links the core statically (only mc_image and mc_error are pulled in) and
# exports only mdrv_entry (drivers/common/plugin.map).
include drivers/common/common.mk

FILES_PLUGIN := $(BUILD)/drivers/mocap-driver-files.so
FILES_OBJ := $(BUILD)/drivers/files/files.o

$(BUILD)/drivers/files/%.o: CPPFLAGS += -Idrivers/common

$(FILES_PLUGIN): $(FILES_OBJ) $(HWDRV_COMMON_OBJ) $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_SO_LDFLAGS) -o $@ $(FILES_OBJ) $(HWDRV_COMMON_OBJ) $(LDFLAGS) $(CORE_LIB) -Wl,--as-needed $(CORE_LIBS)

PLUGINS += $(FILES_PLUGIN)

# The test loads the plugin from $(BUILD)/drivers.
$(BUILD)/tests/test_driver_files: $(FILES_PLUGIN)
