/* test_aravis: the aravis driver plugin against arv-fake-gv-camera-0.8, a fake
 * GigE Vision camera that speaks real GVCP/GVSP over UDP on loopback.
 *
 * The test runs in a network namespace of its own when it may (root, or an
 * unprivileged user namespace), so that parallel runs each get their own
 * 127.0.0.1:3956; otherwise it takes a lock file and shares the host's
 * loopback.  Checks: discovery, config errors, pixel formats and sizes, frame
 * rate and timestamps, packet size, software and hardware trigger modes,
 * stop/start, a camera that stops answering, a camera killed mid-stream and
 * started again. */
#include <errno.h>
#include <fcntl.h>
#include <net/if.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include "drv_check.h"
#include "test_util.h"

#define FAKE_BIN "arv-fake-gv-camera-0.8"
#define SERIAL "MC0001"
#define ID "Aravis-Fake-" SERIAL

static drv_harness H;
static pid_t fake_pid = -1;
static uint8_t frame_buf[4 << 20];
static unsigned long long last_ts; /* timestamp of the last frame pulled */

static void write_file(const char *path, const char *text)
{
	int fd = open(path, O_WRONLY);
	if (fd >= 0) {
		if (write(fd, text, strlen(text)) < 0)
			perror(path);
		close(fd);
	}
}

/* A private network namespace with its loopback up; 0 on success. */
static int private_loopback(void)
{
	uid_t uid = getuid();
	gid_t gid = getgid();
	if (unshare(CLONE_NEWNET) != 0) {
		if (unshare(CLONE_NEWUSER | CLONE_NEWNET) != 0)
			return -1;
		char map[64];
		write_file("/proc/self/setgroups", "deny");
		snprintf(map, sizeof map, "0 %u 1", (unsigned)uid);
		write_file("/proc/self/uid_map", map);
		snprintf(map, sizeof map, "0 %u 1", (unsigned)gid);
		write_file("/proc/self/gid_map", map);
	}
	int s = socket(AF_INET, SOCK_DGRAM, 0);
	if (s < 0)
		return -1;
	struct ifreq ifr;
	memset(&ifr, 0, sizeof ifr);
	snprintf(ifr.ifr_name, sizeof ifr.ifr_name, "lo");
	int rc = ioctl(s, SIOCGIFFLAGS, &ifr);
	if (rc == 0) {
		ifr.ifr_flags |= IFF_UP | IFF_RUNNING;
		rc = ioctl(s, SIOCSIFFLAGS, &ifr);
	}
	close(s);
	return rc;
}

static int in_path(const char *bin)
{
	char cmd[256];
	snprintf(cmd, sizeof cmd, "command -v %s >/dev/null 2>&1", bin);
	return system(cmd) == 0;
}

static void start_fake(void)
{
	fake_pid = fork();
	if (fake_pid == 0) {
		int null = open("/dev/null", O_WRONLY);
		if (null >= 0) {
			dup2(null, STDOUT_FILENO);
			dup2(null, STDERR_FILENO);
		}
		execlp(FAKE_BIN, FAKE_BIN, "-i", "127.0.0.1", "-s", SERIAL, (char *)NULL);
		_exit(127);
	}
}

static void kill_fake(void)
{
	if (fake_pid > 0) {
		kill(fake_pid, SIGCONT);
		kill(fake_pid, SIGKILL);
		waitpid(fake_pid, NULL, 0);
	}
	fake_pid = -1;
}

static void on_exit_kill(void)
{
	kill_fake();
}

/* Waits until discovery lists the fake camera; 1 if it did. */
static int wait_for_camera(double seconds)
{
	mdrv_device_info info[16];
	char err[512];
	unsigned long long end = drv_harness_now_ns() + (unsigned long long)(seconds * 1e9);
	while (drv_harness_now_ns() < end) {
		int n = H.drv->probe(&H.host, info, 16, err, sizeof err);
		for (int i = 0; i < n; i++)
			if (!strcmp(info[i].serial, SERIAL))
				return 1;
		usleep(100000);
	}
	return 0;
}

static void base_config(void)
{
	drv_harness_clear(&H);
	drv_harness_set(&H, "device", ID);
}

/* Opens with the current config and expects failure with a message
 * containing `needle` (open() returns no status, only NULL and the message). */
static void expect_open_error(const char *needle)
{
	drv_check_open_error(&H, "aravis: ", needle);
}

static void test_probe(void)
{
	mdrv_device_info info[16];
	char err[512];
	int n = H.drv->probe(&H.host, info, 16, err, sizeof err);
	CHECK_MSG(n >= 1, "probe found %d cameras (%s)", n, err);
	int found = 0;
	for (int i = 0; i < n; i++) {
		if (strcmp(info[i].serial, SERIAL))
			continue;
		found = 1;
		CHECK(!strcmp(info[i].id, ID));
		CHECK(strstr(info[i].name, "Fake") != NULL);
		CHECK(strstr(info[i].bus_info, "127.0.0.1") != NULL);
	}
	CHECK(found);
}

static void test_config_errors(void)
{
	static const drv_bad_config bad[] = {
		/* MDRV_ERR_CONFIG */
		{{NULL}, "'device'"},
		{{"device", ID, "pixel_format", "YUV9"}, "Mono8"},
		{{"device", ID, "fps", "5000"}, "'fps'"},
		{{"device", ID, "packet_size", "100"}, "'packet_size'"},
		{{"device", ID, "trigger", "Line7"}, "Line0"},
		{{"device", ID, "width", "320"}, "'height'"},
		{{"device", ID, "exposure", "fast"}, "'exposure'"},
		/* MDRV_ERR_NODEV */
		{{"serial", "NOPE42"}, "NOPE42"},
		{{"device", "Aravis-Fake-NOPE42"}, "NOPE42"},
	};
	drv_check_open_errors(&H, "aravis: ", bad, sizeof bad / sizeof bad[0]);
}

/* Pulls `n` frames, checking size and flags; fills timestamps and sequences. */
static int pull(void *dev, int n, unsigned long long *ts, unsigned long long *seq, const mdrv_format *fmt)
{
	char err[512];
	int got = 0;
	for (int i = 0; i < n; i++) {
		mdrv_frame f;
		int st = drv_harness_frame(&H, dev, &f, frame_buf, sizeof frame_buf, 2000, err, sizeof err);
		unsigned long long now = drv_harness_now_ns();
		CHECK_MSG(st == MDRV_OK, "frame %d: status %d: %s", i, st, err);
		if (st != MDRV_OK)
			break;
		CHECK_MSG(f.bytesused == (size_t)fmt->stride * fmt->height, "bytesused %zu", f.bytesused);
		CHECK_MSG(f.flags == 0, "flags 0x%x", f.flags);
		CHECK(f.format.pixfmt == fmt->pixfmt && f.format.width == fmt->width);
		/* stamped on arrival of the first packet: a little in the past */
		CHECK_MSG(f.timestamp_ns <= now && f.timestamp_ns + 500000000ull > now,
			  "timestamp %llu vs now %llu", (unsigned long long)f.timestamp_ns, now);
		last_ts = f.timestamp_ns;
		if (ts)
			ts[i] = f.timestamp_ns;
		if (seq)
			seq[i] = f.sequence;
		got++;
	}
	return got;
}

/* Opens and starts the camera in Mono8 and pulls `frames` frames; NULL when
 * it does not open (a failed check). */
static void *open_mono8(mdrv_format *fmt, int frames)
{
	char err[512];
	base_config();
	drv_harness_set(&H, "pixel_format", "Mono8");
	void *dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "%s", err);
	if (!dev)
		return NULL;
	H.drv->get_format(dev, fmt, err, sizeof err);
	CHECK_MSG(pull(dev, frames, NULL, NULL, fmt) == frames, "%d frames", frames);
	return dev;
}

static void test_format(const char *name, uint32_t pixfmt, unsigned bpp)
{
	char err[512];
	base_config();
	drv_harness_set(&H, "pixel_format", name);
	drv_harness_set(&H, "width", "320");
	drv_harness_set(&H, "height", "240");
	void *dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "%s: %s", name, err);
	if (!dev)
		return;
	mdrv_format fmt;
	CHECK(H.drv->get_format(dev, &fmt, err, sizeof err) == MDRV_OK);
	CHECK_MSG(fmt.pixfmt == pixfmt, "%s: pixfmt %u", name, fmt.pixfmt);
	CHECK(fmt.width == 320 && fmt.height == 240);
	CHECK(fmt.stride == 320 * bpp);
	CHECK(fmt.max_bytes >= (size_t)fmt.stride * fmt.height);
	CHECK_NEAR(fmt.fps, 25.0, 0.5); /* the fake camera's default */
	CHECK_MSG(pull(dev, 3, NULL, NULL, &fmt) == 3, "%s: frames", name);
	/* the fake camera draws a pattern, not a blank image */
	size_t nonzero = 0;
	for (size_t i = 0; i < (size_t)fmt.stride * fmt.height; i++)
		nonzero += frame_buf[i] != 0;
	CHECK_MSG(nonzero > 1000, "%s: %zu non-zero bytes", name, nonzero);
	H.drv->stop(dev);
	H.drv->close(dev);
}

static int cmp_ull(const void *a, const void *b)
{
	unsigned long long x = *(const unsigned long long *)a, y = *(const unsigned long long *)b;
	return x < y ? -1 : x > y;
}

static void test_frame_rate(double fps)
{
	char err[512], val[32];
	base_config();
	drv_harness_set(&H, "pixel_format", "Mono8");
	drv_harness_set(&H, "width", "256");
	drv_harness_set(&H, "height", "128");
	snprintf(val, sizeof val, "%g", fps);
	drv_harness_set(&H, "fps", val);
	void *dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "fps %g: %s", fps, err);
	if (!dev)
		return;
	mdrv_format fmt;
	H.drv->get_format(dev, &fmt, err, sizeof err);
	CHECK_NEAR(fmt.fps, fps, fps * 0.01);
	enum { N = 12 };
	unsigned long long ts[N], seq[N], dt[N - 1];
	int got = pull(dev, N, ts, seq, &fmt);
	CHECK(got == N);
	if (got == N) {
		for (int i = 1; i < N; i++) {
			CHECK_MSG(ts[i] > ts[i - 1], "timestamps must increase");
			CHECK_MSG(seq[i] == seq[i - 1] + 1, "sequence %llu after %llu", seq[i], seq[i - 1]);
			dt[i - 1] = ts[i] - ts[i - 1];
		}
		qsort(dt, N - 1, sizeof dt[0], cmp_ull);
		double median = (double)dt[(N - 1) / 2] * 1e-9;
		printf("fps %g: median frame interval %.2f ms\n", fps, median * 1e3);
		CHECK_NEAR(median, 1.0 / fps, 0.15 / fps);
	}
	H.drv->stop(dev);
	H.drv->close(dev);
}

static void test_packet_size(const char *size, const char *expect_log)
{
	char err[512];
	base_config();
	drv_harness_set(&H, "pixel_format", "Mono8");
	drv_harness_set(&H, "packet_size", size);
	void *dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "packet_size %s: %s", size, err);
	if (!dev)
		return;
	CHECK_MSG(drv_harness_logged(&H, expect_log), "log should contain '%s'", expect_log);
	mdrv_format fmt;
	H.drv->get_format(dev, &fmt, err, sizeof err);
	CHECK(pull(dev, 3, NULL, NULL, &fmt) == 3);
	H.drv->stop(dev);
	H.drv->close(dev);
}

static void test_triggers(void)
{
	char err[512];
	/* software trigger: a frame is exposed only when asked for.  The camera
	 * could run at 25 fps, but after idle spells no stale frames are queued:
	 * each frame is stamped after its request, and none is skipped. */
	base_config();
	drv_harness_set(&H, "pixel_format", "Mono8");
	drv_harness_set(&H, "fps", "25");
	drv_harness_set(&H, "trigger", "software");
	void *dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "software trigger: %s", err);
	if (dev) {
		mdrv_format fmt;
		H.drv->get_format(dev, &fmt, err, sizeof err);
		CHECK(fmt.fps == 0); /* paced by the trigger */
		unsigned long long prev_seq = 0;
		for (int i = 0; i < 3; i++) {
			usleep(300000);
			unsigned long long t_req = drv_harness_now_ns(), seq;
			if (pull(dev, 1, NULL, &seq, &fmt) != 1)
				break;
			if (i > 0)
				CHECK_MSG(seq == prev_seq + 1, "sequence %llu after %llu", seq, prev_seq);
			prev_seq = seq;
			CHECK_MSG(last_ts >= t_req, "frame %d stamped %.1f ms before its trigger", i,
				  (double)(t_req - last_ts) * 1e-6);
		}
		H.drv->stop(dev);
		H.drv->close(dev);
	}
	/* hardware trigger on a line nothing drives: no frames, but the camera
	 * is alive, so the driver says timeout, not unplugged */
	base_config();
	drv_harness_set(&H, "trigger", "Line0");
	dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "Line0 trigger: %s", err);
	if (dev) {
		int timeouts = 0;
		for (int i = 0; i < 6; i++) {
			mdrv_frame f;
			int st = drv_harness_frame(&H, dev, &f, frame_buf, sizeof frame_buf, 300, err, sizeof err);
			CHECK_MSG(st == MDRV_ERR_TIMEOUT, "Line0: status %d (%s)", st, err);
			timeouts += st == MDRV_ERR_TIMEOUT;
		}
		CHECK(timeouts == 6);
		H.drv->stop(dev);
		H.drv->close(dev);
	}
}

static void test_stop_start(void)
{
	char err[512];
	mdrv_format fmt;
	void *dev = open_mono8(&fmt, 2);
	if (!dev)
		return;
	H.drv->stop(dev);
	CHECK(H.drv->start(dev, err, sizeof err) == MDRV_OK);
	CHECK(pull(dev, 2, NULL, NULL, &fmt) == 2);
	H.drv->stop(dev);
	H.drv->close(dev);
}

/* Pulls frames until an error other than a timeout; returns it and the
 * seconds it took to come. */
static int pull_until_error(void *dev, double limit_s, double *took, char *err, size_t errlen)
{
	unsigned long long t0 = drv_harness_now_ns();
	int st = MDRV_OK;
	while ((double)(drv_harness_now_ns() - t0) * 1e-9 < limit_s) {
		mdrv_frame f;
		st = drv_harness_frame(&H, dev, &f, frame_buf, sizeof frame_buf, 200, err, errlen);
		if (st != MDRV_OK && st != MDRV_ERR_TIMEOUT)
			break;
	}
	*took = (double)(drv_harness_now_ns() - t0) * 1e-9;
	return st;
}

/* The camera process freezes (SIGSTOP): it no longer answers, which is what a
 * camera that lost power or link looks like. */
static void test_camera_stops_answering(void)
{
	char err[512];
	mdrv_format fmt;
	void *dev = open_mono8(&fmt, 2);
	if (!dev)
		return;
	kill(fake_pid, SIGSTOP);
	double took;
	int st = pull_until_error(dev, 15, &took, err, sizeof err);
	printf("camera frozen: status %d after %.2f s: %s\n", st, took, err);
	CHECK_MSG(st == MDRV_ERR_NODEV, "status %d: %s", st, err);
	CHECK(strstr(err, ID) != NULL);
	H.drv->stop(dev);
	H.drv->close(dev);
	kill(fake_pid, SIGCONT);
}

/* The camera dies mid-stream and a new one comes up: the driver reports
 * the loss, and a fresh open streams again. */
static void test_restart(void)
{
	char err[512];
	kill_fake();
	start_fake();
	CHECK_MSG(wait_for_camera(10), "fake camera did not come back");
	mdrv_format fmt;
	void *dev = open_mono8(&fmt, 2);
	if (!dev)
		return;
	kill_fake();
	double took;
	int st = pull_until_error(dev, 15, &took, err, sizeof err);
	printf("camera killed: status %d after %.2f s: %s\n", st, took, err);
	CHECK_MSG(st == MDRV_ERR_NODEV, "status %d: %s", st, err);
	H.drv->stop(dev);
	H.drv->close(dev);

	/* opening while it is away fails cleanly */
	expect_open_error(ID); /* MDRV_ERR_NODEV */

	start_fake();
	CHECK_MSG(wait_for_camera(10), "fake camera did not come back");
	dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "reopen: %s", err);
	if (!dev)
		return;
	H.drv->get_format(dev, &fmt, err, sizeof err);
	CHECK(pull(dev, 3, NULL, NULL, &fmt) == 3);
	H.drv->stop(dev);
	H.drv->close(dev);
}

/* Runs one step and prints how long it took. */
#define TIMED(call)                                                                      \
	do {                                                                             \
		unsigned long long t0_ = drv_harness_now_ns();                           \
		call;                                                                    \
		printf("%-45s %6.2f s\n", #call, (double)(drv_harness_now_ns() - t0_) * 1e-9); \
	} while (0)

int main(void)
{
	if (!in_path(FAKE_BIN))
		TEST_SKIP("%s not found (Debian package aravis-tools)", FAKE_BIN);
	/* Before any thread exists: namespaces need a single-threaded process. */
	int lock_fd = -1;
	if (private_loopback() != 0) {
		printf("no private network namespace (%s); sharing the host's loopback under a lock\n",
		       strerror(errno));
		lock_fd = open("/tmp/mocapd-test-aravis.lock", O_CREAT | O_RDWR, 0666);
		if (lock_fd < 0 || flock(lock_fd, LOCK_EX) != 0)
			TEST_SKIP("cannot take /tmp/mocapd-test-aravis.lock");
	}
	drv_check_load(&H, "aravis");
	atexit(on_exit_kill);
	start_fake();
	if (!wait_for_camera(10)) {
		fprintf(stderr, "the fake camera never showed up in discovery\n");
		return 1;
	}
	TIMED(test_probe());
	TIMED(test_config_errors());
	TIMED(test_format("Mono8", MC_PIXFMT_GRAY8, 1));
	TIMED(test_format("BayerRG8", MC_PIXFMT_BAYER_RGGB8, 1));
	TIMED(test_format("BayerBG8", MC_PIXFMT_BAYER_BGGR8, 1));
	TIMED(test_format("RGB8", MC_PIXFMT_RGB24, 3));
	TIMED(test_frame_rate(10));
	TIMED(test_frame_rate(40));
	TIMED(test_packet_size("576", "packet size 576 bytes"));
	TIMED(test_packet_size("auto", "packet size"));
	TIMED(test_triggers());
	TIMED(test_stop_start());
	TIMED(test_camera_stops_answering());
	TIMED(test_restart());
	kill_fake();
	drv_harness_unload(&H);
	return mc_test_finish("test_aravis");
}
