/* mc_jitter: how much an estimated joint trajectory shakes, against the
 * ground truth's (mocap-bench's JITTER line).  Frames are added in order;
 * differences are taken only between consecutive frames of one run, so a
 * frame that was not tracked (mc_jitter_break) never makes a jump between
 * the poses on either side of it look like motion.
 *   velocity error: mean over joints and consecutive pairs of
 *     |(e_k - e_{k-1}) - (g_k - g_{k-1})| / dt            (m/s)
 *   acceleration ratio: mean over joints and consecutive triples of
 *     |e_k - 2 e_{k-1} + e_{k-2}|, divided by the same mean of g
 *     (dt cancels; > 1: the estimate shakes more than the motion). */
#ifndef MC_JITTER_H
#define MC_JITTER_H

#include "base/mc_math.h"

#define MC_JITTER_MAX_JOINTS 32

typedef struct {
	int njoints;
	double dt; /* seconds between consecutive frames */
	int run;   /* frames of the current run kept below (0..2) */
	/* [0]: the last frame added, [1]: the one before */
	mc_vec3 est[2][MC_JITTER_MAX_JOINTS], gt[2][MC_JITTER_MAX_JOINTS];
	double vel_err_sum;
	long vel_n;
	double acc_est_sum, acc_gt_sum;
	long acc_n;
} mc_jitter;

/* njoints (at most MC_JITTER_MAX_JOINTS) per frame, dt seconds apart. */
void mc_jitter_init(mc_jitter *j, int njoints, double dt);
/* The next frame of the run: estimate and truth of each joint, metres. */
void mc_jitter_add(mc_jitter *j, const mc_vec3 *est, const mc_vec3 *gt);
/* A frame that was not tracked: the next frame starts a new run. */
void mc_jitter_break(mc_jitter *j);
/* Mean velocity error, m/s; NAN before two consecutive frames. */
double mc_jitter_vel_err(const mc_jitter *j);
/* Mean acceleration of the estimate over the truth's; NAN before three
 * consecutive frames or when the truth does not accelerate at all. */
double mc_jitter_accel_ratio(const mc_jitter *j);

#endif
