# tests/fuzz/: libFuzzer targets for every file format mocapd reads (issue
# 20), beside the protocol's (fuzz-ipc, in ipc/module.mk):
#
#   config   the INI config (daemon/config.c, mcd_config_parse)
#   rig      the rig JSON (mc_rig_parse)
#   model    the body-model JSON (mc_model_parse)
#   calib    the evaluation data's calib.json (mc_rig_import_ego_calib)
#   cameras  the outside-in cameras.json (mc_rig_import_cameras_json)
#   ocam     OCamCalib's calib_results.txt (mc_rig_import_ocamcalib)
#   bvh      BVH motion (mc_bvh_parse)
#   image    JPEG, PNG and PPM/PGM frames (mc_image_decode)
#   take     a take's record files (record/take.c: take_poses_load, frame
#            records as mocap-export --frames reads them)
#   graph    the motion-graph file (mc_graph_load)
#
# Each is built with $(FUZZ_CC) (clang) with ASan and UBSan, against the
# core and the config code compiled again with the same sanitizers and
# libFuzzer's coverage instrumentation (into $(PFUZZ)/obj).  Seeds live in
# tests/fuzz/seeds/NAME, dictionaries in tests/fuzz/dict/NAME.dict; what a
# run adds to the corpus stays in $(PFUZZ)/NAME/corpus.
#
#   make fuzz-parsers        each target for $(FUZZ_SECONDS) s (60; in make check)
#   make fuzz-parser-NAME    one of them
#   make fuzz-long           each, and the protocol's, for $(FUZZ_LONG_RUNS)
#                            executions (10^7; hours: not in CI)
#
# A finding stops the run with the end of the log; the input is saved as
# $(PFUZZ)/NAME/crash-* (leak-*, timeout-*, oom-*): replay it with
# `$(PFUZZ)/fuzz_NAME FILE`.

FUZZ_CC ?= clang
FUZZ_SECONDS ?= 60
FUZZ_LONG_RUNS ?= 10000000
# Inputs up to 64 KiB; an input that takes over 25 s is a finding (a hang).
FUZZ_PARSER_OPTS ?= -max_len=65536 -timeout=25

PFUZZ := $(BUILD)/fuzz/parsers
PFUZZ_NAMES := config rig model calib cameras ocam bvh image take graph
PFUZZ_BINS := $(PFUZZ_NAMES:%=$(PFUZZ)/fuzz_%)
PFUZZ_SAN := -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer
PFUZZ_CPPFLAGS := -D_GNU_SOURCE -Icore -Idaemon -Irecord -Itests/fuzz -I$(BUILD)/gen \
	-DMOCAPD_PLUGIN_DIR='"$(MOCAPD_PLUGIN_DIR)"' -DMOCAPD_VERSION='"$(MOCAPD_VERSION)"' \
	$(shell $(PKG_CONFIG) --cflags $(CORE_PKGS) inih 2>/dev/null)
PFUZZ_CFLAGS := -std=c11 -Wall -Wextra -Werror -g -O1 $(PFUZZ_SAN)
PFUZZ_LIBS := $(CORE_LIBS) $(shell $(PKG_CONFIG) --libs inih 2>/dev/null) -lz

# The code under test: every core object (the archive links only what a
# target uses) and the config parser with its key table and logger.
PFUZZ_CORE := $(PFUZZ)/libcore.a
PFUZZ_CORE_OBJ := $(CORE_SRC:%.c=$(PFUZZ)/obj/%.o)
PFUZZ_CONFIG_OBJ := $(PFUZZ)/obj/daemon/config.o $(PFUZZ)/obj/daemon/config_keys.o $(PFUZZ)/obj/daemon/config_suggest.o \
	$(PFUZZ)/obj/daemon/log.o

$(PFUZZ)/obj/%.o: %.c
	@mkdir -p $(@D)
	$(FUZZ_CC) $(PFUZZ_CPPFLAGS) $(PFUZZ_CFLAGS) -fsanitize=fuzzer-no-link -MMD -MP -c $< -o $@

$(PFUZZ_CORE): $(PFUZZ_CORE_OBJ) $(PFUZZ)/obj/gen/mc_cl_embed.o
	@rm -f $@
	ar rcs $@ $^

$(PFUZZ)/obj/gen/mc_cl_embed.o: $(BUILD)/gen/mc_cl_embed.c
	@mkdir -p $(@D)
	$(FUZZ_CC) $(PFUZZ_CFLAGS) -c $< -o $@

$(PFUZZ)/fuzz_config: $(PFUZZ_CONFIG_OBJ)
$(PFUZZ)/fuzz_take: $(PFUZZ)/obj/record/take.o $(PFUZZ)/obj/record/take_info.o $(PFUZZ)/obj/record/take_bvh.o
$(PFUZZ_BINS): $(PFUZZ)/fuzz_%: $(PFUZZ)/obj/tests/fuzz/fuzz_%.o $(PFUZZ)/obj/tests/fuzz/fuzz_util.o $(PFUZZ_CORE)
	$(FUZZ_CC) $(PFUZZ_SAN) -fsanitize=fuzzer $(filter %.o,$^) $(PFUZZ_CORE) -o $@ $(PFUZZ_LIBS) -lm

.PHONY: fuzz-parsers fuzz-long $(PFUZZ_NAMES:%=fuzz-parser-%) $(PFUZZ_NAMES:%=fuzz-long-%)
CHECKS += fuzz-parsers

fuzz-parsers: $(PFUZZ_NAMES:%=fuzz-parser-%)

$(PFUZZ_NAMES:%=fuzz-parser-%): fuzz-parser-%: $(PFUZZ)/fuzz_%
	@tests/fuzz/run-fuzzer.sh $* $< tests/fuzz/seeds/$* $(PFUZZ)/$* $(FUZZ_PARSER_OPTS) \
		-max_total_time=$(FUZZ_SECONDS)

# Not in CI: at a few thousand executions a second, hours per target.
fuzz-long: $(PFUZZ_NAMES:%=fuzz-long-%) fuzz-long-ipc

$(PFUZZ_NAMES:%=fuzz-long-%): fuzz-long-%: $(PFUZZ)/fuzz_%
	@tests/fuzz/run-fuzzer.sh $* $< tests/fuzz/seeds/$* $(PFUZZ)/$* $(FUZZ_PARSER_OPTS) -runs=$(FUZZ_LONG_RUNS)

# The protocol's target (ipc/module.mk) with its generated seeds.
.PHONY: fuzz-long-ipc
fuzz-long-ipc: $(BUILD)/fuzz/fuzz_ipc $(BUILD)/fuzz/fuzz_ipc_seeds
	@rm -rf $(BUILD)/fuzz/ipc-long/seeds && mkdir -p $(BUILD)/fuzz/ipc-long/seeds
	@$(BUILD)/fuzz/fuzz_ipc_seeds $(BUILD)/fuzz/ipc-long/seeds
	@tests/fuzz/run-fuzzer.sh ipc $(BUILD)/fuzz/fuzz_ipc $(BUILD)/fuzz/ipc-long/seeds $(BUILD)/fuzz/ipc-long \
		-max_len=65536 -runs=$(FUZZ_LONG_RUNS)
