#include "tracking_thread.h"

#include "frame_size.h"
#include "grouper.h"
#include "log.h"
#include "base/mc_thread.h"
#include "base/mc_throttle.h"
#include "base/mc_time.h"
#include "image/mc_image.h"
#include "image/mc_pixfmt.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define IDLE_WAKE_NS (100 * MC_NS_PER_MS) /* how often an idle thread looks up */

struct mcd_tracking_thread {
	int ncams;
	mcd_camera *cams[MC_MAX_CAMERAS];
	mcd_tracking *tracking;
	srv_keypoint_inbox *inbox;
	mcd_publisher *pub;
	void (*on_finished)(void *ctx);
	void *ctx;
	bool started; /* the thread runs (main thread only) */

	/* Guards everything below, shared with the capture threads and the
	 * main thread. */
	pthread_mutex_t lock;
	pthread_cond_t cond;
	mcd_grouper grouper;
	uint64_t max_age_ns; /* 0: no frame age budget */
	bool stop, finished;
	bool all_failed; /* finished with no camera having reached its end */
	bool reload_pending;
	mc_tracker_settings reload_budget;
	mcd_track_stats st;
	/* The tracker's actor (its model: size, head placement, colours) as
	 * of its last colour calibration, for `mocapctl actor save`. */
	mc_model *actor;
	unsigned actor_version;

	pthread_t thread;
	atomic_uint_fast64_t heartbeat;

	/* The tracking thread's own. */
	mc_image_conv *conv;
	uint8_t *raw[MC_MAX_CAMERAS], *rgb[MC_MAX_CAMERAS];
	size_t raw_cap[MC_MAX_CAMERAS], rgb_cap[MC_MAX_CAMERAS];
	uint64_t seq;
	int turns_seen; /* the tracker's turn-arounds already logged */
	srv_keypoints *kp_batch;
	srv_keypoints *kp_latest; /* per rig camera */
	mc_keypoint *kp;          /* the ones used for one frame set */
	/* The frame size last seen per camera and whether it fits its rig
	 * camera (frame_size.h): checked at the first frame of each size. */
	int seen_w[MC_MAX_CAMERAS], seen_h[MC_MAX_CAMERAS];
	bool size_fits[MC_MAX_CAMERAS];

	/* The in-process detector's newest batch per rig camera: det_offer
	 * is written by the detector thread under det_lock (a copy, never a
	 * wait for a detection), det_latest is the tracking thread's copy. */
	pthread_mutex_t det_lock;
	atomic_bool det_runs; /* a detector feeds this thread (mcd_tracking_thread_expect_detections) */
	srv_keypoints *det_offer;
	uint64_t det_serial[MC_MAX_CAMERAS];
	srv_keypoints *det_latest;
	uint64_t det_seen[MC_MAX_CAMERAS];
	/* The frame set being tracked: how many keypoints t->kp holds, and per
	 * rig camera the capture time whose detection is still awaited (0:
	 * none), with the tolerance that matches it (late_detections). */
	int nkp;
	uint64_t awaited_ns[MC_MAX_CAMERAS];
	uint64_t kp_tol_ns;
	/* When a client's batch for each rig camera last came (mc_now_ns; 0:
	 * never): such a camera's keypoints are awaited like the in-process
	 * detector's (client_feeds). */
	uint64_t client_kp_ns[MC_MAX_CAMERAS];
};

/* ---- one frame set ---------------------------------------------------------------- */

static void note_overrun(mcd_tracking_thread *t, int c, uint64_t sequence, int rc, const mc_err *err)
{
	pthread_mutex_lock(&t->lock);
	uint64_t n = ++t->st.cams[c].overrun;
	pthread_mutex_unlock(&t->lock);
	if (mc_throttle_should_log(n))
		mcd_warn("camera %s: frame %llu was overwritten before it could be tracked (%llu so far)%s%s",
			 mcd_camera_name(t->cams[c]), (unsigned long long)sequence, (unsigned long long)n,
			 rc < 0 ? ": " : "", rc < 0 ? err->msg : "");
}

static void note_undecodable(mcd_tracking_thread *t, int c, const mc_err *err)
{
	pthread_mutex_lock(&t->lock);
	uint64_t n = ++t->st.cams[c].undecodable;
	snprintf(t->st.last_error[c], sizeof(t->st.last_error[c]), "frame dropped: %.220s", err->msg);
	pthread_mutex_unlock(&t->lock);
	if (mc_throttle_should_log(n))
		mcd_warn("camera %s: frame dropped: %s (%llu so far)", mcd_camera_name(t->cams[c]), err->msg,
			 (unsigned long long)n);
}

/* Whether camera c's w x h frames fit its rig camera, said once per size:
 * drivers that take the size from their input (files, take) or pick it
 * themselves cannot be checked by --check. */
static bool size_fits(mcd_tracking_thread *t, int c, int w, int h)
{
	if (!t->tracking)
		return true;
	if (w == t->seen_w[c] && h == t->seen_h[c])
		return t->size_fits[c];
	t->seen_w[c] = w;
	t->seen_h[c] = h;
	const mc_camera *rc = &t->tracking->rig.cams[t->tracking->cam_to_rig[c]];
	double to_rig = 1;
	t->size_fits[c] = mcd_frame_to_rig_scale(w, h, rc->width, rc->height, &to_rig);
	if (!t->size_fits[c]) {
		char why[400];
		mcd_frame_size_explain(w, h, rc, t->tracking->rig.name, why, sizeof(why));
		mcd_error("camera %s: %s; its frames are not tracked", mcd_camera_name(t->cams[c]), why);
		pthread_mutex_lock(&t->lock);
		snprintf(t->st.last_error[c], sizeof(t->st.last_error[c]), "frames not tracked: %.200s", why);
		pthread_mutex_unlock(&t->lock);
	} else if (to_rig != 1) {
		mcd_info("camera %s: %dx%d frames, %g times rig camera '%s' (%dx%d): the tracker resamples them and "
			 "detector keypoints are scaled", mcd_camera_name(t->cams[c]), w, h, 1 / to_rig, rc->name,
			 rc->width, rc->height);
	}
	return t->size_fits[c];
}

/* Copies out and converts the frames of a group; fills views (by rig
 * camera when tracking, else by camera).  Returns how many are usable. */
static int gather_views(mcd_tracking_thread *t, const mcd_group *g, mc_frame_view *views, uint64_t *frame)
{
	int present = 0;
	for (int c = 0; c < t->ncams; c++) {
		if (!g->has[c])
			continue;
		mc_err err = {{0}};
		mc_ring_meta meta;
		int rc = mcd_frame_ring_read(mcd_camera_ring(t->cams[c]), g->frame[c].generation, g->frame[c].sequence,
					     &t->raw[c], &t->raw_cap[c], &meta, &err);
		if (rc != MC_RING_FRAME) {
			note_overrun(t, c, g->frame[c].sequence, rc, &err);
			continue;
		}
		int w, h;
		if (mcd_frame_to_rgb(t->conv, &meta, t->raw[c], &t->rgb[c], &t->rgb_cap[c], &w, &h, &err)) {
			note_undecodable(t, c, &err);
			continue;
		}
		if (!size_fits(t, c, w, h))
			continue;
		int slot = t->tracking ? t->tracking->cam_to_rig[c] : c;
		views[slot] = (mc_frame_view){.width = w, .height = h, .stride = w * 3, .rgb = t->rgb[c],
					      .timestamp_ns = meta.timestamp_ns};
		if (!present++)
			*frame = meta.driver_sequence;
	}
	return present;
}

/* While the tracker waits for a first pose, keypoints up to this much
 * older than the frame set are used: the tracking thread never waits for
 * the detector, and on a loaded machine every detection can come a frame
 * late, which would leave the tracker initialising for ever.  The actor
 * stands for a moment then (docs/TRACKER.md), so a pose 0.3 s old is
 * still a start that the images refine. */
#define INIT_KEYPOINT_AGE_NS 300000000ull

static bool same_instant(const srv_keypoints *b, uint64_t ts, uint64_t tol)
{
	uint64_t a = b->capture_ns;
	return b->nkeypoints && (a > ts ? a - ts : ts - a) <= tol;
}

/* The detector's newest batch of rig camera r, if one came since the last look. */
static void take_detected(mcd_tracking_thread *t, int r)
{
	pthread_mutex_lock(&t->det_lock);
	if (t->det_serial[r] != t->det_seen[r]) {
		t->det_latest[r] = t->det_offer[r];
		t->det_seen[r] = t->det_serial[r];
	}
	pthread_mutex_unlock(&t->det_lock);
}

/* Appends batch b of rig camera r to the frame set's keypoints (t->kp). */
static void append_keypoints(mcd_tracking_thread *t, const srv_keypoints *b, int r)
{
	for (int k = 0; k < b->nkeypoints; k++) {
		t->kp[t->nkp] = b->keypoints[k];
		t->kp[t->nkp++].cam = r;
	}
}

static void count_detected(mcd_tracking_thread *t, int views)
{
	if (!views)
		return;
	pthread_mutex_lock(&t->lock);
	t->st.total.detector_views += (uint64_t)views;
	pthread_mutex_unlock(&t->lock);
}

/* A client (mocap-detect, say) whose batches for rig camera r came this
 * recently is taken to be sending them for every frame, so its keypoints
 * are awaited during the iterations; a client that stopped is not waited
 * for after this. */
#define CLIENT_FEED_NS (2000 * MC_NS_PER_MS)

static bool client_feeds(const mcd_tracking_thread *t, int r, uint64_t now)
{
	return t->client_kp_ns[r] && now - t->client_kp_ns[r] <= CLIENT_FEED_NS;
}

/* Appends batch b of rig camera r to the frame set's keypoints and to the
 * poll's output kp (room for cap - *n more); false if it does not fit. */
static bool join_late(mcd_tracking_thread *t, const srv_keypoints *b, int r, mc_keypoint *kp, int *n, int cap)
{
	if (b->nkeypoints > cap - *n)
		return false;
	t->awaited_ns[r] = 0;
	int first = t->nkp;
	append_keypoints(t, b, r);
	memcpy(kp + *n, t->kp + first, sizeof(*kp) * (size_t)b->nkeypoints);
	*n += b->nkeypoints;
	return true;
}

/* Takes the batches clients sent since the last look, keeping the newest
 * per rig camera.  During the iterations (kp non-NULL) a batch that is the
 * awaited detection of its camera's view joins at once, before a newer
 * batch behind it in the inbox replaces it. */
static void take_client_batches(mcd_tracking_thread *t, int nviews, mc_keypoint *kp, int *n, int cap)
{
	uint64_t now = mc_now_ns();
	srv_keypoints *b = t->kp_batch;
	while (t->inbox && srv_inbox_pop_keypoints(t->inbox, b) == 1) {
		int r = b->cam;
		if (r < 0 || r >= nviews)
			continue;
		t->client_kp_ns[r] = now;
		if (kp && t->awaited_ns[r] && same_instant(b, t->awaited_ns[r], t->kp_tol_ns))
			join_late(t, b, r, kp, n, cap);
		t->kp_latest[r] = *b;
	}
}

/* Keypoints for the frames of this set: per rig camera, the newest batch
 * of the in-process detector if its capture time is that of the camera's
 * view, else the newest batch a client sent, on the same condition.  A
 * camera with neither awaits its detection (late_detections) when a
 * detector feeds it: the in-process one, or a client lately. */
static int collect_keypoints(mcd_tracking_thread *t, const mc_frame_view *views, int nviews)
{
	take_client_batches(t, nviews, NULL, NULL, 0);
	uint64_t now = mc_now_ns();
	pthread_mutex_lock(&t->lock);
	uint64_t tol = t->grouper.tolerance_ns;
	if (t->st.total.track_state == MC_TRACK_INITIALISING && tol < INIT_KEYPOINT_AGE_NS)
		tol = INIT_KEYPOINT_AGE_NS;
	pthread_mutex_unlock(&t->lock);
	t->nkp = 0;
	t->kp_tol_ns = tol;
	int detected = 0;
	for (int r = 0; r < MC_MAX_CAMERAS; r++) {
		t->awaited_ns[r] = 0;
		if (r >= nviews || !views[r].rgb)
			continue;
		take_detected(t, r);
		const srv_keypoints *b = &t->det_latest[r];
		if (same_instant(b, views[r].timestamp_ns, tol))
			detected++;
		else if (!same_instant(b = &t->kp_latest[r], views[r].timestamp_ns, tol)) {
			if (atomic_load(&t->det_runs) || client_feeds(t, r, now))
				t->awaited_ns[r] = views[r].timestamp_ns;
			continue;
		}
		append_keypoints(t, b, r);
	}
	count_detected(t, detected);
	return t->nkp;
}

/* The tracker's keypoint poll (mc_tracker_set_keypoint_poll), between its
 * gradient iterations: the batches of the in-process detector and of
 * clients that came for this frame set after its tracking began.  The
 * tracking thread does not wait for the detector (a pose should not
 * wait), but a detection takes a few milliseconds, so when the tracker
 * starts on a frame set at once (cameras at 30 fps on an idle machine) the
 * keypoints would otherwise come too late for nearly every frame set (5 of
 * 60 views a second in bench-latency); now they join the remaining
 * iterations.  A detector in another process (mocap-detect) is later
 * still, the more so on a loaded machine, where it was in time for 2 of
 * 25 frame sets when only this thread's first look took clients'
 * batches (issue 34). */
static int late_detections(void *ctx, int iteration, mc_keypoint *kp, int cap)
{
	mcd_tracking_thread *t = ctx;
	(void)iteration;
	int n = 0, detected = 0;
	for (int r = 0; r < MC_MAX_CAMERAS; r++) {
		if (!t->awaited_ns[r])
			continue;
		take_detected(t, r);
		const srv_keypoints *b = &t->det_latest[r];
		if (same_instant(b, t->awaited_ns[r], t->kp_tol_ns) && join_late(t, b, r, kp, &n, cap))
			detected++;
	}
	count_detected(t, detected);
	take_client_batches(t, t->tracking->rig.ncams, kp, &n, cap);
	return n;
}

static bool awaiting(const mcd_tracking_thread *t)
{
	for (int r = 0; r < MC_MAX_CAMERAS; r++)
		if (t->awaited_ns[r])
			return true;
	return false;
}

/* On the first frame set with every camera, when the config asks for it. */
static void calibrate_once(mcd_tracking_thread *t, const mc_frame_view *views, int present)
{
	mcd_tracking *tr = t->tracking;
	if (!tr->calibrate_pending || present != t->ncams)
		return;
	tr->calibrate_pending = false;
	mc_err err = {{0}};
	if (mc_tracker_calibrate_colors(tr->tracker, views, tr->rig.ncams, &err))
		mcd_warn("tracker: colour calibration failed: %s; keeping the model's colours", err.msg);
	else
		mcd_info("tracker: actor colours calibrated on the first complete frame set");
}

/* Counts a tracked frame set (rc == 0) or a failure; returns the failures so far. */
static uint64_t count_tracked(mcd_tracking_thread *t, int rc, const mcd_output *o, int inits)
{
	bool started = false;
	pthread_mutex_lock(&t->lock);
	mcd_track_totals *tt = &t->st.total;
	if (rc == 0) {
		tt->tracked++;
		tt->track_ms_total += o->sk.track_ms;
		if (o->sk.track_ms > tt->track_ms_max)
			tt->track_ms_max = o->sk.track_ms;
		started = mcd_first_pose_found(tt->track_state, o->sk.state, inits);
		tt->track_state = (int)o->sk.state;
	} else
		tt->track_errors++;
	uint64_t errors = tt->track_errors, tracked = tt->tracked;
	pthread_mutex_unlock(&t->lock);
	if (started) /* logged outside the lock the capture threads share */
		mcd_info("tracker: first pose found from the detections after %llu frame sets",
			 (unsigned long long)tracked);
	return errors;
}

/* Copies the tracker's actor when it changed (a colour calibration). */
static void snapshot_actor(mcd_tracking_thread *t, mc_tracker *tracker)
{
	unsigned v = mc_tracker_actor_version(tracker);
	if (v == t->actor_version)
		return;
	pthread_mutex_lock(&t->lock);
	if (!t->actor)
		t->actor = malloc(sizeof(*t->actor));
	if (t->actor) {
		*t->actor = *mc_tracker_model(tracker);
		t->actor_version = v;
	}
	pthread_mutex_unlock(&t->lock);
}

bool mcd_tracking_thread_actor(mcd_tracking_thread *t, mc_model *out)
{
	pthread_mutex_lock(&t->lock);
	bool have = t->actor && t->actor_version > 0;
	if (have)
		*out = *t->actor;
	pthread_mutex_unlock(&t->lock);
	return have;
}

static void track(mcd_tracking_thread *t, const mc_frame_view *views, int present, mcd_output *o)
{
	mcd_tracking *tr = t->tracking;
	int nviews = tr->rig.ncams;
	calibrate_once(t, views, present);
	int nkp = collect_keypoints(t, views, nviews);
	mc_err err = {{0}};
	/* Set for every frame set: a reload can replace the tracker. */
	bool poll = atomic_load(&t->det_runs) || awaiting(t);
	mc_tracker_set_keypoint_poll(tr->tracker, poll ? late_detections : NULL, t);
	int rc = mc_tracker_track(tr->tracker, views, nviews, nkp ? t->kp : NULL, nkp, &o->sk, &err);
	nkp = t->nkp; /* with the late ones */
	o->nkp = nkp < MCD_OUTPUT_KEYPOINTS ? nkp : MCD_OUTPUT_KEYPOINTS;
	memcpy(o->kp, t->kp, sizeof(*o->kp) * (size_t)o->nkp);
	if (rc == 0) {
		o->tracked = true;
		o->ndof = mc_tracker_model(tr->tracker)->ndof;
		memcpy(o->pose, mc_tracker_pose(tr->tracker), sizeof(double) * (size_t)o->ndof);
	}
	if (rc == 0)
		snapshot_actor(t, tr->tracker);
	mc_tracker_init_info init;
	mc_tracker_get_init_info(tr->tracker, &init);
	uint64_t errors = count_tracked(t, rc, o, init.inits);
	if (init.turns > t->turns_seen) /* docs/TRACKER.md, "Facing" */
		mcd_info("tracker: the body faced the wrong way: turned around (%d times so far)", init.turns);
	t->turns_seen = init.turns; /* a new tracker (a reload) starts again at 0 */
	if (rc != 0 && mc_throttle_should_log(errors))
		mcd_warn("tracker: %s (%llu failures so far)", err.msg, (unsigned long long)errors);
}

static void process(mcd_tracking_thread *t, const mcd_group *g, uint64_t start_ns)
{
	mc_frame_view views[MC_MAX_CAMERAS];
	memset(views, 0, sizeof(views));
	mcd_output *o = calloc(1, sizeof(*o));
	if (!o)
		return;
	o->ready_ns = g->ready_ns;
	o->track_start_ns = start_ns;
	int present = gather_views(t, g, views, &o->frame);
	o->decoded_ns = mc_now_ns();
	o->seq = ++t->seq;
	o->timestamp_ns = g->timestamp_ns;
	o->present = present;
	o->ncams = t->ncams;
	if (t->tracking && present > 0)
		track(t, views, present, o);
	if (o->tracked)
		o->sk.timestamp_ns = g->timestamp_ns;
	o->track_end_ns = mc_now_ns();
	mcd_publisher_push(t->pub, o);
	free(o);
}

/* ---- the loop (called with the lock held) ------------------------------------------ */

/* Cameras a frame set waits for (up to the deadline): those streaming, and
 * those opening, whose first frame may be on its way. */
static uint32_t expected_cameras(mcd_tracking_thread *t)
{
	uint32_t mask = 0;
	for (int c = 0; c < t->ncams; c++) {
		mcd_cam_state s = mcd_camera_state(t->cams[c]);
		if (s == MCD_CAM_STREAMING || s == MCD_CAM_OPENING)
			mask |= 1u << c;
	}
	return mask;
}

/* Every camera has stopped for good: each reached its end or failed
 * (a config error, an unreadable folder).  *ended: at least one ended. */
static bool streams_over(mcd_tracking_thread *t, bool *ended)
{
	*ended = false;
	if (t->ncams == 0) /* nothing to wait for is not an end */
		return false;
	for (int c = 0; c < t->ncams; c++) {
		mcd_cam_state s = mcd_camera_state(t->cams[c]);
		if (s != MCD_CAM_ENDED && s != MCD_CAM_FAILED)
			return false;
		*ended |= s == MCD_CAM_ENDED;
	}
	return true;
}

static void apply_reload(mcd_tracking_thread *t)
{
	mc_tracker_settings budget = t->reload_budget;
	t->reload_pending = false;
	pthread_mutex_unlock(&t->lock);
	mc_err err = {{0}};
	if (mcd_tracking_reload(t->tracking, &budget, &err))
		mcd_error("reload: tracker: %s; keeping the previous tracker", err.msg);
	pthread_mutex_lock(&t->lock);
}

/* Whether a set captured at ts is past the age budget at `now`. */
static bool too_old(const mcd_tracking_thread *t, uint64_t ts, uint64_t now)
{
	return t->max_age_ns && now > ts && now - ts > t->max_age_ns;
}

/* Pops every frame set due now and tracks the newest, unless it is
 * already older than the age budget; false if none was due. */
static bool track_due(mcd_tracking_thread *t, uint64_t now)
{
	/* Camera states take their own locks; never the other way round. */
	uint32_t expect = expected_cameras(t);
	mcd_group g, newest = {0};
	int due = 0;
	while (mcd_grouper_pop(&t->grouper, now, expect, &g)) {
		if (due++)
			t->st.total.skipped++;
		newest = g;
	}
	if (!due)
		return false;
	if (too_old(t, newest.timestamp_ns, now)) {
		uint64_t n = ++t->st.total.stale;
		double age_ms = (double)(now - newest.timestamp_ns) / 1e6, budget_ms = (double)t->max_age_ns / 1e6;
		pthread_mutex_unlock(&t->lock);
		if (mc_throttle_should_log(n))
			mcd_warn("frame set skipped: %.1f ms old when tracking could start, over the %g ms budget "
				 "([daemon] max_frame_age_ms; %llu so far)",
				 age_ms, budget_ms, (unsigned long long)n);
		pthread_mutex_lock(&t->lock);
		return true;
	}
	pthread_mutex_unlock(&t->lock);
	process(t, &newest, now);
	pthread_mutex_lock(&t->lock);
	return true;
}

static void check_finished(mcd_tracking_thread *t)
{
	bool ended;
	if (t->finished || mcd_grouper_pending(&t->grouper) != 0 || !streams_over(t, &ended) ||
	    !mcd_publisher_idle(t->pub))
		return;
	t->finished = true;
	t->all_failed = !ended;
	/* Said once, here: nothing will come until the config is fixed, and
	 * --exit-at-end stops on it rather than waiting for an end. */
	if (!ended)
		mcd_error("every camera has failed for good (see above); nothing to track until the config is fixed "
			  "and mocapd restarted");
	if (t->on_finished)
		t->on_finished(t->ctx);
}

static void *tracking_main(void *arg)
{
	mcd_tracking_thread *t = arg;
	mc_thread_set_name("mocapd-track");
	pthread_mutex_lock(&t->lock);
	while (!t->stop) {
		atomic_fetch_add(&t->heartbeat, 1);
		if (t->reload_pending) {
			apply_reload(t);
			continue;
		}
		uint64_t now = mc_now_ns();
		if (track_due(t, now))
			continue;
		check_finished(t);
		uint64_t wake = now + IDLE_WAKE_NS;
		uint64_t deadline = mcd_grouper_due(&t->grouper);
		struct timespec ts = mc_ns_timespec(deadline < wake ? deadline : wake);
		pthread_cond_timedwait(&t->cond, &t->lock, &ts);
	}
	pthread_mutex_unlock(&t->lock);
	return NULL;
}

/* ---- lifetime ------------------------------------------------------------------------ */

static int alloc_keypoints(mcd_tracking_thread *t, mc_err *err)
{
	t->kp_batch = calloc(1, sizeof(*t->kp_batch));
	t->kp_latest = calloc(MC_MAX_CAMERAS, sizeof(*t->kp_latest));
	t->det_offer = calloc(MC_MAX_CAMERAS, sizeof(*t->det_offer));
	t->det_latest = calloc(MC_MAX_CAMERAS, sizeof(*t->det_latest));
	t->kp = calloc((size_t)MC_MAX_CAMERAS * SRV_MAX_KEYPOINTS, sizeof(*t->kp));
	if (!t->kp_batch || !t->kp_latest || !t->kp || !t->det_offer || !t->det_latest)
		return mc_err_set(err, "out of memory");
	return 0;
}

mcd_tracking_thread *mcd_tracking_thread_create(const mcd_tracking_thread_config *cfg, mc_err *err)
{
	mcd_tracking_thread *t = calloc(1, sizeof(*t));
	if (!t) {
		mc_err_set(err, "out of memory");
		return NULL;
	}
	t->ncams = cfg->ncams < MC_MAX_CAMERAS ? cfg->ncams : MC_MAX_CAMERAS;
	memcpy(t->cams, cfg->cams, sizeof(t->cams[0]) * (size_t)t->ncams);
	t->tracking = cfg->tracking;
	t->inbox = cfg->keypoints;
	t->on_finished = cfg->on_finished;
	t->ctx = cfg->ctx;
	t->st.total.track_state = -1;
	pthread_mutex_init(&t->lock, NULL);
	pthread_mutex_init(&t->det_lock, NULL);
	mc_cond_init_monotonic(&t->cond);
	mcd_grouper_init(&t->grouper, t->ncams, (uint64_t)(cfg->group_tolerance_ms * 1e6),
			 (uint64_t)(cfg->group_deadline_ms * 1e6));
	t->max_age_ns = (uint64_t)(cfg->max_frame_age_ms * 1e6);
	t->conv = mc_image_conv_new(err);
	if (!t->conv || alloc_keypoints(t, err)) {
		mcd_tracking_thread_destroy(t);
		return NULL;
	}
	return t;
}

int mcd_tracking_thread_start(mcd_tracking_thread *t, mcd_publisher *pub, mc_err *err)
{
	t->pub = pub;
	int rc = pthread_create(&t->thread, NULL, tracking_main, t);
	if (rc)
		return mc_err_set(err, "cannot start the tracking thread: %s", strerror(rc));
	t->started = true;
	return 0;
}

void mcd_tracking_thread_stop(mcd_tracking_thread *t)
{
	if (!t || !t->started)
		return;
	pthread_mutex_lock(&t->lock);
	t->stop = true;
	pthread_cond_signal(&t->cond);
	pthread_mutex_unlock(&t->lock);
	pthread_join(t->thread, NULL);
	t->started = false;
}

void mcd_tracking_thread_destroy(mcd_tracking_thread *t)
{
	if (!t)
		return;
	mcd_tracking_thread_stop(t);
	for (int c = 0; c < MC_MAX_CAMERAS; c++) {
		free(t->raw[c]);
		free(t->rgb[c]);
	}
	free(t->kp_batch);
	free(t->kp_latest);
	free(t->kp);
	free(t->det_offer);
	free(t->det_latest);
	mc_image_conv_free(t->conv);
	pthread_mutex_destroy(&t->det_lock);
	free(t->actor);
	pthread_mutex_destroy(&t->lock);
	pthread_cond_destroy(&t->cond);
	free(t);
}

/* ---- from the other threads ------------------------------------------------------------- */

void mcd_tracking_thread_push(mcd_tracking_thread *t, int cam, uint64_t generation, const mc_ring_meta *meta)
{
	mcd_frame_ref ref = {.generation = generation, .sequence = meta->sequence,
			     .timestamp_ns = meta->timestamp_ns, .arrival_ns = meta->commit_ns ? meta->commit_ns : mc_now_ns()};
	pthread_mutex_lock(&t->lock);
	mcd_grouper_push(&t->grouper, cam, &ref);
	pthread_cond_signal(&t->cond);
	pthread_mutex_unlock(&t->lock);
}

void mcd_tracking_thread_offer_keypoints(mcd_tracking_thread *t, int rig_cam, uint64_t capture_ns,
					 const mc_keypoint *kp, int n)
{
	if (rig_cam < 0 || rig_cam >= MC_MAX_CAMERAS || n < 0)
		return;
	if (n > SRV_MAX_KEYPOINTS)
		n = SRV_MAX_KEYPOINTS;
	pthread_mutex_lock(&t->det_lock);
	srv_keypoints *b = &t->det_offer[rig_cam];
	b->capture_ns = capture_ns;
	b->cam = rig_cam;
	b->nkeypoints = n;
	b->pid = 0;
	memcpy(b->keypoints, kp, sizeof(*kp) * (size_t)n);
	t->det_serial[rig_cam]++;
	pthread_mutex_unlock(&t->det_lock);
}

void mcd_tracking_thread_expect_detections(mcd_tracking_thread *t, bool runs)
{
	atomic_store(&t->det_runs, runs);
}

void mcd_tracking_thread_wake(mcd_tracking_thread *t)
{
	pthread_mutex_lock(&t->lock);
	pthread_cond_signal(&t->cond);
	pthread_mutex_unlock(&t->lock);
}

void mcd_tracking_thread_reload(mcd_tracking_thread *t, double group_tolerance_ms, double group_deadline_ms,
				double max_frame_age_ms, const mc_tracker_settings *budget)
{
	pthread_mutex_lock(&t->lock);
	mcd_grouper_set_limits(&t->grouper, (uint64_t)(group_tolerance_ms * 1e6), (uint64_t)(group_deadline_ms * 1e6));
	t->max_age_ns = (uint64_t)(max_frame_age_ms * 1e6);
	if (budget && t->tracking) {
		t->reload_budget = *budget;
		t->reload_pending = true;
	}
	pthread_cond_signal(&t->cond);
	pthread_mutex_unlock(&t->lock);
}

bool mcd_tracking_thread_finished(mcd_tracking_thread *t)
{
	pthread_mutex_lock(&t->lock);
	bool done = t->finished;
	pthread_mutex_unlock(&t->lock);
	return done;
}

bool mcd_tracking_thread_all_failed(mcd_tracking_thread *t)
{
	pthread_mutex_lock(&t->lock);
	bool failed = t->finished && t->all_failed;
	pthread_mutex_unlock(&t->lock);
	return failed;
}

uint64_t mcd_tracking_thread_heartbeat(mcd_tracking_thread *t)
{
	return atomic_load(&t->heartbeat);
}

void mcd_tracking_thread_stats(mcd_tracking_thread *t, mcd_track_stats *st, bool reset_max)
{
	pthread_mutex_lock(&t->lock);
	*st = t->st;
	const mcd_grouper_stats *gs = &t->grouper.stats;
	st->total.sets = gs->groups;
	st->total.complete_sets = gs->complete;
	for (int c = 0; c < t->ncams; c++) {
		st->cams[c].missing = gs->missing[c];
		st->cams[c].late = gs->late[c] + gs->overflow[c];
	}
	if (reset_max)
		t->st.total.track_ms_max = 0;
	pthread_mutex_unlock(&t->lock);
}
