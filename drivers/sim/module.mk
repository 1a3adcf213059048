# drivers/sim: renders the body model driven by a BVH file.
# Links the core statically and exports only mdrv_entry.
include drivers/common/common.mk

SIM_PLUGIN := $(BUILD)/drivers/mocap-driver-sim.so
SIM_OBJ := $(BUILD)/drivers/sim/sim.o

$(BUILD)/drivers/sim/%.o: CPPFLAGS += -Idrivers/common

$(SIM_PLUGIN): $(SIM_OBJ) $(HWDRV_COMMON_OBJ) $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_SO_LDFLAGS) -o $@ $(SIM_OBJ) $(HWDRV_COMMON_OBJ) $(LDFLAGS) $(CORE_LIB) -Wl,--as-needed $(CORE_LIBS)

PLUGINS += $(SIM_PLUGIN)

# The test loads the plugin from $(BUILD)/drivers.
$(BUILD)/tests/test_driver_sim: $(SIM_PLUGIN)
