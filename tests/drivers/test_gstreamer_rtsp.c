/* test_gstreamer_rtsp: the gstreamer driver on RTSP from a loopback server
 * (gst_rtsp_serve, libgstrtspserver, 127.0.0.1 only):
 *   - /raw over TCP and over UDP: 64x48 RGB at about 30 fps; each frame
 *     carries the server's capture time (CLOCK_MONOTONIC), against which
 *     the driver's timestamps are measured for MOCAP_RTSP_SECONDS (7 by
 *     default; docs/BENCHMARKS_SYSTEM.md has 20 s runs): with
 *     rtsp_timestamps = sender (the default) every frame from the one the
 *     driver names (the server's first RTCP sender report) on is within
 *     5 ms of the capture, the ones before are arrival times; with
 *     rtsp_timestamps = arrival all are arrival times; with a server whose
 *     clock is not ours (`offclock`) the driver says so and keeps arrival
 *     times;
 *   - /h264: decoded to RGB (when x264enc is installed);
 *   - the server killed mid-stream: next_frame says MDRV_ERR_NODEV (TCP:
 *     the connection closes), opening while it is away fails with a
 *     status the host retries (NODEV, not CONFIG), and once a server
 *     listens on the port again, reopening streams (the host does this
 *     with backoff: daemon/capture.c);
 *   - a server that asks for credentials (a second gst_rtsp_serve): none
 *     or wrong ones give a permanent error (MDRV_ERR_CONFIG) saying
 *     unauthorised; the right ones in the URI stream;
 *   - nothing listening: a retried error (MDRV_ERR_NODEV). */
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <sys/wait.h>
#include <unistd.h>

#include "gst_rtsp_spawn.h"
#include "gst_test_util.h"

static drv_harness G;
static pid_t server = -1, auth_server = -1; /* auth_server: the second server (auth, offclock) */
static int port;
static uint8_t buf[1 << 20];

static void kill_wait(pid_t *pid)
{
	if (*pid > 0) {
		kill(*pid, SIGKILL);
		waitpid(*pid, NULL, 0);
	}
	*pid = -1;
}

static void stop_server(void) { kill_wait(&server); }

/* Starts gst_rtsp_serve (next to this program) on `want` (0: any), with
 * `mode` ("" or "auth"), and reads the port it listens on. */
static int start_server_as(int want, const char *mode, pid_t *pid)
{
	char exe[512], path[600];
	ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
	exe[n > 0 ? n : 0] = 0;
	char *slash = strrchr(exe, '/');
	if (slash)
		*slash = 0;
	snprintf(path, sizeof path, "%s/gst_rtsp_serve", exe);
	return gst_rtsp_spawn(path, want, mode, pid);
}

static int start_server(int want) { return start_server_as(want, "", &server); }

static void set_uri_port(const char *auth, int at, const char *mount, const char *transport)
{
	char uri[256];
	drv_harness_clear(&G);
	snprintf(uri, sizeof uri, "rtsp://%s127.0.0.1:%d/%s", auth, at, mount);
	drv_harness_set(&G, "uri", uri);
	drv_harness_set(&G, "rtsp_transport", transport);
	drv_harness_set(&G, "open_timeout", "5000");
}

static void set_uri(const char *auth, const char *mount, const char *transport)
{
	set_uri_port(auth, port, mount, transport);
}

static uint64_t server_time(const uint8_t *b)
{
	uint64_t t = 0;
	for (int i = 7; i >= 0; i--)
		t = t << 8 | b[i];
	return t;
}

/* Timestamp - server capture over a run of frames, ms. */
typedef struct {
	int frames;
	double lag_sum, lag_min, lag_max;
	double arrival_sum; /* delivery - server capture */
} lag_stats;

typedef struct {
	int frames;
	lag_stats arrival, sender; /* before and from the driver's first sender time */
	int after_delivery;        /* timestamps later than the frame's delivery */
	double interval_mean;      /* between timestamps, ms */
	long from;                 /* the first frame with the sender's time (-1: none) */
	double from_s;             /* its time after the first frame, s */
} rtsp_stats;

static void add_lag(lag_stats *l, double lag, double arrival)
{
	if (!l->frames)
		l->lag_min = l->lag_max = lag;
	l->frames++;
	l->lag_sum += lag;
	l->arrival_sum += arrival;
	l->lag_min = fmin(l->lag_min, lag);
	l->lag_max = fmax(l->lag_max, lag);
}

static void print_lags(const char *what, const lag_stats *l)
{
	if (l->frames)
		printf("  %s: %d frames, timestamp - server capture mean %.2f ms (%.2f..%.2f), delivery - server "
		       "capture mean %.2f ms\n", what, l->frames, l->lag_sum / l->frames, l->lag_min, l->lag_max,
		       l->arrival_sum / l->frames);
}

/* The frame from which the driver says its timestamps are the sender's. */
static long sender_from(void)
{
	static const char said[] = "capture times from frame ";
	const char *s = strstr(G.log, said);
	return s ? atol(s + sizeof said - 1) : -1;
}

/* Pulls n frames; with `stamped`, the driver's timestamps against the
 * server's capture times.  A frame the driver does not deliver (its time
 * went back when the first sender report came: MDRV_ERR_TIMEOUT at once)
 * is not counted. */
static rtsp_stats pull(void *dev, int n, int stamped, bool until_warned, mdrv_format *fmt)
{
	char err[1024];
	rtsp_stats st = {.from = -1};
	unsigned long long prev = 0, first = 0;
	int skipped = 0;
	for (int k = 0; k < n; k++) {
		mdrv_frame f;
		int rc = drv_harness_frame(&G, dev, &f, buf, sizeof buf, 2000, err, sizeof err);
		unsigned long long now = drv_harness_now_ns();
		if (rc == MDRV_ERR_TIMEOUT && skipped++ < 5) {
			k--;
			continue;
		}
		CHECK_MSG(rc == MDRV_OK, "frame %d: %d %s", k, rc, err);
		if (rc != MDRV_OK)
			break;
		*fmt = f.format;
		CHECK(f.timestamp_ns > prev);
		CHECK(f.bytesused == f.format.max_bytes);
		prev = f.timestamp_ns;
		if (k == 0)
			first = f.timestamp_ns;
		st.frames++;
		st.after_delivery += f.timestamp_ns > now;
		if (st.from < 0 && (st.from = sender_from()) >= 0)
			st.from_s = (double)(f.timestamp_ns - first) / 1e9;
		if (until_warned && drv_harness_logged(&G, "off ours"))
			n = k + 1; /* the report came and was refused: enough */
		if (!stamped)
			continue;
		double cap = (double)server_time(buf);
		bool sender = st.from >= 0 && (long)f.sequence >= st.from;
		add_lag(sender ? &st.sender : &st.arrival, ((double)f.timestamp_ns - cap) / 1e6, ((double)now - cap) / 1e6);
	}
	if (st.frames > 1)
		st.interval_mean = (double)(prev - first) / 1e6 / (st.frames - 1);
	if (stamped) {
		printf("  %d frames, mean interval %.2f ms, %d not delivered (stamped back)\n", st.frames,
		       st.interval_mean, skipped);
		print_lags("arrival times", &st.arrival);
		if (st.from >= 0)
			printf("  the sender's capture times from frame %ld on (%.2f s in)\n", st.from, st.from_s);
		print_lags("sender times", &st.sender);
	}
	return st;
}

static int seconds(void)
{
	const char *s = getenv("MOCAP_RTSP_SECONDS");
	return s && atoi(s) > 0 ? atoi(s) : 7;
}

static void *open_started(void)
{
	char err[1024];
	void *dev = drv_harness_open_start(&G, err, sizeof err);
	CHECK_MSG(dev != NULL, "open: %s", err);
	return dev;
}

static void close_dev(void *dev)
{
	if (dev) {
		G.drv->stop(dev);
		G.drv->close(dev);
	}
}

/* `stamps`: the value of rtsp_timestamps, "" for the default (sender);
 * `sender_clock`: whether the server's clock is ours. */
static void test_stream(const char *transport, const char *stamps, bool sender_clock)
{
	printf("/raw over %s%s%s%s\n", transport, stamps[0] ? ", rtsp_timestamps = " : "", stamps,
	       sender_clock ? "" : ", the server's clock off ours");
	set_uri("", "raw", transport);
	if (stamps[0])
		drv_harness_set(&G, "rtsp_timestamps", stamps);
	G.log[0] = 0;
	void *dev = open_started();
	if (!dev)
		return;
	mdrv_format fmt = {0};
	uint64_t frames;
	CHECK(G.drv->frame_count && G.drv->frame_count(dev, &frames) != MDRV_OK); /* live: no length */
	bool sender = !strcmp(stamps, "") || !strcmp(stamps, "sender");
	/* Arrival times alone: 2 s tell them; the server's first report
	 * comes 1-4 s in (RTCP's randomised interval). */
	int n = (sender ? seconds() : 2) * 30;
	rtsp_stats st = pull(dev, n, 1, sender && !sender_clock, &fmt);
	CHECK(fmt.pixfmt == MC_PIXFMT_RGB24 && fmt.width == 64 && fmt.height == 48);
	CHECK_MSG(st.frames > 0 && st.after_delivery == 0, "%d timestamps after delivery", st.after_delivery);
	/* Arrival times (before the first sender report, or all of them) are
	 * never before the server captured the frame. */
	CHECK_MSG(!st.arrival.frames || st.arrival.lag_min >= -1.0, "arrival time %.2f ms before the capture",
		  st.arrival.lag_min);
	if (sender && sender_clock) {
		CHECK_MSG(st.from >= 0 && st.sender.frames >= n / 4, "sender times from frame %ld, %d frames", st.from,
			  st.sender.frames);
		CHECK_MSG(st.sender.frames && st.sender.lag_min >= -5.0 && st.sender.lag_max <= 5.0,
			  "sender times %.2f..%.2f ms from the capture (target: within 5 ms)", st.sender.lag_min,
			  st.sender.lag_max);
	} else {
		CHECK_MSG(st.from < 0 && st.sender.frames == 0, "sender times from frame %ld", st.from);
	}
	if (sender && !sender_clock)
		CHECK_MSG(drv_harness_logged(&G, "the sender's clock is") && drv_harness_logged(&G, "off ours"),
			  "no warning that the sender's clock is not ours");
	/* 25 % tells 30 fps from 24 or 40 (arrival times on a loaded machine
	 * have been 12 % off). */
	CHECK_MSG(fabs(st.interval_mean - 1000.0 / 30) < 1000.0 / 30 * 0.25, "mean interval %.2f ms", st.interval_mean);
	close_dev(dev);
}

static void test_h264(void)
{
	if (!gst_test_have("x264enc") || !gst_test_have("avdec_h264")) {
		printf("/h264: x264enc or avdec_h264 not installed, not tested\n");
		return;
	}
	printf("/h264 over tcp\n");
	set_uri("", "h264", "tcp");
	void *dev = open_started();
	mdrv_format fmt = {0};
	if (dev)
		pull(dev, 30, 0, false, &fmt);
	CHECK(fmt.pixfmt == MC_PIXFMT_RGB24 && fmt.width == 320 && fmt.height == 240);
	close_dev(dev);
}

/* The server killed under a streaming camera, away, and back. */
static void test_server_killed(void)
{
	char err[1024];
	printf("server killed mid-stream (tcp)\n");
	set_uri("", "raw", "tcp");
	void *dev = open_started();
	if (!dev)
		return;
	mdrv_format fmt;
	pull(dev, 5, 0, false, &fmt);
	stop_server();
	unsigned long long t0 = drv_harness_now_ns();
	int rc = MDRV_OK, timeouts = 0;
	while (drv_harness_now_ns() - t0 < 10000000000ull) {
		mdrv_frame f;
		rc = drv_harness_frame(&G, dev, &f, buf, sizeof buf, 200, err, sizeof err);
		if (rc == MDRV_ERR_TIMEOUT)
			timeouts++;
		else if (rc != MDRV_OK)
			break;
	}
	printf("  after %.0f ms (%d timeouts): %d %s\n", (double)(drv_harness_now_ns() - t0) / 1e6, timeouts, rc, err);
	CHECK_MSG(rc == MDRV_ERR_NODEV, "a killed server should give NODEV, got %d", rc);
	close_dev(dev);

	printf("reopening while the server is away\n");
	gst_test_open_fails(&G, MDRV_ERR_NODEV, (const char *const[]){"config key 'uri'", "rtsp://", NULL});

	printf("server back on port %d\n", port);
	int again = start_server(port);
	CHECK_MSG(again == port, "server restarted on %d", again);
	dev = open_started();
	if (dev)
		CHECK(pull(dev, 10, 1, false, &fmt).frames == 10);
	close_dev(dev);
}

static void test_auth(void)
{
	int at = start_server_as(0, "auth", &auth_server);
	CHECK_MSG(at > 0, "the server with authentication did not start");
	if (at <= 0)
		return;
	printf("a server asking for credentials, none given\n");
	set_uri_port("", at, "raw", "tcp");
	gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"config key 'uri'", "nauthori", NULL});
	printf("wrong credentials\n");
	set_uri_port("mocap:wrong@", at, "raw", "tcp");
	gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"nauthori", NULL});
	printf("the right credentials in the URI\n");
	set_uri_port("mocap:secret@", at, "raw", "tcp");
	void *dev = open_started();
	mdrv_format fmt = {0};
	if (dev)
		CHECK(pull(dev, 5, 0, false, &fmt).frames == 5);
	CHECK(fmt.pixfmt == MC_PIXFMT_RGB24);
	close_dev(dev);
	kill_wait(&auth_server);
}

int main(void)
{
	static const char *const need[] = {"uridecodebin", "appsink",     "videoconvert", "rtspsrc",
					   "rtpvrawdepay", "rtpvrawpay",  "videotestsrc", "identity"};
	gst_test_require(need, sizeof need / sizeof need[0]);
	signal(SIGPIPE, SIG_IGN);
	drv_check_load(&G, "gstreamer");
	G.quiet = 1;
	port = start_server(0);
	if (port <= 0) {
		stop_server();
		fprintf(stderr, "gst_rtsp_serve did not start\n");
		return 1;
	}
	printf("server on 127.0.0.1:%d\n", port);
	test_stream("tcp", "", true);
	test_stream("udp", "", true);
	test_stream("udp", "arrival", true);
	printf("rtsp_timestamps = later\n");
	set_uri("", "raw", "tcp");
	drv_harness_set(&G, "rtsp_timestamps", "later");
	gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"rtsp_timestamps", "later", NULL});
	int own = port;
	port = start_server_as(0, "offclock", &auth_server);
	CHECK_MSG(port > 0, "the server with its clock off did not start");
	if (port > 0)
		test_stream("tcp", "", false);
	kill_wait(&auth_server);
	port = own;
	test_h264();
	test_auth();
	test_server_killed();
	stop_server();

	printf("nothing listening\n");
	set_uri("", "raw", "tcp");
	gst_test_open_fails(&G, MDRV_ERR_NODEV, (const char *const[]){"config key 'uri'", NULL});
	drv_harness_unload(&G);
	return mc_test_failures ? 1 : 0;
}
