/* motion_take: recorded takes (docs/RECORDING.md) into a motion database,
 * and a walk's poses as a take skeleton for the BVH writer (take_bvh.c). */
#ifndef MOTION_TAKE_H
#define MOTION_TAKE_H

#include "motion/mc_motion.h"
#include "take.h"

/* Adds the poses of the take in dir (its poses.mcr) as one clip.  The
 * take's joints are found by their docs/CONVENTIONS.md names; positions are
 * taken in the take's world frame (outside-in rigs: z up, floor at z = 0).
 * Errors name the take and the missing joint. */
int motion_db_add_take(mc_motion_db *db, const char *dir, const char *cls, mc_err *err);

/* The skeleton as a take definition in BVH axes (y up) with a head joint
 * added at the neck to carry head_top (19 joints), and a pose of it:
 * positions from pose, orientations from mc_motion_orientations and
 * mc_motion_head_rotation, so that the BVH's forward kinematics gives back
 * every joint of pose. */
void motion_take_def(const mc_motion_skel *s, take_def *d);
void motion_take_pose(const mc_motion_skel *s, const mc_vec3 *pose, take_pose *out);

#endif
