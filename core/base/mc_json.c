#include "base/mc_json.h"
#include "base/mc_file.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define PATH_CAP 320
/* An element path: a PATH_CAP path plus "[index]". */
#define ELEM_CAP (PATH_CAP + 24)

/* The result of a parse: 0, or the error naming origin, line and column. */
static int parsed(const json_t *root, const json_error_t *je, const char *origin, mc_err *err)
{
	if (root)
		return 0;
	/* jansson reports unreadable files with line -1 and an errno text. */
	if (je->line < 0)
		return mc_err_set(err, "%s: %s", origin, je->text);
	return mc_err_set(err, "%s:%d:%d: %s", origin, je->line, je->column, je->text);
}

int mc_json_load_file(const char *path, json_t **root, mc_err *err)
{
	json_error_t je;
	*root = NULL;
	if (mc_file_refuse_special(path, err)) /* json_load_file would wait on a FIFO */
		return -1;
	*root = json_load_file(path, JSON_REJECT_DUPLICATES, &je);
	return parsed(*root, &je, path, err);
}

int mc_json_load_text(const char *text, const char *origin, json_t **root, mc_err *err)
{
	json_error_t je;
	*root = json_loads(text, JSON_REJECT_DUPLICATES, &je);
	return parsed(*root, &je, origin, err);
}

char *mc_json_path(char *buf, size_t cap, const char *where, const char *key)
{
	/* A bare file name is a document root: separate with ": ". */
	bool root = strstr(where, ": ") == NULL;
	snprintf(buf, cap, "%s%s%s", where, root ? ": " : ".", key);
	return buf;
}

char *mc_json_path_index(char *buf, size_t cap, const char *where, const char *key, size_t i)
{
	char k[128];
	snprintf(k, sizeof(k), "%s[%zu]", key, i);
	return mc_json_path(buf, cap, where, k);
}

static const char *type_name(const json_t *v)
{
	switch (json_typeof(v)) {
	case JSON_OBJECT: return "an object";
	case JSON_ARRAY: return "an array";
	case JSON_STRING: return "a string";
	case JSON_INTEGER: return "an integer";
	case JSON_REAL: return "a number";
	case JSON_TRUE:
	case JSON_FALSE: return "a boolean";
	case JSON_NULL: return "null";
	}
	return "an unknown value";
}

/* Masks of JSON types for lookup(). */
#define TYPE(t) (1u << (t))
#define T_ANY (~0u)
#define T_NUMBER (TYPE(JSON_INTEGER) | TYPE(JSON_REAL))
#define T_BOOL (TYPE(JSON_TRUE) | TYPE(JSON_FALSE))

/* A member found by lookup(), with its path ("where.key") for the caller's
 * messages. */
struct member {
	json_t *v;
	char path[PATH_CAP];
};

/* Looks up key: 0 found and of one of the `types`, 1 absent and optional,
 * -1 absent and required ("<path>: missing") or of another type
 * ("<path>: expected <what>, got <its type>"). */
static int lookup(const json_t *obj, const char *key, const char *where, bool required, unsigned types,
		  const char *what, struct member *m, mc_err *err)
{
	mc_json_path(m->path, PATH_CAP, where, key);
	m->v = json_is_object(obj) ? json_object_get(obj, key) : NULL;
	if (!m->v || json_is_null(m->v))
		return required ? mc_err_set(err, "%s: missing", m->path) : 1;
	if (!(types & TYPE(json_typeof(m->v))))
		return mc_err_set(err, "%s: expected %s, got %s", m->path, what, type_name(m->v));
	return 0;
}

/* Reads a finite number from v; `path` names it. */
static int number_value(const json_t *v, const char *path, double *out, mc_err *err)
{
	if (!json_is_number(v))
		return mc_err_set(err, "%s: expected a number, got %s", path, type_name(v));
	double x = json_number_value(v);
	if (!isfinite(x))
		return mc_err_set(err, "%s: number is not finite", path);
	*out = x;
	return 0;
}

int mc_json_number(const json_t *obj, const char *key, const char *where, double *out, bool required, mc_err *err)
{
	struct member m;
	int r = lookup(obj, key, where, required, T_NUMBER, "a number", &m, err);
	return r ? r : number_value(m.v, m.path, out, err);
}

int mc_json_positive(const json_t *obj, const char *key, const char *where, double *out, bool required, mc_err *err)
{
	double x;
	int r = mc_json_number(obj, key, where, &x, required, err);
	if (r)
		return r;
	char p[PATH_CAP];
	if (!(x > 0))
		return mc_err_set(err, "%s: must be a positive number, got %g", mc_json_path(p, sizeof(p), where, key), x);
	*out = x;
	return 0;
}

int mc_json_number_range(const json_t *obj, const char *key, const char *where, double lo, double hi, double *out,
			 bool required, mc_err *err)
{
	double x;
	int r = mc_json_number(obj, key, where, &x, required, err);
	if (r)
		return r;
	char p[PATH_CAP];
	if (x < lo || x > hi)
		return mc_err_set(err, "%s: %g is out of range [%g, %g]", mc_json_path(p, sizeof(p), where, key), x, lo,
				  hi);
	*out = x;
	return 0;
}

int mc_json_int(const json_t *obj, const char *key, const char *where, long long lo, long long hi, int *out,
		bool required, mc_err *err)
{
	struct member m;
	int r = lookup(obj, key, where, required, T_NUMBER, "an integer", &m, err);
	if (r)
		return r;
	const char *p = m.path;
	if (json_is_integer(m.v)) {
		json_int_t i = json_integer_value(m.v);
		if (i < lo || i > hi)
			return mc_err_set(err, "%s: %lld is out of range [%lld, %lld]", p, (long long)i, lo, hi);
		*out = (int)i;
		return 0;
	}
	double x;
	if (number_value(m.v, p, &x, err))
		return -1;
	if (x != floor(x))
		return mc_err_set(err, "%s: expected an integer, got %g", p, x);
	if (x < (double)lo || x > (double)hi)
		return mc_err_set(err, "%s: %g is out of range [%lld, %lld]", p, x, lo, hi);
	*out = (int)x;
	return 0;
}

int mc_json_bool(const json_t *obj, const char *key, const char *where, bool *out, bool required, mc_err *err)
{
	struct member m;
	int r = lookup(obj, key, where, required, T_BOOL, "true or false", &m, err);
	if (r == 0)
		*out = json_is_true(m.v);
	return r;
}

int mc_json_string(const json_t *obj, const char *key, const char *where, char *out, size_t cap, bool required,
		   mc_err *err)
{
	struct member m;
	int r = lookup(obj, key, where, required, TYPE(JSON_STRING), "a string", &m, err);
	if (r)
		return r;
	size_t n = json_string_length(m.v);
	if (n + 1 > cap)
		return mc_err_set(err, "%s: string is too long (%zu bytes, at most %zu)", m.path, n, cap - 1);
	if (strlen(json_string_value(m.v)) != n)
		return mc_err_set(err, "%s: string contains a NUL character", m.path);
	memcpy(out, json_string_value(m.v), n + 1);
	return 0;
}

/* Copies the numbers of array `arr` (named `path`) into out[0..n). */
static int array_numbers(const json_t *arr, const char *path, double *out, size_t n, mc_err *err)
{
	for (size_t i = 0; i < n; i++) {
		char p[ELEM_CAP];
		snprintf(p, sizeof(p), "%s[%zu]", path, i);
		if (number_value(json_array_get(arr, i), p, &out[i], err))
			return -1;
	}
	return 0;
}

int mc_json_numbers(const json_t *obj, const char *key, const char *where, double *out, size_t n, bool required,
		    mc_err *err)
{
	struct member m;
	char what[64];
	snprintf(what, sizeof(what), "an array of %zu numbers", n);
	int r = lookup(obj, key, where, required, TYPE(JSON_ARRAY), what, &m, err);
	if (r)
		return r;
	if (json_array_size(m.v) != n)
		return mc_err_set(err, "%s: expected %zu numbers, got %zu", m.path, n, json_array_size(m.v));
	return array_numbers(m.v, m.path, out, n, err);
}

int mc_json_numbers_var(const json_t *obj, const char *key, const char *where, double *out, size_t max, size_t *n,
			bool required, mc_err *err)
{
	json_t *v;
	int r = mc_json_array(obj, key, where, 1, max, &v, required, err);
	if (r)
		return r;
	char p[PATH_CAP];
	mc_json_path(p, sizeof(p), where, key);
	*n = json_array_size(v);
	return array_numbers(v, p, out, *n, err);
}

int mc_json_vec3(const json_t *obj, const char *key, const char *where, mc_vec3 *out, bool required, mc_err *err)
{
	double a[3];
	int r = mc_json_numbers(obj, key, where, a, 3, required, err);
	if (r)
		return r;
	*out = mc_v3(a[0], a[1], a[2]);
	return 0;
}

/* An n x n matrix as n rows of n numbers or n*n numbers, into out (n*n
 * doubles, row-major) only when all of it is valid. */
static int square_matrix(const json_t *obj, const char *key, const char *where, size_t n, void *out, bool required,
			 mc_err *err)
{
	struct member m;
	int r = lookup(obj, key, where, required, T_ANY, NULL, &m, err);
	if (r)
		return r;
	double a[16];
	json_t *v = m.v;
	if (json_is_array(v) && json_array_size(v) == n * n) {
		if (array_numbers(v, m.path, a, n * n, err))
			return -1;
		memcpy(out, a, n * n * sizeof(double));
		return 0;
	}
	if (!json_is_array(v) || json_array_size(v) != n)
		return mc_err_set(err, "%s: expected %zu rows of %zu numbers (or %zu numbers)", m.path, n, n, n * n);
	for (size_t i = 0; i < n; i++) {
		json_t *row = json_array_get(v, i);
		char rp[ELEM_CAP];
		snprintf(rp, sizeof(rp), "%s[%zu]", m.path, i);
		if (!json_is_array(row) || json_array_size(row) != n)
			return mc_err_set(err, "%s: expected a row of %zu numbers", rp, n);
		if (array_numbers(row, rp, a + i * n, n, err))
			return -1;
	}
	memcpy(out, a, n * n * sizeof(double));
	return 0;
}

int mc_json_mat4(const json_t *obj, const char *key, const char *where, double out[4][4], bool required, mc_err *err)
{
	return square_matrix(obj, key, where, 4, out, required, err);
}

int mc_json_mat3(const json_t *obj, const char *key, const char *where, mc_mat3 *out, bool required, mc_err *err)
{
	return square_matrix(obj, key, where, 3, out->m, required, err);
}

int mc_json_array(const json_t *obj, const char *key, const char *where, size_t min, size_t max, json_t **out,
		  bool required, mc_err *err)
{
	struct member m;
	int r = lookup(obj, key, where, required, TYPE(JSON_ARRAY), "an array", &m, err);
	if (r)
		return r;
	size_t n = json_array_size(m.v);
	if (n < min)
		return mc_err_set(err, "%s: needs at least %zu element%s, got %zu", m.path, min, min == 1 ? "" : "s", n);
	if (n > max)
		return mc_err_set(err, "%s: at most %zu elements allowed, got %zu", m.path, max, n);
	*out = m.v;
	return 0;
}

int mc_json_object(const json_t *obj, const char *key, const char *where, json_t **out, bool required, mc_err *err)
{
	struct member m;
	int r = lookup(obj, key, where, required, TYPE(JSON_OBJECT), "an object", &m, err);
	if (r == 0)
		*out = m.v;
	return r;
}

int mc_json_check_keys(const json_t *obj, const char *where, const char *const *allowed, mc_err *err)
{
	const char *key;
	json_t *v;
	json_object_foreach((json_t *)obj, key, v) {
		bool known = false;
		for (const char *const *a = allowed; *a && !known; a++)
			known = strcmp(*a, key) == 0;
		if (!known) {
			char p[PATH_CAP];
			return mc_err_set(err, "%s: unknown field", mc_json_path(p, sizeof(p), where, key));
		}
	}
	return 0;
}

int mc_json_save_file(const json_t *root, const char *path, mc_err *err)
{
	char *text = json_dumps(root, JSON_INDENT(2) | JSON_PRESERVE_ORDER | JSON_REAL_PRECISION(17));
	if (!text)
		return mc_err_set(err, "%s: cannot write: out of memory", path);
	int rc = mc_file_write_atomic(path, text, strlen(text), err);
	free(text);
	return rc;
}
