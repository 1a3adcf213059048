/* pipeline: the wiring of capture -> group and track -> publish.
 *
 * Threads: one capture thread per camera (capture.h) writing into that
 * camera's frame ring; one tracking thread (tracking_thread.h) that groups
 * the views of one instant, reads them out of the rings and runs the
 * tracker; one publishing thread (publish.h); with a [detector] model, a
 * detector thread (detector_thread.h) that detects on the newest frames
 * and hands its keypoints to the tracking thread.  The pipeline creates them,
 * connects each capture thread's reports to the tracking thread, and
 * answers the main thread, which only starts, watches, reloads and stops.
 * In offline mode ([daemon] offline) each capture thread also waits for
 * the tracking thread to take its camera's frames (lockstep.h). */
#ifndef MCD_PIPELINE_H
#define MCD_PIPELINE_H

#include "base/mc_limits.h"
#include "capture.h"
#include "config.h"
#include "detector_thread.h"
#include "publish.h"
#include "server.h"
#include "tracker_setup.h"
#include "tracking_thread.h"

#include <stdbool.h>
#include <stdint.h>

typedef struct {
	char name[MCD_NAME_MAX];
	char driver[MCD_NAME_MAX];
	mcd_cam_state state;
	mcd_cam_counters counters;
	mdrv_format format;
	mcd_cam_track_stats track; /* what the tracking thread counted */
	char last_error[256];      /* the capture thread's, or the last undecodable frame */
} mcd_cam_status;

typedef struct {
	int ncams;
	mcd_cam_status cams[MC_MAX_CAMERAS];
	bool tracking;           /* a tracker is configured */
	mcd_track_totals track;  /* track_ms_max: since the last mcd_pipeline_get_status(.., reset_max) */
	mcd_detector_stats detector; /* ms_max: likewise */
	mcd_publish_stats publish;
	srv_latency_status latency; /* capture to publish, stage by stage, and the skipped sets */
} mcd_pipeline_status;

typedef struct mcd_pipeline mcd_pipeline;

/* Loads the driver plugins of every camera (refusing untrusted ones) and
 * prepares the cameras; starts nothing.  `tracking` (may be NULL: tracker
 * disabled) and `srv` (may be NULL) stay the caller's and must outlive the
 * pipeline. */
mcd_pipeline *mcd_pipeline_create(const mcd_config *cfg, mcd_tracking *tracking, srv_server *srv, mc_err *err);
/* pose_dir: also save every tracked pose there (NULL: no). */
int mcd_pipeline_start(mcd_pipeline *p, const char *pose_dir, mc_err *err);
/* Stops every thread; a camera thread stuck in its driver is abandoned
 * after `grace_ms` (logged) rather than waited for forever. */
void mcd_pipeline_stop(mcd_pipeline *p, int grace_ms);
void mcd_pipeline_destroy(mcd_pipeline *p);

/* Recording (recorder.h): command is MC_CONTROL_RECORD_START, _STOP,
 * _STATUS or _LIST; msg gets the answer.  0, or -1 when refused or failed. */
int mcd_pipeline_record(mcd_pipeline *p, int command, const char *argument, char *msg, size_t cap);
bool mcd_pipeline_recording(mcd_pipeline *p);

/* An eventfd that becomes readable when something the main thread cares
 * about changed: a camera's state or ring, or the end of all streams. */
int mcd_pipeline_event_fd(mcd_pipeline *p);
/* Resets the event fd and returns true if the set of camera rings changed
 * since the last call. */
bool mcd_pipeline_take_events(mcd_pipeline *p);

/* True once every camera has finished its first attempt to open. */
bool mcd_pipeline_cameras_attempted(mcd_pipeline *p);
/* True when no camera will deliver again (all ended or failed for good)
 * and every frame set was tracked and published. */
bool mcd_pipeline_finished(mcd_pipeline *p);
/* Offline mode ([daemon] offline): logs the progress line at most once a
 * second, or with `final` the totals; nothing otherwise.  Main thread. */
void mcd_pipeline_offline_progress(mcd_pipeline *p, uint64_t now, bool final);
/* True when finished because every camera failed for good (none reached
 * an end): --exit-at-end should then exit non-zero. */
bool mcd_pipeline_all_failed(mcd_pipeline *p);
/* True if every pipeline thread has gone round its loop since the last
 * call (a stuck thread makes it false): the watchdog's evidence. */
bool mcd_pipeline_progress(mcd_pipeline *p, char *stuck, size_t cap);

void mcd_pipeline_get_status(mcd_pipeline *p, mcd_pipeline_status *st, bool reset_max);

/* Applies what can change safely at run time: grouping limits, reopen
 * backoff and stall limit, printing, tracker budgets, the detector's rate,
 * threads and confidence threshold. */
void mcd_pipeline_reload(mcd_pipeline *p, const mcd_config *cfg);
/* mocapd --check: every camera's keys, checked by its driver without
 * opening a device (mcd_camera_check).  err gets the first error; with
 * `report`, every camera is checked and each error handed to it. */
int mcd_pipeline_check_cameras(mcd_pipeline *p, void (*report)(const char *msg), mc_err *err);
/* The tracker's actor as of its last calibration; false when there is no
 * tracker or it has not calibrated one yet. */
bool mcd_pipeline_actor(mcd_pipeline *p, mc_model *out);

/* Offers every camera ring to the server's clients (after start and when
 * mcd_pipeline_take_events says the rings changed). */
void mcd_pipeline_share_rings(mcd_pipeline *p);

#endif
