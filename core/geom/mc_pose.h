/* Timed rigid poses: the pose of one frame in another at one instant (e.g.
 * world_from_rig, as a VR runtime reports the head), interpolated in time
 * and applied to points and orientations.  Pure functions, no state.
 *
 * The server uses them to send skeletons in a VR runtime's world frame:
 * the head pose at a frame's capture time is taken from the recent
 * history of head poses (mc_pose_at), then every joint is moved from the
 * rig frame into the world frame (mc_pose_apply). */
#ifndef MC_POSE_H
#define MC_POSE_H

#include "base/mc_math.h"

#include <stdbool.h>
#include <stdint.h>

/* a_from_b at timestamp_ns: p_a = orientation * p_b + position. */
typedef struct {
	uint64_t timestamp_ns;   /* CLOCK_MONOTONIC */
	mc_vec3 position;        /* translation, metres */
	mc_quat orientation;     /* rotation, unit */
} mc_pose;

/* Normalised linear interpolation from a (s = 0) to b (s = 1) on the
 * shorter arc.  Between orientations a few milliseconds apart it matches
 * slerp closely, at a fraction of the cost. */
mc_quat mc_quat_nlerp(mc_quat a, mc_quat b, double s);

/* The pose at t between `before` and `after` (before->timestamp_ns <= t <=
 * after->timestamp_ns): position linear, orientation mc_quat_nlerp; equal
 * timestamps give `before`'s pose.  The result's timestamp is t. */
mc_pose mc_pose_interpolate(const mc_pose *before, const mc_pose *after, uint64_t t);

/* The pose at time t from n poses in any order (a history ring):
 * interpolated between the newest pose at or before t and the oldest at or
 * after it when they are at most 2 * max_age_ns apart; else the nearer of
 * the two that lies within max_age_ns of t, as it is.  false when there is
 * none. */
bool mc_pose_at(const mc_pose *poses, int n, uint64_t t, uint64_t max_age_ns, mc_pose *out);

/* Moves a point and an orientation from frame b into frame a (a_from_b =
 * *pose): *position = R * position + t, *orientation = R * orientation.
 * Either pointer may be NULL. */
void mc_pose_apply(const mc_pose *pose, mc_vec3 *position, mc_quat *orientation);

#endif
