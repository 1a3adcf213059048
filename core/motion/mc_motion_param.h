/* mc_motion_param: motion of a parametric node at a requested speed
 * (Casas et al. 2013 sec. 4, on skeletons; docs/MOTION_GRAPH.md,
 * "Parametric blending").
 *
 * The node's members are sorted by speed; the two that bracket the target
 * (the slowest or the fastest when it lies outside: no extrapolation) are
 * aligned frame to frame by dynamic time warping of their poses in their
 * floor frames (the whole clips, no slope constraint), and blended with a
 * weight w:
 *
 *   - the blended clip lasts (1 - w) T_a + w T_b and is sampled at the
 *     database's rate; sample k sits at the fraction k / (N - 1) of the
 *     warping path (its coordinates averaged over 5 steps), which gives a
 *     fractional frame of each member;
 *   - its pose in its floor frame is (1 - w) q_a + w q_b (joint positions,
 *     then bone lengths re-imposed);
 *   - its root moves by (1 - w) r_a + w r_b per sample, r being a member's
 *     floor-frame motion (x, y, heading) from the previous sample to this
 *     one, expressed in the previous sample's floor frame; the root path is
 *     their integral from the origin, facing +y.
 *
 * w is found by bisection so that the blended clip's mean horizontal pelvis
 * speed is the target. */
#ifndef MC_MOTION_PARAM_H
#define MC_MOTION_PARAM_H

#include "motion/mc_motion_graph.h"

typedef struct {
	int clip_a, clip_b; /* the members blended (equal: one member alone) */
	double w;           /* weight of clip_b */
	double speed;       /* mean horizontal pelvis speed of the result, m/s */
	int nframes;
	mc_vec3 *poses;     /* nframes * MC_MOTION_JOINTS, world (z up, floor 0); free() it */
} mc_param_motion;

/* The motion of parametric node `node` of g at `speed` m/s.  Errors name
 * the node when it does not exist. */
int mc_param_blend(const mc_motion_graph *g, int node, double speed, mc_param_motion *out, mc_err *err);
/* The node of a class, or -1. */
int mc_param_find(const mc_motion_graph *g, const char *cls);

#endif
