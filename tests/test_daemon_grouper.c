/* Grouping views by timestamp (tolerance, deadline, late and lost frames)
 * and the reopen backoff. */
#include "backoff.h"
#include "grouper.h"
#include "test_util.h"

#include <string.h>

#define MS 1000000ull

static mcd_frame_ref ref(uint64_t seq, uint64_t ts_ms, uint64_t arrival_ms)
{
	return (mcd_frame_ref){.sequence = seq, .timestamp_ns = ts_ms * MS, .arrival_ns = arrival_ms * MS};
}

static void test_complete_groups(void)
{
	mcd_grouper g;
	mcd_grouper_init(&g, 2, 5 * MS, 100 * MS);
	mcd_group out;
	CHECK(!mcd_grouper_pop(&g, 0, 3, &out));
	CHECK(mcd_grouper_due(&g) == UINT64_MAX);
	/* camera 0 at t=1000, camera 1 at t=1003: one instant */
	mcd_frame_ref a = ref(0, 1000, 1001), b = ref(7, 1003, 1004);
	CHECK(mcd_grouper_push(&g, 0, &a));
	CHECK(!mcd_grouper_pop(&g, 1002 * MS, 3, &out)); /* still waiting for camera 1 */
	CHECK(mcd_grouper_due(&g) == 1101 * MS);
	CHECK(mcd_grouper_push(&g, 1, &b));
	CHECK(mcd_grouper_pop(&g, 1004 * MS, 3, &out));
	CHECK(out.present == 2 && out.has[0] && out.has[1]);
	CHECK(out.timestamp_ns == 1000 * MS);
	CHECK(out.frame[0].sequence == 0 && out.frame[1].sequence == 7);
	CHECK(out.ready_ns == 1004 * MS); /* complete when its last view arrived */
	CHECK(!mcd_grouper_pop(&g, 1004 * MS, 3, &out));
	CHECK(g.stats.complete == 1 && g.stats.partial == 0);

	/* a stream of pairs, camera 1 always 2 ms after camera 0, arriving in
	 * both orders */
	for (int k = 1; k <= 10; k++) {
		uint64_t t = 1000 + 33 * (uint64_t)k;
		mcd_frame_ref f0 = ref((uint64_t)k, t, t + 1), f1 = ref(7 + (uint64_t)k, t + 2, t + 3);
		if (k % 2) {
			mcd_grouper_push(&g, 0, &f0);
			mcd_grouper_push(&g, 1, &f1);
		} else {
			mcd_grouper_push(&g, 1, &f1);
			mcd_grouper_push(&g, 0, &f0);
		}
		CHECK(mcd_grouper_pop(&g, (t + 3) * MS, 3, &out));
		CHECK(out.present == 2 && out.frame[0].sequence == (uint64_t)k);
		CHECK(out.timestamp_ns == t * MS);
	}
	CHECK(g.stats.complete == 11 && g.stats.missing[0] == 0 && g.stats.missing[1] == 0);
}

static void test_deadline(void)
{
	mcd_grouper g;
	mcd_grouper_init(&g, 2, 5 * MS, 50 * MS);
	mcd_group out;
	mcd_frame_ref a = ref(0, 1000, 1000);
	mcd_grouper_push(&g, 0, &a);
	CHECK(!mcd_grouper_pop(&g, 1049 * MS, 3, &out));
	CHECK(mcd_grouper_pop(&g, 1050 * MS, 3, &out)); /* emitted without camera 1 */
	CHECK(out.ready_ns == 1050 * MS);                /* at its deadline */
	CHECK(out.present == 1 && out.has[0] && !out.has[1]);
	CHECK(g.stats.missing[1] == 1 && g.stats.partial == 1);
	/* camera 1's frame of that instant comes too late: dropped, counted */
	mcd_frame_ref late = ref(0, 1002, 1060);
	CHECK(!mcd_grouper_push(&g, 1, &late));
	CHECK(g.stats.late[1] == 1);
	CHECK(mcd_grouper_pending(&g) == 0);

	/* a camera that is not streaming is not waited for */
	mcd_frame_ref b = ref(1, 1033, 1033);
	mcd_grouper_push(&g, 0, &b);
	CHECK(mcd_grouper_pop(&g, 1033 * MS, 1, &out));
	CHECK(out.present == 1 && g.stats.missing[1] == 2);
}

static void test_lost_frame(void)
{
	/* Camera 1 lost its frame of t=1000 but already delivered t=1033:
	 * no point in waiting for the deadline. */
	mcd_grouper g;
	mcd_grouper_init(&g, 2, 5 * MS, 1000 * MS);
	mcd_group out;
	mcd_frame_ref a0 = ref(0, 1000, 1001), b1 = ref(5, 1033, 1034), a1 = ref(1, 1033, 1035);
	mcd_grouper_push(&g, 1, &b1);
	mcd_grouper_push(&g, 0, &a0);
	CHECK(mcd_grouper_pop(&g, 1034 * MS, 3, &out));
	CHECK(out.present == 1 && out.has[0] && out.timestamp_ns == 1000 * MS);
	CHECK(!mcd_grouper_pop(&g, 1034 * MS, 3, &out)); /* 1033 waits for camera 0 */
	mcd_grouper_push(&g, 0, &a1);
	CHECK(mcd_grouper_pop(&g, 1035 * MS, 3, &out));
	CHECK(out.present == 2 && out.frame[1].sequence == 5 && out.frame[0].sequence == 1);
}

static void test_out_of_tolerance(void)
{
	/* Offset beyond the tolerance: never grouped together. */
	mcd_grouper g;
	mcd_grouper_init(&g, 2, 5 * MS, 20 * MS);
	mcd_group out;
	int groups = 0, pairs = 0;
	for (int k = 0; k < 20; k++) {
		uint64_t t = 1000 + 33 * (uint64_t)k;
		mcd_frame_ref f0 = ref((uint64_t)k, t, t), f1 = ref((uint64_t)k, t + 12, t + 12);
		mcd_grouper_push(&g, 0, &f0);
		mcd_grouper_push(&g, 1, &f1);
		while (mcd_grouper_pop(&g, (t + 12) * MS, 3, &out)) {
			groups++;
			pairs += out.present == 2;
		}
	}
	CHECK(pairs == 0);
	CHECK(groups >= 38); /* every frame alone, all but the last one or two emitted */
	CHECK(g.stats.missing[0] > 0 && g.stats.missing[1] > 0);
}

static void test_three_cameras_and_overflow(void)
{
	mcd_grouper g;
	mcd_grouper_init(&g, 3, 2 * MS, 100 * MS);
	mcd_group out;
	mcd_frame_ref a = ref(1, 500, 500), b = ref(2, 501, 501), c = ref(3, 499, 502);
	mcd_grouper_push(&g, 0, &a);
	mcd_grouper_push(&g, 1, &b);
	CHECK(!mcd_grouper_pop(&g, 502 * MS, 7, &out));
	CHECK(mcd_grouper_pop(&g, 502 * MS, 3, &out)); /* camera 2 went down meanwhile */
	CHECK(out.present == 2);
	CHECK(!mcd_grouper_push(&g, 2, &c)); /* older than the emitted group: late */

	/* a queue that is never drained keeps the newest frames */
	mcd_grouper_init(&g, 2, 2 * MS, 100 * MS);
	for (int k = 0; k < MCD_GROUP_QUEUE + 5; k++) {
		mcd_frame_ref f = ref((uint64_t)k, 1000 + 33 * (uint64_t)k, 1000 + 33 * (uint64_t)k);
		mcd_grouper_push(&g, 0, &f);
	}
	CHECK(g.stats.overflow[0] == 5);
	CHECK(mcd_grouper_pending(&g) == MCD_GROUP_QUEUE);
	CHECK(mcd_grouper_pop(&g, UINT64_MAX / 2, 3, &out));
	CHECK(out.frame[0].sequence == 5);
}

static void test_backoff(void)
{
	mcd_backoff b;
	mcd_backoff_init(&b, 100, 1000);
	CHECK_NEAR(mcd_backoff_next(&b), 100, 0);
	CHECK_NEAR(mcd_backoff_next(&b), 200, 0);
	CHECK_NEAR(mcd_backoff_next(&b), 400, 0);
	CHECK_NEAR(mcd_backoff_next(&b), 800, 0);
	CHECK_NEAR(mcd_backoff_next(&b), 1000, 0);
	CHECK_NEAR(mcd_backoff_next(&b), 1000, 0);
	for (int i = 0; i < 200; i++) /* no overflow after many failures */
		mcd_backoff_next(&b);
	CHECK_NEAR(mcd_backoff_next(&b), 1000, 0);
	CHECK(b.failures == 207);
	mcd_backoff_reset(&b);
	CHECK_NEAR(mcd_backoff_next(&b), 100, 0);
	mcd_backoff_set_limits(&b, 50, 60);
	CHECK_NEAR(mcd_backoff_next(&b), 60, 0);
	mcd_backoff_reset(&b);
	CHECK_NEAR(mcd_backoff_next(&b), 50, 0);
}

int main(void)
{
	test_complete_groups();
	test_deadline();
	test_lost_frame();
	test_out_of_tolerance();
	test_three_cameras_and_overflow();
	test_backoff();
	return mc_test_finish("test_daemon_grouper");
}
