/* log: the daemon's leveled logging to stderr.
 *
 * One line per message, written with a single write(2) so that lines from
 * different threads never interleave.  When stderr is connected to journald
 * (systemd sets $JOURNAL_STREAM to the stream's device:inode), every line
 * gets an sd-daemon "<N>" priority prefix instead of the level word, so that
 * the journal records the right priority.  The level can change at any time
 * (SIGHUP reload); it is the daemon's only piece of global logging state. */
#ifndef MCD_LOG_H
#define MCD_LOG_H

#include <stdbool.h>

/* The same numbers as MDRV_LOG_* in mdrv.h. */
enum { MCD_LOG_ERROR = 0, MCD_LOG_WARN = 1, MCD_LOG_INFO = 2, MCD_LOG_DEBUG = 3 };

/* Decides between plain and journald prefixes (call once, early). */
void mcd_log_init(void);
void mcd_log_set_level(int level);
bool mcd_log_enabled(int level);
/* "error", "warn", "info", "debug" -> level, or -1. */
int mcd_log_parse_level(const char *name);
const char *mcd_log_level_name(int level);

void mcd_log(int level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#define mcd_error(...) mcd_log(MCD_LOG_ERROR, __VA_ARGS__)
#define mcd_warn(...) mcd_log(MCD_LOG_WARN, __VA_ARGS__)
#define mcd_info(...) mcd_log(MCD_LOG_INFO, __VA_ARGS__)
#define mcd_debug(...) mcd_log(MCD_LOG_DEBUG, __VA_ARGS__)

#endif
