/* config_keys: the table of the daemon's own config keys and what it
 * drives: value parsing and validation, the defaults, formatting, and the
 * reload (which keys a reload applies).  The INI reading is in config.c. */
#include "config.h"

#include "log.h"
#include "motion/mc_motion_graph.h" /* MC_EDGE_ESSENTIAL, MC_EDGE_MOTION */

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mc_install_paths.h" /* generated: MC_INSTALL_PLUGIN_DIR follows LIBDIR at make install */

/* Enum keys are stored as int. */
_Static_assert(sizeof(mc_backend) == sizeof(int), "mc_backend is stored as an int");
_Static_assert(sizeof(mcd_rig_format) == sizeof(int), "mcd_rig_format is stored as an int");

/* ---- the table ------------------------------------------------------------ */

static const mcd_key_choice log_levels[] = {
	{"error", MCD_LOG_ERROR, false}, {"warn", MCD_LOG_WARN, false},    {"info", MCD_LOG_INFO, false},
	{"debug", MCD_LOG_DEBUG, false}, {"warning", MCD_LOG_WARN, true}, {NULL, 0, false},
};
static const mcd_key_choice rig_formats[] = {
	{"json", MCD_RIG_JSON, false}, {"ego-calib", MCD_RIG_EGO_CALIB, false},
	{"cameras-json", MCD_RIG_CAMERAS_JSON, false}, {NULL, 0, false}};
static const mcd_key_choice graph_kinds[] = {
	{"essential", MC_EDGE_ESSENTIAL, false}, {"motion", MC_EDGE_MOTION, false}, {NULL, 0, false}};
static const mcd_key_choice filters[] = {
	{"none", MCD_FILTER_NONE, false}, {"one_euro", MCD_FILTER_ONE_EURO, false}, {NULL, 0, false}};
static const mcd_key_choice detector_hints[] = {
	{"none", MCD_HINT_NONE, false}, {"pose", MCD_HINT_POSE, false}, {NULL, 0, false}};
static const mcd_key_choice backends[] = {
	{"opencl", MC_BACKEND_OPENCL, false}, {"reference", MC_BACKEND_REFERENCE, false}, {NULL, 0, false}};

#define BIG 1e308
#define FIELD(type, member) offsetof(type, member), sizeof(((type *)0)->member)
#define D(member) FIELD(mcd_config, member)
#define T(member) FIELD(mcd_config, tracker.member)
#define S(member) FIELD(mcd_config, socket.member)
#define C(member) FIELD(mcd_camera_config, member)
#define K(member) FIELD(mcd_config, detector.member)
#define N(member) FIELD(mcd_config, network.member)
#define R(member) FIELD(mcd_config, record.member)
#define G(member) FIELD(mcd_config, source.member)
#define O(member) FIELD(mcd_config, output.member)
#define TRACKER_DEFAULT NULL /* mc_tracker_settings_default */

static const mcd_config_key keys[] = {
	/* section, key, type, field, lo, hi, choices, default, reload */
	{MCD_SEC_DAEMON, "plugin_dir", MCD_KEY_PATH, D(plugin_dir), 0, 0, NULL, MC_INSTALL_PLUGIN_DIR, false},
	{MCD_SEC_DAEMON, "log_level", MCD_KEY_ENUM, D(log_level), 0, 0, log_levels, "info", true},
	{MCD_SEC_DAEMON, "print", MCD_KEY_BOOL, D(print), 0, 0, NULL, "false", true},
	{MCD_SEC_DAEMON, "group_tolerance_ms", MCD_KEY_REAL, D(group_tolerance_ms), 0, 1000, NULL, "10", true},
	{MCD_SEC_DAEMON, "group_deadline_ms", MCD_KEY_POSITIVE, D(group_deadline_ms), 0, 10000, NULL, "100", true},
	{MCD_SEC_DAEMON, "max_frame_age_ms", MCD_KEY_REAL, D(max_frame_age_ms), 0, 60000, NULL, "0", true},
	{MCD_SEC_DAEMON, "reopen_initial_ms", MCD_KEY_POSITIVE, D(reopen_initial_ms), 0, 600000, NULL, "250", true},
	{MCD_SEC_DAEMON, "reopen_max_ms", MCD_KEY_POSITIVE, D(reopen_max_ms), 0, 3600000, NULL, "10000", true},
	{MCD_SEC_DAEMON, "stall_timeout_ms", MCD_KEY_POSITIVE, D(stall_timeout_ms), 0, 600000, NULL, "3000", true},
	{MCD_SEC_DAEMON, "status_interval_s", MCD_KEY_POSITIVE, D(status_interval_s), 0, 3600, NULL, "1", true},
	{MCD_SEC_DAEMON, "stats_log_interval_s", MCD_KEY_REAL, D(stats_log_interval_s), 0, 86400, NULL, "10", true},
	{MCD_SEC_DAEMON, "offline", MCD_KEY_BOOL, D(offline), 0, 0, NULL, "false", false},

	{MCD_SEC_CAMERA, "driver", MCD_KEY_NAME, C(driver), 0, 0, NULL, NULL, false},
	{MCD_SEC_CAMERA, "rig_camera", MCD_KEY_STRING, C(rig_camera), 0, 0, NULL, NULL, false},
	{MCD_SEC_CAMERA, "ring_slots", MCD_KEY_INT, C(ring_slots), 2, 1024, NULL, "8", false},

	{MCD_SEC_TRACKER, "enabled", MCD_KEY_BOOL, T(enabled), 0, 0, NULL, "true", false},
	{MCD_SEC_TRACKER, "rig", MCD_KEY_PATH, T(rig), 0, 0, NULL, NULL, false},
	{MCD_SEC_TRACKER, "rig_format", MCD_KEY_ENUM, T(rig_format), 0, 0, rig_formats, "json", false},
	{MCD_SEC_TRACKER, "rig_ocam", MCD_KEY_BOOL, T(rig_ocam), 0, 0, NULL, "false", false},
	{MCD_SEC_TRACKER, "model", MCD_KEY_PATH, T(model), 0, 0, NULL, NULL, false},
	{MCD_SEC_TRACKER, "init_joints", MCD_KEY_PATH, T(init_joints), 0, 0, NULL, NULL, false},
	{MCD_SEC_TRACKER, "pose_prior", MCD_KEY_OPT_PATH, T(pose_prior), 0, 0, NULL, NULL, false},
	{MCD_SEC_TRACKER, "actor", MCD_KEY_PATH, T(actor), 0, 0, NULL, NULL, false},
	{MCD_SEC_TRACKER, "actor_dir", MCD_KEY_PATH, T(actor_dir), 0, 0, NULL, "/var/lib/mocapd/actors", true},
	{MCD_SEC_TRACKER, "calibrate_colors", MCD_KEY_BOOL, T(calibrate_colors), 0, 0, NULL, "false", false},
	{MCD_SEC_TRACKER, "recover", MCD_KEY_BOOL, T(settings.recover), 0, 0, NULL, "true", false},
	{MCD_SEC_TRACKER, "ray_fit", MCD_KEY_BOOL, T(settings.ray_fit), 0, 0, NULL, "true", false},
	{MCD_SEC_TRACKER, "backend", MCD_KEY_ENUM, T(settings.backend), 0, 0, backends, TRACKER_DEFAULT, false},
	{MCD_SEC_TRACKER, "width", MCD_KEY_INT, T(settings.width), 1, 8192, NULL, TRACKER_DEFAULT, false},
	{MCD_SEC_TRACKER, "height", MCD_KEY_INT, T(settings.height), 1, 8192, NULL, TRACKER_DEFAULT, false},
	/* The budget keys: mc_tracker_set_budget changes them on a running tracker. */
	{MCD_SEC_TRACKER, "iterations", MCD_KEY_INT, T(settings.iterations), 1, INT32_MAX, NULL, TRACKER_DEFAULT, true},
	{MCD_SEC_TRACKER, "pixel_fraction", MCD_KEY_POSITIVE, T(settings.pixel_fraction), 0, 1, NULL, TRACKER_DEFAULT,
	 true},
	{MCD_SEC_TRACKER, "dropout", MCD_KEY_REAL, T(settings.dropout), 0, 0.99, NULL, TRACKER_DEFAULT, true},
	{MCD_SEC_TRACKER, "step", MCD_KEY_POSITIVE, T(settings.step), 0, BIG, NULL, TRACKER_DEFAULT, true},
	{MCD_SEC_TRACKER, "momentum", MCD_KEY_REAL, T(settings.momentum), 0, 0.999, NULL, TRACKER_DEFAULT, true},
	{MCD_SEC_TRACKER, "lambda_detection", MCD_KEY_REAL, T(settings.lambda_detection), 0, 1000, NULL,
	 TRACKER_DEFAULT, false},
	{MCD_SEC_TRACKER, "detection_trust_max", MCD_KEY_REAL, T(settings.detection_trust_max), 1, 100, NULL,
	 TRACKER_DEFAULT, false},
	{MCD_SEC_TRACKER, "color_sight_cut", MCD_KEY_REAL, T(settings.color_sight_cut), 0, 1, NULL, TRACKER_DEFAULT,
	 false},
	{MCD_SEC_TRACKER, "lambda_smooth", MCD_KEY_REAL, T(settings.lambda_smooth), 0, 1000, NULL, TRACKER_DEFAULT,
	 false},
	{MCD_SEC_TRACKER, "lambda_floor", MCD_KEY_REAL, T(settings.lambda_floor), 0, 1000, NULL, TRACKER_DEFAULT,
	 false},
	{MCD_SEC_TRACKER, "lambda_prior", MCD_KEY_REAL, T(settings.lambda_prior), 0, 1000, NULL, TRACKER_DEFAULT,
	 false},
	{MCD_SEC_TRACKER, "opencl_platform", MCD_KEY_CL_INDEX, T(settings.cl_platform), 0, 0, NULL, TRACKER_DEFAULT,
	 false},
	{MCD_SEC_TRACKER, "opencl_device", MCD_KEY_CL_INDEX, T(settings.cl_device), 0, 0, NULL, TRACKER_DEFAULT, false},
	{MCD_SEC_TRACKER, "seed", MCD_KEY_U64, T(settings.seed), 0, 0, NULL, TRACKER_DEFAULT, false},

	{MCD_SEC_SOCKET, "enabled", MCD_KEY_BOOL, S(enabled), 0, 0, NULL, "true", false},
	{MCD_SEC_SOCKET, "path", MCD_KEY_PATH, S(path), 0, 108 /* sun_path */, NULL, "/run/mocapd/mocapd.sock",
	 false},
	{MCD_SEC_SOCKET, "group", MCD_KEY_NAME, S(group), 0, 0, NULL, NULL, false},
	{MCD_SEC_SOCKET, "mode", MCD_KEY_MODE, S(mode), 0, 0, NULL, "0660", false},
	{MCD_SEC_SOCKET, "max_clients", MCD_KEY_INT, S(max_clients), 1, 1024, NULL, "64", false},

	/* Off unless listen is given; then token_file is required (config.c). */
	{MCD_SEC_NETWORK, "listen", MCD_KEY_HOST_PORT, N(listen), 0, 0, NULL, NULL, false},
	{MCD_SEC_NETWORK, "token_file", MCD_KEY_OPT_PATH, N(token_file), 0, 0, NULL, NULL, false},
	{MCD_SEC_NETWORK, "privileged", MCD_KEY_BOOL, N(privileged), 0, 0, NULL, "false", false},

	/* Read when a take starts: a reload changes the next take. */
	{MCD_SEC_RECORD, "directory", MCD_KEY_PATH, R(directory), 0, 0, NULL, "/var/lib/mocapd/takes", false},
	{MCD_SEC_RECORD, "frames", MCD_KEY_BOOL, R(frames), 0, 0, NULL, "true", false},
	{MCD_SEC_RECORD, "max_seconds", MCD_KEY_REAL, R(max_seconds), 0, 1e7, NULL, "0", false},
	{MCD_SEC_RECORD, "max_mb", MCD_KEY_REAL, R(max_mb), 0, 1e9, NULL, "0", false},
	{MCD_SEC_RECORD, "sync_ms", MCD_KEY_REAL, R(sync_ms), 0, 10000, NULL, "100", false},

	{MCD_SEC_SOURCE, "graph", MCD_KEY_OPT_PATH, G(graph), 0, 0, NULL, NULL, false},
	{MCD_SEC_SOURCE, "graph_kind", MCD_KEY_ENUM, G(kind), 0, 0, graph_kinds, "essential", false},
	{MCD_SEC_SOURCE, "rate", MCD_KEY_POSITIVE, G(rate), 0, 1000, NULL, "30", false},
	{MCD_SEC_SOURCE, "seed", MCD_KEY_INT, G(seed), 0, 2147483647, NULL, "1", false},

	/* A new model and nice take a restart; the rest is applied between detections. */
	{MCD_SEC_DETECTOR, "model", MCD_KEY_OPT_PATH, K(model), 0, 0, NULL, NULL, false},
	{MCD_SEC_DETECTOR, "rate", MCD_KEY_REAL, K(rate), 0, 1000, NULL, "0", true},
	{MCD_SEC_DETECTOR, "threads", MCD_KEY_INT, K(threads), 1, 64, NULL, "1", true},
	{MCD_SEC_DETECTOR, "min_confidence", MCD_KEY_REAL_AUTO, K(min_confidence), 0, 1, NULL, "auto", true},
	{MCD_SEC_DETECTOR, "nice", MCD_KEY_INT, K(nice), 0, 19, NULL, "10", false},
	{MCD_SEC_DETECTOR, "hint", MCD_KEY_ENUM, K(hint), 0, 0, detector_hints, "none", false},
	{MCD_SEC_DETECTOR, "flip", MCD_KEY_BOOL, K(flip), 0, 0, NULL, "false", true},

	/* The publishing thread takes a new filter between two skeletons (and
	 * starts it again), so all of these reload. */
	{MCD_SEC_OUTPUT, "filter", MCD_KEY_ENUM, O(filter), 0, 0, filters, "none", true},
	{MCD_SEC_OUTPUT, "filter_min_cutoff_hz", MCD_KEY_POSITIVE, O(min_cutoff_hz), 0, 1000, NULL, "1", true},
	{MCD_SEC_OUTPUT, "filter_beta", MCD_KEY_REAL, O(beta), 0, 1000, NULL, "8", true},
	{MCD_SEC_OUTPUT, "filter_d_cutoff_hz", MCD_KEY_POSITIVE, O(d_cutoff_hz), 0, 1000, NULL, "1", true},
	{MCD_SEC_OUTPUT, "filter_max_gap_ms", MCD_KEY_POSITIVE, O(max_gap_ms), 0, 10000, NULL, "200", true},
};

const mcd_config_key *mcd_config_keys(size_t *n)
{
	*n = sizeof(keys) / sizeof(keys[0]);
	return keys;
}

const mcd_config_key *mcd_config_key_find(mcd_section section, const char *key)
{
	for (size_t i = 0; i < sizeof(keys) / sizeof(keys[0]); i++)
		if (keys[i].section == section && strcmp(keys[i].key, key) == 0)
			return &keys[i];
	return NULL;
}

const char *mcd_section_name(mcd_section section)
{
	static const char *const names[MCD_NSECTIONS] = {"daemon", "camera", "tracker", "socket", "detector", "network",
								 "record", "source", "output"};
	return (unsigned)section < MCD_NSECTIONS ? names[section] : "?";
}

/* ---- parsing values ---------------------------------------------------------- */

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

static int p_int(const mcd_config_key *k, const char *value, void *field, char *why, size_t n)
{
	long long v;
	if (parse_long(value, &v) == 0 && v >= k->lo && v <= k->hi) {
		*(int *)field = (int)v;
		return 0;
	}
	if (k->lo == 1 && k->hi >= INT32_MAX)
		snprintf(why, n, "expected a positive integer, got '%s'", value);
	else if (k->lo == 0 && k->hi >= INT32_MAX)
		snprintf(why, n, "expected a non-negative integer, got '%s'", value);
	else
		snprintf(why, n, "expected an integer from %.0f to %.0f, got '%s'", k->lo, k->hi, value);
	return -1;
}

static int p_u64(const char *value, void *field, char *why, size_t n)
{
	long long v;
	if (parse_long(value, &v) == 0 && v >= 0) {
		*(uint64_t *)field = (uint64_t)v;
		return 0;
	}
	snprintf(why, n, "expected a non-negative integer, got '%s'", value);
	return -1;
}

static int p_real(const mcd_config_key *k, const char *value, void *field, char *why, size_t n)
{
	char *end;
	errno = 0;
	double v = strtod(value, &end);
	if (!errno && end != value && !*end && isfinite(v) && v >= k->lo && v <= k->hi) {
		*(double *)field = v;
		return 0;
	}
	if (k->lo == 0 && k->hi > 1e300)
		snprintf(why, n, "expected a non-negative number, got '%s'", value);
	else if (k->hi > 1e300)
		snprintf(why, n, "expected a number of at least %g, got '%s'", k->lo, value);
	else
		snprintf(why, n, "expected a number from %g to %g, got '%s'", k->lo, k->hi, value);
	return -1;
}

/* A strictly positive number up to hi; the message names hi when the
 * table bounds the key, so that a value too large is not told "positive". */
static int p_positive(const mcd_config_key *k, const char *value, void *field, char *why, size_t n)
{
	double v;
	if (p_real(k, value, &v, why, n) == 0 && v > 0) {
		*(double *)field = v;
		return 0;
	}
	if (k->hi > 1e300)
		snprintf(why, n, "expected a positive number, got '%s'", value);
	else
		snprintf(why, n, "expected a number above 0 and at most %g, got '%s'", k->hi, value);
	return -1;
}

static int p_bool(const char *value, void *field, char *why, size_t n)
{
	static const char *const yes[] = {"true", "yes", "on", "1"}, *const no[] = {"false", "no", "off", "0"};
	for (int i = 0; i < 4; i++) {
		if (strcasecmp(value, yes[i]) == 0 || strcasecmp(value, no[i]) == 0) {
			*(bool *)field = strcasecmp(value, yes[i]) == 0;
			return 0;
		}
	}
	snprintf(why, n, "expected true or false, got '%s'", value);
	return -1;
}

static int p_string(const mcd_config_key *k, const char *value, void *field, char *why, size_t n)
{
	if (!*value) {
		snprintf(why, n, "expected a value, got nothing");
		return -1;
	}
	if (strlen(value) >= k->size) {
		snprintf(why, n, "too long (at most %zu bytes)", k->size - 1);
		return -1;
	}
	memcpy(field, value, strlen(value) + 1);
	return 0;
}

/* "HOST:PORT" or "[IPV6]:PORT"; the host is resolved when the daemon
 * starts its listener. */
static int p_host_port(const mcd_config_key *k, const char *value, void *field, char *why, size_t n)
{
	const char *colon = strrchr(value, ':');
	bool bracketed = value[0] == '[' && colon && colon > value && colon[-1] == ']';
	bool ok = colon && colon > value && colon[1] && strlen(colon + 1) <= 5 &&
		  (bracketed || !memchr(value, ':', (size_t)(colon - value)));
	for (const char *c = colon ? colon + 1 : ""; ok && *c; c++)
		ok = isdigit((unsigned char)*c);
	if (!ok || atoi(colon + 1) > 65535) {
		snprintf(why, n, "expected HOST:PORT (e.g. 0.0.0.0:7878, [::]:7878), got '%s'", value);
		return -1;
	}
	return p_string(k, value, field, why, n);
}

/* A name made of letters, digits, '_' and '-' (driver names become file
 * names, so nothing else may get in). */
static int p_name(const mcd_config_key *k, const char *value, void *field, char *why, size_t n)
{
	for (const char *c = value; *c; c++)
		if (!isalnum((unsigned char)*c) && *c != '_' && *c != '-') {
			snprintf(why, n, "expected a name of letters, digits, '_' and '-', got '%s'", value);
			return -1;
		}
	return p_string(k, value, field, why, n);
}

/* A path; a relative one is taken relative to the config file's directory,
 * so that a config works from any working directory (systemd starts the
 * daemon in /).  `cap` is the field's size. */
static int p_path(size_t cap, const char *value, void *field, const char *base_dir, bool optional, char *why,
		  size_t n)
{
	if (!*value && optional) {
		*(char *)field = 0;
		return 0;
	}
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
	if (len < 0 || (size_t)len >= cap) {
		snprintf(why, n, "path too long (at most %zu bytes)", cap - 1);
		return -1;
	}
	memcpy(field, buf, (size_t)len + 1);
	return 0;
}

/* "expected opencl or reference, got 'cuda'" */
static int p_enum(const mcd_config_key *k, const char *value, void *field, char *why, size_t n)
{
	for (const mcd_key_choice *c = k->choices; c->name; c++)
		if (strcmp(value, c->name) == 0) {
			*(int *)field = c->value;
			return 0;
		}
	int listed = 0;
	for (const mcd_key_choice *c = k->choices; c->name; c++)
		listed += !c->alias;
	size_t len = (size_t)snprintf(why, n, "expected");
	int i = 0;
	for (const mcd_key_choice *c = k->choices; c->name && len < n; c++) {
		if (c->alias)
			continue;
		const char *sep = i == 0 ? " " : i == listed - 1 ? " or " : ", ";
		len += (size_t)snprintf(why + len, n - len, "%s%s", sep, c->name);
		i++;
	}
	if (len < n)
		snprintf(why + len, n - len, ", got '%s'", value);
	return -1;
}

/* "auto" (-1) or an index. */
static int p_cl_index(const char *value, void *field, char *why, size_t n)
{
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

static int p_mode(const char *value, void *field, char *why, size_t n)
{
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

int mcd_config_key_parse(const mcd_config_key *k, const char *value, void *base, const char *base_dir, char *why,
			 size_t n)
{
	void *field = (char *)base + k->offset;
	switch (k->type) {
	case MCD_KEY_BOOL:
		return p_bool(value, field, why, n);
	case MCD_KEY_INT:
		return p_int(k, value, field, why, n);
	case MCD_KEY_U64:
		return p_u64(value, field, why, n);
	case MCD_KEY_REAL:
		return p_real(k, value, field, why, n);
	case MCD_KEY_POSITIVE:
		return p_positive(k, value, field, why, n);
	case MCD_KEY_STRING:
		return p_string(k, value, field, why, n);
	case MCD_KEY_HOST_PORT:
		return p_host_port(k, value, field, why, n);
	case MCD_KEY_NAME:
		return p_name(k, value, field, why, n);
	case MCD_KEY_PATH:
	case MCD_KEY_OPT_PATH:
		return p_path(k->hi > 0 ? (size_t)k->hi : k->size, value, field, base_dir, k->type == MCD_KEY_OPT_PATH,
			      why, n);
	case MCD_KEY_ENUM:
		return p_enum(k, value, field, why, n);
	case MCD_KEY_CL_INDEX:
		return p_cl_index(value, field, why, n);
	case MCD_KEY_MODE:
		return p_mode(value, field, why, n);
	case MCD_KEY_REAL_AUTO:
		if (strcmp(value, "auto") == 0) {
			*(double *)field = -1;
			return 0;
		}
		if (p_real(k, value, field, why, n) == 0)
			return 0;
		snprintf(why, n, "expected auto or a number from %g to %g, got '%s'", k->lo, k->hi, value);
		return -1;
	}
	snprintf(why, n, "no parser for this key");
	return -1;
}

/* ---- formatting, defaults ------------------------------------------------------ */

static const char *enum_name(const mcd_config_key *k, int v)
{
	for (const mcd_key_choice *c = k->choices; c->name; c++)
		if (c->value == v && !c->alias)
			return c->name;
	return "?";
}

const char *mcd_config_key_format(const mcd_config_key *k, const void *base, char *buf, size_t cap)
{
	const void *field = (const char *)base + k->offset;
	switch (k->type) {
	case MCD_KEY_BOOL:
		snprintf(buf, cap, "%s", *(const bool *)field ? "true" : "false");
		break;
	case MCD_KEY_INT:
		snprintf(buf, cap, "%d", *(const int *)field);
		break;
	case MCD_KEY_U64:
		snprintf(buf, cap, "%llu", (unsigned long long)*(const uint64_t *)field);
		break;
	case MCD_KEY_REAL:
	case MCD_KEY_POSITIVE:
		snprintf(buf, cap, "%.9g", *(const double *)field);
		break;
	case MCD_KEY_STRING:
	case MCD_KEY_HOST_PORT:
	case MCD_KEY_NAME:
	case MCD_KEY_PATH:
	case MCD_KEY_OPT_PATH:
		snprintf(buf, cap, "%s", (const char *)field);
		break;
	case MCD_KEY_ENUM:
		snprintf(buf, cap, "%s", enum_name(k, *(const int *)field));
		break;
	case MCD_KEY_CL_INDEX:  /* an int, */
	case MCD_KEY_REAL_AUTO: /* a double; both "auto" when negative */
	{
		bool real = k->type == MCD_KEY_REAL_AUTO;
		double v = real ? *(const double *)field : *(const int *)field;
		if (v < 0)
			snprintf(buf, cap, "auto");
		else
			snprintf(buf, cap, real ? "%.9g" : "%.0f", v);
		break;
	}
	case MCD_KEY_MODE:
		snprintf(buf, cap, "%04o", *(const unsigned *)field);
		break;
	}
	return buf;
}

/* Parses the table's default of every key of `section` into base. */
static void set_defaults(mcd_section section, void *base)
{
	for (size_t i = 0; i < sizeof(keys) / sizeof(keys[0]); i++) {
		const mcd_config_key *k = &keys[i];
		char why[300];
		if (k->section == section && k->def && mcd_config_key_parse(k, k->def, base, NULL, why, sizeof(why)))
			mcd_error("config: the default of [%s] %s: %s", mcd_section_name(section), k->key, why);
	}
}

void mcd_config_defaults(mcd_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	mc_tracker_settings_default(&cfg->tracker.settings);
	set_defaults(MCD_SEC_DAEMON, cfg);
	set_defaults(MCD_SEC_TRACKER, cfg);
	set_defaults(MCD_SEC_SOCKET, cfg);
	set_defaults(MCD_SEC_DETECTOR, cfg);
	set_defaults(MCD_SEC_NETWORK, cfg);
	set_defaults(MCD_SEC_RECORD, cfg);
	set_defaults(MCD_SEC_SOURCE, cfg);
	set_defaults(MCD_SEC_OUTPUT, cfg);
}

void mcd_camera_config_defaults(mcd_camera_config *cam)
{
	set_defaults(MCD_SEC_CAMERA, cam);
}

/* ---- reload ------------------------------------------------------------------------ */

static bool same_value(const mcd_config_key *k, const mcd_config *a, const mcd_config *b)
{
	const char *fa = (const char *)a + k->offset, *fb = (const char *)b + k->offset;
	if (k->type == MCD_KEY_STRING || k->type == MCD_KEY_HOST_PORT || k->type == MCD_KEY_NAME ||
	    k->type == MCD_KEY_PATH || k->type == MCD_KEY_OPT_PATH)
		return strcmp(fa, fb) == 0;
	return memcmp(fa, fb, k->size) == 0;
}

static bool same_camera(const mcd_camera_config *x, const mcd_camera_config *y)
{
	if (strcmp(x->name, y->name) || x->nkeys != y->nkeys)
		return false;
	for (size_t i = 0; i < sizeof(keys) / sizeof(keys[0]); i++) {
		const mcd_config_key *k = &keys[i];
		if (k->section == MCD_SEC_CAMERA && memcmp((const char *)x + k->offset, (const char *)y + k->offset, k->size))
			return false;
	}
	for (int k = 0; k < x->nkeys; k++)
		if (strcmp(x->keys[k].key, y->keys[k].key) || strcmp(x->keys[k].value, y->keys[k].value))
			return false;
	return true;
}

static bool same_cameras(const mcd_config *a, const mcd_config *b)
{
	if (a->ncams != b->ncams)
		return false;
	for (int c = 0; c < a->ncams; c++)
		if (!same_camera(&a->cams[c], &b->cams[c]))
			return false;
	return true;
}

/* Appends ", item" (or "item" first) to a list in buf. */
static void list_add(char *buf, size_t cap, const char *item)
{
	size_t n = strlen(buf);
	if (n + 1 < cap)
		snprintf(buf + n, cap - n, "%s%s", n ? ", " : "", item);
}

int mcd_config_take_reloadable(mcd_config *cur, const mcd_config *neu, char *changes, size_t cap)
{
	char applied[512] = "", restart[512] = "", item[96];
	int refused = 0;
	if (!same_cameras(cur, neu)) {
		mcd_warn("reload: cameras changed; that takes a restart (systemctl restart mocapd)");
		list_add(restart, sizeof(restart), "cameras");
		refused++;
	}
	for (size_t i = 0; i < sizeof(keys) / sizeof(keys[0]); i++) {
		const mcd_config_key *k = &keys[i];
		if (k->section == MCD_SEC_CAMERA || same_value(k, cur, neu))
			continue;
		snprintf(item, sizeof(item), "[%s] %s", mcd_section_name(k->section), k->key);
		if (k->reload) {
			memcpy((char *)cur + k->offset, (const char *)neu + k->offset, k->size);
			list_add(applied, sizeof(applied), item);
			continue;
		}
		mcd_warn("reload: %s changed; that takes a restart (systemctl restart mocapd)", item);
		list_add(restart, sizeof(restart), item);
		refused++;
	}
	if (changes && cap) {
		if (!applied[0] && !restart[0])
			snprintf(changes, cap, "nothing changed");
		else
			snprintf(changes, cap, "%s%s%s%s%s", applied[0] ? "applied: " : "", applied,
				 applied[0] && restart[0] ? "; " : "", restart[0] ? MCD_RELOAD_NEEDS_RESTART : "", restart);
	}
	return refused;
}
