/* drv_common: helpers shared by the driver plugins (v4l2, usb, aravis,
 * libcamera, openni2, files, sim): reading typed values from the camera's config
 * section with clear errors, formatting errors into the caller's buffer, and
 * logging through the host.
 *
 * Every error message starts with the driver's name and names the config key
 * and the offending value, e.g.
 *   "v4l2: config key 'width': expected an integer in [1, 16384], got 'wide'"
 * The host adds the camera's section and the config file in front. */
#ifndef DRV_COMMON_H
#define DRV_COMMON_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "mdrv.h"
#include "base/mc_time.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Formats a message into err (may be NULL) and returns `status`, so that a
 * driver can write `return drv_errf(err, errlen, MDRV_ERR_CONFIG, ...)`. */
int drv_errf(char *err, size_t errlen, int status, const char *fmt, ...)
	__attribute__((format(printf, 4, 5)));

/* Tells the host why open() failed (host->open_status, when it has one)
 * and returns NULL, for `return drv_open_failed(host, rc);`. */
void *drv_open_failed(const mdrv_host *host, int status);

/* Logs through host->log when the host offers one. */
void drv_logf(const mdrv_host *host, int level, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* The value of `key`, or NULL when the key is absent or empty. */
const char *drv_cfg_str(const mdrv_host *host, const char *key);

/* Typed reads.  Each returns MDRV_OK and stores the value (or leaves `*out`
 * untouched when the key is absent), or MDRV_ERR_CONFIG with a message that
 * names the driver, the key, the accepted range and the value given. */
int drv_cfg_uint(const mdrv_host *host, const char *drv, const char *key, unsigned min, unsigned max,
		 unsigned *out, char *err, size_t errlen);
int drv_cfg_double(const mdrv_host *host, const char *drv, const char *key, double min, double max,
		   double *out, char *err, size_t errlen);
int drv_cfg_bool(const mdrv_host *host, const char *drv, const char *key, bool *out, char *err, size_t errlen);
/* Hexadecimal 16-bit id such as a USB vendor ("046d" or "0x046d"). */
int drv_cfg_hex16(const mdrv_host *host, const char *drv, const char *key, uint16_t *out, bool *present,
		  char *err, size_t errlen);

/* A setting that is either "auto" or a number in [min, max]. */
typedef struct {
	bool present; /* the key was given */
	bool is_auto;
	double value;
} drv_auto_value;
int drv_cfg_auto_double(const mdrv_host *host, const char *drv, const char *key, double min, double max,
			drv_auto_value *out, char *err, size_t errlen);

/* One of `names` (case-insensitive); stores its index. */
int drv_cfg_choice(const mdrv_host *host, const char *drv, const char *key, const char *const *names,
		   int n_names, int *out, char *err, size_t errlen);

/* A CLOCK_MONOTONIC time in nanoseconds, digits only (such as the `epoch` of
 * the files and sim drivers); sets *present when the key is given. */
int drv_cfg_monotonic_ns(const mdrv_host *host, const char *drv, const char *key, uint64_t *out, bool *present,
			 char *err, size_t errlen);

/* Copies src into dst (size n), always NUL-terminating; NULL src gives "". */
void drv_strlcpy(char *dst, const char *src, size_t n);

#ifdef __cplusplus
}
#endif

#endif
