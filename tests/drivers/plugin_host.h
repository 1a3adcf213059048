/* plugin_host: a minimal host for the single-file plugin tests
 * tests/test_driver_files.c and tests/test_driver_sim.c.  The top Makefile
 * links each tests/test_*.c alone, so they cannot link drv_harness.c; this
 * header gives them the same few pieces: a key/value config section, the
 * plugin loaded with dlopen as the daemon loads it, and open/start, pull and
 * open-must-fail helpers that leave the driver's message in `err`.  A config
 * carries the host its camera is opened with, which must outlive the camera.
 *
 * The plugin is found in $MOCAP_DRIVER_DIR, else in <this program's
 * folder>/../drivers (the layout of $(BUILD)/tests and $(BUILD)/drivers).
 * Include after test_util.h. */
#ifndef PLUGIN_HOST_H
#define PLUGIN_HOST_H

#include <dlfcn.h>
#include <libgen.h>
#include <limits.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "mdrv.h"
#include "base/mc_time.h"

typedef struct {
	const char *keys[16];
	char vals[16][PATH_MAX];
	int n;
	mdrv_host host; /* set by open_start() */
} config;

static const mdrv_driver *drv; /* the plugin under test */
static char err[512];           /* the driver's last message */

static inline const char *cfg_get(void *ctx, const char *key)
{
	config *c = ctx;
	for (int i = 0; i < c->n; i++)
		if (strcmp(c->keys[i], key) == 0)
			return c->vals[i];
	return NULL;
}

static inline void cfg_log(void *ctx, int level, const char *msg)
{
	(void)ctx;
	printf("driver log [%d]: %s\n", level, msg);
}

/* Sets `key` (a string that outlives c) to a copy of val. */
static inline void cfg_set(config *c, const char *key, const char *val)
{
	for (int i = 0; i < c->n; i++)
		if (strcmp(c->keys[i], key) == 0) {
			snprintf(c->vals[i], sizeof(c->vals[i]), "%s", val);
			return;
		}
	c->keys[c->n] = key;
	snprintf(c->vals[c->n++], sizeof(c->vals[0]), "%s", val);
}

/* cfg_set() for each key, value pair of a list that ends in NULL. */
static inline __attribute__((sentinel)) void cfg_setv(config *c, ...)
{
	va_list ap;
	va_start(ap, c);
	for (const char *key; (key = va_arg(ap, const char *)) != NULL;)
		cfg_set(c, key, va_arg(ap, const char *));
	va_end(ap);
}

static inline mdrv_host host_for(config *c) { return (mdrv_host){.ctx = c, .config_get = cfg_get, .log = cfg_log}; }

/* Loads mocap-driver-NAME.so; NULL when it cannot be loaded. */
static inline const mdrv_driver *load_plugin(const char *name, void **dl)
{
	char dir[PATH_MAX], path[PATH_MAX + 64];
	const char *env = getenv("MOCAP_DRIVER_DIR");
	if (env) {
		snprintf(dir, sizeof(dir), "%s", env);
	} else {
		char exe[PATH_MAX];
		ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
		if (n <= 0)
			return NULL;
		exe[n] = 0;
		snprintf(dir, sizeof(dir), "%s/../drivers", dirname(exe));
	}
	snprintf(path, sizeof(path), "%s/mocap-driver-%s.so", dir, name);
	*dl = dlopen(path, RTLD_NOW | RTLD_LOCAL);
	if (!*dl) {
		fprintf(stderr, "dlopen: %s\n", dlerror());
		return NULL;
	}
	mdrv_entry_fn entry = (mdrv_entry_fn)dlsym(*dl, MDRV_ENTRY_SYMBOL);
	return entry ? entry() : NULL;
}

/* Opens and starts with config c (and its host); NULL (err set) on failure. */
static inline void *open_start(config *c)
{
	c->host = host_for(c);
	void *dev = drv->open(&c->host, err, sizeof(err));
	if (dev && drv->start(dev, err, sizeof(err)) != MDRV_OK) {
		drv->close(dev);
		return NULL;
	}
	return dev;
}

/* open_start(), checking that it opened and, when fmt is not NULL, that
 * get_format() gives the format into *fmt. */
static inline void *open_checked(config *c, mdrv_format *fmt)
{
	void *dev = open_start(c);
	CHECK_MSG(dev != NULL, "%s", err);
	if (dev && fmt)
		CHECK(drv->get_format(dev, fmt, err, sizeof(err)) == MDRV_OK);
	return dev;
}

/* Pulls one frame into buf (cap bytes); returns the driver's status. */
static inline int pull(void *dev, mdrv_frame *f, uint8_t *buf, size_t cap, int timeout_ms)
{
	memset(f, 0, sizeof(*f));
	f->data = buf;
	f->capacity = cap;
	return drv->next_frame(dev, f, timeout_ms, err, sizeof(err));
}

/* Opening with config c must fail with a message containing needle. */
static inline void expect_open_fails(config *c, const char *needle)
{
	mdrv_host h = host_for(c);
	void *dev = drv->open(&h, err, sizeof(err));
	CHECK_MSG(dev == NULL, "open succeeded, expected '%s'", needle);
	CHECK_MSG(strstr(err, needle) != NULL, "'%s' lacks '%s'", err, needle);
	if (dev)
		drv->close(dev);
}

#endif
