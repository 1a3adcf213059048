/* The detector thread (detector_thread.h).
 *
 * Why it reads the rings itself instead of taking the frame sets the
 * tracking thread decodes: the tracking thread never waits for the
 * detector, so keypoints are only of use for a frame set if they come
 * before its last gradient iteration (they join between iterations), and
 * the sooner they come, the more iterations use them.  Detections made on
 * the frames the tracking thread has decoded would start only as their
 * tracking starts.  So the detector
 * starts on each frame the moment its capture thread commits it, in
 * parallel with the grouping (which waits for the other cameras) and the
 * tracking thread's own decoding, and pays for a second JPEG decoding
 * (about 0.3 ms per 256x256 view here) to be in time.  One worker per
 * camera, so that the second camera's view does not wait for the first's
 * detection (with one thread for both, the right camera's keypoints came
 * too late for about half the frame sets of test_daemon_detector). */
#include "detector_thread.h"

#include "frame_size.h"
#include "log.h"
#include "mc_detector.h"
#include "base/mc_thread.h"
#include "base/mc_throttle.h"
#include "base/mc_time.h"
#include "server.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define IDLE_WAKE_NS (100 * MC_NS_PER_MS)
#define RATE_SLACK_NS (2 * MC_NS_PER_MS) /* a frame this much early still counts as due */

typedef struct {
	uint64_t generation, sequence, timestamp_ns;
} frame_ref;

/* One camera's worker: its own thread and network (a loaded network is
 * used by one thread at a time), so that no camera's frame waits for
 * another camera's detection. */
typedef struct {
	mcd_detector_thread *d;
	int cam;
	mc_detector *det;
	mc_image_conv *conv;
	uint8_t *raw, *rgb;
	size_t raw_cap, rgb_cap;
	mc_detection dets[MC_DETECTOR_MAX_JOINTS];
	mc_keypoint kps[MC_DETECTOR_MAX_JOINTS];
	pthread_t thread;
	bool started;
	uint64_t one_look_seen; /* the detector's one-look count already in the stats */
	/* Under d->lock: */
	bool pending;
	frame_ref next;
	uint64_t taken_ns; /* capture time of the last frame taken, 0 none */
	bool cfg_changed;
} worker;

struct mcd_detector_thread {
	int ncams;
	mcd_camera *cams[MC_MAX_CAMERAS];
	int cam_to_rig[MC_MAX_CAMERAS];
	const mc_rig *rig; /* NULL: keypoints stay in frame pixels */
	mcd_tracking_thread *sink;
	int map[MC_DETECTOR_MAX_JOINTS];
	float model_threshold;
	bool started;
	worker w[MC_MAX_CAMERAS];

	/* Guards the workers' shared parts and everything below (capture
	 * threads, main thread); each worker waits on its own condition. */
	pthread_mutex_t lock;
	pthread_cond_t cond[MC_MAX_CAMERAS];
	bool stop;
	mcd_detector_config cfg;
	mcd_detector_stats st;
	mcd_publisher *pose_source; /* [detector] hint = pose; set before the start */
};

const char *mcd_detector_state_name(mcd_detector_state s)
{
	switch (s) {
	case MCD_DETECTOR_OFF: return "off";
	case MCD_DETECTOR_RUNNING: return "running";
	case MCD_DETECTOR_FAILED: return "failed";
	}
	return "?";
}

/* ---- one view ------------------------------------------------------------------------ */

static void note_error(mcd_detector_thread *d, int c, const mc_err *err)
{
	pthread_mutex_lock(&d->lock);
	uint64_t n = ++d->st.errors;
	snprintf(d->st.message, sizeof(d->st.message), "camera %s: %.400s", mcd_camera_name(d->cams[c]), err->msg);
	pthread_mutex_unlock(&d->lock);
	if (mc_throttle_should_log(n))
		mcd_warn("detector: camera %s: %s (%llu so far)", mcd_camera_name(d->cams[c]), err->msg,
			 (unsigned long long)n);
}

/* Keypoints come in frame pixels; the tracker takes rig camera pixels.
 * -1 when the frame size does not fit the rig camera's. */
static int scale_to_rig(const mcd_detector_thread *d, int rig, int width, int height, mc_keypoint *kps, int nk)
{
	if (!d->rig)
		return 0;
	const mc_camera *rc = &d->rig->cams[rig];
	double s = 1;
	if (!mcd_frame_to_rig_scale(width, height, rc->width, rc->height, &s))
		return -1;
	for (int k = 0; s != 1 && k < nk; k++) {
		kps[k].u = mcd_frame_to_rig_coord(kps[k].u, s);
		kps[k].v = mcd_frame_to_rig_coord(kps[k].v, s);
	}
	return 0;
}

/* A pose at most this much older or newer than the frame gives the hint. */
#define HINT_MAX_AGE_NS 500000000ull

/* [detector] hint = pose: the square around the newest tracked pose in
 * the worker's camera, when there is one and the frame is at the rig
 * camera's size (a MoveNet model then looks there first). */
static void set_hint(worker *w, int rig, uint64_t capture_ns, int width, int height)
{
	mcd_detector_thread *d = w->d;
	mc_vec3 joints[MC_MAX_JOINTS];
	mc_detector_set_person_square(w->det, NULL);
	if (d->cfg.hint != MCD_HINT_POSE || !d->pose_source || !d->rig)
		return;
	const mc_camera *cam = &d->rig->cams[rig];
	int n = mcd_publisher_latest_joints(d->pose_source, capture_ns, HINT_MAX_AGE_NS, joints, MC_MAX_JOINTS);
	mc_detector_square sq;
	if (n > 0 && width == cam->width && height == cam->height &&
	    mc_detector_square_around(cam, joints, n, &sq) == 0)
		mc_detector_set_person_square(w->det, &sq);
}

/* Reads, converts and detects the worker's camera's frame `f`; hands the
 * keypoints on. */
static void detect_view(worker *w, const frame_ref *f)
{
	mcd_detector_thread *d = w->d;
	int c = w->cam;
	mc_err err = {{0}};
	mc_ring_meta meta;
	int rc = mcd_frame_ring_read(mcd_camera_ring(d->cams[c]), f->generation, f->sequence, &w->raw, &w->raw_cap,
				     &meta, &err);
	if (rc != MC_RING_FRAME) {
		pthread_mutex_lock(&d->lock);
		d->st.skipped++;
		pthread_mutex_unlock(&d->lock);
		return;
	}
	int width, height;
	if (mcd_frame_to_rgb(w->conv, &meta, w->raw, &w->rgb, &w->rgb_cap, &width, &height, &err)) {
		note_error(d, c, &err);
		return;
	}
	int rig = d->cam_to_rig[c];
	set_hint(w, rig, meta.timestamp_ns, width, height);
	int n = mc_detector_detect(w->det, w->rgb, width, height, 0, w->dets, MC_DETECTOR_MAX_JOINTS, &err);
	if (n < 0) {
		note_error(d, c, &err);
		return;
	}
	int nk = mc_detections_to_keypoints(w->dets, n, rig, d->map, w->kps, MC_DETECTOR_MAX_JOINTS);
	if (scale_to_rig(d, rig, width, height, w->kps, nk))
		return; /* a size that does not fit: the tracking thread says so */
	mcd_tracking_thread_offer_keypoints(d->sink, rig, meta.timestamp_ns, w->kps, nk);
	mc_detector_timing tm;
	mc_detector_get_timing(w->det, &tm);
	pthread_mutex_lock(&d->lock);
	d->st.detections++;
	d->st.one_look += tm.one_look - w->one_look_seen;
	w->one_look_seen = tm.one_look;
	d->st.keypoints += (uint64_t)nk;
	d->st.ms_last = tm.last_ms;
	d->st.ms_total += tm.last_ms;
	if (tm.last_ms > d->st.ms_max)
		d->st.ms_max = tm.last_ms;
	pthread_mutex_unlock(&d->lock);
}

/* ---- the loop ------------------------------------------------------------------------- */

/* Called with the lock held, on the worker's thread. */
static void apply_settings(worker *w)
{
	mcd_detector_thread *d = w->d;
	w->cfg_changed = false;
	float thr = d->cfg.min_confidence < 0 ? d->model_threshold : (float)d->cfg.min_confidence;
	mc_detector_set_threshold(w->det, thr);
	mc_detector_set_flip(w->det, d->cfg.flip);
	if (w->cam == 0) /* process-wide: one worker sets it */
		mc_detector_set_threads(d->cfg.threads);
}

/* The tracking thread and its OpenCL workers get the cores first when
 * both want them ([detector] nice): a pose should not wait for a
 * detection, whose keypoints join the tracking when they come
 * (docs/BENCHMARKS_HISTORY.md, "The budget with the detector, and the detector's priority"). */
static void name_and_lower_priority(worker *w)
{
	mcd_detector_thread *d = w->d;
	mc_thread_set_name("mocapd-detect%d", w->cam);
	if (d->cfg.nice > 0 && mc_thread_lower_priority(d->cfg.nice) < 0)
		mcd_warn("detector: camera %s: cannot lower the thread's priority by %d: %s", mcd_camera_name(d->cams[w->cam]),
			 d->cfg.nice, strerror(errno));
}

static void *worker_main(void *arg)
{
	worker *w = arg;
	mcd_detector_thread *d = w->d;
	name_and_lower_priority(w);
	pthread_mutex_lock(&d->lock);
	while (!d->stop) {
		if (w->cfg_changed)
			apply_settings(w);
		if (!w->pending) {
			struct timespec ts = mc_ns_timespec(mc_now_ns() + IDLE_WAKE_NS);
			pthread_cond_timedwait(&d->cond[w->cam], &d->lock, &ts);
			continue;
		}
		frame_ref f = w->next;
		w->pending = false;
		w->taken_ns = f.timestamp_ns;
		pthread_mutex_unlock(&d->lock);
		detect_view(w, &f);
		pthread_mutex_lock(&d->lock);
	}
	pthread_mutex_unlock(&d->lock);
	return NULL;
}

/* ---- lifetime --------------------------------------------------------------------------- */

static void fail(mcd_detector_thread *d, const char *where, const char *msg)
{
	d->st.state = MCD_DETECTOR_FAILED;
	snprintf(d->st.message, sizeof(d->st.message), "%s", msg);
	mcd_error("%s: %s; tracking without the detector's keypoints", where, msg);
}

/* Maps the detector's joints to the body model's; false if none match. */
static bool map_joints(mcd_detector_thread *d, const mc_detector *det, const mc_model *model, const char *where)
{
	int matched = mc_detector_map_model(det, model, d->map);
	int nj = mc_detector_njoints(det);
	for (int j = 0; j < nj; j++)
		if (d->map[j] < 0)
			mcd_info("detector: joint %s is not in the body model; dropped", mc_detector_joint_name(det, j));
	if (matched > 0)
		return true;
	char msg[400];
	snprintf(msg, sizeof(msg), "%s: none of its %d joints is a joint of the body model", mc_detector_path(det), nj);
	fail(d, where, msg);
	return false;
}

/* Every camera's worker, with its own network (the first is loaded
 * already). */
static int make_workers(mcd_detector_thread *d, mc_detector *first, mc_err *err)
{
	for (int c = 0; c < d->ncams; c++) {
		worker *w = &d->w[c];
		w->d = d;
		w->cam = c;
		w->det = c ? mc_detector_load(d->cfg.model, err) : first;
		if (!w->det || !(w->conv = mc_image_conv_new(err)))
			return -1;
		apply_settings(w);
	}
	return 0;
}

static void log_running(const mcd_detector_thread *d)
{
	const mc_detector *det = d->w[0].det;
	int iw, ih;
	mc_detector_input_size(det, &iw, &ih);
	char rate[64] = "every frame";
	if (d->cfg.rate > 0)
		snprintf(rate, sizeof(rate), "at most %g views/s per camera", d->cfg.rate);
	mcd_info("detector: %s (%d joints, %dx%d input), %s, threshold %.2f%s, %d OpenCV thread%s, one worker per camera "
		 "at nice +%d",
		 d->cfg.model, mc_detector_njoints(det), iw, ih, rate, (double)mc_detector_threshold(det),
		 mc_detector_flip(det) ? ", flip test" : "", d->cfg.threads, d->cfg.threads == 1 ? "" : "s", d->cfg.nice);
}

mcd_detector_thread *mcd_detector_thread_create(const mcd_detector_thread_config *cfg, mc_err *err)
{
	mcd_detector_thread *d = calloc(1, sizeof(*d));
	if (!d) {
		mc_err_set(err, "out of memory");
		return NULL;
	}
	d->ncams = cfg->ncams < MC_MAX_CAMERAS ? cfg->ncams : MC_MAX_CAMERAS;
	memcpy(d->cams, cfg->cams, sizeof(d->cams[0]) * (size_t)d->ncams);
	memcpy(d->cam_to_rig, cfg->cam_to_rig, sizeof(d->cam_to_rig[0]) * (size_t)d->ncams);
	d->rig = cfg->rig;
	d->sink = cfg->sink;
	d->cfg = *cfg->cfg;
	pthread_mutex_init(&d->lock, NULL);
	for (int c = 0; c < MC_MAX_CAMERAS; c++)
		mc_cond_init_monotonic(&d->cond[c]);
	snprintf(d->st.model, sizeof(d->st.model), "%.255s", cfg->cfg->model);
	if (!cfg->cfg->model[0] || d->ncams == 0)
		return d; /* off */
	mc_err lerr = {{0}};
	mc_detector_set_threads(d->cfg.threads);
	mc_detector *first = mc_detector_load(cfg->cfg->model, &lerr);
	if (!first) {
		fail(d, cfg->where, lerr.msg);
		return d;
	}
	if (!map_joints(d, first, cfg->model, cfg->where)) {
		mc_detector_free(first);
		return d;
	}
	d->model_threshold = mc_detector_threshold(first);
	if (make_workers(d, first, err)) {
		if (!d->w[0].det)
			mc_detector_free(first);
		mcd_detector_thread_destroy(d);
		return NULL;
	}
	d->st.state = MCD_DETECTOR_RUNNING;
	log_running(d);
	return d;
}

void mcd_detector_thread_set_pose_source(mcd_detector_thread *d, mcd_publisher *pub)
{
	d->pose_source = pub;
}

int mcd_detector_thread_start(mcd_detector_thread *d, mc_err *err)
{
	if (d->st.state != MCD_DETECTOR_RUNNING)
		return 0;
	for (int c = 0; c < d->ncams; c++) {
		int rc = pthread_create(&d->w[c].thread, NULL, worker_main, &d->w[c]);
		if (rc) {
			mcd_detector_thread_stop(d);
			return mc_err_set(err, "cannot start the detector thread of camera %s: %s", mcd_camera_name(d->cams[c]),
					  strerror(rc));
		}
		d->w[c].started = true;
	}
	d->started = true;
	mcd_tracking_thread_expect_detections(d->sink, true);
	return 0;
}

void mcd_detector_thread_stop(mcd_detector_thread *d)
{
	if (!d)
		return;
	pthread_mutex_lock(&d->lock);
	d->stop = true;
	for (int c = 0; c < d->ncams; c++)
		pthread_cond_signal(&d->cond[c]);
	pthread_mutex_unlock(&d->lock);
	for (int c = 0; c < d->ncams; c++)
		if (d->w[c].started) {
			pthread_join(d->w[c].thread, NULL);
			d->w[c].started = false;
		}
	if (d->started)
		mcd_tracking_thread_expect_detections(d->sink, false);
	d->started = false;
}

void mcd_detector_thread_destroy(mcd_detector_thread *d)
{
	if (!d)
		return;
	mcd_detector_thread_stop(d);
	for (int c = 0; c < d->ncams; c++) {
		worker *w = &d->w[c];
		mc_detector_free(w->det);
		mc_image_conv_free(w->conv);
		free(w->raw);
		free(w->rgb);
	}
	pthread_mutex_destroy(&d->lock);
	for (int c = 0; c < MC_MAX_CAMERAS; c++)
		pthread_cond_destroy(&d->cond[c]);
	free(d);
}

/* ---- from the other threads --------------------------------------------------------------- */

void mcd_detector_thread_push(mcd_detector_thread *d, int cam, uint64_t generation, const mc_ring_meta *meta)
{
	if (!d || !d->started || cam < 0 || cam >= d->ncams)
		return;
	worker *w = &d->w[cam];
	pthread_mutex_lock(&d->lock);
	uint64_t period = d->cfg.rate > 0 ? (uint64_t)(1e9 / d->cfg.rate) : 0;
	bool due = !period || !w->taken_ns || meta->timestamp_ns + RATE_SLACK_NS >= w->taken_ns + period;
	if (due) {
		if (w->pending)
			d->st.skipped++; /* the worker is behind: the newer frame wins */
		w->pending = true;
		w->next = (frame_ref){generation, meta->sequence, meta->timestamp_ns};
		pthread_cond_signal(&d->cond[cam]);
	}
	pthread_mutex_unlock(&d->lock);
}

void mcd_detector_thread_reload(mcd_detector_thread *d, const mcd_detector_config *cfg)
{
	if (!d)
		return;
	pthread_mutex_lock(&d->lock);
	d->cfg.rate = cfg->rate;
	d->cfg.threads = cfg->threads;
	d->cfg.min_confidence = cfg->min_confidence;
	if (cfg->flip != d->cfg.flip && d->w[0].det)
		mcd_info("detector: flip test %s from the next detection", cfg->flip ? "on" : "off");
	d->cfg.flip = cfg->flip;
	for (int c = 0; c < d->ncams; c++) {
		d->w[c].cfg_changed = true;
		pthread_cond_signal(&d->cond[c]);
	}
	pthread_mutex_unlock(&d->lock);
}

void mcd_detector_thread_stats(mcd_detector_thread *d, mcd_detector_stats *st, bool reset_max)
{
	if (!d) {
		memset(st, 0, sizeof(*st));
		return;
	}
	pthread_mutex_lock(&d->lock);
	*st = d->st;
	if (reset_max)
		d->st.ms_max = 0;
	pthread_mutex_unlock(&d->lock);
}

int mcd_detector_check(const mcd_detector_config *cfg, const char *where, mc_err *err)
{
	if (!cfg->model[0])
		return 0;
	mc_err lerr = {{0}};
	mc_detector *det = mc_detector_load(cfg->model, &lerr);
	if (!det)
		return mc_err_set(err, "%s: %s", where, lerr.msg);
	mc_detector_free(det);
	return 0;
}
