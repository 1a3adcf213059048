/* soak_gst: the gstreamer driver under the soak's fault checks (issue 33).
 * Usage: soak_gst SECONDS (at least 20; make soak-check runs 30).
 *
 * mocapd (started as tests/daemon/harness.h does, tracker off) runs two
 * gstreamer cameras:
 *   - "rtsp_tcp" and "rtsp_udp": /raw of the loopback RTSP server
 *     (build/tests/drivers/gst_rtsp_serve) over TCP and over UDP; every
 *     cycle (about 6 s) the server is killed with SIGKILL and started again
 *     on the same port 1 s later: over TCP the driver says NODEV at once,
 *     over UDP the frames stop and the host reopens after stall_timeout_ms;
 *     the host reopens both with backoff;
 *   - "video": an MKV of the demo clip's left camera (made here with
 *     gst-launch-1.0), pace = asap: it plays to its end in the first
 *     second and stays ended.
 * After every restart it waits for both RTSP cameras to stream again (new
 * frames, state ok) and, at the end of the cycle (seconds into the
 * stream), samples /proc/<mocapd> (VmRSS, Threads, fds).  Verdict:
 *   - every restart streams again within 10 s;
 *   - after the warm-up (the first two restarts: GStreamer starts its
 *     thread pools and caches, one more fd the first time) the daemon's fds
 *     and threads at the end (the fewest of the last three samples: a
 *     sample may catch one fd fewer or more for a moment, as one in 49
 *     restarts did) are no more than after the second restart, and its
 *     RSS grows by under 1 MB in all;
 *   - mocapd alive throughout and exiting 0 on SIGTERM.
 * mocapd runs with MALLOC_ARENA_MAX=1: every reopen starts new GStreamer
 * streaming threads, and glibc gives new threads arenas of their own (up to
 * 8 per core) whose free space counts in RSS; with the default, RSS grew
 * by 100-200 kB per restart for the first ten here, flattening out, with
 * one arena it is flat after the warm-up (+24 kB over five restarts), so a
 * leak shows.
 * Exit status 0 pass, 1 fail, 77 skip (not built, or a GStreamer element
 * missing).  Run from the repository root. */
#include "drivers/gst_rtsp_spawn.h"
#include "soak_util.h"

#include <signal.h>

#define CYCLE_MS 6000
#define AWAY_MS 1000
#define RECOVER_MS 10000
#define RSS_LIMIT_KB 1024
#define MAX_CYCLES 512
#define WARMUP 2 /* restarts */

static mcd_run run;
static char server_exe[PATH_MAX + 64];
static pid_t server = -1;

/* Starts the server on `port` (0: any) and returns the port it listens
 * on, -1 if it did not start. */
static int start_server(int port) { return gst_rtsp_spawn(server_exe, port, "", &server); }

static void stop_server(void)
{
	if (server > 0) {
		kill(server, SIGKILL);
		waitpid(server, NULL, 0);
	}
	server = -1;
}

/* Each RTSP camera's frames while it streams (state ok), -1 while not. */
static bool rtsp_frames(long long frames[2])
{
	static const char *const names[2] = {"rtsp_tcp", "rtsp_udp"};
	mocap_daemon_status st;
	frames[0] = frames[1] = -1;
	if (!soak_status(run.sock, &st))
		return false;
	for (int i = 0; i < st.ncams; i++)
		for (int k = 0; k < 2; k++)
			if (!strcmp(st.cams[i].name, names[k]) && st.cams[i].state == 0)
				frames[k] = (long long)st.cams[i].frames;
	return true;
}

/* Waits until both RTSP cameras stream frames newer than `after`; the
 * time it took in ms, or -1 after RECOVER_MS. */
static long wait_streaming(const long long after[2])
{
	uint64_t t0 = mcd_now_ms();
	while (mcd_now_ms() - t0 < RECOVER_MS) {
		mcd_run_read_notify(&run);
		long long n[2];
		if (rtsp_frames(n) && n[0] > after[0] + 3 && n[1] > after[1] + 3)
			return (long)(mcd_now_ms() - t0);
		mcd_sleep_ms(100);
	}
	return -1;
}

static bool make_mkv(const char *path)
{
	char cmd[PATH_MAX + 512];
	snprintf(cmd, sizeof cmd,
		 "gst-launch-1.0 -q imagesequencesrc location=tests/data/ego_demo/left/%%05d.jpg start-index=0 "
		 "stop-index=59 framerate=30/1 ! jpegparse ! matroskamux ! filesink location=%s", path);
	return system(cmd) == 0;
}

static bool have_elements(void)
{
	return system("for e in rtspsrc rtpvrawdepay rtpvrawpay imagesequencesrc jpegparse matroskamux matroskademux; do "
		      "gst-inspect-1.0 --exists $e || exit 1; done 2>/dev/null") == 0;
}

static int setup(int *port)
{
	if (!mcd_find_build_up(3))
		return 77;
	char gst_so[PATH_MAX + 64];
	snprintf(gst_so, sizeof gst_so, "%s/drivers/mocap-driver-gstreamer.so", mcd_build_dir);
	snprintf(server_exe, sizeof server_exe, "%s/tests/drivers/gst_rtsp_serve", mcd_build_dir);
	if (access(gst_so, R_OK) || access(server_exe, X_OK) || access("tests/data/ego_demo/left", R_OK)) {
		printf("soak_gst: needs %s, %s and tests/data/ego_demo (run from the repository root)\n", gst_so,
		       server_exe);
		return 77;
	}
	if (!have_elements()) {
		printf("soak_gst: a GStreamer element it needs is not installed\n");
		return 77;
	}
	if (!mcd_run_init(&run))
		return 1;
	char mkv[PATH_MAX], conf[4 * PATH_MAX];
	snprintf(mkv, sizeof mkv, "%s/left.mkv", run.dir);
	if (!make_mkv(mkv) || (*port = start_server(0)) <= 0) {
		printf("soak_gst: cannot make %s or start %s\n", mkv, server_exe);
		return 1;
	}
	snprintf(conf, sizeof conf,
		 "[daemon]\nplugin_dir = %s/drivers\nreopen_initial_ms = 100\nreopen_max_ms = 1000\n"
		 "stall_timeout_ms = 2000\nstatus_interval_s = 1\n[socket]\npath = @SOCK@\n[tracker]\nenabled = false\n"
		 "[camera rtsp_tcp]\ndriver = gstreamer\nuri = rtsp://127.0.0.1:%d/raw\nrtsp_transport = tcp\n"
		 "open_timeout = 3000\n"
		 "[camera rtsp_udp]\ndriver = gstreamer\nuri = rtsp://127.0.0.1:%d/raw\nrtsp_transport = udp\n"
		 "open_timeout = 3000\n"
		 "[camera video]\ndriver = gstreamer\nuri = %s\npace = asap\n",
		 mcd_build_dir, *port, *port, mkv);
	mcd_run_config(&run, conf);
	return 0;
}

int main(int argc, char **argv)
{
	setvbuf(stdout, NULL, _IOLBF, 0);
	signal(SIGPIPE, SIG_IGN);
	long secs = argc > 1 ? atol(argv[1]) : 30;
	if (secs < 20) {
		fprintf(stderr, "soak_gst: at least 20 s (got %ld)\n", secs);
		return 2;
	}
	int port = 0, rc = setup(&port);
	if (rc != 0) {
		stop_server();
		if (run.dir[0])
			mcd_run_cleanup(&run);
		return rc;
	}
	static const long long none[2] = {-4, -4};
	static const char *const env[] = {"MALLOC_ARENA_MAX=1", NULL};
	if (!mcd_run_start(&run, NULL, env) || !mcd_run_wait_notify(&run, "READY=1", 60000) || wait_streaming(none) < 0) {
		mcd_run_dump(&run, "start");
		stop_server();
		mcd_run_cleanup(&run);
		return 1;
	}
	printf("soak_gst: %ld s, mocapd pid %d, RTSP server on port %d killed every %d ms for %d ms\n", secs,
	       (int)run.pid, port, CYCLE_MS, AWAY_MS);
	static sample at[MAX_CYCLES];
	int cycles = 0, lost = 0;
	bool pass = true;
	uint64_t end = mcd_now_ms() + (uint64_t)secs * 1000;
	while (mcd_now_ms() + CYCLE_MS <= end && cycles < MAX_CYCLES && mcd_run_alive(&run)) {
		uint64_t cycle_end = mcd_now_ms() + CYCLE_MS;
		long long before[2];
		rtsp_frames(before);
		stop_server();
		mcd_sleep_ms(AWAY_MS);
		mcd_run_read_notify(&run);
		int again = start_server(port);
		long ms = again == port ? wait_streaming(before) : -1;
		while (mcd_now_ms() < cycle_end && mcd_run_alive(&run)) { /* streaming */
			mcd_run_read_notify(&run);
			mcd_sleep_ms(100);
		}
		sample *s = &at[cycles];
		sample_daemon(run.pid, s); /* settled: seconds into the stream */
		printf("cycle %d: server back on %d, streaming again after %ld ms; then rss %ld kB, %ld fds, %ld "
		       "threads\n", cycles + 1, again, ms, s->rss_kb, s->fds, s->threads);
		if (ms < 0) {
			printf("FAIL: cycle %d: the RTSP cameras did not both stream again within %d ms\n", cycles + 1,
			       RECOVER_MS);
			lost++;
		}
		cycles++;
	}
	bool alive = mcd_run_alive(&run);
	printf("\n---- soak_gst verdict: %d restarts ----\n", cycles);
	if (!alive)
		pass = false, printf("FAIL: mocapd died (wait status %d)\n", run.status);
	if (lost || cycles < WARMUP + 1)
		pass = false, printf("FAIL: %d of %d restarts did not stream again (%d needed)\n", lost, cycles, WARMUP + 1);
	const sample *base = &at[WARMUP - 1], *last = &at[cycles > 0 ? cycles - 1 : 0];
	long fds = base->fds, threads = base->threads; /* the fewest of the last three */
	for (int k = cycles - 3 > WARMUP ? cycles - 3 : WARMUP, first = k; k < cycles; k++) {
		fds = k == first || at[k].fds < fds ? at[k].fds : fds;
		threads = k == first || at[k].threads < threads ? at[k].threads : threads;
	}
	printf("fds %ld, threads %ld after the warm-up; at the end %ld and %ld\n", base->fds, base->threads, fds, threads);
	if (fds > base->fds || threads > base->threads)
		pass = false, printf("FAIL: the daemon holds more fds or threads than after the warm-up\n");
	long growth = cycles > WARMUP ? last->rss_kb - base->rss_kb : 0;
	printf("RSS after the warm-up (%d restarts) %ld kB, after the last %ld kB: growth %+ld kB (limit < %d kB)\n",
	       WARMUP, base->rss_kb, last->rss_kb, growth, RSS_LIMIT_KB);
#if defined(__SANITIZE_ADDRESS__)
	printf("RSS not judged: built with AddressSanitizer (its quarantine holds freed memory)\n");
#else
	if (growth >= RSS_LIMIT_KB)
		pass = false, printf("FAIL: RSS grew by %ld kB\n", growth);
#endif
	stop_server();
	if (alive) {
		mcd_run_signal(&run, SIGTERM);
		int exit_rc = mcd_run_wait_exit(&run, 20000);
		printf("mocapd exit status on SIGTERM: %d\n", exit_rc);
		if (exit_rc != 0)
			pass = false, printf("FAIL: mocapd did not exit 0\n");
	}
	if (!pass)
		mcd_run_dump(&run, "soak_gst");
	printf("VERDICT: %s\n", pass ? "PASS" : "FAIL");
	mcd_run_cleanup(&run);
	return pass ? 0 : 1;
}
