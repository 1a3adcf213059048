#include "log.h"

#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static atomic_int log_level = MCD_LOG_INFO;
static atomic_bool log_journal = false;

static const char *const level_names[] = {"error", "warn", "info", "debug"};
/* syslog priorities: LOG_ERR, LOG_WARNING, LOG_INFO, LOG_DEBUG */
static const int level_priority[] = {3, 4, 6, 7};

void mcd_log_init(void)
{
	/* systemd documents this check: $JOURNAL_STREAM names the stream it
	 * connected, which stderr still is unless it was redirected. */
	const char *js = getenv("JOURNAL_STREAM");
	unsigned long long dev, ino;
	struct stat st;
	bool journal = js && sscanf(js, "%llu:%llu", &dev, &ino) == 2 && fstat(STDERR_FILENO, &st) == 0 &&
		       (unsigned long long)st.st_dev == dev && (unsigned long long)st.st_ino == ino;
	atomic_store(&log_journal, journal);
}

void mcd_log_set_level(int level)
{
	if (level < MCD_LOG_ERROR)
		level = MCD_LOG_ERROR;
	if (level > MCD_LOG_DEBUG)
		level = MCD_LOG_DEBUG;
	atomic_store(&log_level, level);
}

bool mcd_log_enabled(int level)
{
	return level <= atomic_load(&log_level);
}

int mcd_log_parse_level(const char *name)
{
	for (int i = 0; i < 4; i++)
		if (strcmp(name, level_names[i]) == 0)
			return i;
	if (strcmp(name, "warning") == 0)
		return MCD_LOG_WARN;
	return -1;
}

const char *mcd_log_level_name(int level)
{
	return level >= 0 && level < 4 ? level_names[level] : "?";
}

void mcd_log(int level, const char *fmt, ...)
{
	if (!mcd_log_enabled(level))
		return;
	if (level < 0)
		level = 0;
	if (level > 3)
		level = 3;
	char line[2048];
	int n;
	if (atomic_load(&log_journal))
		n = snprintf(line, sizeof(line), "<%d>", level_priority[level]);
	else
		n = snprintf(line, sizeof(line), "mocapd: %s: ", level_names[level]);
	va_list ap;
	va_start(ap, fmt);
	int m = vsnprintf(line + n, sizeof(line) - (size_t)n - 1, fmt, ap);
	va_end(ap);
	size_t len = (size_t)n + (m < 0 ? 0 : (size_t)m);
	if (len > sizeof(line) - 2)
		len = sizeof(line) - 2; /* cut, never overflow */
	/* Messages must stay one line each, and plain text: a driver's or a
	 * client's text (a STEER argument) could hold newlines, or an ESC
	 * that starts a terminal control sequence on the operator's screen.
	 * Every control byte (below 0x20, and DEL) becomes a space. */
	for (size_t i = (size_t)n; i < len; i++)
		if ((unsigned char)line[i] < 0x20 || line[i] == 0x7f)
			line[i] = ' ';
	line[len++] = '\n';
	ssize_t w = write(STDERR_FILENO, line, len);
	(void)w;
}
