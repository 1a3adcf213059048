/* mc_ik: fitting a model's skeleton to 3D joint positions.
 *
 * Used to initialise tracking from the ground truth of frame 0 (evaluation
 * protocol) or from any 3D joint estimate, and by the sim driver to retarget
 * motion capture onto the body model. */
#ifndef MC_IK_H
#define MC_IK_H

#include "base/mc_error.h"
#include "body/mc_model.h"

/* One target: a model joint and where it should be, in the rig frame.
 * With a non-zero (unit) dir the target is a ray from `position`, a
 * camera's centre: only the joint's offset from the ray counts (a 2D
 * detection seen from a camera, whose depth is unknown), measured by
 * mc_ray_offset (geom/mc_ray.h). */
typedef struct {
	int joint;
	mc_vec3 position;
	double weight;
	mc_vec3 dir;
} mc_ik_target;

/* Targets farther than this from the rig origin, or point targets all
 * within MC_IK_MIN_SPREAD_M of the first, are refused: no body is there
 * (issue 20, defect 8: all-zero or 1e308 initial joints). */
#define MC_IK_TARGET_MAX_M 100.0
#define MC_IK_MIN_SPREAD_M 0.05

typedef struct {
	int iterations;       /* Levenberg-Marquardt iterations */
	double pose_prior;    /* Tikhonov weight pulling joint dofs to 0, or to prior_pose */
	const double *prior_pose; /* NULL: 0; else the pose the prior pulls toward (ndof values) */
	bool fit_bone_scale;  /* set bone_scale from target bone lengths first */
	bool fit_root;        /* also solve for the root placement */
	bool restarts;        /* try other starts while the fit is poor (default true) */
	double ray_near;      /* ray targets' offsets by the angle nearer than this (geom/mc_ray.h; default 0) */
} mc_ik_options;

void mc_ik_options_default(mc_ik_options *o);

/* The first of the n targets on `joint`, or NULL. */
const mc_ik_target *mc_ik_find_target(const mc_ik_target *t, int n, int joint);

/* Sets bone_scale[j] from the distances between targets of joint j and of
 * its parent where both are given; other joints get the median scale. */
void mc_ik_fit_bone_scale(mc_model *model, const mc_ik_target *targets, int n);

/* Solves for pose (model->ndof values, in/out: the start value is used) and,
 * with fit_root, for the root placement: model->rig_from_root for fixed
 * roots, pose[0..5] for free roots.  Returns the RMS residual in metres, or
 * a negative value with err set. */
/* A free root's place (p[0..5]) from the rigid fit (mc_xform_fit_rigid)
 * of the pose's joints joint[i] onto position[i] with weight[i]: the
 * skeleton moves as one, in place and facing the right way, before any
 * solve (mc_ik_solve does it for its point targets).  At most
 * MC_IK_PLACE_MAX points are used; fewer than 3, or a fixed root: nothing. */
#define MC_IK_PLACE_MAX 64
void mc_ik_place_free_root(const mc_model *m, double *p, const int *joint, const mc_vec3 *position,
			   const double *weight, int n);

double mc_ik_solve(mc_model *model, double *pose, const mc_ik_target *targets, int n, const mc_ik_options *o,
		   mc_err *err);

#endif
