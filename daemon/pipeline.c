#include "pipeline.h"

#include "lockstep.h"
#include "log.h"
#include "plugin.h"
#include "recorder.h"
#include "textbuf.h"
#include "tracking_thread.h"
#include "base/mc_time.h"

#include <dirent.h>
#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <unistd.h>

/* Frame 0 of every camera is due this long after start, so that all
 * cameras are open before it. */
#define EPOCH_AHEAD_NS (300 * MC_NS_PER_MS)

struct mcd_pipeline {
	int ncams;
	mcd_plugin_set plugins;
	mcd_camera *cams[MC_MAX_CAMERAS];
	bool joined[MC_MAX_CAMERAS];
	mcd_tracking_thread *tracker;
	mcd_detector_thread *detector; /* NULL: no [detector] model */
	srv_server *srv;
	mcd_publisher *pub;
	mcd_recorder *recorder;
	bool print;
	mcd_output_config output; /* [output]: the filter the publisher starts with */
	bool tracking; /* a tracker is configured */
	const mc_rig *rig; /* its rig (NULL: none), for the settings a reload gives it */
	int event_fd;
	bool offline; /* [daemon] offline: capture waits for the tracker */
	mcd_lockstep lockstep;
	bool started; /* the tracking thread runs */
	bool stopped; /* mcd_pipeline_stop ran */

	/* The ring each camera's newest frame is in (written by the capture
	 * threads), and the one last offered to clients (main thread). */
	atomic_uint_fast64_t ring_generation[MC_MAX_CAMERAS];
	uint64_t shared_generation[MC_MAX_CAMERAS];

	/* last values seen by mcd_pipeline_progress (main thread only) */
	uint64_t seen_tracking, seen_publish, seen_cam[MC_MAX_CAMERAS];
};

/* Hands [output]'s filter to the publisher (none: off); logs it when it
 * is on at start or when a reload changed it. */
static void set_output_filter(mcd_publisher *pub, const mcd_output_config *out, bool changed)
{
	bool on = out->filter == MCD_FILTER_ONE_EURO;
	mc_one_euro_params params = {out->min_cutoff_hz, out->beta, out->d_cutoff_hz};
	mcd_publisher_set_filter(pub, on ? &params : NULL, out->max_gap_ms / 1e3);
	if (on && changed)
		mcd_info("output: One-Euro filter on (min cutoff %g Hz, beta %g per m/s, speed cutoff %g Hz; "
			 "%.0f ms lag at 1 m/s; a gap over %g ms restarts it)",
			 params.min_cutoff_hz, params.beta, params.d_cutoff_hz, 1e3 * mc_one_euro_lag_s(&params, 1.0),
			 out->max_gap_ms);
	else if (changed)
		mcd_info("output: filter off (raw poses)");
}

static void wake_main(void *ctx)
{
	mcd_pipeline *p = ctx;
	uint64_t one = 1;
	ssize_t w = write(p->event_fd, &one, sizeof(one));
	(void)w; /* EAGAIN: already readable */
}

/* ---- what the capture threads report (on their threads) ---------------------------- */

static void on_frame(void *ctx, int cam, uint64_t generation, const mc_ring_meta *meta)
{
	mcd_pipeline *p = ctx;
	atomic_store(&p->ring_generation[cam], generation);
	if (p->offline) /* on the camera's own thread, the only one that asks may_deliver for it */
		mcd_lockstep_delivered(&p->lockstep, cam);
	mcd_tracking_thread_push(p->tracker, cam, generation, meta);
	mcd_detector_thread_push(p->detector, cam, generation, meta);
	mcd_recorder_push_frame(p->recorder, cam, generation, meta);
}

/* Offline: not before every camera has tried to open (a camera whose
 * thread has not started yet is not waited for, and the first frame sets
 * would go on without it; live, EPOCH_AHEAD_NS gives them that time), then
 * in step with the tracking thread. */
static bool may_deliver(void *ctx, int cam)
{
	mcd_pipeline *p = ctx;
	return mcd_pipeline_cameras_attempted(p) && mcd_lockstep_may_deliver(&p->lockstep, cam);
}

static void on_change(void *ctx, int cam)
{
	mcd_pipeline *p = ctx;
	(void)cam;
	mcd_tracking_thread_wake(p->tracker);
	wake_main(p);
}

/* ---- lifetime -------------------------------------------------------------------------- */

/* Offline mode waits for every camera that may still deliver: a view
 * that comes after its frame set went on is dropped as late, and a
 * decoder held back by the tracker can take longer than the live
 * deadline to deliver (a camera that ended or failed is not waited for). */
static double group_deadline_ms(const mcd_config *cfg)
{
	if (cfg->offline && cfg->stall_timeout_ms > cfg->group_deadline_ms)
		return cfg->stall_timeout_ms;
	return cfg->group_deadline_ms;
}

/* Offline, every frame set is tracked however old it is. */
static double max_frame_age_ms(const mcd_config *cfg)
{
	return cfg->offline ? 0 : cfg->max_frame_age_ms;
}

static int create_tracking_thread(mcd_pipeline *p, const mcd_config *cfg, mcd_tracking *tracking, mc_err *err)
{
	mcd_tracking_thread_config tc = {
		.ncams = p->ncams,
		.cams = p->cams,
		.tracking = tracking,
		.keypoints = p->srv ? srv_keypoints_inbox(p->srv) : NULL,
		.group_tolerance_ms = cfg->group_tolerance_ms,
		.group_deadline_ms = group_deadline_ms(cfg),
		.max_frame_age_ms = max_frame_age_ms(cfg),
		.on_finished = wake_main,
		.ctx = p,
	};
	p->tracker = mcd_tracking_thread_create(&tc, err);
	if (p->tracker)
		mcd_lockstep_init(&p->lockstep, p->tracker, p->ncams, mc_now_ns());
	if (tracking)
		p->rig = &tracking->rig;
	return p->tracker ? 0 : -1;
}

/* The detector thread, when the config names a model and there is a
 * tracker to feed; a model that does not load leaves it FAILED, not an error. */
static int create_detector_thread(mcd_pipeline *p, const mcd_config *cfg, mcd_tracking *tracking, mc_err *err)
{
	if (!cfg->detector.model[0])
		return 0;
	if (!tracking) {
		if (!cfg->tracker.enabled)
			mcd_warn("detector: [tracker] enabled = false, so no tracker to feed; the detector is off");
		return 0;
	}
	char where[PATH_MAX + 64];
	mcd_detector_thread_config dc = {
		.ncams = p->ncams,
		.cams = p->cams,
		.cam_to_rig = tracking->cam_to_rig,
		.rig = &tracking->rig,
		.model = mc_tracker_model(tracking->tracker),
		.sink = p->tracker,
		.cfg = &cfg->detector,
		.where = mcd_config_where(cfg, "detector", "model", where, sizeof(where)),
	};
	p->detector = mcd_detector_thread_create(&dc, err);
	return p->detector ? 0 : -1;
}

/* The recording thread, idle until a take starts. */
static int create_recorder(mcd_pipeline *p, const mcd_config *cfg, mcd_tracking *tracking, mc_err *err)
{
	mcd_recorder_setup rs = {
		.cfg = &cfg->record,
		.daemon_cfg = cfg,
		.ncams = p->ncams,
		.cams = p->cams,
		.model = tracking ? mc_tracker_model(tracking->tracker) : NULL,
	};
	p->recorder = mcd_recorder_create(&rs, err);
	if (p->recorder && p->srv)
		srv_set_head_pose_tap(p->srv, mcd_recorder_push_head_pose, p->recorder);
	return p->recorder ? 0 : -1;
}

/* Loads the drivers and creates the cameras, all with one time origin. */
static int create_cameras(mcd_pipeline *p, const mcd_config *cfg, mc_err *err)
{
	mcd_camera_sink sink = {.ctx = p, .on_frame = on_frame, .on_change = on_change,
				.may_deliver = p->offline ? may_deliver : NULL};
	uint64_t epoch = p->offline ? MCD_OFFLINE_EPOCH_NS : mc_now_ns() + EPOCH_AHEAD_NS;
	if (p->offline) {
		mcd_info("offline: every frame set is tracked; the cameras wait for the tracker");
		mcd_lockstep_check_config(cfg);
	}
	for (int c = 0; c < p->ncams; c++) {
		const mcd_camera_config *cc = &cfg->cams[c];
		const mcd_plugin *pl = mcd_plugin_set_get(&p->plugins, cfg, cc, err);
		if (!pl || !(p->cams[c] = mcd_camera_create(c, cc, cfg->file, pl, &sink, err)))
			return -1;
		mcd_camera_set_limits(p->cams[c], cfg->reopen_initial_ms, cfg->reopen_max_ms, cfg->stall_timeout_ms);
		mcd_camera_set_epoch(p->cams[c], epoch);
		p->joined[c] = true;
	}
	return 0;
}

mcd_pipeline *mcd_pipeline_create(const mcd_config *cfg, mcd_tracking *tracking, srv_server *srv, mc_err *err)
{
	mcd_pipeline *p = calloc(1, sizeof(*p));
	if (!p) {
		mc_err_set(err, "out of memory");
		return NULL;
	}
	p->ncams = cfg->ncams;
	p->srv = srv;
	p->print = cfg->print;
	p->output = cfg->output;
	p->tracking = tracking != NULL;
	p->offline = cfg->offline;
	p->event_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	if (p->event_fd < 0) {
		mc_err_set(err, "eventfd: %s", strerror(errno));
		mcd_pipeline_destroy(p);
		return NULL;
	}
	/* The cameras are created first (the tracking thread reads them), but
	 * report to it only once started. */
	if (create_cameras(p, cfg, err) || create_tracking_thread(p, cfg, tracking, err) ||
	    create_detector_thread(p, cfg, tracking, err) || create_recorder(p, cfg, tracking, err)) {
		mcd_pipeline_destroy(p);
		return NULL;
	}
	return p;
}

int mcd_pipeline_start(mcd_pipeline *p, const char *pose_dir, mc_err *err)
{
	p->pub = mcd_publisher_create(p->srv, stdout, p->print, err);
	if (!p->pub)
		return -1;
	if (pose_dir)
		mcd_publisher_save_poses(p->pub, pose_dir);
	mcd_publisher_set_recorder(p->pub, p->recorder);
	set_output_filter(p->pub, &p->output, p->output.filter != MCD_FILTER_NONE);
	if (mcd_tracking_thread_start(p->tracker, p->pub, err))
		return -1;
	p->started = true;
	if (p->detector)
		mcd_detector_thread_set_pose_source(p->detector, p->pub);
	if (p->detector && mcd_detector_thread_start(p->detector, err))
		return -1;
	for (int c = 0; c < p->ncams; c++) {
		if (mcd_camera_start(p->cams[c], err))
			return -1;
		p->joined[c] = false;
	}
	return 0;
}

/* Asks every capture thread to stop, then waits for each up to grace_ms. */
static void stop_cameras(mcd_pipeline *p, int grace_ms)
{
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
}

void mcd_pipeline_stop(mcd_pipeline *p, int grace_ms)
{
	if (p->stopped)
		return;
	p->stopped = true;
	stop_cameras(p, grace_ms);
	mcd_detector_thread_stop(p->detector);
	if (p->started) {
		mcd_tracking_thread_stop(p->tracker);
		p->started = false;
	}
	mcd_publisher_destroy(p->pub);
	p->pub = NULL;
	/* After the publisher: the take gets the last skeletons, then ends. */
	if (p->srv)
		srv_set_head_pose_tap(p->srv, NULL, NULL);
	mcd_recorder_destroy(p->recorder);
	p->recorder = NULL;
}

void mcd_pipeline_destroy(mcd_pipeline *p)
{
	if (!p)
		return;
	mcd_pipeline_stop(p, 2000);
	mcd_detector_thread_destroy(p->detector);
	mcd_tracking_thread_destroy(p->tracker);
	bool all_joined = true;
	for (int c = 0; c < p->ncams; c++) {
		if (p->cams[c])
			mcd_camera_destroy(p->cams[c]); /* a stuck one is left to its thread */
		all_joined &= p->joined[c] || !p->cams[c];
	}
	/* A thread still inside a driver must keep its code mapped. */
	if (all_joined)
		mcd_plugin_set_unload(&p->plugins);
	if (p->event_fd >= 0)
		close(p->event_fd);
	free(p);
}

/* ---- queries for the main thread -------------------------------------------------------- */

static int take_entry(const struct dirent *e)
{
	return e->d_name[0] != '.' && (e->d_type == DT_DIR || e->d_type == DT_UNKNOWN);
}

/* "record list": the directory, then the takes in it, one name a line in
 * name order, so that a client that cannot read the directory (TCP, another
 * user) still learns them; names that do not fit are counted. */
static void list_takes(const char *dir, char *msg, size_t cap)
{
	size_t len = 0;
	msg[0] = 0;
	mcd_appendf(msg, cap, &len, "%s", dir);
	struct dirent **names = NULL;
	int n = scandir(dir, &names, take_entry, alphasort);
	int shown = 0;
	for (int i = 0; i < n; i++) {
		if (len + strlen(names[i]->d_name) + 32 < cap) { /* room for the "more" line */
			mcd_appendf(msg, cap, &len, "\n%s", names[i]->d_name);
			shown++;
		}
		free(names[i]);
	}
	free(names);
	if (shown < n)
		mcd_appendf(msg, cap, &len, "\n... and %d more", n - shown);
}

int mcd_pipeline_record(mcd_pipeline *p, int command, const char *argument, char *msg, size_t cap)
{
	if (!p->recorder) {
		snprintf(msg, cap, "mocapd is stopping");
		return -1;
	}
	switch (command) {
	case MC_CONTROL_RECORD_START: {
		mc_model *actor = malloc(sizeof(*actor)); /* the tracker's, for the take */
		bool have = actor && mcd_pipeline_actor(p, actor);
		int rc = mcd_recorder_start(p->recorder, argument, have ? actor : NULL, msg, cap);
		free(actor);
		return rc;
	}
	case MC_CONTROL_RECORD_STOP: return mcd_recorder_stop(p->recorder, msg, cap);
	case MC_CONTROL_RECORD_STATUS: mcd_recorder_status(p->recorder, msg, cap); return 0;
	default: list_takes(mcd_recorder_directory(p->recorder), msg, cap); return 0;
	}
}

bool mcd_pipeline_recording(mcd_pipeline *p)
{
	return mcd_recorder_active(p->recorder);
}

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
	for (int c = 0; c < p->ncams; c++)
		if (atomic_load(&p->ring_generation[c]) != p->shared_generation[c])
			changed = true;
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
	return mcd_tracking_thread_finished(p->tracker) && mcd_publisher_idle(p->pub);
}

/* The frame sets a recording makes: the longest camera's frames (the
 * others' frame sets go on without the cameras that ended); 0 when a
 * camera does not say how many it has. */
static uint64_t expected_sets(mcd_pipeline *p)
{
	uint64_t most = 0;
	for (int c = 0; c < p->ncams; c++) {
		mcd_cam_counters k;
		mcd_camera_counters(p->cams[c], &k);
		if (!k.expected_frames)
			return 0;
		most = k.expected_frames > most ? k.expected_frames : most;
	}
	return most;
}

void mcd_pipeline_offline_progress(mcd_pipeline *p, uint64_t now, bool final)
{
	if (p->offline && p->tracker)
		mcd_lockstep_progress(&p->lockstep, now, final, expected_sets(p));
}

bool mcd_pipeline_all_failed(mcd_pipeline *p)
{
	return mcd_tracking_thread_all_failed(p->tracker);
}

/* True if the heartbeat moved since the last look (*seen); names the thread in stuck if not. */
static bool moved(uint64_t hb, uint64_t *seen, const char *thread, char *stuck, size_t cap)
{
	bool ok = hb == UINT64_MAX || hb != *seen; /* UINT64_MAX: the thread has finished */
	if (!ok)
		snprintf(stuck, cap, "%s", thread);
	*seen = hb;
	return ok;
}

bool mcd_pipeline_progress(mcd_pipeline *p, char *stuck, size_t cap)
{
	stuck[0] = 0;
	bool ok = moved(mcd_tracking_thread_heartbeat(p->tracker), &p->seen_tracking, "tracking thread", stuck, cap);
	ok &= moved(mcd_publisher_heartbeat(p->pub), &p->seen_publish, "publishing thread", stuck, cap);
	for (int c = 0; c < p->ncams; c++) {
		char name[MCD_NAME_MAX + 32];
		snprintf(name, sizeof(name), "camera %s capture thread", mcd_camera_name(p->cams[c]));
		ok &= moved(mcd_camera_heartbeat(p->cams[c]), &p->seen_cam[c], name, stuck, cap);
	}
	return ok;
}

static void camera_status(mcd_pipeline *p, int c, const mcd_track_stats *ts, mcd_cam_status *cs)
{
	snprintf(cs->name, sizeof(cs->name), "%s", mcd_camera_name(p->cams[c]));
	snprintf(cs->driver, sizeof(cs->driver), "%s", mcd_camera_driver(p->cams[c]));
	cs->track = ts->cams[c];
	snprintf(cs->last_error, sizeof(cs->last_error), "%s", ts->last_error[c]);
	cs->state = mcd_camera_state(p->cams[c]);
	mcd_camera_counters(p->cams[c], &cs->counters);
	cs->format = mcd_camera_format(p->cams[c]);
	if (!cs->last_error[0] || cs->state != MCD_CAM_STREAMING)
		mcd_camera_last_error(p->cams[c], cs->last_error, sizeof(cs->last_error));
}

bool mcd_pipeline_actor(mcd_pipeline *p, mc_model *out)
{
	return p->tracking && p->tracker && mcd_tracking_thread_actor(p->tracker, out);
}

void mcd_pipeline_get_status(mcd_pipeline *p, mcd_pipeline_status *st, bool reset_max)
{
	mcd_track_stats ts;
	mcd_tracking_thread_stats(p->tracker, &ts, reset_max);
	memset(st, 0, sizeof(*st));
	st->ncams = p->ncams;
	st->tracking = p->tracking;
	st->track = ts.total;
	mcd_detector_thread_stats(p->detector, &st->detector, reset_max);
	for (int c = 0; c < p->ncams; c++)
		camera_status(p, c, &ts, &st->cams[c]);
	if (p->pub) {
		mcd_publisher_stats(p->pub, &st->publish);
		mcd_publisher_latency(p->pub, &st->latency);
	}
	st->latency.skipped_behind = ts.total.skipped;
	st->latency.skipped_stale = ts.total.stale;
	st->latency.incomplete = ts.total.sets - ts.total.complete_sets;
}

int mcd_pipeline_check_cameras(mcd_pipeline *p, void (*report)(const char *msg), mc_err *err)
{
	int rc = 0;
	for (int c = 0; c < p->ncams; c++) {
		mc_err e;
		if (mcd_camera_check(p->cams[c], &e) == 0)
			continue;
		if (rc == 0)
			*err = e;
		rc = -1;
		if (!report)
			break;
		report(e.msg);
	}
	return rc;
}

void mcd_pipeline_reload(mcd_pipeline *p, const mcd_config *cfg)
{
	mc_tracker_settings settings = cfg->tracker.settings;
	if (p->rig)
		mcd_tracker_settings(cfg, p->rig, &settings);
	mcd_tracking_thread_reload(p->tracker, cfg->group_tolerance_ms, group_deadline_ms(cfg), max_frame_age_ms(cfg),
				   &settings);
	mcd_detector_thread_reload(p->detector, &cfg->detector);
	for (int c = 0; c < p->ncams; c++)
		mcd_camera_set_limits(p->cams[c], cfg->reopen_initial_ms, cfg->reopen_max_ms, cfg->stall_timeout_ms);
	bool changed = memcmp(&p->output, &cfg->output, sizeof(p->output)) != 0;
	p->output = cfg->output;
	if (p->pub) {
		mcd_publisher_set_print(p->pub, cfg->print);
		set_output_filter(p->pub, &p->output, changed);
	}
}

void mcd_pipeline_share_rings(mcd_pipeline *p)
{
	if (!p->srv)
		return;
	srv_clear_rings(p->srv);
	for (int c = 0; c < p->ncams; c++) {
		uint64_t size = 0;
		int fd = mcd_frame_ring_dup(mcd_camera_ring(p->cams[c]), &size);
		if (fd < 0)
			continue;
		mc_err err;
		if (srv_add_ring(p->srv, mcd_camera_name(p->cams[c]), fd, size, &err) < 0)
			mcd_warn("camera %s: cannot offer its ring to clients: %s", mcd_camera_name(p->cams[c]), err.msg);
		close(fd);
	}
	for (int c = 0; c < p->ncams; c++)
		p->shared_generation[c] = atomic_load(&p->ring_generation[c]);
}
