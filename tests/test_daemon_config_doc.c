/* docs/CONFIG.md against the daemon's config key table (daemon/config.h,
 * mcd_config_keys): every key of the table is documented in its section's
 * table, every documented key is in the table, the documented defaults are
 * the table's, and the keys "Reloading" lists as taking effect at once
 * are exactly those the table marks reloadable. */
#include "config.h"
#include "daemon/harness.h"
#include "test_util.h"

#include <ctype.h>
#include <string.h>
#include <unistd.h>

#define MAX_TICKS 8

static mcd_config defaults;
static mcd_camera_config camera_defaults;

/* The `...` spans of text[0..len), at most max, each at most cap bytes. */
static int ticks(const char *text, size_t len, char out[][128], int max)
{
	int n = 0;
	const char *end = text + len;
	for (const char *p = text; p < end && n < max;) {
		const char *a = memchr(p, '`', (size_t)(end - p));
		const char *b = a ? memchr(a + 1, '`', (size_t)(end - a - 1)) : NULL;
		if (!b)
			break;
		snprintf(out[n++], 128, "%.*s", (int)(b - a - 1), a + 1);
		p = b + 1;
	}
	return n;
}

/* The section a "## ..." heading names, or -1. */
static int section_of(const char *line)
{
	static const char *const heads[] = {"## [daemon]", "## [camera NAME]", "## [tracker]", "## [socket]",
					    "## [detector]", "## [network]", "## [record]", "## [source]",
					    "## [output]"};
	static const mcd_section secs[] = {MCD_SEC_DAEMON, MCD_SEC_CAMERA, MCD_SEC_TRACKER, MCD_SEC_SOCKET,
					   MCD_SEC_DETECTOR, MCD_SEC_NETWORK, MCD_SEC_RECORD, MCD_SEC_SOURCE,
					   MCD_SEC_OUTPUT};
	for (int i = 0; i < MCD_NSECTIONS; i++)
		if (strncmp(line, heads[i], strlen(heads[i])) == 0)
			return (int)secs[i];
	return -1;
}

/* Digits after the decimal point of a number as written ("0.333" -> 3), or
 * -1 if the text is not a plain number. */
static int decimals(const char *s)
{
	char *end;
	strtod(s, &end);
	if (end == s || *end)
		return -1;
	const char *dot = strchr(s, '.');
	return dot ? (int)strlen(dot + 1) : 0;
}

/* A documented default is the table's value as written, or rounded to the
 * digits the text shows; "$(PREFIX)/x" stands for any prefix. */
static bool same_default(const char *doc, const char *table)
{
	const char *prefix = strstr(doc, "$(PREFIX)");
	if (prefix == doc) {
		size_t n = strlen(doc + 9), m = strlen(table);
		return m >= n && strcmp(table + m - n, doc + 9) == 0;
	}
	int d = decimals(doc);
	if (d > 0 && decimals(table) >= 0) {
		double tol = 0.5;
		for (int i = 0; i < d; i++)
			tol /= 10;
		return fabs(strtod(doc, NULL) - strtod(table, NULL)) <= tol * 1.0001;
	}
	return strcmp(doc, table) == 0;
}

static const char *table_default(const mcd_config_key *k, char *buf, size_t cap)
{
	const void *base = k->section == MCD_SEC_CAMERA ? (const void *)&camera_defaults : (const void *)&defaults;
	return mcd_config_key_format(k, base, buf, cap);
}

static bool documented[128];

static void check_row(int section, const char *row, size_t len)
{
	/* | `key`, `key2` | default | meaning | */
	const char *c1 = memchr(row + 1, '|', len - 1);
	const char *c2 = c1 ? memchr(c1 + 1, '|', (size_t)(row + len - c1 - 1)) : NULL;
	if (!c1 || !c2)
		return;
	char names[MAX_TICKS][128], defs[MAX_TICKS][128];
	int nnames = ticks(row, (size_t)(c1 - row), names, MAX_TICKS);
	int ndefs = ticks(c1, (size_t)(c2 - c1), defs, MAX_TICKS);
	size_t nkeys;
	const mcd_config_key *keys = mcd_config_keys(&nkeys);
	for (int i = 0; i < nnames; i++) {
		const mcd_config_key *k = mcd_config_key_find((mcd_section)section, names[i]);
		CHECK_MSG(k, "docs/CONFIG.md documents [%s] %s, which the daemon does not have",
			  mcd_section_name((mcd_section)section), names[i]);
		if (!k)
			continue;
		documented[k - keys] = true;
		char value[PATH_MAX];
		table_default(k, value, sizeof(value));
		const char *doc = ndefs == nnames ? defs[i] : ndefs == 1 ? defs[0] : NULL;
		if (!doc)
			CHECK_MSG(ndefs == 0 && value[0] == 0, "[%s] %s: docs/CONFIG.md gives no default, the daemon's is '%s'",
				  mcd_section_name(k->section), k->key, value);
		else
			CHECK_MSG(same_default(doc, value), "[%s] %s: docs/CONFIG.md says the default is '%s', the daemon's is '%s'",
				  mcd_section_name(k->section), k->key, doc, value);
	}
}

static void check_key_tables(const char *text)
{
	int section = -1;
	for (const char *line = text; *line;) {
		const char *nl = strchr(line, '\n');
		size_t len = nl ? (size_t)(nl - line) : strlen(line);
		if (strncmp(line, "## ", 3) == 0)
			section = section_of(line);
		else if (section >= 0 && line[0] == '|' && len > 4 && line[2] == '`')
			check_row(section, line, len);
		line += len + (nl ? 1 : 0);
	}
	size_t nkeys;
	const mcd_config_key *keys = mcd_config_keys(&nkeys);
	for (size_t i = 0; i < nkeys; i++)
		CHECK_MSG(documented[i], "[%s] %s is not in docs/CONFIG.md's table of [%s]", mcd_section_name(keys[i].section),
			  keys[i].key, mcd_section_name(keys[i].section));
}

/* The key `name` of section *in (of any section if in is NULL), or NULL. */
static const mcd_config_key *any_key(const char *name, mcd_section *in)
{
	for (int s = MCD_SEC_DAEMON; s < MCD_NSECTIONS; s++) {
		const mcd_config_key *k = mcd_config_key_find((mcd_section)s, name);
		if (k && (!in || *in == (mcd_section)s))
			return k;
	}
	return NULL;
}

static void check_reload_section(const char *text)
{
	const char *start = strstr(text, "## Reloading");
	const char *rest = start ? strstr(start, "Everything else") : NULL;
	const char *end = rest ? strstr(rest, "\n## ") : NULL;
	CHECK_MSG(start && rest && end, "docs/CONFIG.md: no \"## Reloading\" section with \"Everything else\"");
	if (!start || !rest || !end)
		return;
	size_t nkeys;
	const mcd_config_key *keys = mcd_config_keys(&nkeys);
	bool listed[128] = {false};
	char t[64][128];
	/* What takes effect at once: "- `[daemon]`: `log_level` ..." */
	int n = ticks(start, (size_t)(rest - start), t, 64);
	mcd_section sec = MCD_SEC_DAEMON;
	for (int i = 0; i < n; i++) {
		if (t[i][0] == '[') {
			sec = strcmp(t[i], "[tracker]") == 0    ? MCD_SEC_TRACKER
			      : strcmp(t[i], "[detector]") == 0 ? MCD_SEC_DETECTOR
			      : strcmp(t[i], "[output]") == 0   ? MCD_SEC_OUTPUT
								: MCD_SEC_DAEMON;
			continue;
		}
		const mcd_config_key *k = any_key(t[i], &sec);
		if (!k)
			continue; /* an option or a function, not a key */
		listed[k - keys] = true;
		CHECK_MSG(k->reload, "docs/CONFIG.md lists [%s] %s as applied by a reload; the daemon needs a restart",
			  mcd_section_name(k->section), k->key);
	}
	for (size_t i = 0; i < nkeys; i++)
		CHECK_MSG(!keys[i].reload || listed[i], "[%s] %s: a reload applies it, but docs/CONFIG.md does not say so",
			  mcd_section_name(keys[i].section), keys[i].key);
	/* What takes a restart */
	n = ticks(rest, (size_t)(end - rest), t, 64);
	for (int i = 0; i < n; i++) {
		const mcd_config_key *k = any_key(t[i], NULL);
		CHECK_MSG(!k || !k->reload, "docs/CONFIG.md says %s takes a restart; a reload applies it", t[i]);
	}
}

int main(void)
{
	if (access("docs/CONFIG.md", R_OK) != 0)
		TEST_SKIP("run from the repository root (docs/CONFIG.md not found)");
	char *text = mcd_read_file("docs/CONFIG.md");
	size_t nkeys;
	mcd_config_keys(&nkeys);
	CHECK(nkeys <= sizeof(documented) / sizeof(documented[0]));
	mcd_config_defaults(&defaults);
	mcd_camera_config_defaults(&camera_defaults);
	check_key_tables(text);
	check_reload_section(text);
	free(text);
	return mc_test_finish("test_daemon_config_doc");
}
