/* tracking_thread: the thread that turns camera frames into skeletons.
 *
 * Each capture thread hands it every frame it committed to its camera's
 * ring (mcd_tracking_thread_push, on the capture thread).  The tracking
 * thread groups them by instant (grouper.h); for the frame set that is due
 * it copies the views out of the rings, converts them to RGB24
 * (core/image/mc_image.h), takes the keypoints for them (those of the
 * in-process detector, else those clients sent, from the server's keypoint
 * inbox, ipc/server.h), runs the tracker
 * (tracker_setup.h) and hands the result to the publishing thread
 * (publish.h).  With the tracker disabled, frame sets
 * are still grouped and handed on, untracked.
 *
 * With many frame sets due at once (the tracker is slower than the
 * cameras), only the newest is tracked and the older ones are counted as
 * skipped: a live pose is worth more than a complete but late one.  With
 * a frame age budget, a newest set already older than the budget when
 * tracking could start is skipped too (counted as stale). */
#ifndef MCD_TRACKING_THREAD_H
#define MCD_TRACKING_THREAD_H

#include "base/mc_error.h"
#include "base/mc_limits.h"
#include "capture.h"
#include "publish.h"
#include "server.h"
#include "tracker_setup.h"

#include <stdbool.h>
#include <stdint.h>

/* Counters of the tracking thread and its grouper: over all frame sets, */
typedef struct {
	uint64_t sets;          /* frame sets emitted by the grouper */
	uint64_t complete_sets; /* with every camera */
	uint64_t tracked;       /* frame sets tracked */
	uint64_t skipped;       /* frame sets skipped because newer ones were due */
	uint64_t stale;         /* frame sets skipped: older than the age budget when tracking could start */
	uint64_t track_errors;
	double track_ms_total;  /* sum over all tracked sets */
	double track_ms_max;    /* since the last mcd_tracking_thread_stats(.., reset_max) */
	int track_state;        /* mc_track_state of the last tracked set, -1 none */
	uint64_t detector_views; /* views tracked with the in-process detector's keypoints */
} mcd_track_totals;

/* ... and per camera. */
typedef struct {
	uint64_t missing;     /* frame sets emitted without this camera */
	uint64_t late;        /* frames that came after their frame set */
	uint64_t overrun;     /* frames overwritten in the ring before use */
	uint64_t undecodable; /* frames that failed conversion to RGB */
} mcd_cam_track_stats;

typedef struct {
	mcd_track_totals total;
	mcd_cam_track_stats cams[MC_MAX_CAMERAS];
	char last_error[MC_MAX_CAMERAS][256]; /* of each camera's last undecodable frame */
} mcd_track_stats;

typedef struct {
	int ncams;
	mcd_camera *const *cams; /* the cameras, by index; they outlive the thread */
	mcd_tracking *tracking;  /* NULL: the tracker is disabled */
	/* Where the keypoints clients send wait (srv_keypoints_inbox); NULL:
	 * no socket, so no keypoints from clients (the in-process detector's
	 * come through mcd_tracking_thread_offer_keypoints). */
	srv_keypoint_inbox *keypoints;
	double group_tolerance_ms, group_deadline_ms;
	double max_frame_age_ms; /* 0: no budget ([daemon] max_frame_age_ms) */
	/* Called (on the tracking thread) once every stream has ended and
	 * every frame set was handed on. */
	void (*on_finished)(void *ctx);
	void *ctx;
} mcd_tracking_thread_config;

typedef struct mcd_tracking_thread mcd_tracking_thread;

mcd_tracking_thread *mcd_tracking_thread_create(const mcd_tracking_thread_config *cfg, mc_err *err);
/* Starts the thread; its results go to `pub`, which must outlive it. */
int mcd_tracking_thread_start(mcd_tracking_thread *t, mcd_publisher *pub, mc_err *err);
/* Stops and joins the thread (nothing if it is not running). */
void mcd_tracking_thread_stop(mcd_tracking_thread *t);
void mcd_tracking_thread_destroy(mcd_tracking_thread *t);

/* A frame of camera `cam` was committed to ring `generation` (a capture
 * thread's mcd_camera_sink.on_frame). */
void mcd_tracking_thread_push(mcd_tracking_thread *t, int cam, uint64_t generation, const mc_ring_meta *meta);
/* The in-process detector's keypoints for rig camera `rig_cam`'s frame
 * captured at capture_ns (detector_thread.h; on its thread).  Only copied:
 * the next frame set whose view of that camera has this capture time uses
 * them, in place of a client's batch. */
void mcd_tracking_thread_offer_keypoints(mcd_tracking_thread *t, int rig_cam, uint64_t capture_ns,
					 const mc_keypoint *kp, int n);
/* The in-process detector started (runs) or stopped.  Only while one runs
 * does the tracking of a frame set whose keypoints have not come look for
 * them between its gradient iterations (the tracker's keypoint poll). */
void mcd_tracking_thread_expect_detections(mcd_tracking_thread *t, bool runs);
/* A camera changed state: look again at which cameras a frame set waits for. */
void mcd_tracking_thread_wake(mcd_tracking_thread *t);
/* Reload: new grouping limits and frame age budget now; the tracker's
 * budget (`budget`, may be NULL) between two frame sets. */
void mcd_tracking_thread_reload(mcd_tracking_thread *t, double group_tolerance_ms, double group_deadline_ms,
				double max_frame_age_ms, const mc_tracker_settings *budget);

/* Whether a frame set tracked in state `now`, after one in `last_state`
 * (-1: none yet), is the first pose found from the detections (the
 * tracker's `inits` first fits so far): the log says so once. */
static inline bool mcd_first_pose_found(int last_state, mc_track_state now, int inits)
{
	return inits > 0 && now != MC_TRACK_INITIALISING && (last_state < 0 || last_state == MC_TRACK_INITIALISING);
}

/* True once every stream ended and every frame set was handed on. */
bool mcd_tracking_thread_finished(mcd_tracking_thread *t);
/* True once finished with every camera failed for good (none ended). */
bool mcd_tracking_thread_all_failed(mcd_tracking_thread *t);
/* Counts the loop's iterations (the watchdog's evidence). */
uint64_t mcd_tracking_thread_heartbeat(mcd_tracking_thread *t);
void mcd_tracking_thread_stats(mcd_tracking_thread *t, mcd_track_stats *st, bool reset_max);
/* The tracker's actor as of its last colour calibration (any thread);
 * false before the first. */
bool mcd_tracking_thread_actor(mcd_tracking_thread *t, mc_model *out);

#endif
