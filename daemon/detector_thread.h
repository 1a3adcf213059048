/* detector_thread: the in-process 2D joint detector ([detector] in the
 * config; the runtime is detect/mc_detector.h).
 *
 * One worker thread per camera, each with its own mc_detector.  Each
 * capture thread tells its worker of every frame it commits
 * (mcd_detector_thread_push, next to the tracking thread's push); the
 * worker copies the newest frame out of the ring, converts it to RGB24,
 * detects at the configured rate and hands
 * the keypoints, stamped with the frame's capture time and the rig camera,
 * to the tracking thread (mcd_tracking_thread_offer_keypoints), which
 * matches them to its frame sets by capture time like the keypoints
 * clients send.  Nothing here ever makes the tracking thread wait.
 *
 * A model that does not load leaves the thread off, in state FAILED with
 * mc_detector_load's message (it names the file and the mismatch); the
 * daemon tracks on without keypoints. */
#ifndef MCD_DETECTOR_THREAD_H
#define MCD_DETECTOR_THREAD_H

#include "base/mc_error.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "capture.h"
#include "config.h"
#include "publish.h"
#include "tracking_thread.h"

#include <stdbool.h>
#include <stdint.h>

typedef enum {
	MCD_DETECTOR_OFF = 0,     /* no [detector] model (or no tracker) */
	MCD_DETECTOR_RUNNING = 1,
	MCD_DETECTOR_FAILED = 2,  /* the model did not load: see message */
} mcd_detector_state;

const char *mcd_detector_state_name(mcd_detector_state s);

typedef struct {
	mcd_detector_state state;
	char model[256];          /* the configured path (cut to fit) */
	char message[512];        /* FAILED: why; else the last detection error, if any */
	uint64_t detections;      /* views detected */
	uint64_t keypoints;       /* keypoints handed to the tracking thread */
	uint64_t skipped;         /* views not detected: a newer frame of the camera came first, or it was overwritten */
	uint64_t errors;          /* views that failed (conversion, network) */
	double ms_last, ms_max;   /* per view: read, conversion, network and decoding */
	double ms_total;          /* sum over all detected views (means over intervals) */
	uint64_t one_look;        /* [detector] hint = pose: views that needed only the look at the tracked pose */
} mcd_detector_stats;

typedef struct {
	int ncams;
	mcd_camera *const *cams;  /* they outlive the thread */
	const int *cam_to_rig;    /* configured camera -> rig camera */
	const mc_rig *rig;        /* its sizes: keypoints are scaled to them (frame_size.h) */
	const mc_model *model;    /* the body model, to map joint names */
	mcd_tracking_thread *sink;
	const mcd_detector_config *cfg;
	const char *where;        /* "mocapd.conf:40: [detector] model", for messages */
} mcd_detector_thread_config;

typedef struct mcd_detector_thread mcd_detector_thread;

/* Loads the model.  NULL only when out of memory; a model that does not
 * load gives a thread in state FAILED (logged), whose start does nothing. */
mcd_detector_thread *mcd_detector_thread_create(const mcd_detector_thread_config *cfg, mc_err *err);
/* Where the tracked pose comes from, for [detector] hint = pose (set before
 * the start; NULL: no hint). */
void mcd_detector_thread_set_pose_source(mcd_detector_thread *d, mcd_publisher *pub);
int mcd_detector_thread_start(mcd_detector_thread *d, mc_err *err);
void mcd_detector_thread_stop(mcd_detector_thread *d);
void mcd_detector_thread_destroy(mcd_detector_thread *d);

/* A frame of camera `cam` was committed (on a capture thread). */
void mcd_detector_thread_push(mcd_detector_thread *d, int cam, uint64_t generation, const mc_ring_meta *meta);
/* Reload: rate, threads and min_confidence from the next detection. */
void mcd_detector_thread_reload(mcd_detector_thread *d, const mcd_detector_config *cfg);
void mcd_detector_thread_stats(mcd_detector_thread *d, mcd_detector_stats *st, bool reset_max);

/* For mocapd --check: loads the model (and drops it); -1 with err naming
 * the config line, the file and the mismatch. */
int mcd_detector_check(const mcd_detector_config *cfg, const char *where, mc_err *err);

#endif
