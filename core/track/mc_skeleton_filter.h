/* mc_skeleton_filter: the One-Euro filter (base/mc_one_euro.h) over
 * published skeletons, for clients that want smooth poses (mocapd's
 * [output] filter, docs/CONFIG.md).
 *
 * Each joint's position has its own One-Euro filter, with a cutoff from
 * that joint's speed: a still hip is smoothed hard while a moving hand
 * keeps up.  A joint's orientation is smoothed with the same factor as
 * the fastest of the joint itself and its children: the children's
 * positions are what that rotation moves, so the rotation lags no more
 * than they do (a root turning on the spot still gets a high cutoff).
 * Orientations are blended on the quaternion (normalised lerp along the
 * shorter way), which for the small steps between frames is a slerp.
 * Bone lengths are not enforced: a joint on a curved path is smoothed to
 * the inside of it and neighbouring joints lag by their own tau, so bones
 * change length a little (under 2 mm for an arm swinging at 1-2 m/s,
 * test_one_euro).
 *
 * The filter starts again (the sample passes through unchanged) on the
 * first skeleton, after a LOST or INITIALISING one (which also passes
 * through: a pose being searched for must not be blended with the last
 * good one), when the joint count changes, when time does not move
 * forward, and after a gap longer than max_gap_s (the motion in the gap
 * is unknown, so blending across it would drag the pose). */
#ifndef MC_SKELETON_FILTER_H
#define MC_SKELETON_FILTER_H

#include "base/mc_one_euro.h"
#include "track/mc_tracker.h"

typedef struct {
	mc_one_euro_params params;
	double max_gap_s;
	bool started;
	uint64_t last_ns;
	int njoints;
	mc_one_euro3 position[MC_MAX_JOINTS];
	mc_quat orientation[MC_MAX_JOINTS]; /* the previous output */
} mc_skeleton_filter;

void mc_skeleton_filter_init(mc_skeleton_filter *f, const mc_one_euro_params *params, double max_gap_s);
void mc_skeleton_filter_reset(mc_skeleton_filter *f);

/* Filters sk in place (positions and orientations; confidence, state and
 * the rest untouched), taking sk->timestamp_ns as its time.  Returns true
 * when it blended with earlier skeletons, false when sk passed through
 * unchanged (a start, see above). */
bool mc_skeleton_filter_apply(mc_skeleton_filter *f, mc_skeleton *sk);

/* Joint j's velocity estimate (m/s, the filter's dx_hat) after the last
 * apply; zero after a start. */
mc_vec3 mc_skeleton_filter_velocity(const mc_skeleton_filter *f, int j);

#endif
