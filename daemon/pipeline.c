#include "pipeline.h"

#include "grouper.h"
#include "log.h"
#include "image/mc_image.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#define MS 1000000ull

struct mcd_pipeline {
	int ncams;
	char config_file[PATH_MAX];
	int nplugins;
	mcd_plugin plugins[MCD_MAX_CAMERAS];
	mcd_camera *cams[MCD_MAX_CAMERAS];
	bool joined[MCD_MAX_CAMERAS];
	mcd_tracking *tracking;
	srv_server *srv;
	mcd_publisher *pub;
	bool print;
	int event_fd;

	/* Guards everything below, shared by the threads. */
	pthread_mutex_t lock;
	pthread_cond_t cond;
	mcd_grouper grouper;
	bool stop, started, finished;
	bool stopped; /* mcd_pipeline_stop ran (main thread only) */
	bool reload_pending;
	mcd_tracker_config reload_tc;
	mcd_pipeline_status st; /* counters kept by the tracking thread */
	uint64_t shared_generation[MCD_MAX_CAMERAS];
	uint64_t ring_generation[MCD_MAX_CAMERAS];

	pthread_t thread;
	atomic_uint_fast64_t heartbeat;
	/* last values seen by mcd_pipeline_progress (main thread only) */
	uint64_t seen_tracking, seen_publish, seen_cam[MCD_MAX_CAMERAS];

	/* Tracking thread only. */
	mc_image_conv *conv;
	uint8_t *raw[MCD_MAX_CAMERAS], *rgb[MCD_MAX_CAMERAS];
	size_t raw_cap[MCD_MAX_CAMERAS], rgb_cap[MCD_MAX_CAMERAS];
	uint64_t seq;
	srv_keypoints *kp_batch;
	srv_keypoints *kp_latest; /* per rig camera */
	mc_keypoint *kp;                /* the ones used for one frame set */
};

static uint64_t now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static void wake_main(mcd_pipeline *p)
{
	uint64_t one = 1;
	ssize_t w = write(p->event_fd, &one, sizeof(one));
	(void)w; /* EAGAIN: already readable */
}

/* ---- what the capture threads report --------------------------------------- */

static void on_frame(void *ctx, int cam, uint64_t generation, const mc_ring_meta *meta)
{
	mcd_pipeline *p = ctx;
	mcd_frame_ref ref = {.generation = generation, .sequence = meta->sequence,
			     .timestamp_ns = meta->timestamp_ns, .arrival_ns = meta->commit_ns ? meta->commit_ns : now_ns()};
	pthread_mutex_lock(&p->lock);
	mcd_grouper_push(&p->grouper, cam, &ref);
	p->ring_generation[cam] = generation;
	pthread_cond_signal(&p->cond);
	pthread_mutex_unlock(&p->lock);
}

static void on_change(void *ctx, int cam)
{
	mcd_pipeline *p = ctx;
	(void)cam;
	pthread_mutex_lock(&p->lock);
	pthread_cond_signal(&p->cond);
	pthread_mutex_unlock(&p->lock);
	wake_main(p);
}

/* ---- the tracking thread -------------------------------------------------------- */

/* Cameras a frame set waits for (up to the deadline): those streaming, and
 * those opening, whose first frame may be on its way. */
static uint32_t expected_cameras(mcd_pipeline *p)
{
	uint32_t mask = 0;
	for (int c = 0; c < p->ncams; c++) {
		mcd_cam_state s = mcd_camera_state(p->cams[c]);
		if (s == MCD_CAM_STREAMING || s == MCD_CAM_OPENING)
			mask |= 1u << c;
	}
	return mask;
}

/* Every camera has stopped for good and at least one reached its end. */
static bool streams_over(mcd_pipeline *p)
{
	bool ended = false;
	for (int c = 0; c < p->ncams; c++) {
		mcd_cam_state s = mcd_camera_state(p->cams[c]);
		if (s != MCD_CAM_ENDED && s != MCD_CAM_FAILED)
			return false;
		ended |= s == MCD_CAM_ENDED;
	}
	return ended;
}

/* Logs the first few of a kind of problem, then every power of two. */
static bool worth_logging(uint64_t n)
{
	return n <= 3 || (n & (n - 1)) == 0;
}

/* Converts camera c's frame (raw[c]) to RGB24 in rgb[c]. */
static int to_rgb(mcd_pipeline *p, int c, const mc_ring_meta *meta, int *w, int *h, mc_err *err)
{
	mc_image_frame fr = {.pixfmt = meta->pixfmt, .width = meta->width, .height = meta->height,
			     .stride = meta->stride, .data = p->raw[c], .bytes = meta->bytesused};
	*w = (int)meta->width;
	*h = (int)meta->height;
	if (meta->pixfmt == 4 /* MC_PIXFMT_MJPEG */ && (*w == 0 || *h == 0)) {
		if (mc_image_jpeg_size(p->conv, p->raw[c], meta->bytesused, w, h, err))
			return -1;
	}
	size_t need = (size_t)*w * (size_t)*h * 3;
	if (p->rgb_cap[c] < need) {
		uint8_t *grown = realloc(p->rgb[c], need);
		if (!grown)
			return mc_err_set(err, "out of memory");
		p->rgb[c] = grown;
		p->rgb_cap[c] = need;
	}
	return mc_image_to_rgb24(p->conv, &fr, p->rgb[c], need, err);
}

/* Copies out and converts the frames of a group; fills views (by rig
 * camera when tracking, else by camera).  Returns how many are usable. */
static int gather_views(mcd_pipeline *p, const mcd_group *g, mc_frame_view *views, uint64_t *frame)
{
	int present = 0;
	for (int c = 0; c < p->ncams; c++) {
		if (!g->has[c])
			continue;
		mc_err err = {{0}};
		mc_ring_meta meta;
		int rc = mcd_camera_read(p->cams[c], g->frame[c].generation, g->frame[c].sequence, &p->raw[c],
					 &p->raw_cap[c], &meta, &err);
		if (rc != MC_RING_FRAME) {
			pthread_mutex_lock(&p->lock);
			uint64_t n = ++p->st.cams[c].overrun;
			pthread_mutex_unlock(&p->lock);
			if (worth_logging(n))
				mcd_warn("camera %s: frame %llu was overwritten before it could be tracked (%llu so far)%s%s",
					 mcd_camera_name(p->cams[c]), (unsigned long long)g->frame[c].sequence,
					 (unsigned long long)n, rc < 0 ? ": " : "", rc < 0 ? err.msg : "");
			continue;
		}
		int w, h;
		if (to_rgb(p, c, &meta, &w, &h, &err)) {
			pthread_mutex_lock(&p->lock);
			uint64_t n = ++p->st.cams[c].undecodable;
			snprintf(p->st.cams[c].last_error, sizeof(p->st.cams[c].last_error), "frame dropped: %.220s",
				 err.msg);
			pthread_mutex_unlock(&p->lock);
			if (worth_logging(n))
				mcd_warn("camera %s: frame dropped: %s (%llu so far)", mcd_camera_name(p->cams[c]), err.msg,
					 (unsigned long long)n);
			continue;
		}
		int slot = p->tracking ? p->tracking->cam_to_rig[c] : c;
		views[slot] = (mc_frame_view){.width = w, .height = h, .stride = w * 3, .rgb = p->rgb[c],
					      .timestamp_ns = meta.timestamp_ns};
		if (!present++)
			*frame = meta.driver_sequence;
	}
	return present;
}

/* Keypoints sent by clients for the frames of this set. */
static int collect_keypoints(mcd_pipeline *p, const mc_frame_view *views, int nviews)
{
	if (!p->srv || !p->kp_batch)
		return 0;
	while (srv_poll_keypoints(p->srv, p->kp_batch) == 1)
		if (p->kp_batch->cam >= 0 && p->kp_batch->cam < nviews)
			p->kp_latest[p->kp_batch->cam] = *p->kp_batch;
	pthread_mutex_lock(&p->lock);
	uint64_t tol = p->grouper.tolerance_ns;
	pthread_mutex_unlock(&p->lock);
	int n = 0;
	for (int r = 0; r < nviews; r++) {
		const srv_keypoints *b = &p->kp_latest[r];
		if (!views[r].rgb || !b->nkeypoints)
			continue;
		uint64_t a = b->capture_ns, t = views[r].timestamp_ns;
		if ((a > t ? a - t : t - a) > tol)
			continue;
		for (int k = 0; k < b->nkeypoints; k++) {
			p->kp[n] = b->keypoints[k];
			p->kp[n++].cam = r;
		}
	}
	return n;
}

static void track(mcd_pipeline *p, const mc_frame_view *views, int present, mcd_output *o)
{
	mcd_tracking *t = p->tracking;
	int nviews = t->rig.ncams;
	mc_err err = {{0}};
	if (t->calibrate_pending && present == p->ncams) {
		t->calibrate_pending = false;
		if (mc_tracker_calibrate_colors(t->tracker, views, nviews, &err))
			mcd_warn("tracker: colour calibration failed: %s; keeping the model's colours", err.msg);
		else
			mcd_info("tracker: actor colours calibrated on the first complete frame set");
	}
	int nkp = collect_keypoints(p, views, nviews);
	int rc = mc_tracker_track(t->tracker, views, nviews, nkp ? p->kp : NULL, nkp, &o->sk, &err);
	pthread_mutex_lock(&p->lock);
	if (rc == 0) {
		o->tracked = true;
		o->ndof = mc_tracker_model(t->tracker)->ndof;
		memcpy(o->pose, mc_tracker_pose(t->tracker), sizeof(double) * (size_t)o->ndof);
		p->st.tracked++;
		p->st.track_ms_total += o->sk.track_ms;
		if (o->sk.track_ms > p->st.track_ms_max)
			p->st.track_ms_max = o->sk.track_ms;
		p->st.track_state = (int)o->sk.state;
	} else
		p->st.track_errors++;
	uint64_t errors = p->st.track_errors;
	pthread_mutex_unlock(&p->lock);
	if (rc != 0 && worth_logging(errors))
		mcd_warn("tracker: %s (%llu failures so far)", err.msg, (unsigned long long)errors);
}

static void process(mcd_pipeline *p, const mcd_group *g)
{
	mc_frame_view views[MC_MAX_CAMERAS];
	memset(views, 0, sizeof(views));
	mcd_output *o = calloc(1, sizeof(*o));
	if (!o)
		return;
	int present = gather_views(p, g, views, &o->frame);
	o->seq = ++p->seq;
	o->timestamp_ns = g->timestamp_ns;
	o->present = present;
	o->ncams = p->ncams;
	if (p->tracking && present > 0)
		track(p, views, present, o);
	if (o->tracked)
		o->sk.timestamp_ns = g->timestamp_ns;
	mcd_publisher_push(p->pub, o);
	free(o);
}

static void apply_reload(mcd_pipeline *p)
{
	mcd_tracker_config tc = p->reload_tc;
	p->reload_pending = false;
	pthread_mutex_unlock(&p->lock);
	mc_err err = {{0}};
	if (p->tracking && mcd_tracking_reload(p->tracking, &tc, &err))
		mcd_error("reload: tracker: %s; keeping the previous tracker", err.msg);
	pthread_mutex_lock(&p->lock);
}

static void wait_until(mcd_pipeline *p, uint64_t until)
{
	struct timespec ts = {.tv_sec = (time_t)(until / 1000000000ull), .tv_nsec = (long)(until % 1000000000ull)};
	pthread_cond_timedwait(&p->cond, &p->lock, &ts);
}

static void *tracking_main(void *arg)
{
	mcd_pipeline *p = arg;
	pthread_mutex_lock(&p->lock);
	while (!p->stop) {
		atomic_fetch_add(&p->heartbeat, 1);
		if (p->reload_pending) {
			apply_reload(p);
			continue;
		}
		/* Camera states take their own locks; never the other way round. */
		uint32_t expect = expected_cameras(p);
		uint64_t now = now_ns();
		mcd_group g, newest = {0};
		int due = 0;
		while (mcd_grouper_pop(&p->grouper, now, expect, &g)) {
			if (due++)
				p->st.skipped++;
			newest = g;
		}
		if (due) {
			pthread_mutex_unlock(&p->lock);
			process(p, &newest);
			pthread_mutex_lock(&p->lock);
			continue;
		}
		if (!p->finished && mcd_grouper_pending(&p->grouper) == 0 && streams_over(p) &&
		    mcd_publisher_idle(p->pub)) {
			p->finished = true;
			wake_main(p);
		}
		uint64_t wake = now + 100 * MS;
		uint64_t deadline = mcd_grouper_due(&p->grouper);
		if (deadline < wake)
			wake = deadline;
		wait_until(p, wake);
	}
	pthread_mutex_unlock(&p->lock);
	return NULL;
}

/* ---- lifetime -------------------------------------------------------------------------- */

static const mcd_plugin *load_plugin(mcd_pipeline *p, const mcd_config *cfg, const mcd_camera_config *cam,
				     mc_err *err)
{
	for (int i = 0; i < p->nplugins; i++)
		if (strcmp(p->plugins[i].name, cam->driver) == 0)
			return &p->plugins[i];
	mcd_plugin *pl = &p->plugins[p->nplugins];
	if (mcd_plugin_load(cfg->plugin_dir, cam->driver, geteuid(), getegid(), pl, err)) {
		mc_err_prefix(err, "%s:%d: [camera %s] driver", cfg->file, cam->driver_line, cam->name);
		return NULL;
	}
	p->nplugins++;
	mcd_info("driver %s: %s (%s)", cam->driver, pl->driver->description ? pl->driver->description : "",
		 pl->path);
	return pl;
}

mcd_pipeline *mcd_pipeline_create(const mcd_config *cfg, mcd_tracking *tracking, srv_server *srv, mc_err *err)
{
	mcd_pipeline *p = calloc(1, sizeof(*p));
	if (!p) {
		mc_err_set(err, "out of memory");
		return NULL;
	}
	p->ncams = cfg->ncams;
	p->tracking = tracking;
	p->srv = srv;
	p->print = cfg->print;
	p->st.track_state = -1;
	p->st.tracking = tracking != NULL;
	snprintf(p->config_file, sizeof(p->config_file), "%s", cfg->file);
	pthread_mutex_init(&p->lock, NULL);
	pthread_condattr_t ca;
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&p->cond, &ca);
	pthread_condattr_destroy(&ca);
	p->event_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	mcd_grouper_init(&p->grouper, p->ncams, (uint64_t)(cfg->group_tolerance_ms * 1e6),
			 (uint64_t)(cfg->group_deadline_ms * 1e6));
	p->conv = mc_image_conv_new(err);
	if (p->event_fd < 0 || !p->conv) {
		if (p->event_fd < 0)
			mc_err_set(err, "eventfd: %s", strerror(errno));
		mcd_pipeline_destroy(p);
		return NULL;
	}
	if (srv) {
		p->kp_batch = calloc(1, sizeof(*p->kp_batch));
		p->kp_latest = calloc(MC_MAX_CAMERAS, sizeof(*p->kp_latest));
		p->kp = calloc((size_t)MC_MAX_CAMERAS * SRV_MAX_KEYPOINTS, sizeof(*p->kp));
		if (!p->kp_batch || !p->kp_latest || !p->kp) {
			mc_err_set(err, "out of memory");
			mcd_pipeline_destroy(p);
			return NULL;
		}
	}
	mcd_camera_sink sink = {.ctx = p, .on_frame = on_frame, .on_change = on_change};
	/* Frame 0 of every camera at the same instant, a little ahead so that
	 * all cameras are open before it is due. */
	uint64_t epoch = now_ns() + 300 * MS;
	for (int c = 0; c < p->ncams; c++) {
		const mcd_camera_config *cc = &cfg->cams[c];
		const mcd_plugin *pl = load_plugin(p, cfg, cc, err);
		if (!pl || !(p->cams[c] = mcd_camera_create(c, cc, cfg->file, pl, &sink, err))) {
			mcd_pipeline_destroy(p);
			return NULL;
		}
		mcd_camera_set_limits(p->cams[c], cfg->reopen_initial_ms, cfg->reopen_max_ms, cfg->stall_timeout_ms);
		mcd_camera_set_epoch(p->cams[c], epoch);
		p->joined[c] = true;
		snprintf(p->st.cams[c].name, sizeof(p->st.cams[c].name), "%s", cc->name);
		snprintf(p->st.cams[c].driver, sizeof(p->st.cams[c].driver), "%s", cc->driver);
	}
	p->st.ncams = p->ncams;
	return p;
}

int mcd_pipeline_start(mcd_pipeline *p, const char *pose_dir, mc_err *err)
{
	p->pub = mcd_publisher_create(p->srv, stdout, p->print, err);
	if (!p->pub)
		return -1;
	if (pose_dir)
		mcd_publisher_save_poses(p->pub, pose_dir);
	int rc = pthread_create(&p->thread, NULL, tracking_main, p);
	if (rc)
		return mc_err_set(err, "cannot start the tracking thread: %s", strerror(rc));
	p->started = true;
	for (int c = 0; c < p->ncams; c++) {
		if (mcd_camera_start(p->cams[c], err))
			return -1;
		p->joined[c] = false;
	}
	return 0;
}

void mcd_pipeline_stop(mcd_pipeline *p, int grace_ms)
{
	if (p->stopped)
		return;
	p->stopped = true;
	for (int c = 0; c < p->ncams; c++)
		if (p->cams[c])
			mcd_camera_request_stop(p->cams[c]);
	for (int c = 0; c < p->ncams; c++) {
		if (!p->cams[c] || p->joined[c])
			continue;
		if (mcd_camera_join(p->cams[c], grace_ms) == 0)
			p->joined[c] = true;
		else
			mcd_error("camera %s: its driver did not return within %d ms; leaving it behind",
				  mcd_camera_name(p->cams[c]), grace_ms);
	}
	if (p->started) {
		pthread_mutex_lock(&p->lock);
		p->stop = true;
		pthread_cond_signal(&p->cond);
		pthread_mutex_unlock(&p->lock);
		pthread_join(p->thread, NULL);
		p->started = false;
	}
	mcd_publisher_destroy(p->pub);
	p->pub = NULL;
}

void mcd_pipeline_destroy(mcd_pipeline *p)
{
	if (!p)
		return;
	mcd_pipeline_stop(p, 2000);
	bool all_joined = true;
	for (int c = 0; c < p->ncams; c++) {
		if (p->cams[c])
			mcd_camera_destroy(p->cams[c]); /* a stuck one is left to its thread */
		all_joined &= p->joined[c] || !p->cams[c];
	}
	/* A thread still inside a driver must keep its code mapped. */
	if (all_joined)
		for (int i = 0; i < p->nplugins; i++)
			mcd_plugin_unload(&p->plugins[i]);
	for (int c = 0; c < MCD_MAX_CAMERAS; c++) {
		free(p->raw[c]);
		free(p->rgb[c]);
	}
	free(p->kp_batch);
	free(p->kp_latest);
	free(p->kp);
	mc_image_conv_free(p->conv);
	if (p->event_fd >= 0)
		close(p->event_fd);
	pthread_mutex_destroy(&p->lock);
	pthread_cond_destroy(&p->cond);
	free(p);
}

/* ---- queries for the main thread -------------------------------------------------------- */

int mcd_pipeline_event_fd(mcd_pipeline *p)
{
	return p->event_fd;
}

bool mcd_pipeline_take_events(mcd_pipeline *p)
{
	uint64_t v;
	ssize_t r = read(p->event_fd, &v, sizeof(v));
	(void)r;
	bool changed = false;
	pthread_mutex_lock(&p->lock);
	for (int c = 0; c < p->ncams; c++)
		if (p->ring_generation[c] != p->shared_generation[c])
			changed = true;
	pthread_mutex_unlock(&p->lock);
	return changed;
}

bool mcd_pipeline_cameras_attempted(mcd_pipeline *p)
{
	for (int c = 0; c < p->ncams; c++)
		if (!mcd_camera_attempted(p->cams[c]))
			return false;
	return true;
}

bool mcd_pipeline_finished(mcd_pipeline *p)
{
	pthread_mutex_lock(&p->lock);
	bool done = p->finished;
	pthread_mutex_unlock(&p->lock);
	return done && mcd_publisher_idle(p->pub);
}

bool mcd_pipeline_progress(mcd_pipeline *p, char *stuck, size_t cap)
{
	bool ok = true;
	stuck[0] = 0;
	uint64_t hb = atomic_load(&p->heartbeat);
	if (hb == p->seen_tracking) {
		ok = false;
		snprintf(stuck, cap, "tracking thread");
	}
	p->seen_tracking = hb;
	hb = mcd_publisher_heartbeat(p->pub);
	if (hb == p->seen_publish) {
		ok = false;
		snprintf(stuck, cap, "publishing thread");
	}
	p->seen_publish = hb;
	for (int c = 0; c < p->ncams; c++) {
		hb = mcd_camera_heartbeat(p->cams[c]);
		if (hb != UINT64_MAX && hb == p->seen_cam[c]) {
			ok = false;
			snprintf(stuck, cap, "camera %s capture thread", mcd_camera_name(p->cams[c]));
		}
		p->seen_cam[c] = hb;
	}
	return ok;
}

void mcd_pipeline_get_status(mcd_pipeline *p, mcd_pipeline_status *st, bool reset_max)
{
	pthread_mutex_lock(&p->lock);
	*st = p->st;
	st->sets = p->grouper.stats.groups;
	st->complete_sets = p->grouper.stats.complete;
	for (int c = 0; c < p->ncams; c++) {
		st->cams[c].missing = p->grouper.stats.missing[c];
		st->cams[c].late = p->grouper.stats.late[c] + p->grouper.stats.overflow[c];
	}
	if (reset_max)
		p->st.track_ms_max = 0;
	pthread_mutex_unlock(&p->lock);
	for (int c = 0; c < p->ncams; c++) {
		mcd_cam_status *cs = &st->cams[c];
		cs->state = mcd_camera_state(p->cams[c]);
		mcd_camera_counters(p->cams[c], &cs->counters);
		cs->format = mcd_camera_format(p->cams[c]);
		if (!cs->last_error[0] || cs->state != MCD_CAM_STREAMING)
			mcd_camera_last_error(p->cams[c], cs->last_error, sizeof(cs->last_error));
	}
	if (p->pub)
		mcd_publisher_stats(p->pub, &st->publish);
}

void mcd_pipeline_reload(mcd_pipeline *p, const mcd_config *cfg)
{
	pthread_mutex_lock(&p->lock);
	mcd_grouper_set_limits(&p->grouper, (uint64_t)(cfg->group_tolerance_ms * 1e6),
			       (uint64_t)(cfg->group_deadline_ms * 1e6));
	p->reload_tc = cfg->tracker;
	p->reload_pending = p->tracking != NULL;
	pthread_cond_signal(&p->cond);
	pthread_mutex_unlock(&p->lock);
	for (int c = 0; c < p->ncams; c++)
		mcd_camera_set_limits(p->cams[c], cfg->reopen_initial_ms, cfg->reopen_max_ms, cfg->stall_timeout_ms);
	if (p->pub)
		mcd_publisher_set_print(p->pub, cfg->print);
}

void mcd_pipeline_share_rings(mcd_pipeline *p)
{
	if (!p->srv)
		return;
	srv_clear_rings(p->srv);
	for (int c = 0; c < p->ncams; c++) {
		uint64_t size = 0;
		int fd = mcd_camera_ring_dup(p->cams[c], &size);
		if (fd < 0)
			continue;
		mc_err err;
		if (srv_add_ring(p->srv, mcd_camera_name(p->cams[c]), fd, size, &err) < 0)
			mcd_warn("camera %s: cannot offer its ring to clients: %s", mcd_camera_name(p->cams[c]), err.msg);
		close(fd);
	}
	pthread_mutex_lock(&p->lock);
	for (int c = 0; c < p->ncams; c++)
		p->shared_generation[c] = p->ring_generation[c];
	pthread_mutex_unlock(&p->lock);
}
