/* bench_gstreamer: CPU time of the gstreamer driver delivering every frame
 * of a video file (pace asap, so that the clip's length in frames, not the
 * wall clock, sets the work), for docs/BENCHMARKS.md "GStreamer driver".
 * Usage: bench_gstreamer FILE [FORMAT]; prints frames, the clip's length
 * and the process's CPU time (all threads: decoder, conversion, copy).
 * `make bench-gstreamer` makes a 1280x720 30 fps H.264 clip and compares
 * this with gst-launch-1.0 decoding the same clip to a fakesink. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "drv_check.h"

static double cpu_seconds(void)
{
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	return (double)ru.ru_utime.tv_sec + ru.ru_utime.tv_usec / 1e6 + (double)ru.ru_stime.tv_sec +
	       ru.ru_stime.tv_usec / 1e6;
}

int main(int argc, char **argv)
{
	if (argc < 2) {
		fprintf(stderr, "usage: %s FILE [FORMAT]\n", argv[0]);
		return 2;
	}
	drv_harness h;
	drv_check_load(&h, "gstreamer");
	h.quiet = 1;
	drv_harness_set(&h, "uri", argv[1]);
	drv_harness_set(&h, "pace", "asap");
	drv_harness_set(&h, "format", argc > 2 ? argv[2] : "rgb24");
	char err[1024];
	size_t cap = 64 << 20;
	uint8_t *buf = malloc(cap);
	double c0 = cpu_seconds();
	unsigned long long t0 = drv_harness_now_ns();
	void *dev = drv_harness_open_start(&h, err, sizeof err);
	if (!dev || !buf) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	mdrv_frame f;
	int n = 0, rc;
	double fps = 0;
	while ((rc = drv_harness_frame(&h, dev, &f, buf, cap, 5000, err, sizeof err)) == MDRV_OK) {
		fps = f.format.fps;
		n++;
	}
	h.drv->stop(dev);
	h.drv->close(dev);
	double cpu = cpu_seconds() - c0, wall = (double)(drv_harness_now_ns() - t0) / 1e9;
	double clip = fps > 0 ? n / fps : 0;
	printf("%d frames (%.2f s of video) in %.2f s wall, %.2f s CPU: %.1f %% of one core at the clip's rate (%s)\n",
	       n, clip, wall, cpu, clip > 0 ? 100 * cpu / clip : 0, rc == MDRV_ERR_END ? "to the end" : err);
	free(buf);
	drv_harness_unload(&h);
	return rc == MDRV_ERR_END ? 0 : 1;
}
