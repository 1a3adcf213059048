/* textbuf: appending printf-style pieces to a fixed-size text buffer, for
 * the one-line texts the daemon prints (frame lines in publish.c, status
 * lines in status.c).  A text that does not fit is cut, never overrun. */
#ifndef MCD_TEXTBUF_H
#define MCD_TEXTBUF_H

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>

/* Appends to buf (cap bytes, text so far *len bytes) and advances *len; when
 * the piece does not fit, the text is cut at cap - 1 and *len stays there. */
static inline __attribute__((format(printf, 4, 5))) void mcd_appendf(char *buf, size_t cap, size_t *len,
								      const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	int w = vsnprintf(buf + *len, cap > *len ? cap - *len : 0, fmt, ap);
	va_end(ap);
	if (w > 0)
		*len = *len + (size_t)w < cap ? *len + (size_t)w : (cap ? cap - 1 : 0);
}

#endif
