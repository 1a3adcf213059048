# mocapd: the one build entry.  See README.md.
#
#   make            build everything into $(BUILD)/
#   make check      unit and integration tests, then again under ASan+UBSan
#   make bench      benchmarks (print their figures)
#   make install    PREFIX=/usr/local LIBDIR=$(PREFIX)/lib SYSCONFDIR=/etc DESTDIR=
#   make uninstall  the same variables
#   make deps       install the Debian packages the build and tests need (root)
#
# BUILD selects the output folder, so that several builds (e.g. SAN=1) can
# live side by side.  Component folders add their own rules in module.mk
# files, included below; they append to BINS, LIBS, PLUGINS, CHECKS, BENCHES.

PREFIX ?= /usr/local
DESTDIR ?=
# Where the installed files go; the programs carry these paths (compiled in
# through $(BUILD)/gen/mc_install_paths.h, rewritten whenever they change).
LIBDIR ?= $(PREFIX)/lib
DATADIR ?= $(PREFIX)/share
SYSCONFDIR ?= /etc
BUILD ?= build
SAN ?= 0
INSTALL_PATHS_H := $(BUILD)/gen/mc_install_paths.h

CC ?= cc
CXX ?= c++
PKG_CONFIG ?= pkg-config

# Packages the core and the tools link against.
CORE_PKGS := jansson libpng OpenCL libturbojpeg

OPT := -O2
ifeq ($(SAN),1)
  OPT := -O1
  SANFLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
endif

CPPFLAGS := -D_GNU_SOURCE -Icore -Idrivers -Iipc -I$(BUILD)/gen
CFLAGS := -std=c11 -Wall -Wextra -Werror -g $(OPT) -fPIC -pthread $(SANFLAGS) \
	$(shell $(PKG_CONFIG) --cflags $(CORE_PKGS) 2>/dev/null)
CXXFLAGS := -std=c++17 -Wall -Wextra -Werror -g $(OPT) -fPIC -pthread $(SANFLAGS)
LDFLAGS := -pthread $(SANFLAGS)
CORE_LIBS := $(shell $(PKG_CONFIG) --libs $(CORE_PKGS) 2>/dev/null) -lm

CORE_SRC := $(wildcard core/*/*.c)
CORE_OBJ := $(CORE_SRC:%.c=$(BUILD)/%.o) $(BUILD)/gen/mc_cl_embed.o
CORE_LIB := $(BUILD)/libmocapcore.a
CL_SRC := $(wildcard core/energy/cl/*.cl)

TEST_SRC := $(wildcard tests/test_*.c)
TESTS := $(TEST_SRC:tests/%.c=$(BUILD)/tests/%)
TOOL_SRC := $(wildcard tools/*.c)
TOOLS := $(TOOL_SRC:tools/%.c=$(BUILD)/bin/%)

BINS :=
LIBS :=
PLUGINS :=
CHECKS :=
BENCHES :=

.PHONY: all check check-unit check-san bench install uninstall deps deps-train clean
all:

-include $(sort $(wildcard */module.mk) $(wildcard drivers/*/module.mk) $(wildcard tests/*/module.mk))

# The OpenCL energy kernel alone: evaluations per second at several pixel counts.
BENCHES += bench-cl
.PHONY: bench-cl
bench-cl: $(BUILD)/tests/bench_cl_energy
	$(BUILD)/tests/bench_cl_energy

# The tracker on every evaluation clip (../shared/data/ego/*): accuracy and speed.
DATA_DIR ?= ../shared/data
BENCHES += bench-tracker
.PHONY: bench-tracker
bench-tracker: $(BUILD)/bin/mocap-bench
	@if [ -d $(DATA_DIR)/ego ]; then \
		for c in $(DATA_DIR)/ego/*/; do $(BUILD)/bin/mocap-bench --clip $$c --quiet || exit 1; done; \
	else echo "bench-tracker: $(DATA_DIR)/ego not found, skipped"; fi

# The tracker's accuracy over seeds 1-10 on every clip (ego and outside-in):
# each clip's mean MPJPE and its standard error, for judging a tracker
# change against the seed-to-seed spread (docs/BENCHMARKS.md).
BENCHES += bench-tracker-seeds
.PHONY: bench-tracker-seeds
bench-tracker-seeds: $(BUILD)/bin/mocap-bench
	DATA_DIR=$(DATA_DIR) tests/bench/tracker_seeds.sh -n 10 -j 2 -b $(BUILD)/bin/mocap-bench

# The shipped detector inside the protocol on every evaluation clip: 2D
# error and cost, and the tracker's MPJPE and fps with detection, with and
# without the colour term, and started from the detections alone (--init
# detect, nothing from gt.json) (docs/BENCHMARKS.md, docs/DETECTOR.md); then
# the offline model when it ships, side by side.
DETECTOR_MODEL ?= $(wildcard config/models/ego_detector.onnx)
DETECTOR_OFFLINE_MODEL ?= $(wildcard config/models/ego_offline_detector.onnx)
BENCHES += bench-detector
.PHONY: bench-detector
bench-detector: $(BUILD)/bin/mocap-bench
	@if [ -z "$(DETECTOR_MODEL)" ]; then echo "bench-detector: no config/models/ego_detector.onnx, skipped"; \
	elif [ -d $(DATA_DIR)/ego ]; then \
		for c in $(DATA_DIR)/ego/*/; do \
			$(BUILD)/bin/mocap-bench --clip $$c --detector $(DETECTOR_MODEL) --quiet --no-thesis || exit 1; \
			$(BUILD)/bin/mocap-bench --clip $$c --detector $(DETECTOR_MODEL) --lambda-color 0 --quiet \
				--no-thesis --reference-frames 0 | grep -E '^(RESULT|DETECT2D)' | sed 's/^/no colour term: /' || exit 1; \
			$(BUILD)/bin/mocap-bench --clip $$c --detector $(DETECTOR_MODEL) --init detect --quiet --no-thesis \
				--reference-frames 0 | grep -E '^(RESULT|BONES|init from)' | sed 's/^/--init detect: /' || exit 1; \
			if [ -n "$(DETECTOR_OFFLINE_MODEL)" ]; then \
				$(BUILD)/bin/mocap-bench --clip $$c --detector $(DETECTOR_OFFLINE_MODEL) --quiet --no-thesis \
					--reference-frames 0 | grep -E '^(RESULT|DETECT2D|JITTER|LIMBS)' | sed 's/^/offline model: /' \
					|| exit 1; fi; \
		done; \
	else echo "bench-detector: $(DATA_DIR)/ego not found, skipped"; fi

# The held-out clips that `make eval-clips` renders (other motions, builds,
# garments and scenes than the dev clips, some with a bystander): the shipped
# detectors beside the tracker, seeds 1-3 (docs/BENCHMARKS.md, "Held-out clips").
EVAL_CLIPS_DIR ?= $(BUILD)/clips
OUTSIDE_DETECTOR ?= $(firstword $(wildcard config/models/outside_detector.onnx))
BENCHES += bench-heldout
.PHONY: bench-heldout
bench-heldout: $(BUILD)/bin/mocap-bench
	@if [ -z "$(DETECTOR_MODEL)" ] || [ -z "$(OUTSIDE_DETECTOR)" ]; then \
		echo "bench-heldout: no shipped detector in config/models, skipped"; \
	else tests/bench/tracker_seeds.sh -n 3 -j 1 -b $(BUILD)/bin/mocap-bench -d $(EVAL_CLIPS_DIR)/ego -- \
			--detector $(DETECTOR_MODEL) && \
		tests/bench/tracker_seeds.sh -n 3 -j 1 -b $(BUILD)/bin/mocap-bench -d $(EVAL_CLIPS_DIR)/outside -- \
			--detector $(OUTSIDE_DETECTOR); fi

# Outside-in clips (shared/data/outside): every clip with all four cameras,
# with two neighbouring cameras (90 degrees apart) and with two opposite
# ones, from colour alone and, when the outside-in detector ships, with it
# (docs/BENCHMARKS_TRACKING.md, "Outside-in").
BENCHES += bench-outside
.PHONY: bench-outside
bench-outside: $(BUILD)/bin/mocap-bench
	@if [ -d $(DATA_DIR)/outside ]; then \
		for c in $(DATA_DIR)/outside/*/; do for cams in 0,1,2,3 0,1 2,3 0,2; do \
			$(BUILD)/bin/mocap-bench --clip $$c --cameras $$cams --quiet --no-thesis --reference-frames 0 \
				| grep -E '^RESULT' || exit 1; \
			if [ -n "$(OUTSIDE_DETECTOR)" ]; then \
				$(BUILD)/bin/mocap-bench --clip $$c --cameras $$cams --detector $(OUTSIDE_DETECTOR) --quiet \
					--no-thesis --reference-frames 0 | grep -E '^(RESULT|DETECT2D)' | sed 's/^/detector: /' || exit 1; \
			fi; \
		done; done; \
	else echo "bench-outside: $(DATA_DIR)/outside not found, skipped"; fi

all: $(CORE_LIB) $(TESTS) $(TOOLS) $(BINS) $(LIBS) $(PLUGINS)

$(BUILD)/%.o: %.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/%.o: %.cpp
	@mkdir -p $(@D)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -MMD -MP -c $< -o $@

# OpenCL kernels are embedded in the binary: each core/energy/cl/NAME.cl becomes
# `const unsigned char mc_cl_NAME[]` plus `mc_cl_NAME_len`.
$(BUILD)/gen/mc_cl_embed.c: $(CL_SRC) Makefile
	@mkdir -p $(@D)
	@echo "/* generated from the kernels in core/energy/cl by the Makefile */" > $@.tmp
	@for f in $(CL_SRC); do n=$$(basename $$f .cl); \
		xxd -i -n mc_cl_$$n $$f | sed 's/^unsigned/const unsigned/' >> $@.tmp; done
	@mv $@.tmp $@

$(BUILD)/gen/mc_cl_embed.o: $(BUILD)/gen/mc_cl_embed.c
	$(CC) $(CFLAGS) -c $< -o $@

# The install paths the programs carry.  Rewritten only when a path
# changes, so that `make install PREFIX=/usr` after a plain `make` rebuilds
# exactly what carries them (their objects depend on this file).
.PHONY: FORCE
$(INSTALL_PATHS_H): FORCE
	@mkdir -p $(@D)
	@printf '%s\n' '/* generated by the Makefile: the install paths and version of this build */' \
		'#define MC_VERSION "$(MOCAPD_VERSION)"' \
		'#define MC_INSTALL_PLUGIN_DIR "$(LIBDIR)/mocapd/drivers"' \
		'#define MC_INSTALL_DATA_DIR "$(DATADIR)/mocapd"' \
		'#define MC_INSTALL_SYSCONF_DIR "$(SYSCONFDIR)/mocapd"' > $@.tmp
	@if cmp -s $@.tmp $@; then rm -f $@.tmp; else mv $@.tmp $@; fi

$(CORE_LIB): $(CORE_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(BUILD)/tests/%: tests/%.c $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(CORE_LIB) $(CORE_LIBS)

$(BUILD)/bin/%: tools/%.c $(CORE_LIB) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(CORE_LIB) $(CORE_LIBS)

# mocap-bench links the detector runtime (detect/, C++ behind a C header)
# and its own helpers in tools/bench/.  Literal paths: detect/module.mk's
# variables are read later than this rule's prerequisites would need.  The
# include flags are on the objects and the recipe only: a target-specific
# variable on the program would leak into the core objects it builds.
BENCH_TOOL_OBJ := $(patsubst tools/bench/%.c,$(BUILD)/tools/bench/%.o,$(wildcard tools/bench/*.c))
$(BUILD)/tools/bench/%.o: CPPFLAGS += -Idetect -Itools
# options.c prints the version and the installed data folder.
$(BUILD)/tools/bench/options.o: $(INSTALL_PATHS_H)
$(BUILD)/bin/mocap-bench: tools/mocap-bench.c $(BENCH_TOOL_OBJ) $(BUILD)/libmocapdetect.a $(CORE_LIB) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Idetect -Itools $(CFLAGS) -MMD -MP $< $(BENCH_TOOL_OBJ) -o $@ $(LDFLAGS) $(BUILD)/libmocapdetect.a $(CORE_LIB) \
		$(CORE_LIBS) $(DETECT_LIBS)

# Unit tests: every $(BUILD)/tests/test_* program (exit 0 pass, 77 skip).
check-unit: all
	tests/run-tests.sh $(BUILD) $(TESTS)

check-san:
	$(MAKE) SAN=1 BUILD=$(BUILD)-san check-unit

# make install into a temporary PREFIX, the installed programs run from
# there, make uninstall (tests/install-test.sh; its own BUILD folder).
# Every program's -h, --version and a bad option (tests/cli-test.sh; the
# install test runs it on the installed programs too).
CHECKS += check-cli
.PHONY: check-cli
check-cli: $(BINS) $(TOOLS)
	MOCAP_BUILD=$(BUILD) tests/run-tests.sh $(BUILD) tests/cli-test.sh

# Programs run from the build tree find its plugins and files (tests/tree-test.sh).
CHECKS += check-tree
.PHONY: check-tree
check-tree: $(BINS) $(PLUGINS)
	MOCAP_BUILD=$(BUILD) tests/run-tests.sh $(BUILD) tests/tree-test.sh

CHECKS += check-install
.PHONY: check-install
check-install:
	tests/run-tests.sh $(BUILD) tests/install-test.sh

check: check-unit $(CHECKS)
	$(MAKE) check-san

bench: all $(BENCHES)

# What is installed: the programs, libraries and plugins, not the tests.
INSTALLED := $(TOOLS) $(BINS) $(LIBS) $(PLUGINS)
install: $(INSTALLED)
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(LIBDIR)/mocapd/drivers \
		$(DESTDIR)$(DATADIR)/mocapd/models $(DESTDIR)$(DATADIR)/mocapd/rigs
	install -m 755 $(TOOLS) $(BINS) $(DESTDIR)$(PREFIX)/bin/
	$(if $(PLUGINS),install -m 755 $(PLUGINS) $(DESTDIR)$(LIBDIR)/mocapd/drivers/)
	install -m 644 config/models/*.json $(DESTDIR)$(DATADIR)/mocapd/models/
	install -m 644 config/rigs/*.json $(DESTDIR)$(DATADIR)/mocapd/rigs/
	@# The linker's cache learns the new libmocap.so.1 only from ldconfig:
	@# without it, programs built against the installed libmocap fail to
	@# load it.  Not for staged installs (DESTDIR: packages run it).
	@if [ -n "$(DESTDIR)" ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v ldconfig >/dev/null; then ldconfig && echo "ldconfig: done"; \
	else echo "make install: run 'sudo ldconfig' so that programs find $(LIBDIR)/libmocap.so.1"; fi
	@case ":$$(ldconfig -v 2>/dev/null | sed -n 's/^\([^ \t]*\):.*/\1/p' | tr '\n' ':'):" in \
	*":$(LIBDIR):"*) ;; \
	*) [ -n "$(DESTDIR)" ] || echo "make install: $(LIBDIR) is not in the linker's search path: build against it with -Wl,-rpath,$(LIBDIR) or add it to /etc/ld.so.conf.d/";; esac

# Removes what `make install` put there, with the same variables (the
# config in $(SYSCONFDIR)/mocapd is kept: it may hold the user's changes).
uninstall:
	rm -f $(addprefix $(DESTDIR)$(PREFIX)/bin/,$(notdir $(TOOLS) $(BINS)))
	rm -rf $(DESTDIR)$(LIBDIR)/mocapd $(DESTDIR)$(DATADIR)/mocapd

# Every Debian package the build, the tests and the benchmarks need
# (component folders add their own in their module.mk: DEB_PACKAGES +=).
DEB_PACKAGES += build-essential pkg-config xxd clang llvm libclang-rt-14-dev \
	libjansson-dev libinih-dev libpng-dev libjpeg62-turbo-dev libturbojpeg0-dev \
	libsystemd-dev systemd ocl-icd-opencl-dev opencl-headers pocl-opencl-icd clinfo \
	libaravis-dev aravis-tools aravis-tools-cli v4l-utils libusb-1.0-0-dev libcamera-dev libopenni2-dev \
	qemu-system-x86 linux-image-amd64 busybox-static kmod cpio udev python3 python3-pytest python3-venv python3-pip scdoc \
	libopencv-dev liblo-dev libavformat-dev libavcodec-dev libavutil-dev zlib1g-dev dpkg-dev debhelper dh-python fakeroot lintian

# Only for generating detector training data and training it (docs/DETECTOR.md).
DEB_TRAIN_PACKAGES := blender python3-torch python3-numpy python3-pil python3-opencv python3-onnx

deps:
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $(DEB_PACKAGES)

deps-train:
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $(DEB_TRAIN_PACKAGES)
	# npm, for `make models-movenet`: Debian's, unless a Node.js with its own npm is there.
	command -v npm >/dev/null 2>&1 || DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends nodejs npm

clean:
	rm -rf build build-*

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
