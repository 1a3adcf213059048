/* The systemd watchdog is fed from the pipeline's own progress: with
 * WATCHDOG_USEC set, mocapd sends WATCHDOG=1 while every pipeline thread
 * goes round its loop, stops when one is stuck (a driver that hangs in
 * next_frame), and starts again when it comes back.  A daemon that is not
 * asked for a watchdog sends none. */
#include "daemon/harness.h"
#include "test_util.h"

#define CONF                                 \
	"[daemon]\n"                         \
	"plugin_dir = @FAULTY@\n"            \
	"status_interval_s = 0.2\n"          \
	"[socket]\n"                         \
	"path = @SOCK@\n"                    \
	"[tracker]\n"                        \
	"enabled = false\n"                  \
	"[camera a]\n"                       \
	"driver = faulty\n"                  \
	"device = A\n"                       \
	"[camera b]\n"                       \
	"driver = faulty\n"                  \
	"device = B\n"

/* Times (ms since t0) at which WATCHDOG=1 arrived, read for `for_ms`. */
static int collect_pings(mcd_run *r, uint64_t t0, int for_ms, uint64_t *at, int max)
{
	int n = 0;
	uint64_t end = mcd_now_ms() + (uint64_t)for_ms;
	while (mcd_now_ms() < end) {
		struct pollfd p = {.fd = r->notify_fd, .events = POLLIN};
		poll(&p, 1, 20);
		char buf[4096];
		ssize_t len;
		while ((len = recv(r->notify_fd, buf, sizeof(buf) - 1, 0)) > 0) {
			buf[len] = 0;
			if (strstr(buf, "WATCHDOG=1") && n < max)
				at[n++] = mcd_now_ms() - t0;
		}
	}
	return n;
}

static int longest_gap(const uint64_t *at, int n, uint64_t from, uint64_t to)
{
	uint64_t prev = from, gap = 0;
	for (int i = 0; i < n; i++) {
		if (at[i] - prev > gap)
			gap = at[i] - prev;
		prev = at[i];
	}
	if (to > prev && to - prev > gap)
		gap = to - prev;
	return (int)gap;
}

static void test_pings_and_hang(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	/* camera b hangs inside next_frame for 2.5 s after 45 frames (1.5 s) */
	mcd_run_config(&r, CONF "hang_after = 45\nhang_ms = 2500\n");
	const char *const env[] = {"WATCHDOG_USEC=600000", NULL};
	uint64_t t0 = mcd_now_ms();
	CHECK(mcd_run_start(&r, NULL, env));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 10000));
	uint64_t at[256];
	int n = collect_pings(&r, t0, 5500, at, 256);
	/* healthy: a ping every 300 ms (half the period) */
	int early = 0;
	for (int i = 0; i < n; i++)
		early += at[i] < 1500;
	CHECK_MSG(early >= 2, "%d pings in the first 1.5 s", early);
	/* stuck camera: no ping for well over the watchdog period */
	int gap = longest_gap(at, n, at[0], 5500);
	CHECK_MSG(gap >= 1500, "longest gap between pings %d ms", gap);
	CHECK(mcd_run_wait_log(&r, "watchdog: the camera b capture thread made no progress; not feeding the watchdog", 0));
	/* back to normal: pings again at the end */
	int late = 0;
	for (int i = 0; i < n; i++)
		late += at[i] > 4700;
	CHECK_MSG(late >= 1, "no ping after the hang ended (%d pings in all)", n);
	mcd_run_stop(&r, 10000, "watchdog");
}

static void test_no_watchdog_asked(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, CONF);
	CHECK(mcd_run_start(&r, NULL, NULL));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 10000));
	CHECK(mcd_run_wait_notify(&r, "STATUS=tracker off", 3000));
	mcd_sleep_ms(800);
	mcd_run_read_notify(&r);
	CHECK(mcd_count(r.notes, "WATCHDOG=1") == 0);
	mcd_run_stop(&r, 10000, "watchdog off");
}

int main(void)
{
	if (!mcd_find_build())
		TEST_SKIP("mocapd is not built");
	test_pings_and_hang();
	test_no_watchdog_asked();
	return mc_test_finish("test_daemon_watchdog");
}
