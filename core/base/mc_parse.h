/* mc_parse: numbers from text, for command lines, control requests and
 * config values, so that every reader accepts the same things. */
#ifndef MC_PARSE_H
#define MC_PARSE_H

#include <stdbool.h>

/* The whole of s as a finite number (strtod's syntax; nothing after it, no
 * overflow or underflow).  Returns false, *out unchanged, otherwise. */
bool mc_parse_double(const char *s, double *out);

#endif
