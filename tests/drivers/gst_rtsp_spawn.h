/* gst_rtsp_spawn: starts the loopback RTSP server (gst_rtsp_serve) for
 * the programs that stream from it: test_gstreamer_rtsp and the soak's
 * gstreamer case (tests/soak/soak_gst.c).  No GStreamer needed here. */
#ifndef GST_RTSP_SPAWN_H
#define GST_RTSP_SPAWN_H

#include <stdio.h>
#include <sys/types.h>
#include <unistd.h>

/* Starts the server program `exe` on `port` (0: any free port) with
 * `mode` ("" or one of its modes: "auth", "offclock"), sets *pid, and
 * returns the port it listens on (read from its "PORT n" line), or -1. */
static inline int gst_rtsp_spawn(const char *exe, int port, const char *mode, pid_t *pid)
{
	char arg[16];
	snprintf(arg, sizeof arg, "%d", port);
	int fds[2];
	if (pipe(fds) != 0)
		return -1;
	*pid = fork();
	if (*pid == 0) {
		dup2(fds[1], STDOUT_FILENO);
		close(fds[0]);
		execl(exe, exe, arg, mode[0] ? mode : (char *)NULL, (char *)NULL);
		_exit(127);
	}
	close(fds[1]);
	FILE *f = fdopen(fds[0], "r");
	int got = -1;
	if (!f || fscanf(f, "PORT %d", &got) != 1)
		got = -1;
	if (f)
		fclose(f);
	return got;
}

#endif
