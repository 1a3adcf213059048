# calibrate/: mocap-calibrate, camera intrinsics and rig extrinsics from
# images of a ChArUco board (OpenCV calib3d and aruco from Debian's contrib
# modules, C++ behind the core's C headers); docs/CALIBRATION.md.  The board,
# the solver and the report are a small library that the tests link.

CALIB_LIB := $(BUILD)/libmocapcalib.a
CALIB_OBJ := $(BUILD)/calibrate/calib_board.o $(BUILD)/calibrate/calib_solve.o $(BUILD)/calibrate/calib_report.o \
	$(BUILD)/calibrate/calib_live.o
MOCAP_CALIBRATE := $(BUILD)/bin/mocap-calibrate
CALIB_TESTS := $(patsubst calibrate/tests/%.cpp,$(BUILD)/calibrate/tests/%,$(wildcard calibrate/tests/test_*.cpp))
CALIB_CV_CFLAGS := $(shell $(PKG_CONFIG) --cflags opencv4 2>/dev/null)
CALIB_CV_LIBS := $(filter -L% -lopencv_aruco -lopencv_calib3d -lopencv_imgcodecs -lopencv_imgproc \
	-lopencv_features2d -lopencv_flann -lopencv_core,$(shell $(PKG_CONFIG) --libs opencv4 2>/dev/null))
# The live collector is a client of mocapd (libmocap) and maps its rings (the core).
CALIB_LINK := $(CALIB_LIB) $(BUILD)/libmocap.a $(CORE_LIB) $(CORE_LIBS) $(CALIB_CV_LIBS) -lstdc++

DEB_PACKAGES += libopencv-contrib-dev
LIBS += $(CALIB_LIB)
BINS += $(MOCAP_CALIBRATE)
TESTS += $(CALIB_TESTS)

$(BUILD)/calibrate/%.o: CPPFLAGS += -Icalibrate $(CALIB_CV_CFLAGS)

$(CALIB_LIB): $(CALIB_OBJ)
	@rm -f $@
	ar rcs $@ $^

# It prints MC_VERSION (--version).
$(BUILD)/calibrate/mocap-calibrate.o: $(INSTALL_PATHS_H)

$(MOCAP_CALIBRATE): $(BUILD)/calibrate/mocap-calibrate.o $(CALIB_LIB) $(BUILD)/libmocap.a $(CORE_LIB)
	@mkdir -p $(@D)
	$(CXX) $(CXXFLAGS) $< -o $@ $(LDFLAGS) $(CALIB_LINK)

# The tests render boards through known cameras and calibrate them; the
# end-to-end part runs the program.
$(BUILD)/calibrate/tests/%: $(BUILD)/calibrate/tests/%.o $(CALIB_LIB) $(BUILD)/libmocap.a $(CORE_LIB) | $(MOCAP_CALIBRATE)
	@mkdir -p $(@D) $(BUILD)/tests
	$(CXX) $(CXXFLAGS) $< -o $@ $(LDFLAGS) $(CALIB_LINK)

$(BUILD)/calibrate/tests/%.o: CPPFLAGS += -Itests

# The live test runs mocapd and its files driver.
$(BUILD)/calibrate/tests/test_calibrate_live: | $(BUILD)/bin/mocapd $(BUILD)/drivers/mocap-driver-files.so
