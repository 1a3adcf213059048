/* grouper: gathers the views of one instant from several cameras.
 *
 * Capture threads report each committed frame (its ring sequence number,
 * its capture timestamp and when it arrived).  A group is anchored at the
 * oldest pending frame; every camera's oldest pending frame within
 * `tolerance` of the anchor's timestamp joins it.  A group is emitted
 *   - at once when every expected camera has a frame in it;
 *   - at once when every expected camera that is missing has already moved
 *     on (its oldest pending frame is newer than anchor + tolerance: the
 *     frame for this instant was lost);
 *   - otherwise when `deadline` has passed since its first member arrived:
 *     a missing camera is counted, never waited on forever.
 * "Expected" cameras are those the caller says may deliver; a camera that
 * is down is not waited for (but still counted as missing).
 * A frame that arrives after its instant's group was emitted (its timestamp
 * is within tolerance of, or older than, the last emitted group) is late:
 * it is dropped and counted.  Timestamps of one camera must not decrease.
 *
 * Pure bookkeeping, no locking and no clock: the caller passes `now`. */
#ifndef MCD_GROUPER_H
#define MCD_GROUPER_H

#include "base/mc_limits.h"

#include <stdbool.h>
#include <stdint.h>

#define MCD_GROUP_QUEUE 32 /* pending frames per camera; older ones are dropped */

typedef struct {
	uint64_t generation;   /* of the camera's ring */
	uint64_t sequence;     /* in the camera's ring */
	uint64_t timestamp_ns; /* capture time */
	uint64_t arrival_ns;   /* when the capture thread committed it */
} mcd_frame_ref;

typedef struct {
	uint64_t timestamp_ns; /* the anchor's: the oldest member */
	/* When the group became due: its last member's arrival, or its
	 * deadline when it was released without a camera that may still
	 * deliver (latency accounting: capture -> ready -> tracked). */
	uint64_t ready_ns;
	int present;
	bool has[MC_MAX_CAMERAS];
	mcd_frame_ref frame[MC_MAX_CAMERAS];
} mcd_group;

typedef struct {
	uint64_t groups, complete, partial;
	uint64_t missing[MC_MAX_CAMERAS]; /* groups emitted without this camera */
	uint64_t late[MC_MAX_CAMERAS];    /* frames too late for their group */
	uint64_t overflow[MC_MAX_CAMERAS];/* frames dropped because the queue was full */
} mcd_grouper_stats;

typedef struct {
	int ncams;
	uint64_t tolerance_ns, deadline_ns;
	struct {
		mcd_frame_ref q[MCD_GROUP_QUEUE];
		int head, count;
	} cam[MC_MAX_CAMERAS];
	bool emitted_any;
	uint64_t last_ts; /* timestamp of the last emitted group */
	mcd_grouper_stats stats;
} mcd_grouper;

void mcd_grouper_init(mcd_grouper *g, int ncams, uint64_t tolerance_ns, uint64_t deadline_ns);
void mcd_grouper_set_limits(mcd_grouper *g, uint64_t tolerance_ns, uint64_t deadline_ns);
/* Adds a frame of camera `cam`. Returns false if it was dropped as late. */
bool mcd_grouper_push(mcd_grouper *g, int cam, const mcd_frame_ref *f);
/* Emits the next group if one is due at time `now`; `expect` has bit c set
 * for every camera c that is streaming. Returns true and fills *out. */
bool mcd_grouper_pop(mcd_grouper *g, uint64_t now, uint32_t expect, mcd_group *out);
/* When the pending group, if any, falls due by its deadline (UINT64_MAX if
 * nothing is pending), so that the caller can sleep until then. */
uint64_t mcd_grouper_due(const mcd_grouper *g);
/* Frames waiting. */
int mcd_grouper_pending(const mcd_grouper *g);

#endif
