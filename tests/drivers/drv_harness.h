/* drv_harness: loads a driver plugin (mocap-driver-NAME.so) with dlopen, as
 * the daemon does, and offers it a host whose config section is a small
 * key/value table the test fills in.  Log messages from the driver go to
 * stderr and are kept, so that a test can check what was logged.
 *
 * The plugin folder is $MOCAP_DRIVER_DIR, else <exe dir>/../../drivers (the
 * layout of $(BUILD)/tests/drivers/test_* and $(BUILD)/drivers/). */
#ifndef DRV_HARNESS_H
#define DRV_HARNESS_H

#include <pthread.h>
#include <stddef.h>

#include "mdrv.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DRV_HARNESS_MAX_KEYS 32

typedef struct {
	void *dl;
	const mdrv_driver *drv;
	mdrv_host host;
	char keys[DRV_HARNESS_MAX_KEYS][64];
	char vals[DRV_HARNESS_MAX_KEYS][512];
	int n_keys;
	pthread_mutex_t log_lock;
	char log[16384]; /* every message, one a line (truncated when full) */
	int quiet;       /* 1: do not echo log messages to stderr */
} drv_harness;

/* Loads the plugin `name` ("v4l2", "aravis", ...). 0 or -1 with err. */
int drv_harness_load(drv_harness *h, const char *name, char *err, size_t errlen);
void drv_harness_unload(drv_harness *h);

/* Sets (or with val NULL removes) a config key. */
void drv_harness_set(drv_harness *h, const char *key, const char *val);
void drv_harness_clear(drv_harness *h);

/* 1 if `needle` occurs in the log so far. */
int drv_harness_logged(drv_harness *h, const char *needle);

/* Opens and starts a camera with the current config; NULL with err. */
void *drv_harness_open_start(drv_harness *h, char *err, size_t errlen);

/* Pulls one frame into a buffer of `cap` bytes; returns the status. */
int drv_harness_frame(drv_harness *h, void *dev, mdrv_frame *f, void *buf, size_t cap, int timeout_ms, char *err,
		      size_t errlen);

/* The time of CLOCK_MONOTONIC now, in ns. */
unsigned long long drv_harness_now_ns(void);

#ifdef __cplusplus
}
#endif

#endif
