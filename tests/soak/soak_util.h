/* soak_util: what the soak programs share (tests/soak/soak.c, the main
 * soak, and soak_gst.c, its gstreamer case): sampling the daemon's
 * /proc entries and asking it for its status. */
#ifndef SOAK_UTIL_H
#define SOAK_UTIL_H

#include "daemon/harness.h"
#include "mocap.h"

#include <dirent.h>

typedef struct {
	double t;
	long rss_kb, threads, fds;
} sample;

/* VmRSS, Threads and the open fds of process pid; false if it is gone. */
static inline bool sample_daemon(pid_t pid, sample *s)
{
	char path[64];
	snprintf(path, sizeof(path), "/proc/%d/status", (int)pid);
	FILE *f = fopen(path, "r");
	if (!f)
		return false;
	char line[256];
	s->rss_kb = s->threads = -1;
	while (fgets(line, sizeof(line), f)) {
		if (strncmp(line, "VmRSS:", 6) == 0)
			s->rss_kb = atol(line + 6);
		else if (strncmp(line, "Threads:", 8) == 0)
			s->threads = atol(line + 8);
	}
	fclose(f);
	snprintf(path, sizeof(path), "/proc/%d/fd", (int)pid);
	DIR *d = opendir(path);
	if (!d)
		return false;
	s->fds = 0;
	for (struct dirent *e; (e = readdir(d));)
		if (e->d_name[0] != '.')
			s->fds++;
	closedir(d);
	return s->rss_kb >= 0;
}

/* The daemon's status through a fresh connection to sock; false if
 * unavailable. */
static inline bool soak_status(const char *sock, mocap_daemon_status *st)
{
	mocap_client *c = mocap_connect(sock, "soak-main");
	if (!c)
		return false;
	bool ok = mocap_get_status(c, st) == 0;
	mocap_close(c);
	return ok;
}

/* A camera's STATUS state as mocapctl names it (mocap.h): 4, failed for
 * good, comes from protocol version 3 daemons, which libmocap speaks. */
static inline const char *camera_state_name(int state)
{
	static const char *const names[] = {"ok", "stalled", "error", "off", "failed"};
	return state >= 0 && state < 5 ? names[state] : "unknown";
}

static inline bool write_file(const char *path, const char *text)
{
	FILE *f = fopen(path, "w");
	if (!f)
		return false;
	bool ok = fputs(text, f) >= 0;
	return fclose(f) == 0 && ok;
}

#endif
