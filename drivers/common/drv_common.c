/* drv_common: config, error and logging helpers shared by the hardware
 * driver plugins.  See drv_common.h. */
#include "drv_common.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

int drv_errf(char *err, size_t errlen, int status, const char *fmt, ...)
{
	if (err && errlen) {
		va_list ap;
		va_start(ap, fmt);
		vsnprintf(err, errlen, fmt, ap);
		va_end(ap);
	}
	return status;
}

void *drv_open_failed(const mdrv_host *host, int status)
{
	if (host && host->open_status)
		host->open_status(host->ctx, status);
	return NULL;
}

void drv_logf(const mdrv_host *host, int level, const char *fmt, ...)
{
	if (!host || !host->log)
		return;
	char msg[1024];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(msg, sizeof msg, fmt, ap);
	va_end(ap);
	host->log(host->ctx, level, msg);
}

const char *drv_cfg_str(const mdrv_host *host, const char *key)
{
	if (!host || !host->config_get)
		return NULL;
	const char *v = host->config_get(host->ctx, key);
	return v && *v ? v : NULL;
}

/* The value of `key` as drv_cfg_str() gives it; *present (unless NULL) tells
 * whether there is one. */
static const char *cfg_value(const mdrv_host *host, const char *key, bool *present)
{
	const char *v = drv_cfg_str(host, key);
	if (present)
		*present = v != NULL;
	return v;
}

/* Parses all of `v` as an unsigned integer in `base` (strtoull's syntax, but
 * no minus sign); false if `v` is not one or does not fit. */
static bool parse_unsigned(const char *v, int base, unsigned long long *out)
{
	char *end;
	errno = 0;
	*out = strtoull(v, &end, base);
	return !errno && end != v && !*end && v[0] != '-';
}

int drv_cfg_uint(const mdrv_host *host, const char *drv, const char *key, unsigned min, unsigned max,
		 unsigned *out, char *err, size_t errlen)
{
	const char *v = drv_cfg_str(host, key);
	if (!v)
		return MDRV_OK;
	unsigned long long n;
	if (!parse_unsigned(v, 10, &n) || n < min || n > max)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key '%s': expected an integer in [%u, %u], got '%s'", drv, key, min, max, v);
	*out = (unsigned)n;
	return MDRV_OK;
}

/* Parses a finite number in [min, max]; false if `v` is not one. */
static bool parse_double(const char *v, double min, double max, double *out)
{
	char *end;
	errno = 0;
	double d = strtod(v, &end);
	if (errno || end == v || *end || !isfinite(d) || d < min || d > max)
		return false;
	*out = d;
	return true;
}

int drv_cfg_double(const mdrv_host *host, const char *drv, const char *key, double min, double max,
		   double *out, char *err, size_t errlen)
{
	const char *v = drv_cfg_str(host, key);
	if (!v)
		return MDRV_OK;
	if (!parse_double(v, min, max, out))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key '%s': expected a number in [%g, %g], got '%s'", drv, key, min, max, v);
	return MDRV_OK;
}

int drv_cfg_bool(const mdrv_host *host, const char *drv, const char *key, bool *out, char *err, size_t errlen)
{
	const char *v = drv_cfg_str(host, key);
	if (!v)
		return MDRV_OK;
	static const char *const yes[] = {"true", "yes", "on", "1"};
	static const char *const no[] = {"false", "no", "off", "0"};
	for (size_t i = 0; i < sizeof yes / sizeof yes[0]; i++) {
		if (!strcasecmp(v, yes[i])) {
			*out = true;
			return MDRV_OK;
		}
		if (!strcasecmp(v, no[i])) {
			*out = false;
			return MDRV_OK;
		}
	}
	return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key '%s': expected true or false, got '%s'", drv,
			key, v);
}

int drv_cfg_hex16(const mdrv_host *host, const char *drv, const char *key, uint16_t *out, bool *present,
		  char *err, size_t errlen)
{
	const char *v = cfg_value(host, key, present);
	if (!v)
		return MDRV_OK;
	unsigned long long n;
	if (!parse_unsigned(v, 16, &n) || n > 0xffff)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key '%s': expected a 16-bit hexadecimal id such as 046d, got '%s'", drv,
				key, v);
	*out = (uint16_t)n;
	return MDRV_OK;
}

int drv_cfg_auto_double(const mdrv_host *host, const char *drv, const char *key, double min, double max,
			drv_auto_value *out, char *err, size_t errlen)
{
	const char *v = cfg_value(host, key, &out->present);
	out->is_auto = false;
	if (!v)
		return MDRV_OK;
	if (!strcasecmp(v, "auto")) {
		out->is_auto = true;
		return MDRV_OK;
	}
	if (!parse_double(v, min, max, &out->value))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key '%s': expected 'auto' or a number in [%g, %g], got '%s'", drv, key,
				min, max, v);
	return MDRV_OK;
}

int drv_cfg_choice(const mdrv_host *host, const char *drv, const char *key, const char *const *names,
		   int n_names, int *out, char *err, size_t errlen)
{
	const char *v = drv_cfg_str(host, key);
	if (!v)
		return MDRV_OK;
	for (int i = 0; i < n_names; i++) {
		if (!strcasecmp(v, names[i])) {
			*out = i;
			return MDRV_OK;
		}
	}
	char list[256] = "";
	for (int i = 0; i < n_names; i++) {
		size_t len = strlen(list);
		snprintf(list + len, sizeof list - len, "%s%s", i ? ", " : "", names[i]);
	}
	return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key '%s': expected one of %s, got '%s'", drv, key,
			list, v);
}

int drv_cfg_monotonic_ns(const mdrv_host *host, const char *drv, const char *key, uint64_t *out, bool *present,
			 char *err, size_t errlen)
{
	const char *v = drv_cfg_str(host, key);
	if (!v)
		return MDRV_OK;
	unsigned long long n;
	if (v[0] < '0' || v[0] > '9' || !parse_unsigned(v, 10, &n))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key '%s': expected CLOCK_MONOTONIC nanoseconds, got '%s'", drv, key, v);
	*out = n;
	*present = true;
	return MDRV_OK;
}

void drv_strlcpy(char *dst, const char *src, size_t n)
{
	if (!n)
		return;
	snprintf(dst, n, "%s", src ? src : "");
}
