# Frame ring extras:
#   check-ring-tsan  test_ring built and run under ThreadSanitizer (CHECKS)
#   bench-ring       two 1280x1024 YUYV cameras at 60 fps (BENCHES)

# Clang's TSan also sees races inside memcpy that GCC's inlining hides.
RING_TSAN_CC ?= $(shell command -v clang >/dev/null 2>&1 && echo clang || echo $(CC))
RING_TSAN_TEST := $(BUILD)/tsan/test_ring
RING_BENCH := $(BUILD)/tests/bench_ring
BENCH_RING_SECONDS ?= 5

# Only the ring and its error module: no need to rebuild the whole core
# with another compiler and sanitizer.
$(RING_TSAN_TEST): tests/test_ring.c tests/test_util.h core/ring/mc_ring.c core/ring/mc_ring.h core/base/mc_error.c core/base/mc_error.h
	@mkdir -p $(@D)
	$(RING_TSAN_CC) -std=c11 -Wall -Wextra -Werror -D_GNU_SOURCE -Icore -g -O1 -fsanitize=thread -pthread \
		tests/test_ring.c core/ring/mc_ring.c core/base/mc_error.c -o $@

.PHONY: check-ring-tsan bench-ring
check-ring-tsan: $(RING_TSAN_TEST)
	TSAN_OPTIONS="halt_on_error=1 exitcode=66 $(TSAN_OPTIONS)" $(RING_TSAN_TEST)

$(RING_BENCH): tests/bench_ring.c $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(CORE_LIB) $(CORE_LIBS)

bench-ring: $(RING_BENCH)
	$(RING_BENCH) $(BENCH_RING_SECONDS)

CHECKS += check-ring-tsan
BENCHES += bench-ring
