/* mc_ray: how far a point is from a camera's ray through a keypoint.
 *
 * The distance from the ray's line is what the keypoint term, the ray fit
 * and the inverse kinematics pull on, in metres.  Near the camera it says
 * little: every ray of a camera passes through its centre, so a joint at
 * the camera (a wrist beside a head-mounted camera) is within centimetres
 * of all of them and no keypoint pulls it out again (docs/TRACKER.md,
 * "Distance from a ray").  So a point nearer than MC_RAY_NEAR_M along the
 * ray is measured by its angle off the ray times MC_RAY_NEAR_M, as if it
 * were that far out, and one nearer than MC_RAY_MIN_DEPTH_M (or behind the
 * camera) from the ray's point at that depth, scaled alike.  Beyond
 * MC_RAY_NEAR_M (every outside-in joint) the offset is the line's.  The
 * starts and re-fits from detections (track/mc_init.c) keep the line's
 * offset (mc_ik_options.ray_near 0): there the angle weighed the neck and
 * shoulders, a few tenths of a metre below the cameras, over the limbs. */
#ifndef MC_RAY_H
#define MC_RAY_H

#include "base/mc_math.h"

/* Measured on the head rig's held-out clips (docs/TRACKER.md, "Distance
 * from a ray"): at 0.5 m the shoulders' keypoints held the torso too
 * stiffly and the sword-holding wrists got worse; 0.2 m helped less. */
#define MC_RAY_NEAR_M 0.3
#define MC_RAY_MIN_DEPTH_M 0.05

/* The offset of point v (relative to the camera's centre) from the ray
 * along unit vector dir, by the angle nearer than `near` metres
 * (MC_RAY_NEAR_M; 0: the line's offset everywhere). */
mc_vec3 mc_ray_offset(mc_vec3 v, mc_vec3 dir, double near);
/* The change of that offset for a move dv of the point (its Jacobian
 * times dv). */
mc_vec3 mc_ray_offset_move(mc_vec3 v, mc_vec3 dir, double near, mc_vec3 dv);
/* The Jacobian's transpose times g: the gradient with respect to the
 * point of a loss whose gradient with respect to the offset is g. */
mc_vec3 mc_ray_offset_pull(mc_vec3 v, mc_vec3 dir, double near, mc_vec3 g);

#endif
