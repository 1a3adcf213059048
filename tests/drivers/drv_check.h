/* drv_check: checks shared by the driver test programs, on top of
 * drv_harness (the host) and test_util.h (CHECK_MSG and its failure count,
 * which is per program: hence a header and not a function in drv_harness.c). */
#ifndef DRV_CHECK_H
#define DRV_CHECK_H

#include <stdio.h>
#include <string.h>

#include "drv_harness.h"
#include "test_util.h"

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

#endif
