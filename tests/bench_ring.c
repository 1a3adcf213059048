/* Benchmark of core/ring/mc_ring: two 1280x1024 YUYV cameras at 60 fps.
 *
 * Each camera has a producer thread paced at 60 Hz (absolute deadlines) that
 * copies a full frame into a ring slot, as a V4L2 driver copying out of its
 * mmap buffer would, and a reader thread that blocks on the ring's futex and
 * copies every frame out.  Printed: throughput, commit -> read latency
 * (p50/p99/max, from the ring's commit timestamp to the end of the reader's
 * copy), frames missed, and CPU time (getrusage) per thread and in total.
 *
 * Usage: bench_ring [seconds] (default 5). */
#include "ring/mc_ring.h"
#include "base/mc_stats.h"
#include "base/mc_time.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#define WIDTH 1280
#define HEIGHT 1024
#define FRAME_BYTES ((size_t)WIDTH * HEIGHT * 2) /* YUYV: 2 bytes per pixel */
#define FPS 60.0
#define NCAMS 2
#define NSLOTS 4

typedef struct {
	mc_ring *ring;
	int frames_to_write;
	/* results */
	double producer_cpu_s, reader_cpu_s;
	uint64_t read, missed, torn, bad;
	double *latency_us; /* one per frame read */
	atomic_int producer_done;
} camera;

static double thread_cpu_s(void)
{
	struct rusage ru;
	getrusage(RUSAGE_THREAD, &ru);
	return (double)ru.ru_utime.tv_sec + (double)ru.ru_stime.tv_sec +
	       ((double)ru.ru_utime.tv_usec + (double)ru.ru_stime.tv_usec) * 1e-6;
}

static void *producer(void *arg)
{
	camera *cam = arg;
	uint8_t *source = malloc(FRAME_BYTES); /* stands for the driver's DMA buffer */
	memset(source, 0x80, FRAME_BYTES);
	uint64_t period = (uint64_t)(1e9 / FPS);
	uint64_t start = mc_now_ns();
	mc_err err;
	for (int i = 0; i < cam->frames_to_write; i++) {
		uint64_t due = start + (uint64_t)i * period;
		struct timespec ts = {.tv_sec = (time_t)(due / 1000000000ull), .tv_nsec = (long)(due % 1000000000ull)};
		clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
		size_t cap;
		uint8_t *slot = mc_ring_slot_begin(cam->ring, &cap);
		memcpy(slot, source, FRAME_BYTES);
		uint64_t seq = (uint64_t)i;
		memcpy(slot, &seq, sizeof(seq)); /* lets the reader check what it got */
		mc_ring_meta meta = {.timestamp_ns = due, .bytesused = FRAME_BYTES, .pixfmt = 3 /* YUYV */,
				     .width = WIDTH, .height = HEIGHT, .stride = WIDTH * 2};
		if (mc_ring_slot_commit(cam->ring, &meta, &err) != 0) {
			fprintf(stderr, "commit: %s\n", err.msg);
			break;
		}
	}
	cam->producer_cpu_s = thread_cpu_s();
	atomic_store(&cam->producer_done, 1);
	free(source);
	return NULL;
}

static void *reader(void *arg)
{
	camera *cam = arg;
	uint8_t *buf = malloc(FRAME_BYTES);
	mc_ring_cursor cur = mc_ring_cursor_now(cam->ring);
	mc_ring_meta meta;
	mc_err err;
	for (;;) {
		int rc = mc_ring_read_next(cam->ring, &cur, buf, FRAME_BYTES, &meta, &err);
		if (rc == MC_RING_FRAME) {
			uint64_t t = mc_now_ns();
			uint64_t seq;
			memcpy(&seq, buf, sizeof(seq));
			if (seq != meta.sequence)
				cam->bad++;
			cam->latency_us[cam->read++] = (double)(t - meta.commit_ns) * 1e-3;
		} else if (rc == MC_RING_NONE) {
			if (atomic_load(&cam->producer_done) && cur.next >= mc_ring_head(cam->ring))
				break;
			mc_ring_wait(cam->ring, &cur, 50, &err);
		} else if (rc < 0) {
			fprintf(stderr, "read: %s\n", err.msg);
			cam->bad++;
			break;
		}
	}
	cam->missed = cur.missed;
	cam->torn = cur.torn;
	cam->reader_cpu_s = thread_cpu_s();
	free(buf);
	return NULL;
}

int main(int argc, char **argv)
{
	double seconds = argc > 1 ? atof(argv[1]) : 5.0;
	if (!(seconds > 0 && seconds < 3600)) {
		fprintf(stderr, "usage: bench_ring [seconds]\n");
		return 2;
	}
	int nframes = (int)(seconds * FPS);
	camera cams[NCAMS];
	memset(cams, 0, sizeof(cams));
	mc_err err;
	for (int c = 0; c < NCAMS; c++) {
		char name[16];
		snprintf(name, sizeof(name), "cam%d", c);
		cams[c].ring = mc_ring_create(name, NSLOTS, FRAME_BYTES, &err);
		if (!cams[c].ring) {
			fprintf(stderr, "bench_ring: %s\n", err.msg);
			return 1;
		}
		cams[c].frames_to_write = nframes;
		cams[c].latency_us = calloc((size_t)nframes, sizeof(double));
		atomic_init(&cams[c].producer_done, 0);
	}
	struct rusage ru0, ru1;
	getrusage(RUSAGE_SELF, &ru0);
	uint64_t t0 = mc_now_ns();
	pthread_t th[2 * NCAMS];
	for (int c = 0; c < NCAMS; c++)
		pthread_create(&th[2 * c + 1], NULL, reader, &cams[c]);
	for (int c = 0; c < NCAMS; c++)
		pthread_create(&th[2 * c], NULL, producer, &cams[c]);
	for (int i = 0; i < 2 * NCAMS; i++)
		pthread_join(th[i], NULL);
	double wall = (double)(mc_now_ns() - t0) * 1e-9;
	getrusage(RUSAGE_SELF, &ru1);
	double cpu = (double)(ru1.ru_utime.tv_sec - ru0.ru_utime.tv_sec) + (double)(ru1.ru_stime.tv_sec - ru0.ru_stime.tv_sec) +
		     ((double)(ru1.ru_utime.tv_usec - ru0.ru_utime.tv_usec) + (double)(ru1.ru_stime.tv_usec - ru0.ru_stime.tv_usec)) * 1e-6;

	printf("bench_ring: %d cameras, %dx%d YUYV (%.2f MB/frame), %.0f fps, %d slots, %.1f s\n", NCAMS, WIDTH, HEIGHT,
	       FRAME_BYTES / 1e6, FPS, NSLOTS, wall);
	int failed = 0;
	uint64_t total_read = 0;
	for (int c = 0; c < NCAMS; c++) {
		camera *cam = &cams[c];
		mc_stats_sort(cam->latency_us, cam->read);
		printf("  cam%d: %llu/%d frames read, %llu missed, %llu torn, %llu bad; latency commit->read "
		       "p50 %.1f us, p99 %.1f us, max %.1f us; cpu producer %.3f s, reader %.3f s\n",
		       c, (unsigned long long)cam->read, nframes, (unsigned long long)cam->missed,
		       (unsigned long long)cam->torn, (unsigned long long)cam->bad, mc_stats_percentile(cam->latency_us, cam->read, 50),
		       mc_stats_percentile(cam->latency_us, cam->read, 99),
		       cam->read ? cam->latency_us[cam->read - 1] : 0.0, cam->producer_cpu_s, cam->reader_cpu_s);
		total_read += cam->read;
		failed |= cam->bad != 0;
		free(cam->latency_us);
		mc_ring_close(cam->ring);
	}
	printf("  throughput %.1f frames/s, %.1f MB/s read; process CPU %.3f s = %.1f%% of one core\n",
	       (double)total_read / wall, (double)total_read * FRAME_BYTES / 1e6 / wall, cpu, 100.0 * cpu / wall);
	return failed;
}
