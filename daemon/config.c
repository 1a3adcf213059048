#include "config.h"

#include "log.h"

#include <ctype.h>
#include <errno.h>
#include <ini.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef MOCAPD_PLUGIN_DIR
#define MOCAPD_PLUGIN_DIR "/usr/local/lib/mocapd/drivers"
#endif

/* ---- values ------------------------------------------------------------ */

/* A key of a fixed section: how to parse it and where it goes. */
typedef struct key_def key_def;
typedef int (*value_parser)(const key_def *def, const char *value, void *field, const char *base_dir, char *why,
			    size_t whylen);
struct key_def {
	const char *key;
	value_parser parse;
	size_t offset; /* of the field in the section's struct */
	double lo, hi; /* numeric range */
	size_t cap;    /* string capacity */
};

static int parse_long(const char *value, long long *out)
{
	char *end;
	errno = 0;
	long long v = strtoll(value, &end, 10);
	if (errno || end == value || *end)
		return -1;
	*out = v;
	return 0;
}

static int p_int(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)base_dir;
	long long v;
	if (parse_long(value, &v) == 0 && v >= d->lo && v <= d->hi) {
		*(int *)field = (int)v;
		return 0;
	}
	if (d->lo == 1 && d->hi >= INT32_MAX)
		snprintf(why, n, "expected a positive integer, got '%s'", value);
	else if (d->lo == 0 && d->hi >= INT32_MAX)
		snprintf(why, n, "expected a non-negative integer, got '%s'", value);
	else
		snprintf(why, n, "expected an integer from %.0f to %.0f, got '%s'", d->lo, d->hi, value);
	return -1;
}

static int p_seed(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)d, (void)base_dir;
	long long v;
	if (parse_long(value, &v) == 0 && v >= 0) {
		*(long long *)field = v;
		return 0;
	}
	snprintf(why, n, "expected a non-negative integer, got '%s'", value);
	return -1;
}

static int p_double(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)base_dir;
	char *end;
	errno = 0;
	double v = strtod(value, &end);
	if (!errno && end != value && !*end && isfinite(v) && v >= d->lo && v <= d->hi) {
		*(double *)field = v;
		return 0;
	}
	if (d->lo == 0 && d->hi > 1e300)
		snprintf(why, n, "expected a non-negative number, got '%s'", value);
	else if (d->hi > 1e300)
		snprintf(why, n, "expected a number of at least %g, got '%s'", d->lo, value);
	else
		snprintf(why, n, "expected a number from %g to %g, got '%s'", d->lo, d->hi, value);
	return -1;
}

/* A strictly positive number; lo is the smallest allowed value. */
static int p_positive(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	if (p_double(d, value, field, base_dir, why, n) == 0 && *(double *)field > 0)
		return 0;
	snprintf(why, n, "expected a positive number, got '%s'", value);
	return -1;
}

static int p_bool(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)d, (void)base_dir;
	static const char *const yes[] = {"true", "yes", "on", "1"}, *const no[] = {"false", "no", "off", "0"};
	for (int i = 0; i < 4; i++) {
		if (strcasecmp(value, yes[i]) == 0) {
			*(bool *)field = true;
			return 0;
		}
		if (strcasecmp(value, no[i]) == 0) {
			*(bool *)field = false;
			return 0;
		}
	}
	snprintf(why, n, "expected true or false, got '%s'", value);
	return -1;
}

static int p_string(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)base_dir;
	if (!*value) {
		snprintf(why, n, "expected a value, got nothing");
		return -1;
	}
	if (strlen(value) >= d->cap) {
		snprintf(why, n, "too long (at most %zu bytes)", d->cap - 1);
		return -1;
	}
	memcpy(field, value, strlen(value) + 1);
	return 0;
}

/* A name made of letters, digits, '_' and '-' (driver names become file
 * names, so nothing else may get in). */
static int p_name(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	for (const char *c = value; *c; c++)
		if (!isalnum((unsigned char)*c) && *c != '_' && *c != '-') {
			snprintf(why, n, "expected a name of letters, digits, '_' and '-', got '%s'", value);
			return -1;
		}
	return p_string(d, value, field, base_dir, why, n);
}

/* A path; a relative one is taken relative to the config file's directory,
 * so that a config works from any working directory (systemd starts the
 * daemon in /). */
static int p_path(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	if (!*value) {
		snprintf(why, n, "expected a path, got nothing");
		return -1;
	}
	char buf[PATH_MAX];
	int len;
	if (value[0] == '/' || !base_dir || !*base_dir || strcmp(base_dir, ".") == 0)
		len = snprintf(buf, sizeof(buf), "%s", value);
	else
		len = snprintf(buf, sizeof(buf), "%s/%s", base_dir, value);
	if (len < 0 || (size_t)len >= d->cap) {
		snprintf(why, n, "path too long (at most %zu bytes)", d->cap - 1);
		return -1;
	}
	memcpy(field, buf, (size_t)len + 1);
	return 0;
}

static int p_log_level(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)d, (void)base_dir;
	int level = mcd_log_parse_level(value);
	if (level < 0) {
		snprintf(why, n, "expected error, warn, info or debug, got '%s'", value);
		return -1;
	}
	*(int *)field = level;
	return 0;
}

static int p_backend(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)d, (void)base_dir;
	if (strcmp(value, "opencl") == 0)
		*(int *)field = 0; /* MC_BACKEND_OPENCL */
	else if (strcmp(value, "reference") == 0)
		*(int *)field = 1; /* MC_BACKEND_REFERENCE */
	else {
		snprintf(why, n, "expected opencl or reference, got '%s'", value);
		return -1;
	}
	return 0;
}

static int p_rig_format(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)d, (void)base_dir;
	if (strcmp(value, "json") == 0)
		*(mcd_rig_format *)field = MCD_RIG_JSON;
	else if (strcmp(value, "ego-calib") == 0)
		*(mcd_rig_format *)field = MCD_RIG_EGO_CALIB;
	else {
		snprintf(why, n, "expected json or ego-calib, got '%s'", value);
		return -1;
	}
	return 0;
}

/* "auto" (-1) or an index. */
static int p_cl_index(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)d, (void)base_dir;
	long long v;
	if (strcmp(value, "auto") == 0)
		*(int *)field = -1;
	else if (parse_long(value, &v) == 0 && v >= 0 && v < 64)
		*(int *)field = (int)v;
	else {
		snprintf(why, n, "expected auto or an index from 0 to 63, got '%s'", value);
		return -1;
	}
	return 0;
}

static int p_mode(const key_def *d, const char *value, void *field, const char *base_dir, char *why, size_t n)
{
	(void)d, (void)base_dir;
	char *end;
	errno = 0;
	unsigned long v = strtoul(value, &end, 8);
	if (errno || end == value || *end || v > 0777 || value[0] != '0') {
		snprintf(why, n, "expected an octal mode such as 0660, got '%s'", value);
		return -1;
	}
	*(unsigned *)field = (unsigned)v;
	return 0;
}

/* ---- sections ---------------------------------------------------------- */

#define BIG 1e308
#define F(type, member) offsetof(type, member)

static const key_def daemon_keys[] = {
	{"plugin_dir", p_path, F(mcd_config, plugin_dir), 0, 0, PATH_MAX},
	{"log_level", p_log_level, F(mcd_config, log_level), 0, 0, 0},
	{"print", p_bool, F(mcd_config, print), 0, 0, 0},
	{"group_tolerance_ms", p_double, F(mcd_config, group_tolerance_ms), 0, 1000, 0},
	{"group_deadline_ms", p_positive, F(mcd_config, group_deadline_ms), 0, 10000, 0},
	{"reopen_initial_ms", p_positive, F(mcd_config, reopen_initial_ms), 0, 600000, 0},
	{"reopen_max_ms", p_positive, F(mcd_config, reopen_max_ms), 0, 3600000, 0},
	{"stall_timeout_ms", p_positive, F(mcd_config, stall_timeout_ms), 0, 600000, 0},
	{"status_interval_s", p_positive, F(mcd_config, status_interval_s), 0, 3600, 0},
	{"stats_log_interval_s", p_double, F(mcd_config, stats_log_interval_s), 0, 86400, 0},
	{NULL, NULL, 0, 0, 0, 0},
};

static const key_def tracker_keys[] = {
	{"enabled", p_bool, F(mcd_tracker_config, enabled), 0, 0, 0},
	{"rig", p_path, F(mcd_tracker_config, rig), 0, 0, PATH_MAX},
	{"rig_format", p_rig_format, F(mcd_tracker_config, rig_format), 0, 0, 0},
	{"rig_ocam", p_bool, F(mcd_tracker_config, rig_ocam), 0, 0, 0},
	{"model", p_path, F(mcd_tracker_config, model), 0, 0, PATH_MAX},
	{"init_joints", p_path, F(mcd_tracker_config, init_joints), 0, 0, PATH_MAX},
	{"calibrate_colors", p_bool, F(mcd_tracker_config, calibrate_colors), 0, 0, 0},
	{"backend", p_backend, F(mcd_tracker_config, backend), 0, 0, 0},
	{"width", p_int, F(mcd_tracker_config, width), 1, 8192, 0},
	{"height", p_int, F(mcd_tracker_config, height), 1, 8192, 0},
	{"iterations", p_int, F(mcd_tracker_config, iterations), 1, INT32_MAX, 0},
	{"pixel_fraction", p_positive, F(mcd_tracker_config, pixel_fraction), 0, 1, 0},
	{"dropout", p_double, F(mcd_tracker_config, dropout), 0, 0.99, 0},
	{"step", p_positive, F(mcd_tracker_config, step), 0, BIG, 0},
	{"momentum", p_double, F(mcd_tracker_config, momentum), 0, 0.999, 0},
	{"lambda_detection", p_double, F(mcd_tracker_config, lambda_detection), 0, 1000, 0},
	{"lambda_smooth", p_double, F(mcd_tracker_config, lambda_smooth), 0, 1000, 0},
	{"opencl_platform", p_cl_index, F(mcd_tracker_config, cl_platform), 0, 0, 0},
	{"opencl_device", p_cl_index, F(mcd_tracker_config, cl_device), 0, 0, 0},
	{"seed", p_seed, F(mcd_tracker_config, seed), 0, 0, 0},
	{NULL, NULL, 0, 0, 0, 0},
};

static const key_def socket_keys[] = {
	{"enabled", p_bool, F(mcd_socket_config, enabled), 0, 0, 0},
	{"path", p_path, F(mcd_socket_config, path), 0, 0, 108}, /* sun_path */
	{"group", p_name, F(mcd_socket_config, group), 0, 0, MCD_NAME_MAX},
	{"mode", p_mode, F(mcd_socket_config, mode), 0, 0, 0},
	{"max_clients", p_int, F(mcd_socket_config, max_clients), 1, 1024, 0},
	{NULL, NULL, 0, 0, 0, 0},
};

/* Keys of [camera NAME] the daemon reads itself; all others go to the driver. */
static const key_def camera_keys[] = {
	{"driver", p_name, F(mcd_camera_config, driver), 0, 0, MCD_NAME_MAX},
	{"rig_camera", p_string, F(mcd_camera_config, rig_camera), 0, 0, MCD_NAME_MAX},
	{"ring_slots", p_int, F(mcd_camera_config, ring_slots), 2, 1024, 0},
	{NULL, NULL, 0, 0, 0, 0},
};

void mcd_config_defaults(mcd_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	snprintf(cfg->plugin_dir, sizeof(cfg->plugin_dir), "%s", MOCAPD_PLUGIN_DIR);
	cfg->log_level = MCD_LOG_INFO;
	cfg->group_tolerance_ms = 10;
	cfg->group_deadline_ms = 100;
	cfg->reopen_initial_ms = 250;
	cfg->reopen_max_ms = 10000;
	cfg->stall_timeout_ms = 3000;
	cfg->status_interval_s = 1;
	cfg->stats_log_interval_s = 10;
	mcd_tracker_config *t = &cfg->tracker;
	t->enabled = true;
	t->rig_format = MCD_RIG_JSON;
	t->backend = -1;
	t->width = t->height = t->iterations = -1;
	t->pixel_fraction = t->dropout = t->step = t->momentum = NAN;
	t->lambda_detection = t->lambda_smooth = NAN;
	t->cl_platform = t->cl_device = -2;
	t->seed = -1;
	cfg->socket.enabled = true;
	snprintf(cfg->socket.path, sizeof(cfg->socket.path), "/run/mocapd/mocapd.sock");
	cfg->socket.mode = 0660;
	cfg->socket.max_clients = 64;
}

/* ---- parsing ----------------------------------------------------------- */

typedef enum { SEC_NONE, SEC_DAEMON, SEC_TRACKER, SEC_SOCKET, SEC_CAMERA } section_kind;

typedef struct {
	mcd_config *cfg;
	mc_err *err;
	bool failed;
	const char *origin;
	/* the text being read, line by line */
	const char *text;
	size_t pos;
	int line;
	/* the current section, as seen by the reader */
	section_kind kind;
	char section[MCD_NAME_MAX + 8];
	mcd_camera_config *cam;
	/* headers seen, to catch a section given twice */
	int nheaders;
	struct {
		char name[MCD_NAME_MAX + 8];
		int line;
	} headers[MCD_MAX_CAMERAS + 8];
} parser;

static int fail(parser *p, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int fail(parser *p, const char *fmt, ...)
{
	if (p->failed)
		return 0; /* keep the first error */
	p->failed = true;
	char msg[400];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	mc_err_set(p->err, "%s:%d: %s", p->origin, p->line, msg);
	return 0;
}

static void record_where(mcd_config *cfg, const char *section, const char *key, int line)
{
	int n = cfg->nwhere;
	if (n >= (int)(sizeof(cfg->where) / sizeof(cfg->where[0])))
		return;
	snprintf(cfg->where[n].section, sizeof(cfg->where[n].section), "%s", section);
	snprintf(cfg->where[n].key, sizeof(cfg->where[n].key), "%s", key);
	cfg->where[n].line = line;
	cfg->nwhere = n + 1;
}

static int find_where(const mcd_config *cfg, const char *section, const char *key)
{
	for (int i = 0; i < cfg->nwhere; i++)
		if (strcmp(cfg->where[i].section, section) == 0 && strcmp(cfg->where[i].key, key) == 0)
			return cfg->where[i].line;
	return 0;
}

const char *mcd_config_where(const mcd_config *cfg, const char *section, const char *key, char *buf, size_t cap)
{
	int line = find_where(cfg, section, key);
	if (line > 0)
		snprintf(buf, cap, "%s:%d: [%s] %s", cfg->file, line, section, key);
	else
		snprintf(buf, cap, "%s: [%s] %s", cfg->file, section, key);
	return buf;
}

static bool valid_name(const char *s)
{
	if (!*s)
		return false;
	for (; *s; s++)
		if (!isalnum((unsigned char)*s) && *s != '_' && *s != '-')
			return false;
	return true;
}

static bool valid_driver_key(const char *key)
{
	if (!*key || *key == '.')
		return false;
	for (const char *c = key; *c; c++)
		if (!isalnum((unsigned char)*c) && *c != '_' && *c != '-' && *c != '.')
			return false;
	return true;
}

/* Called by the reader for every "[...]" line. */
static void begin_section(parser *p, const char *name)
{
	for (int i = 0; i < p->nheaders; i++)
		if (strcmp(p->headers[i].name, name) == 0) {
			fail(p, "section [%s] given twice (first at line %d)", name, p->headers[i].line);
			return;
		}
	if (p->nheaders < (int)(sizeof(p->headers) / sizeof(p->headers[0]))) {
		snprintf(p->headers[p->nheaders].name, sizeof(p->headers[0].name), "%s", name);
		p->headers[p->nheaders++].line = p->line;
	}
	snprintf(p->section, sizeof(p->section), "%s", name);
	p->cam = NULL;
	if (strcmp(name, "daemon") == 0)
		p->kind = SEC_DAEMON;
	else if (strcmp(name, "tracker") == 0) {
		p->kind = SEC_TRACKER;
		p->cfg->tracker.line = p->line;
	} else if (strcmp(name, "socket") == 0)
		p->kind = SEC_SOCKET;
	else if (strncmp(name, "camera", 6) == 0 && (name[6] == ' ' || name[6] == 0)) {
		p->kind = SEC_CAMERA;
		const char *cam_name = name + 6;
		while (*cam_name == ' ')
			cam_name++;
		if (!*cam_name) {
			fail(p, "[camera] needs a name: [camera NAME]");
			return;
		}
		if (!valid_name(cam_name) || strlen(cam_name) >= MCD_NAME_MAX) {
			fail(p, "[%s]: a camera name is letters, digits, '_' and '-', at most %d bytes", name,
			     MCD_NAME_MAX - 1);
			return;
		}
		if (p->cfg->ncams >= MCD_MAX_CAMERAS) {
			fail(p, "[%s]: too many cameras (at most %d)", name, MCD_MAX_CAMERAS);
			return;
		}
		mcd_camera_config *cam = &p->cfg->cams[p->cfg->ncams++];
		memset(cam, 0, sizeof(*cam));
		snprintf(cam->name, sizeof(cam->name), "%s", cam_name);
		cam->line = p->line;
		cam->ring_slots = 8;
		p->cam = cam;
	} else {
		p->kind = SEC_NONE;
		fail(p, "unknown section [%s] (expected [daemon], [camera NAME], [tracker] or [socket])", name);
	}
}

/* inih's reader: hands out one line at a time, counting lines and seeing
 * section headers before inih does. */
static char *read_line(char *buf, int cap, void *stream)
{
	parser *p = stream;
	if (p->failed || !p->text[p->pos])
		return NULL;
	const char *start = p->text + p->pos;
	const char *nl = strchr(start, '\n');
	size_t len = nl ? (size_t)(nl - start) + 1 : strlen(start);
	p->pos += len;
	p->line++;
	size_t content = len - (nl ? 1 : 0);
	if (content && start[content - 1] == '\r')
		content--;
	if (content + 2 > (size_t)cap) {
		fail(p, "line too long (at most %d characters)", cap - 2);
		return NULL;
	}
	memcpy(buf, start, content);
	buf[content] = '\n';
	buf[content + 1] = 0;

	const char *s = buf;
	while (*s == ' ' || *s == '\t')
		s++;
	bool blank = *s == '\n' || *s == ';' || *s == '#';
	if (!blank && s != buf) {
		/* inih would read an indented line as the continuation of the
		 * previous value: refuse it rather than misread it. */
		fail(p, "indented line (inih reads it as the continuation of the previous value); remove the "
			"indentation");
		return NULL;
	}
	if (*s == '[') {
		const char *end = strchr(s, ']');
		if (end) {
			char name[MCD_NAME_MAX + 8];
			size_t n = (size_t)(end - s - 1);
			if (n >= sizeof(name)) {
				fail(p, "section name too long");
				return NULL;
			}
			memcpy(name, s + 1, n);
			name[n] = 0;
			begin_section(p, name);
		}
	}
	return buf;
}

static const key_def *find_key(const key_def *table, const char *key)
{
	for (const key_def *d = table; d->key; d++)
		if (strcmp(d->key, key) == 0)
			return d;
	return NULL;
}

static int apply_key(parser *p, const key_def *def, void *base, const char *key, const char *value)
{
	int first = find_where(p->cfg, p->section, key);
	if (first)
		return fail(p, "[%s] %s: given twice (first at line %d)", p->section, key, first);
	char why[300];
	if (def->parse(def, value, (char *)base + def->offset, p->cfg->dir, why, sizeof(why)) != 0)
		return fail(p, "[%s] %s: %s", p->section, key, why);
	record_where(p->cfg, p->section, key, p->line);
	return 1;
}

/* Driver keys that hold a path: "path" and "*_path". */
static bool is_path_key(const char *key)
{
	size_t n = strlen(key);
	return strcmp(key, "path") == 0 || (n > 5 && strcmp(key + n - 5, "_path") == 0);
}

static int camera_key(parser *p, const char *key, const char *value)
{
	mcd_camera_config *cam = p->cam;
	if (!cam)
		return 0; /* the header already failed */
	const key_def *def = find_key(camera_keys, key);
	if (def) {
		int ok = apply_key(p, def, cam, key, value);
		if (ok && strcmp(key, "driver") == 0)
			cam->driver_line = p->line;
		if (ok && strcmp(key, "rig_camera") == 0)
			cam->rig_camera_line = p->line;
		return ok;
	}
	/* A driver key: checked against what the driver reads, at open.  Dots
	 * group keys (ctrl.NAME for camera controls). */
	if (!valid_driver_key(key) || strlen(key) >= MCD_NAME_MAX)
		return fail(p, "[%s] %s: a driver key is letters, digits, '_', '-' and '.'", p->section, key);
	const mcd_kv *dup = mcd_camera_config_find(cam, key);
	if (dup)
		return fail(p, "[%s] %s: given twice (first at line %d)", p->section, key, dup->line);
	if (cam->nkeys >= MCD_MAX_DRIVER_KEYS)
		return fail(p, "[%s] %s: too many driver keys (at most %d)", p->section, key, MCD_MAX_DRIVER_KEYS);
	if (strlen(value) >= MCD_VALUE_MAX)
		return fail(p, "[%s] %s: value too long (at most %d bytes)", p->section, key, MCD_VALUE_MAX - 1);
	mcd_kv *kv = &cam->keys[cam->nkeys++];
	snprintf(kv->key, sizeof(kv->key), "%s", key);
	snprintf(kv->value, sizeof(kv->value), "%s", value);
	if (is_path_key(key)) {
		/* Like the daemon's own paths: relative to the config file. */
		char why[300];
		const key_def def = {key, p_path, 0, 0, 0, sizeof(kv->value)};
		if (p_path(&def, value, kv->value, p->cfg->dir, why, sizeof(why)) != 0)
			return fail(p, "[%s] %s: %s", p->section, key, why);
	}
	kv->line = p->line;
	record_where(p->cfg, p->section, key, p->line);
	return 1;
}

static int on_key(void *user, const char *section, const char *key, const char *value)
{
	parser *p = user;
	(void)section; /* the reader tracks it, with its line */
	if (p->failed)
		return 0;
	const key_def *table = NULL;
	void *base = NULL;
	switch (p->kind) {
	case SEC_NONE:
		if (!p->section[0])
			return fail(p, "%s: key outside any section (start with [daemon])", key);
		return 0; /* unknown section, already reported */
	case SEC_CAMERA:
		return camera_key(p, key, value);
	case SEC_DAEMON:
		table = daemon_keys, base = p->cfg;
		break;
	case SEC_TRACKER:
		table = tracker_keys, base = &p->cfg->tracker;
		break;
	case SEC_SOCKET:
		table = socket_keys, base = &p->cfg->socket;
		break;
	}
	const key_def *def = find_key(table, key);
	if (!def)
		return fail(p, "[%s] %s: unknown key", p->section, key);
	return apply_key(p, def, base, key, value);
}

/* ---- checks across keys ------------------------------------------------ */

static int check_cameras(mcd_config *cfg, mc_err *err)
{
	if (cfg->ncams == 0)
		return mc_err_set(err, "%s: no [camera NAME] section; at least one camera is needed", cfg->file);
	for (int i = 0; i < cfg->ncams; i++) {
		mcd_camera_config *c = &cfg->cams[i];
		for (int j = 0; j < i; j++)
			if (strcmp(cfg->cams[j].name, c->name) == 0)
				return mc_err_set(err, "%s:%d: [camera %s] given twice", cfg->file, c->line, c->name);
		if (!c->driver[0])
			return mc_err_set(err, "%s:%d: [camera %s]: missing key 'driver'", cfg->file, c->line, c->name);
		if (!cfg->tracker.enabled)
			continue;
		if (!c->rig_camera[0])
			return mc_err_set(err,
					  "%s:%d: [camera %s]: missing key 'rig_camera' (which rig camera this is; "
					  "needed while the tracker is enabled)",
					  cfg->file, c->line, c->name);
		for (int j = 0; j < i; j++)
			if (strcmp(cfg->cams[j].rig_camera, c->rig_camera) == 0)
				return mc_err_set(err,
						  "%s:%d: [camera %s] rig_camera: '%s' is already taken by [camera %s] "
						  "(line %d)",
						  cfg->file, c->rig_camera_line, c->name, c->rig_camera,
						  cfg->cams[j].name, cfg->cams[j].rig_camera_line);
	}
	return 0;
}

static int check_tracker(mcd_config *cfg, mc_err *err)
{
	mcd_tracker_config *t = &cfg->tracker;
	if (!t->enabled)
		return 0;
	if (!t->line)
		return mc_err_set(err, "%s: no [tracker] section (give rig and model, or enabled = false)", cfg->file);
	if (!t->rig[0])
		return mc_err_set(err, "%s:%d: [tracker]: missing key 'rig'", cfg->file, t->line);
	if (!t->model[0])
		return mc_err_set(err, "%s:%d: [tracker]: missing key 'model'", cfg->file, t->line);
	return 0;
}

static int check_daemon(mcd_config *cfg, mc_err *err)
{
	if (cfg->reopen_max_ms < cfg->reopen_initial_ms) {
		char where[300];
		return mc_err_set(err, "%s: must be at least reopen_initial_ms (%g)",
				  mcd_config_where(cfg, "daemon", "reopen_max_ms", where, sizeof(where)),
				  cfg->reopen_initial_ms);
	}
	return 0;
}

/* ---- entry points ------------------------------------------------------ */

int mcd_config_parse(const char *text, const char *origin, const char *base_dir, mcd_config *cfg, mc_err *err)
{
	mcd_config_defaults(cfg);
	snprintf(cfg->file, sizeof(cfg->file), "%s", origin);
	snprintf(cfg->dir, sizeof(cfg->dir), "%s", base_dir ? base_dir : ".");
	parser p = {.cfg = cfg, .err = err, .origin = origin, .text = text};
	int rc = ini_parse_stream(read_line, &p, on_key, &p);
	if (p.failed)
		return -1;
	if (rc > 0)
		return mc_err_set(err, "%s:%d: syntax error (expected [section] or key = value)", origin, rc);
	if (rc < 0)
		return mc_err_set(err, "%s: cannot parse (out of memory)", origin);
	if (check_tracker(cfg, err) || check_cameras(cfg, err) || check_daemon(cfg, err))
		return -1;
	return 0;
}

int mcd_config_load(const char *path, mcd_config *cfg, mc_err *err)
{
	FILE *f = fopen(path, "rb");
	if (!f)
		return mc_err_set(err, "%s: cannot open: %s", path, strerror(errno));
	char *text = NULL;
	size_t len = 0, cap = 0;
	char chunk[4096];
	size_t n;
	while ((n = fread(chunk, 1, sizeof(chunk), f)) > 0) {
		if (len + n + 1 > cap) {
			cap = (len + n + 1) * 2;
			char *grown = realloc(text, cap);
			if (!grown) {
				free(text);
				fclose(f);
				return mc_err_set(err, "%s: out of memory", path);
			}
			text = grown;
		}
		memcpy(text + len, chunk, n);
		len += n;
		if (len > (1u << 20)) {
			free(text);
			fclose(f);
			return mc_err_set(err, "%s: larger than 1 MiB; not a mocapd config", path);
		}
	}
	bool bad = ferror(f);
	fclose(f);
	if (bad) {
		free(text);
		return mc_err_set(err, "%s: read error", path);
	}
	if (!text) {
		text = calloc(1, 1);
		if (!text)
			return mc_err_set(err, "%s: out of memory", path);
	}
	text[len] = 0;
	if (strlen(text) != len) {
		free(text);
		return mc_err_set(err, "%s: contains a NUL byte; not a text file", path);
	}
	char dir[PATH_MAX];
	snprintf(dir, sizeof(dir), "%s", path);
	char *slash = strrchr(dir, '/');
	if (slash == dir)
		dir[1] = 0;
	else if (slash)
		*slash = 0;
	else
		snprintf(dir, sizeof(dir), ".");
	int rc = mcd_config_parse(text, path, dir, cfg, err);
	free(text);
	return rc;
}

const mcd_kv *mcd_camera_config_find(const mcd_camera_config *cam, const char *key)
{
	for (int i = 0; i < cam->nkeys; i++)
		if (strcmp(cam->keys[i].key, key) == 0)
			return &cam->keys[i];
	return NULL;
}
