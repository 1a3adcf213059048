/* publish: the publishing thread.  Takes tracked skeletons (or, with the
 * tracker disabled, bare frame-set records) from the tracking thread
 * through a short queue that never blocks its writer (the oldest entry is
 * dropped and counted when full), hands them to the socket server and, with
 * printing on, writes one text line per frame to stdout.
 *
 * With the output filter on ([output] filter, docs/CONFIG.md) the socket
 * server (POSE/FRAME messages and the latest-pose block) and the printed
 * lines get the filtered skeleton; the recorder and --save-poses keep the
 * tracker's own (a take records what was measured; a filter can be applied
 * when it is played back or exported). */
#ifndef MCD_PUBLISH_H
#define MCD_PUBLISH_H

#include "base/mc_error.h"
#include "base/mc_one_euro.h"
#include "server.h"
#include "track/mc_tracker.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#define MCD_OUTPUT_KEYPOINTS 256 /* 8 cameras x 32 joints */

typedef struct {
	uint64_t seq;          /* frame sets handled by the tracking thread */
	uint64_t timestamp_ns; /* capture time */
	/* CLOCK_MONOTONIC of the stages after capture (latency.h): the set
	 * complete (or released at its deadline), tracking started, the views
	 * decoded, tracking ended. */
	uint64_t ready_ns, track_start_ns, decoded_ns, track_end_ns;
	uint64_t frame;        /* the driver's frame number (first camera present) */
	int present, ncams;    /* cameras in the frame set */
	bool tracked;          /* sk and pose are valid */
	mc_skeleton sk;
	int ndof;
	double pose[MC_MAX_DOF];
	/* The 2D keypoints tracked with (clients' and the detector's), for
	 * the recorder; at most MCD_OUTPUT_KEYPOINTS. */
	int nkp;
	mc_keypoint kp[MCD_OUTPUT_KEYPOINTS];
} mcd_output;

typedef struct {
	uint64_t published;    /* entries handled */
	uint64_t dropped;      /* entries dropped because the queue was full */
	uint64_t server_errors;
} mcd_publish_stats;

typedef struct mcd_publisher mcd_publisher;

/* srv may be NULL (no socket); out is where lines go (stdout). */
mcd_publisher *mcd_publisher_create(srv_server *srv, FILE *out, bool print, mc_err *err);
void mcd_publisher_destroy(mcd_publisher *p); /* stops the thread after draining */
void mcd_publisher_push(mcd_publisher *p, const mcd_output *o);
/* The joints (rig frame) of the newest skeleton pushed whose state was ok
 * or uncertain, if it is at most max_age_ns older than now_ns: their count
 * (at most max), else 0.  Any thread. */
int mcd_publisher_latest_joints(mcd_publisher *p, uint64_t now_ns, uint64_t max_age_ns, mc_vec3 *out, int max);
void mcd_publisher_set_print(mcd_publisher *p, bool print);
/* The output filter: params NULL turns it off.  A call that changes
 * anything starts the filter again at the next skeleton. */
void mcd_publisher_set_filter(mcd_publisher *p, const mc_one_euro_params *params, double max_gap_s);
/* Hands every tracked skeleton, with its publish counter, to the recorder
 * (recorder.h).  Call before frames flow. */
typedef struct mcd_recorder mcd_recorder;
void mcd_publisher_set_recorder(mcd_publisher *p, mcd_recorder *r);
/* Also writes every tracked pose to DIR/pose_<frame>.json ({"note", "pose"},
 * the format tools/mocap-render reads with --pose).  Call before frames
 * flow.  NULL stops it. */
void mcd_publisher_save_poses(mcd_publisher *p, const char *dir);
void mcd_publisher_stats(mcd_publisher *p, mcd_publish_stats *st);
/* Stage times (capture to publish) of the newest published frame sets:
 * p50, p99, max and the window (latency.h); skip counters untouched. */
void mcd_publisher_latency(mcd_publisher *p, srv_latency_status *out);
uint64_t mcd_publisher_heartbeat(mcd_publisher *p);
/* True when nothing is queued or being handled. */
bool mcd_publisher_idle(mcd_publisher *p);

/* The text line for one output (no newline), e.g.
 *   "frame 12 t=0.400 ok 35.1ms 2/2 neck=(0.150,0.267,0.170) ..." */
void mcd_format_output(const mcd_output *o, uint64_t t0_ns, char *buf, size_t cap);

#endif
