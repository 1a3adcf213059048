/* vmc_config: mocap-vmc's settings (docs/VMC.md, "Configuration"). */
#include "vmc_config.h"

#include "base/mc_parse.h"

#include <ini.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vmc_settings_default(vmc_settings *s)
{
	memset(s, 0, sizeof(*s));
	snprintf(s->host, sizeof(s->host), "127.0.0.1");
	s->port = VMC_DEFAULT_PORT;
	s->space = MOCAP_SPACE_WORLD;
	s->up = -1;
	s->floor_auto = true;
	s->rest = VMC_REST_TPOSE;
	s->min_confidence = 0.3f;
	s->low = VMC_LOW_HOLD;
	s->ease_s = 0.5;
}

static int parse_number(const char *value, double lo, double hi, double *out)
{
	double v;
	if (!mc_parse_double(value, &v) || v < lo || v > hi)
		return -1;
	*out = v;
	return 0;
}

/* value among names[0..n-1]: its index, else -1. */
static int parse_choice(const char *value, const char *const *names, int n)
{
	for (int i = 0; i < n; i++)
		if (strcmp(value, names[i]) == 0)
			return i;
	return -1;
}

/* HOST:PORT or [IPV6]:PORT: host and port in one. */
static int set_target(vmc_settings *s, const char *value, mc_err *err)
{
	const char *colon = strrchr(value, ':');
	const char *host = value, *host_end = colon;
	if (value[0] == '[') {
		host = value + 1;
		host_end = strchr(value, ']');
		if (!host_end || host_end + 1 != colon)
			host_end = NULL;
	}
	double port;
	if (!colon || !host_end || host_end == host || (size_t)(host_end - host) >= sizeof(s->host) ||
	    parse_number(colon + 1, 1, 65535, &port) < 0 || port != floor(port))
		return mc_err_set(err, "target: '%s': expected HOST:PORT (or [IPV6]:PORT), port 1..65535", value);
	snprintf(s->host, sizeof(s->host), "%.*s", (int)(host_end - host), host);
	s->port = (int)port;
	return 0;
}

int vmc_settings_set(vmc_settings *s, const char *key, const char *value, mc_err *err)
{
	double v;
	int c;
	if (strcmp(key, "host") == 0) {
		if (!*value || strlen(value) >= sizeof(s->host))
			return mc_err_set(err, "host: expected a host name or address");
		snprintf(s->host, sizeof(s->host), "%s", value);
	} else if (strcmp(key, "target") == 0) {
		return set_target(s, value, err);
	} else if (strcmp(key, "port") == 0) {
		if (parse_number(value, 1, 65535, &v) < 0 || v != floor(v))
			return mc_err_set(err, "port: '%s': expected a UDP port, 1..65535", value);
		s->port = (int)v;
	} else if (strcmp(key, "rate") == 0) {
		if (parse_number(value, 0, 1000, &v) < 0)
			return mc_err_set(err, "rate: '%s': expected bundles per second, 0..1000 (0: every frame)", value);
		s->rate = v;
	} else if (strcmp(key, "space") == 0) {
		static const char *const names[] = {"rig", "world"};
		if ((c = parse_choice(value, names, 2)) < 0)
			return mc_err_set(err, "space: '%s': expected world or rig", value);
		s->space = c == 1 ? MOCAP_SPACE_WORLD : MOCAP_SPACE_RIG;
	} else if (strcmp(key, "up") == 0) {
		static const char *const names[] = {"y", "z", "head", "auto"};
		if ((c = parse_choice(value, names, 4)) < 0)
			return mc_err_set(err, "up: '%s': expected auto, y, z or head", value);
		s->up = c == 3 ? -1 : (c == 0 ? VMC_UP_Y : c == 1 ? VMC_UP_Z : VMC_UP_HEAD);
	} else if (strcmp(key, "floor_height") == 0) {
		s->floor_auto = strcmp(value, "auto") == 0;
		if (!s->floor_auto && parse_number(value, -100, 100, &s->floor_height) < 0)
			return mc_err_set(err, "floor_height: '%s': expected auto or metres, -100..100", value);
	} else if (strcmp(key, "rest") == 0) {
		static const char *const names[] = {"tpose", "model"};
		if ((c = parse_choice(value, names, 2)) < 0)
			return mc_err_set(err, "rest: '%s': expected tpose or model", value);
		s->rest = c == 0 ? VMC_REST_TPOSE : VMC_REST_MODEL;
	} else if (strcmp(key, "min_confidence") == 0) {
		if (parse_number(value, 0, 1, &v) < 0)
			return mc_err_set(err, "min_confidence: '%s': expected 0..1", value);
		s->min_confidence = (float)v;
	} else if (strcmp(key, "low_confidence") == 0) {
		static const char *const names[] = {"hold", "rest"};
		if ((c = parse_choice(value, names, 2)) < 0)
			return mc_err_set(err, "low_confidence: '%s': expected hold or rest", value);
		s->low = c == 0 ? VMC_LOW_HOLD : VMC_LOW_REST;
	} else if (strcmp(key, "ease_s") == 0) {
		if (parse_number(value, 0, 60, &s->ease_s) < 0)
			return mc_err_set(err, "ease_s: '%s': expected seconds, 0..60", value);
	} else if (strcmp(key, "bones") == 0) {
		if (strlen(value) >= sizeof(s->bones))
			return mc_err_set(err, "bones: path too long");
		snprintf(s->bones, sizeof(s->bones), "%s", value);
	} else
		return mc_err_set(err, "%s: unknown key (docs/VMC.md lists them)", key);
	return 0;
}

typedef struct {
	vmc_settings *s;
	mc_err *err;
	int failed;
} settings_file;

static int on_key(void *user, const char *section, const char *key, const char *value)
{
	settings_file *f = user;
	if (f->failed)
		return 0;
	if (strcmp(section, "vmc") != 0) {
		f->failed = mc_err_set(f->err, "[%s] %s: unknown section (mocap-vmc reads [vmc])", section, key);
		return 0;
	}
	if (vmc_settings_set(f->s, key, value, f->err) < 0) {
		f->failed = mc_err_prefix(f->err, "[vmc]");
		return 0;
	}
	return 1;
}

int vmc_settings_load(vmc_settings *s, const char *path, mc_err *err)
{
	FILE *fp = fopen(path, "r");
	if (!fp)
		return mc_err_set(err, "%s: cannot open the config file", path);
	mc_err why = {""};
	settings_file f = {.s = s, .err = &why};
	int line = ini_parse_file(fp, on_key, &f);
	fclose(fp);
	if (line == 0)
		return 0;
	if (!f.failed)
		mc_err_set(&why, "not `key = value` or `[section]`");
	return mc_err_set(err, "%s: line %d: %s", path, line, why.msg);
}

vmc_up vmc_settings_up(const vmc_settings *s, const mocap_skeleton_frame *f, const mocap_skeleton_def *sk)
{
	if (s->up >= 0)
		return (vmc_up)s->up;
	if (sk->rig_is_world)
		return VMC_UP_Z; /* outside-in: the rig is the world, z up */
	/* A VR runtime's world is OpenXR's (y up); a head-mounted rig's own
	 * frame has no up but the head's. */
	return f->space == MOCAP_SPACE_WORLD ? VMC_UP_Y : VMC_UP_HEAD;
}

double vmc_settings_floor(const vmc_settings *s, vmc_up up)
{
	if (!s->floor_auto)
		return s->floor_height;
	return up == VMC_UP_HEAD ? VMC_DEFAULT_RIG_FLOOR : 0;
}
