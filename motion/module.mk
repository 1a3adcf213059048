# motion/: mocap-graph, motion graphs over recorded takes and BVH files
# (docs/MOTION_GRAPH.md).  The database, costs, graphs, graph file and
# synthesis are in the core (core/motion/); this folder adds the takes
# (through the record library), the command line and the tests.

MOTION_LIB := $(BUILD)/libmocapmotion.a
MOTION_OBJ := $(BUILD)/motion/motion_take.o
MOCAP_GRAPH := $(BUILD)/bin/mocap-graph
MOTION_TESTS := $(patsubst motion/tests/%.c,$(BUILD)/motion/tests/%,$(wildcard motion/tests/test_*.c))
MOTION_LINK := $(MOTION_LIB) $(BUILD)/libmocaprecord.a $(CORE_LIB) $(CORE_LIBS) -lz
MOTION_LINK_DEPS := $(MOTION_LIB) $(BUILD)/libmocaprecord.a $(CORE_LIB)

LIBS += $(MOTION_LIB)
BINS += $(MOCAP_GRAPH)
TESTS += $(MOTION_TESTS)

$(BUILD)/motion/%.o: CPPFLAGS += -Imotion -Irecord

$(MOTION_LIB): $(MOTION_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(MOCAP_GRAPH): motion/mocap-graph.c $(MOTION_LINK_DEPS) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Imotion -Irecord $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(MOTION_LINK)

# Unit tests (a synthetic BVH, no shared data) and the data tests (the CMU
# files in ../shared/data, skipped when absent); both run mocap-graph too.
$(BUILD)/motion/tests/%: motion/tests/%.c $(MOTION_LINK_DEPS) | $(MOCAP_GRAPH)
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Imotion -Irecord -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(MOTION_LINK)

# The measurements of docs/BENCHMARKS_SYSTEM.md ("Motion graphs"): tests/bench/graph.sh.
BENCHES += bench-graph
.PHONY: bench-graph
bench-graph: $(MOCAP_GRAPH)
	tests/bench/graph.sh $(BUILD)

# mocapd's graph source end to end: mocapd with [source] graph, a libmocap
# client (its own rule: it links libmocap and needs mocapd built).
$(BUILD)/motion/tests/test_graph_source: motion/tests/test_graph_source.c $(MOTION_LINK_DEPS) $(BUILD)/libmocap.a \
		| $(BUILD)/bin/mocapd
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Imotion -Irecord -Iipc -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(BUILD)/libmocap.a \
		$(MOTION_LINK)
