/* drv_check: checks shared by the driver test programs, on top of
 * drv_harness (the host) and test_util.h (CHECK_MSG and its failure count,
 * which is per program: hence a header and not a function in drv_harness.c). */
#ifndef DRV_CHECK_H
#define DRV_CHECK_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drv_harness.h"
#include "test_util.h"

/* Loads the plugin `name` into h, or prints why not and exits 1. */
static inline void drv_check_load(drv_harness *h, const char *name)
{
	char err[1024];
	if (drv_harness_load(h, name, err, sizeof err) != 0) {
		fprintf(stderr, "%s\n", err);
		exit(1);
	}
}

/* Probes into info (cap entries), checks that probe worked and prints the
 * count as "probe: N <what>"; returns the count. */
static inline int drv_check_probe(drv_harness *h, mdrv_device_info *info, int cap, const char *what)
{
	char err[1024];
	int n = h->drv->probe(&h->host, info, cap, err, sizeof err);
	CHECK_MSG(n >= 0, "probe: %s", err);
	printf("probe: %d %s\n", n, what);
	return n;
}

/* Opens a camera with h's current config and expects it to fail with a
 * message that contains `needle` and starts with `prefix`, the driver's
 * name as its errors give it ("v4l2: "). */
static inline void drv_check_open_error(drv_harness *h, const char *prefix, const char *needle)
{
	char err[1024] = "";
	void *dev = h->drv->open(&h->host, err, sizeof err);
	CHECK_MSG(dev == NULL, "open should fail (%s)", needle);
	if (dev) {
		h->drv->close(dev);
		return;
	}
	printf("  %s\n", err);
	CHECK_MSG(strstr(err, needle) != NULL, "error '%s' should mention '%s'", err, needle);
	CHECK_MSG(strncmp(err, prefix, strlen(prefix)) == 0, "error '%s' should name the driver", err);
}

/* A config that opening must refuse: up to four keys as key, value pairs
 * (the unused ones NULL) on an empty section, and a fragment of the error. */
typedef struct {
	const char *kv[8];
	const char *needle;
} drv_bad_config;

/* drv_check_open_error() for each of the n configs in turn. */
static inline void drv_check_open_errors(drv_harness *h, const char *prefix, const drv_bad_config *bad, size_t n)
{
	for (size_t i = 0; i < n; i++) {
		drv_harness_clear(h);
		for (size_t k = 0; k < 8 && bad[i].kv[k]; k += 2)
			drv_harness_set(h, bad[i].kv[k], bad[i].kv[k + 1]);
		drv_check_open_error(h, prefix, bad[i].needle);
	}
}

#endif
