/* config: reading the INI text (inih) section by section and line by
 * line, the checks across keys, and the entry points.  What each key is
 * (type, range, default, reload) is the table in config_keys.c. */
#include "config.h"

#include "base/mc_file.h"

#include <ctype.h>
#include <errno.h>
#include <ini.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- parsing ----------------------------------------------------------- */

typedef struct {
	mcd_config *cfg;
	mc_err *err;
	mcd_config_errors *all; /* NULL: stop at the first error */
	bool failed;
	const char *origin;
	/* the text being read, line by line */
	const char *text;
	size_t pos;
	int line;
	/* the current section, as seen by the reader */
	bool known; /* a section the daemon knows; then `kind` says which */
	mcd_section kind;
	char section[MCD_NAME_MAX + 8];
	mcd_camera_config *cam;
	/* headers seen, to catch a section given twice */
	int nheaders;
	struct {
		char name[MCD_NAME_MAX + 8];
		int line;
	} headers[MC_MAX_CAMERAS + 8];
} parser;

static void errors_add(mcd_config_errors *all, const char *msg)
{
	all->n++;
	size_t n = strlen(msg);
	if (all->len + n + 2 > all->cap) {
		all->untold++;
		return;
	}
	memcpy(all->buf + all->len, msg, n);
	all->len += n;
	all->buf[all->len++] = '\n';
	all->buf[all->len] = 0;
}

/* Records an error at the current line: err keeps the first; with `all`
 * every one is listed and reading goes on. */
static int fail(parser *p, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int fail(parser *p, const char *fmt, ...)
{
	if (p->failed && !p->all)
		return 0; /* keep the first error */
	char msg[400];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	mc_err e;
	mc_err_set(&e, "%s:%d: %s", p->origin, p->line, msg);
	if (!p->failed)
		*p->err = e;
	p->failed = true;
	if (p->all)
		errors_add(p->all, e.msg);
	return 0;
}

/* False when the table is full: the key could then not be checked for a
 * second occurrence, so the caller refuses the file rather than accept a
 * duplicate unseen. */
static bool record_where(mcd_config *cfg, const char *section, const char *key, int line)
{
	int n = cfg->nwhere;
	if (n >= (int)(sizeof(cfg->where) / sizeof(cfg->where[0])))
		return false;
	snprintf(cfg->where[n].section, sizeof(cfg->where[n].section), "%s", section);
	snprintf(cfg->where[n].key, sizeof(cfg->where[n].key), "%s", key);
	cfg->where[n].line = line;
	cfg->nwhere = n + 1;
	return true;
}

#define MAX_WHERE ((int)(sizeof(((mcd_config *)0)->where) / sizeof(((mcd_config *)0)->where[0])))

static int find_where(const mcd_config *cfg, const char *section, const char *key)
{
	for (int i = 0; i < cfg->nwhere; i++)
		if (strcmp(cfg->where[i].section, section) == 0 && strcmp(cfg->where[i].key, key) == 0)
			return cfg->where[i].line;
	return 0;
}

bool mcd_config_is_set(const mcd_config *cfg, const char *section, const char *key)
{
	return find_where(cfg, section, key) > 0;
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

/* "[camera NAME]": a new camera with the table's defaults. */
static void begin_camera(parser *p, const char *name)
{
	const char *cam_name = name + 6;
	while (*cam_name == ' ')
		cam_name++;
	if (!*cam_name) {
		fail(p, "[camera] needs a name: [camera NAME]");
		return;
	}
	if (!valid_name(cam_name) || strlen(cam_name) >= MCD_NAME_MAX) {
		fail(p, "[%s]: a camera name is letters, digits, '_' and '-', at most %d bytes", name, MCD_NAME_MAX - 1);
		return;
	}
	if (p->cfg->ncams >= MC_MAX_CAMERAS) {
		fail(p, "[%s]: too many cameras (at most %d)", name, MC_MAX_CAMERAS);
		return;
	}
	mcd_camera_config *cam = &p->cfg->cams[p->cfg->ncams++];
	memset(cam, 0, sizeof(*cam));
	/* checked above to fit; the precision tells the compiler so (-O1 builds warn otherwise) */
	snprintf(cam->name, sizeof(cam->name), "%.*s", (int)sizeof(cam->name) - 1, cam_name);
	cam->line = p->line;
	mcd_camera_config_defaults(cam);
	p->cam = cam;
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
	p->known = true;
	if (strcmp(name, "daemon") == 0)
		p->kind = MCD_SEC_DAEMON;
	else if (strcmp(name, "tracker") == 0) {
		p->kind = MCD_SEC_TRACKER;
		p->cfg->tracker.line = p->line;
	} else if (strcmp(name, "socket") == 0)
		p->kind = MCD_SEC_SOCKET;
	else if (strcmp(name, "detector") == 0)
		p->kind = MCD_SEC_DETECTOR;
	else if (strcmp(name, "network") == 0)
		p->kind = MCD_SEC_NETWORK;
	else if (strcmp(name, "record") == 0)
		p->kind = MCD_SEC_RECORD;
	else if (strcmp(name, "source") == 0)
		p->kind = MCD_SEC_SOURCE;
	else if (strcmp(name, "output") == 0)
		p->kind = MCD_SEC_OUTPUT;
	else if (strncmp(name, "camera", 6) == 0 && (name[6] == ' ' || name[6] == 0)) {
		p->kind = MCD_SEC_CAMERA;
		begin_camera(p, name);
	} else {
		p->known = false;
		const char *near = mcd_config_suggest_section(name);
		if (near)
			fail(p, "unknown section [%s] (did you mean [%s%s]?)", name, near,
			     strcmp(near, "camera") == 0 ? " NAME" : "");
		else
			fail(p, "unknown section [%s] (expected [daemon], [camera NAME], [tracker], [socket], [detector], "
				"[network], [record], [source] or [output])", name);
	}
}

/* Refuses an indented line; begins the section a "[...]" line names.
 * False on an error. */
static bool check_line(parser *p, const char *buf)
{
	const char *s = buf;
	while (*s == ' ' || *s == '\t')
		s++;
	bool blank = *s == '\n' || *s == ';' || *s == '#';
	if (!blank && s != buf) {
		/* inih would read an indented line as the continuation of the
		 * previous value: refuse it rather than misread it. */
		fail(p, "indented line (inih reads it as the continuation of the previous value); remove the "
			"indentation");
		return false;
	}
	const char *end = *s == '[' ? strchr(s, ']') : NULL;
	if (!end)
		return true;
	char name[MCD_NAME_MAX + 8];
	size_t n = (size_t)(end - s - 1);
	if (n >= sizeof(name)) {
		fail(p, "section name too long");
		return false;
	}
	memcpy(name, s + 1, n);
	name[n] = 0;
	begin_section(p, name);
	return true;
}

/* inih's reader: hands out one line at a time, counting lines and seeing
 * section headers before inih does. */
static char *read_line(char *buf, int cap, void *stream)
{
	parser *p = stream;
	if ((p->failed && !p->all) || !p->text[p->pos])
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
		if (!p->all)
			return NULL;
		content = 0; /* read on as an empty line */
	}
	memcpy(buf, start, content);
	buf[content] = '\n';
	buf[content + 1] = 0;

	if (check_line(p, buf))
		return buf;
	if (!p->all)
		return NULL;
	strcpy(buf, "\n"); /* reported; read on */
	return buf;
}

static int apply_key(parser *p, const mcd_config_key *k, void *base, const char *key, const char *value)
{
	int first = find_where(p->cfg, p->section, key);
	if (first)
		return fail(p, "[%s] %s: given twice (first at line %d)", p->section, key, first);
	char why[300];
	if (mcd_config_key_parse(k, value, base, p->cfg->dir, why, sizeof(why)) != 0)
		return fail(p, "[%s] %s: %s", p->section, key, why);
	if (!record_where(p->cfg, p->section, key, p->line))
		return fail(p, "[%s] %s: more than %d keys in the file; not a mocapd config", p->section, key, MAX_WHERE);
	return 1;
}

/* Driver keys that hold a path: "path" and "*_path". */
static bool is_path_key(const char *key)
{
	size_t n = strlen(key);
	return strcmp(key, "path") == 0 || (n > 5 && strcmp(key + n - 5, "_path") == 0);
}

/* A key of [camera NAME] that the daemon does not read itself: checked
 * against what the driver reads, at open.  Dots group keys (ctrl.NAME for
 * camera controls). */
static int driver_key(parser *p, mcd_camera_config *cam, const char *key, const char *value)
{
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
		const mcd_config_key path = {.section = MCD_SEC_CAMERA, .key = key, .type = MCD_KEY_PATH,
					     .size = sizeof(kv->value)};
		char why[300];
		if (mcd_config_key_parse(&path, value, kv->value, p->cfg->dir, why, sizeof(why)) != 0)
			return fail(p, "[%s] %s: %s", p->section, key, why);
	}
	kv->line = p->line;
	if (!record_where(p->cfg, p->section, key, p->line))
		return fail(p, "[%s] %s: more than %d keys in the file; not a mocapd config", p->section, key, MAX_WHERE);
	return 1;
}

static int camera_key(parser *p, const char *key, const char *value)
{
	mcd_camera_config *cam = p->cam;
	if (!cam)
		return 0; /* the header already failed */
	const mcd_config_key *k = mcd_config_key_find(MCD_SEC_CAMERA, key);
	if (!k)
		return driver_key(p, cam, key, value);
	int ok = apply_key(p, k, cam, key, value);
	if (ok && strcmp(key, "driver") == 0)
		cam->driver_line = p->line;
	if (ok && strcmp(key, "rig_camera") == 0)
		cam->rig_camera_line = p->line;
	return ok;
}

static int on_key(void *user, const char *section, const char *key, const char *value)
{
	parser *p = user;
	(void)section; /* the reader tracks it, with its line */
	if (p->failed && !p->all)
		return 0;
	if (!p->known) {
		if (!p->section[0])
			return fail(p, "%s: key outside any section (start with [daemon])", key);
		return 0; /* unknown section, already reported */
	}
	if (p->kind == MCD_SEC_CAMERA)
		return camera_key(p, key, value);
	const mcd_config_key *k = mcd_config_key_find(p->kind, key);
	if (!k) {
		const char *near = mcd_config_suggest_key(p->kind, key);
		if (near)
			return fail(p, "[%s] %s: unknown key (did you mean '%s'?)", p->section, key, near);
		return fail(p, "[%s] %s: unknown key", p->section, key);
	}
	return apply_key(p, k, p->cfg, key, value);
}

/* ---- checks across keys ------------------------------------------------ */

static int check_cameras(mcd_config *cfg, mc_err *err)
{
	if (cfg->source.graph[0]) { /* a graph source replaces cameras and tracker */
		if (cfg->ncams > 0)
			return mc_err_set(err, "%s:%d: [camera %s]: [source] graph replaces the cameras; remove one or the other",
					  cfg->file, cfg->cams[0].line, cfg->cams[0].name);
		return 0;
	}
	if (cfg->ncams == 0)
		return mc_err_set(err, "%s: no [camera NAME] section; at least one camera is needed (or a [source] graph)",
				  cfg->file);
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
	if (cfg->source.graph[0]) { /* the graph source tracks nothing */
		if (t->line)
			return mc_err_set(err, "%s:%d: [tracker]: [source] graph replaces the tracker; remove one or the other",
					  cfg->file, t->line);
		t->enabled = false;
		return 0;
	}
	if (!t->line)
		return mc_err_set(err, "%s: no [tracker] section (give rig and model, or enabled = false)", cfg->file);
	if (!t->rig[0])
		return mc_err_set(err, "%s:%d: [tracker]: missing key 'rig'", cfg->file, t->line);
	if (!t->model[0])
		return mc_err_set(err, "%s:%d: [tracker]: missing key 'model'", cfg->file, t->line);
	if (t->actor[0] && t->init_joints[0]) {
		char where[300];
		return mc_err_set(err, "%s: excludes init_joints (an actor starts from the detections)",
				  mcd_config_where(cfg, "tracker", "actor", where, sizeof(where)));
	}
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

static int check_network(mcd_config *cfg, mc_err *err)
{
	const mcd_network_config *n = &cfg->network;
	char where[300];
	if (n->listen[0] && !n->token_file[0])
		return mc_err_set(err, "%s: needs token_file, a file with the access token TCP clients must present "
				       "(e.g. made with: head -c 24 /dev/urandom | base64 > FILE)",
				  mcd_config_where(cfg, "network", "listen", where, sizeof(where)));
	if (!cfg->socket.enabled && n->listen[0])
		return mc_err_set(err, "%s: the TCP listener belongs to the client server, which [socket] enabled = false "
				       "turns off", mcd_config_where(cfg, "network", "listen", where, sizeof(where)));
	return 0;
}

/* ---- entry points ------------------------------------------------------ */

/* The checks across keys, each on its own: with `all` every one that
 * fails is listed, else the first stops. */
static int check_across(mcd_config *cfg, mcd_config_errors *all, mc_err *err)
{
	int (*const checks[])(mcd_config *, mc_err *) = {check_tracker, check_cameras, check_daemon, check_network};
	int rc = 0;
	for (size_t i = 0; i < sizeof(checks) / sizeof(checks[0]); i++) {
		mc_err e;
		if (checks[i](cfg, &e) == 0)
			continue;
		if (rc == 0)
			*err = e;
		rc = -1;
		if (!all)
			break;
		errors_add(all, e.msg);
	}
	return rc;
}

int mcd_config_parse(const char *text, const char *origin, const char *base_dir, mcd_config *cfg, mc_err *err)
{
	return mcd_config_parse_all(text, origin, base_dir, cfg, NULL, err);
}

int mcd_config_parse_all(const char *text, const char *origin, const char *base_dir, mcd_config *cfg,
			 mcd_config_errors *all, mc_err *err)
{
	mcd_config_defaults(cfg);
	snprintf(cfg->file, sizeof(cfg->file), "%s", origin);
	snprintf(cfg->dir, sizeof(cfg->dir), "%s", base_dir ? base_dir : ".");
	parser p = {.cfg = cfg, .err = err, .all = all, .origin = origin, .text = text};
	/* A UTF-8 byte order mark (some editors write one) is not a key. */
	if (!strncmp(text, "\xEF\xBB\xBF", 3))
		p.pos = 3;
	int rc = ini_parse_stream(read_line, &p, on_key, &p);
	if (p.failed)
		return -1;
	if (rc > 0) {
		mc_err_set(err, "%s:%d: syntax error (expected [section] or key = value)", origin, rc);
		if (all)
			errors_add(all, err->msg);
		return -1;
	}
	if (rc < 0)
		return mc_err_set(err, "%s: cannot parse (out of memory)", origin);
	return check_across(cfg, all, err);
}

/* The whole file as a NUL-terminated text (malloc'ed), at most 1 MiB. */
static char *read_file(FILE *f, const char *path, mc_err *err)
{
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
				mc_err_set(err, "%s: out of memory", path);
				return NULL;
			}
			text = grown;
		}
		memcpy(text + len, chunk, n);
		len += n;
		if (len > (1u << 20)) {
			free(text);
			mc_err_set(err, "%s: larger than 1 MiB; not a mocapd config", path);
			return NULL;
		}
	}
	if (ferror(f)) {
		free(text);
		mc_err_set(err, "%s: read error", path);
		return NULL;
	}
	if (!text && !(text = calloc(1, 1))) {
		mc_err_set(err, "%s: out of memory", path);
		return NULL;
	}
	text[len] = 0;
	if (strlen(text) != len) {
		free(text);
		mc_err_set(err, "%s: contains a NUL byte; not a text file", path);
		return NULL;
	}
	return text;
}

/* Opens the config for reading, refusing anything but a regular file: a
 * FIFO without a writer would block `mocapd --check` for ever
 * (mc_file_open_regular opens it non-blocking and checks it first). */
static FILE *open_config(const char *path, mc_err *err)
{
	FILE *f = mc_file_open_regular(path, err);
	if (!f && strstr(err->msg, ": not a regular file (")) {
		size_t n = strlen(err->msg);
		snprintf(err->msg + n, sizeof(err->msg) - n, "; refused");
	}
	return f;
}

int mcd_config_load(const char *path, mcd_config *cfg, mc_err *err)
{
	return mcd_config_load_all(path, cfg, NULL, err);
}

int mcd_config_load_all(const char *path, mcd_config *cfg, mcd_config_errors *all, mc_err *err)
{
	FILE *f = open_config(path, err);
	if (!f) {
		if (all)
			errors_add(all, err->msg);
		return -1;
	}
	char *text = read_file(f, path, err);
	fclose(f);
	if (!text) {
		if (all)
			errors_add(all, err->msg);
		return -1;
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
	int rc = mcd_config_parse_all(text, path, dir, cfg, all, err);
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
