/* mc_error: a fixed-size error message filled by functions that can fail.
 *
 * Loaders name the file and the field (or line and key) in the message, e.g.
 *   "config/rigs/ego.json: cameras[1].fx: must be a positive number"
 * so that the caller can print it as is.  No allocation, no global state. */
#ifndef MC_ERROR_H
#define MC_ERROR_H

#include <stddef.h>

typedef struct {
	char msg[512];
} mc_err;

/* printf-style; err may be NULL. Always returns -1 so that callers can write
 * `return mc_err_set(err, "...")`. */
int mc_err_set(mc_err *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prefixes the existing message with "prefix: ". Returns -1. */
int mc_err_prefix(mc_err *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* For command-line programs: prints "prog: message" on stderr and exits
 * with code. */
void mc_fail_exit(const char *prog, int code, const char *fmt, ...)
	__attribute__((format(printf, 3, 4), noreturn));

#endif
