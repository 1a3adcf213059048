# tests/soak: the soak test of mocapd (issue 20): two sim cameras and a
# fault-injecting one, watching, slow, killed and churning clients, status
# and reloads, for SOAK_S seconds; per-minute RSS, fds, threads and frame
# counts, then a verdict (tests/soak/soak.c says which).
#
#   make soak          SOAK_S=3600 by default; not part of CI
#   make soak-check    the same program for 2 minutes, part of make check
#
# Run from the repository root (it plays tests/data/sim/walk_131_01_4s.bvh).

SOAK_S ?= 3600
SOAK := $(BUILD)/tests/soak/soak
SOAK_DEPS := $(BUILD)/bin/mocapd $(BUILD)/drivers/mocap-driver-sim.so $(BUILD)/tests/faulty/mocap-driver-faulty.so

CHECKS += soak-check
all: $(SOAK)

$(SOAK): tests/soak/soak.c $(BUILD)/libmocap.a
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(BUILD)/libmocap.a -lm

.PHONY: soak soak-check
soak: $(SOAK) $(SOAK_DEPS)
	$(SOAK) $(SOAK_S)

# 2 minutes; RSS growth measured after the first 30 s.
soak-check: $(SOAK) $(SOAK_DEPS)
	$(SOAK) 120
