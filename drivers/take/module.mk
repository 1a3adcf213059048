# drivers/take: replays one camera of a recorded take (record/take.h) with
# its original timing.  Links the take reader and the core statically and
# exports only mdrv_entry.
include drivers/common/common.mk

TAKE_PLUGIN := $(BUILD)/drivers/mocap-driver-take.so
TAKE_OBJ := $(BUILD)/drivers/take/take_drv.o

$(BUILD)/drivers/take/%.o: CPPFLAGS += -Idrivers/common -Irecord

# record/module.mk is included later: its library by path.
$(TAKE_PLUGIN): $(TAKE_OBJ) $(HWDRV_COMMON_OBJ) $(BUILD)/libmocaprecord.a $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(HWDRV_SO_LDFLAGS) -o $@ $(TAKE_OBJ) $(HWDRV_COMMON_OBJ) $(LDFLAGS) $(BUILD)/libmocaprecord.a $(CORE_LIB) \
		-Wl,--as-needed $(CORE_LIBS) -ljansson -lz

PLUGINS += $(TAKE_PLUGIN)
