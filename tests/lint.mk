# The include rule of core/ (core/README.md), checked over the #include
# lines; then on a copy of core/ with one upward include planted, which the
# script must reject (so the check itself is known to work).
CHECKS += check-includes
.PHONY: check-includes
check-includes:
	tests/lint/check-includes.sh .
	@rm -rf $(BUILD)/lint && mkdir -p $(BUILD)/lint && cp -r core $(BUILD)/lint/
	@echo '#include "track/mc_tracker.h"' >> $(BUILD)/lint/core/base/mc_math.h
	@if tests/lint/check-includes.sh $(BUILD)/lint >$(BUILD)/lint/out.txt 2>&1; then \
		echo "check-includes: a planted upward include was not caught"; exit 1; fi
	@grep -q 'core/base includes "track/mc_tracker.h"' $(BUILD)/lint/out.txt && \
		echo "check-includes: a planted upward include is caught"
