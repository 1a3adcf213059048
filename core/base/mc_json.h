/* mc_json: small helpers over jansson for loaders whose errors must name the
 * file and the field.
 *
 * Every getter takes `where`, the path of the enclosing object, and `key`,
 * the member to read. Messages read "<where>.<key>: <problem>", or
 * "<where>: <key>: <problem>" when `where` is a document root (a bare file
 * name without ": "), e.g.
 *   mc_json_number(j, "offset", "model.json: joints[3]", ...)
 *     -> "model.json: joints[3].offset: expected a number"
 *   mc_json_string(root, "name", "rig.json", ...)
 *     -> "rig.json: name: missing"
 *
 * Return values of the getters:
 *    0  the member was present and valid; *out is set;
 *    1  the member is absent and not required; *out is left untouched
 *       (so callers preset defaults);
 *   -1  error (missing but required, wrong type, out of range, ...), with err
 *       set.
 * JSON null counts as absent. Numbers are rejected when not finite (jansson
 * already refuses NaN, Infinity and overflowing literals such as 1e999 at
 * parse time; the check is kept for values built in memory). */
#ifndef MC_JSON_H
#define MC_JSON_H

#include "base/mc_error.h"
#include "base/mc_math.h"

#include <jansson.h>
#include <stdbool.h>
#include <stddef.h>

/* Parses a file. Duplicate keys are rejected. The error names the file, line
 * and column: "rig.json:12:5: end of file expected near '}'". */
int mc_json_load_file(const char *path, json_t **root, mc_err *err);
/* Parses a text; `origin` names it in errors like a file name. */
int mc_json_load_text(const char *text, const char *origin, json_t **root, mc_err *err);

/* Writes the path of `key` inside `where` ("where.key" or "where: key", see
 * above) into buf. Returns buf. */
char *mc_json_path(char *buf, size_t cap, const char *where, const char *key);
/* The same for element i of array `key`: "where.key[i]". */
char *mc_json_path_index(char *buf, size_t cap, const char *where, const char *key, size_t i);

/* Any finite number (integer or real). */
int mc_json_number(const json_t *obj, const char *key, const char *where, double *out, bool required, mc_err *err);
/* A finite number > 0. */
int mc_json_positive(const json_t *obj, const char *key, const char *where, double *out, bool required, mc_err *err);
/* A finite number in [lo, hi]. */
int mc_json_number_range(const json_t *obj, const char *key, const char *where, double lo, double hi, double *out,
			 bool required, mc_err *err);
/* An integer in [lo, hi]; a real with an integral value (e.g. 256.0) is accepted. */
int mc_json_int(const json_t *obj, const char *key, const char *where, long long lo, long long hi, int *out,
		bool required, mc_err *err);
int mc_json_bool(const json_t *obj, const char *key, const char *where, bool *out, bool required, mc_err *err);
/* A string of at most cap-1 bytes (longer strings are an error, not cut). */
int mc_json_string(const json_t *obj, const char *key, const char *where, char *out, size_t cap, bool required,
		   mc_err *err);
/* An array of exactly n finite numbers. */
int mc_json_numbers(const json_t *obj, const char *key, const char *where, double *out, size_t n, bool required,
		    mc_err *err);
/* An array of 1..max finite numbers; *n receives the length. */
int mc_json_numbers_var(const json_t *obj, const char *key, const char *where, double *out, size_t max, size_t *n,
			bool required, mc_err *err);
/* [x, y, z]. */
int mc_json_vec3(const json_t *obj, const char *key, const char *where, mc_vec3 *out, bool required, mc_err *err);
/* A 4x4 matrix as 4 rows of 4 numbers, or 16 numbers row-major. */
int mc_json_mat4(const json_t *obj, const char *key, const char *where, double out[4][4], bool required, mc_err *err);
/* A 3x3 matrix as 3 rows of 3 numbers, or 9 numbers row-major. */
int mc_json_mat3(const json_t *obj, const char *key, const char *where, mc_mat3 *out, bool required, mc_err *err);
/* An array with min..max elements (borrowed reference). */
int mc_json_array(const json_t *obj, const char *key, const char *where, size_t min, size_t max, json_t **out,
		  bool required, mc_err *err);
/* An object (borrowed reference). */
int mc_json_object(const json_t *obj, const char *key, const char *where, json_t **out, bool required, mc_err *err);

/* Rejects members of obj not listed in `allowed` (NULL-terminated), so that a
 * misspelt optional field is an error rather than silently ignored. */
int mc_json_check_keys(const json_t *obj, const char *where, const char *const *allowed, mc_err *err);

/* Writes root to path (pretty-printed, keys in insertion order), atomically
 * and synced (mc_file_write_atomic). */
int mc_json_save_file(const json_t *root, const char *path, mc_err *err);

#endif
