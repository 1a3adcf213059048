# The output filter ([output] filter = one_euro, docs/CONFIG.md) on the
# tracker's real poses: mocap-bench tracks each evaluation clip with the
# shipped detector of the clip's rig (DETECTOR_MODEL or OUTSIDE_DETECTOR,
# the Makefile's), as mocapd runs, and writes its estimates (named by rig: the two
# folders hold clips of the same names); bench_filter filters them as
# mocapd's publishing thread does and prints the raw and filtered MPJPE,
# velocity error, acceleration against the truth's and the error of a
# prediction 40 ms ahead (BENCHES).
BENCH_FILTER := $(BUILD)/tests/bench_filter

BENCHES += bench-filter
.PHONY: bench-filter
bench-filter: $(BUILD)/bin/mocap-bench $(BENCH_FILTER)
	@clips="$$(ls -d $(DATA_DIR)/ego/*/ $(DATA_DIR)/outside/*/ 2>/dev/null)"; \
	if [ -z "$$clips" ]; then echo "bench-filter: no clips in $(DATA_DIR)/ego or $(DATA_DIR)/outside, skipped"; exit 0; fi; \
	if [ -z "$(DETECTOR_MODEL)" ] || [ -z "$(OUTSIDE_DETECTOR)" ]; then \
		echo "bench-filter: no shipped detector in config/models, skipped"; exit 0; fi; \
	for c in $$clips; do n=$$(basename $$(dirname $$c))-$$(basename $$c); \
		case $$c in */outside/*) det=$(OUTSIDE_DETECTOR);; *) det=$(DETECTOR_MODEL);; esac; \
		$(BUILD)/bin/mocap-bench --clip $$c --quiet --no-thesis --reference-frames 0 --detector $$det \
			--out $(BUILD)/bench-filter-$$n.jsonl | grep '^RESULT' || exit 1; \
		$(BENCH_FILTER) $$c $(BUILD)/bench-filter-$$n.jsonl || exit 1; \
	done
