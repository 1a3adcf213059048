/* Latency accounting and stale frame sets, end to end: mocapd on the
 * bundled clip (10 fps, both cameras) reports where a frame set's time
 * goes (STATUS's latency block through libmocap: every stage, their sum
 * the total, the total below what a client measures from capture to
 * receive), and with a frame age budget no set can meet it skips every set
 * as stale, publishes nothing and says so. */
#include "daemon/harness.h"
#include "mocap.h"
#include "test_util.h"

static char repo[PATH_MAX];

static bool start(mcd_run *r, const char *daemon_extra)
{
	char text[8 * PATH_MAX];
	mcd_demo_clip_config(text, sizeof(text), repo, 10, daemon_extra, "", NULL, "");
	mcd_run_config(r, text);
	const char *const args[] = {NULL};
	return mcd_run_start_ready(r, args);
}

/* The status once at least `sets` frame sets were published (or 30 s). */
static bool status_after(mocap_client *c, unsigned sets, mocap_daemon_status *st)
{
	for (int i = 0; i < 300; i++) {
		if (mocap_get_status(c, st) != 0)
			return false;
		if (st->latency.window >= sets)
			return true;
		mcd_sleep_ms(100);
	}
	return false;
}

static void check_stages(mcd_run *r)
{
	mocap_client *c = mocap_connect(r->sock, "latency");
	CHECK_MSG(c, "%s", mocap_errmsg());
	if (!c)
		return;
	mocap_skeleton_frame *f = calloc(1, sizeof(*f));
	double receive_ms = 0;
	if (mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0)
		for (int i = 0; i < 10 && mocap_read_frame(c, f, 10000) == 1; i++)
			receive_ms += (double)(f->receive_ns - f->capture_ns) / 1e6 / 10;
	mocap_daemon_status *st = calloc(1, sizeof(*st));
	CHECK(status_after(c, 10, st));
	const mocap_latency_status *l = &st->latency;
	printf("capture to publish: %.1f ms p50, %.1f p99 over %u sets (ready %.1f, wait %.1f, decode %.1f, track %.1f, "
	       "publish %.2f); capture to receive %.1f ms (mean of 10)\n",
	       l->stage[MOCAP_LAT_TOTAL].p50, l->stage[MOCAP_LAT_TOTAL].p99, l->window, l->stage[MOCAP_LAT_READY].p50,
	       l->stage[MOCAP_LAT_WAIT].p50, l->stage[MOCAP_LAT_DECODE].p50, l->stage[MOCAP_LAT_TRACK].p50,
	       l->stage[MOCAP_LAT_PUBLISH].p50, receive_ms);
	CHECK(l->known && l->window >= 10 && l->skipped_stale == 0);
	CHECK(l->stage[MOCAP_LAT_TRACK].p50 > 0 && l->stage[MOCAP_LAT_TOTAL].p50 >= l->stage[MOCAP_LAT_TRACK].p50);
	for (int s = 0; s < MOCAP_LAT_NSTAGES; s++)
		CHECK(l->stage[s].p50 >= 0 && l->stage[s].p50 <= l->stage[s].p99 && l->stage[s].p99 <= l->stage[s].max);
	/* The stages add up (their maxima bound the total's). */
	double sum_max = 0;
	for (int s = 0; s < MOCAP_LAT_TOTAL; s++)
		sum_max += l->stage[s].max;
	CHECK(l->stage[MOCAP_LAT_TOTAL].max <= sum_max + 0.01);
	/* What a client sees from capture to receive includes the daemon's part. */
	CHECK(receive_ms > 0 && receive_ms + 0.5 >= l->stage[MOCAP_LAT_TOTAL].p50 * 0.5);
	free(st);
	free(f);
	mocap_close(c);
}

/* A budget of 1 us: every set is stale by the time it could be tracked. */
static void check_stale(mcd_run *r)
{
	mocap_client *c = mocap_connect(r->sock, "stale");
	CHECK_MSG(c, "%s", mocap_errmsg());
	mocap_daemon_status *st = calloc(1, sizeof(*st));
	bool seen = false;
	for (int i = 0; c && i < 100 && !seen; i++) {
		CHECK(mocap_get_status(c, st) == 0);
		seen = st->latency.skipped_stale >= 5;
		if (!seen)
			mcd_sleep_ms(100);
	}
	CHECK_MSG(seen, "%llu stale sets skipped", (unsigned long long)st->latency.skipped_stale);
	CHECK(st->frames_published == 0 && st->latency.window == 0 && st->frames_dropped >= st->latency.skipped_stale);
	CHECK(mcd_run_wait_log(r, "over the 0.001 ms budget ([daemon] max_frame_age_ms", 5000));
	free(st);
	mocap_close(c);
}

/* Runs mocapd with the [daemon] lines `extra`, checks it, stops it. */
static void run(const char *extra, void (*check)(mcd_run *r), const char *what)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	if (start(&r, extra)) { /* a failed start is dumped and cleaned up */
		check(&r);
		mcd_run_stop(&r, 20000, what);
	}
}

int main(void)
{
	mcd_require_build_and_clip(repo, sizeof(repo));
	run("", check_stages, "latency");
	run("max_frame_age_ms = 0.001\n", check_stale, "stale");
	return mc_test_finish("test_daemon_latency");
}
