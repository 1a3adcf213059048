/* recorder: the recording thread.  Writes takes (record/take.h,
 * docs/RECORDING.md) from what the other threads hand it without waiting:
 * camera frame references from the capture threads (the bytes are copied
 * out of the camera's ring here, so a recorder that falls behind loses
 * frames, counted, and never holds up capture) and tracked skeletons from
 * the publishing thread.  Files are synced every sync_ms; a write error or
 * a full disk stops the take cleanly with the reason in the status and the
 * log, and tracking goes on. */
#ifndef MCD_RECORDER_H
#define MCD_RECORDER_H

#include "base/mc_error.h"
#include "capture.h"
#include "config.h"
#include "publish.h"
#include "geom/mc_pose.h"
#include "ring/mc_ring.h"
#include "take.h"

#include <stdbool.h>

typedef struct mcd_recorder mcd_recorder;

typedef struct {
	const mcd_record_config *cfg; /* copied */
	const mcd_config *daemon_cfg; /* its file and the tracker's files, copied into each take */
	int ncams;
	mcd_camera **cams;
	const mc_model *model;        /* the tracker's, for the skeleton definition; NULL: no tracker (frames only) */
} mcd_recorder_setup;

mcd_recorder *mcd_recorder_create(const mcd_recorder_setup *s, mc_err *err);
/* Stops a take in progress (complete) and the thread. */
void mcd_recorder_destroy(mcd_recorder *r);

/* Main thread.  name: a take name (letters, digits, '.', '_', '-') in
 * [record] directory, an absolute path, or "" for take-YYYYmmdd-HHMMSS.
 * actor (may be NULL): the tracker's actor now, saved as the take's
 * actor.json.  0 and msg "recording DIR", or -1 and msg saying why. */
int mcd_recorder_start(mcd_recorder *r, const char *name, const mc_model *actor, char *msg, size_t cap);
int mcd_recorder_stop(mcd_recorder *r, char *msg, size_t cap);
bool mcd_recorder_active(mcd_recorder *r);
/* "recording DIR: 12.3 s, 370 poses, ..." or "not recording (last take
 * DIR: stopped: REASON)". */
void mcd_recorder_status(mcd_recorder *r, char *msg, size_t cap);
/* The [record] directory (for `mocapctl record list`). */
const char *mcd_recorder_directory(const mcd_recorder *r);

/* From the capture threads and the publishing thread: never block. */
void mcd_recorder_push_frame(mcd_recorder *r, int cam, uint64_t generation, const mc_ring_meta *meta);
void mcd_recorder_push_pose(mcd_recorder *r, const mcd_output *o, uint64_t seq);
/* A VR runtime's head pose (the socket server's head pose tap, on the
 * server's thread: ctx is the recorder). */
void mcd_recorder_push_head_pose(void *ctx, const mc_pose *hp);

#endif
