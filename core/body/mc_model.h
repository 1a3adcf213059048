/* mc_model: kinematic skeleton and sum-of-Gaussians body model.
 *
 * A model is a tree of joints, each with 0-3 revolute degrees of freedom
 * about axes of its own local frame, and isotropic Gaussians rigidly attached
 * to joints.  The model file format is JSON, documented in
 * docs/MODEL_FORMAT.md (with the default human model's conventions).
 *
 * Pose vector layout (mc_model.ndof doubles):
 *   free root (outside-in): p[0..2] root translation in the rig (world)
 *                           frame, p[3..5] root rotation vector;
 *   fixed root (egocentric): no root dofs; the root (head) sits at
 *                           model->rig_from_root, fixed to the rig;
 *   then each joint's dofs, at joints[j].dof0, in joint order.
 * Joint j's frame is parent_frame * T(bone_scale[j] * offset_j) * R_axis0(p) R_axis1(p) ...
 * where the root's parent frame is rig_from_root (fixed) or
 * T(p[0..2]) * R(p[3..5]) (free).  A Gaussian's centre is
 * rig_from_joint[joint] * (bone_scale[scale_joint] * offset).
 *
 * Everything here is plain data: no allocation, no hidden state. */
#ifndef MC_MODEL_H
#define MC_MODEL_H

#include "base/mc_error.h"
#include "base/mc_math.h"

#include <stdbool.h>

#define MC_MAX_JOINTS 32
#define MC_MAX_GAUSSIANS 128
#define MC_MAX_DOF 96
#define MC_JOINT_NAME_MAX 32

typedef struct {
	char name[MC_JOINT_NAME_MAX];
	int parent;        /* -1 for the root; parents come before children */
	mc_vec3 offset;    /* rest offset from the parent, parent frame, metres */
	int ndof;          /* 0..3 */
	int axis[3];       /* local axis of each dof: 0 = x, 1 = y, 2 = z */
	double lower[3], upper[3]; /* limits, radians */
	int dof0;          /* index of the first dof in the pose vector */
} mc_joint;

typedef struct {
	int joint;         /* joint whose frame the Gaussian moves with */
	int scale_joint;   /* joint whose bone_scale scales `offset` */
	mc_vec3 offset;    /* centre in the joint frame, metres, unscaled */
	double radius;     /* radius of the sphere it stands for */
	double sigma, c;   /* from radius and smoothness (thesis 4.3) */
	double rgb[3];     /* albedo, 0..1 */
} mc_gauss_def;

typedef struct {
	char name[64];
	int njoints;
	mc_joint joints[MC_MAX_JOINTS];
	bool root_free;
	mc_xform rig_from_root;   /* used when !root_free */
	/* Free root: the orientation its rotation dofs p[3..5] turn from,
	 * R_root = R(p[3..5]) R(root_base), as a rotation vector (zero: the
	 * identity).  The tracker re-centres it (mc_model_recentre_root) so
	 * that p[3..5] stays small, far from the rotation vector's wrap at pi.
	 * Outside mc_tracker_track it is zero; model files do not carry it. */
	mc_vec3 root_base;
	int ndof;
	int ngauss;
	mc_gauss_def gauss[MC_MAX_GAUSSIANS];
	double smoothness_m;      /* thesis 4.3, default 0.1 */
	double bone_scale[MC_MAX_JOINTS]; /* per-actor, 1 = as loaded */
} mc_model;

/* Number of pose dofs of a free root (translation + rotation vector). */
#define MC_ROOT_FREE_DOFS 6

/* Results of forward kinematics at one pose, in the rig frame. */
typedef struct {
	mc_xform rig_from_joint[MC_MAX_JOINTS];
	mc_vec3 mu[MC_MAX_GAUSSIANS];
	/* For every pose dof k: its rotation axis and pivot in the rig frame
	 * (revolute dofs), used by Jacobians: a point x moving with dof k has
	 * d x / d p_k = dof_axis[k] x (x - dof_pivot[k]).  The same holds for
	 * the free root's rotation-vector dofs (k = 3..5), whose dof_axis is
	 * column k-3 of the left Jacobian of SO(3) at p[3..5] (not unit length)
	 * and whose pivot is p[0..2].  For its translation dofs (k = 0..2)
	 * dof_axis is the unit translation direction, d x / d p_k = dof_axis[k],
	 * and dof_pivot is zero. */
	mc_vec3 dof_axis[MC_MAX_DOF];
	mc_vec3 dof_pivot[MC_MAX_DOF];
} mc_fk;

/* Load / parse (origin names the text in errors) / save the JSON format of
 * docs/MODEL_FORMAT.md.  Loading computes dof0, ndof, sigma and c.  Errors
 * name the file and field, e.g. "m.json: joints[4].parent: cycle through
 * 'spine'".  Saving writes every field explicitly (angles in degrees,
 * colours as numbers, every Gaussian's bone) except the free-text "note"
 * and bone_scale values of 1; it refuses a model that fails
 * mc_model_validate. */
int mc_model_load(const char *path, mc_model *model, mc_err *err);
int mc_model_parse(const char *json_text, const char *origin, mc_model *model, mc_err *err);
int mc_model_save(const mc_model *model, const char *path, mc_err *err);

/* Checks a model built in memory (tree order, names, limits, dof counts,
 * Gaussians, bone scales), then assigns joints[].dof0 and model->ndof and
 * computes every Gaussian's sigma and c.  Call it after filling a model by
 * hand.  Errors name the joint or Gaussian. */
int mc_model_finalize(mc_model *model, mc_err *err);
/* The same checks without changing the model (dof0/ndof must already be
 * consistent). */
int mc_model_validate(const mc_model *model, mc_err *err);

/* Makes a fixed-root model's root free (six pose dofs in front of the
 * joints' own, rig_from_root dropped), e.g. a head-mounted model used on an
 * outside-in rig.  The pose vector grows by MC_ROOT_FREE_DOFS. */
int mc_model_make_root_free(mc_model *model, mc_err *err);

/* Free root: folds the rotation of poses[0] into model->root_base and
 * re-expresses every pose in poses[0 .. n-1] against the new base, so that
 * poses[0]'s rotation dofs become zero and each pose's skeleton is
 * unchanged.  Does nothing for a fixed root. */
void mc_model_recentre_root(mc_model *model, double *const *poses, int n);
/* The inverse: folds root_base into the rotation dofs of poses[0 .. n-1]
 * (each skeleton unchanged) and sets it to zero. */
void mc_model_fold_root_base(mc_model *model, double *const *poses, int n);

/* Index of a joint by name, or -1. */
int mc_model_find_joint(const mc_model *model, const char *name);
/* The name of the same joint on the other side of the body (left_X <->
 * right_X) into out[cap]: 1 when written, 0 for a joint of neither side,
 * -1 when out is too small. */
int mc_joint_other_side_name(const char *name, char *out, size_t cap);
/* Index of the same joint on the other side of the body, or -1 (a joint of
 * neither side, or one whose partner the model lacks). */
int mc_model_other_side(const mc_model *model, int joint);

/* Smoothness levels m accepted by mc_sphere_to_gaussian. */
#define MC_SMOOTHNESS_MIN 0.01
#define MC_SMOOTHNESS_MAX 0.99

/* Gaussian (c, sigma) standing for a sphere of radius r at smoothness m:
 * 1 - V at the centre equals m and the visibility's inflection point lies at
 * distance r from the centre (thesis 4.3), solved numerically for an
 * orthographic view of the Gaussian alone.  sigma is proportional to r and
 * c to 1/r (about 0.62 r and 2.06 / r at m = 0.1).  Returns 0, or -1 when r
 * is not a positive finite number or m is outside
 * [MC_SMOOTHNESS_MIN, MC_SMOOTHNESS_MAX]. */
int mc_sphere_to_gaussian(double radius, double m, double *sigma, double *c);

/* Recomputes every Gaussian's sigma and c from its radius and smoothness_m. */
int mc_model_update_gaussians(mc_model *model, mc_err *err);

/* The rest pose: every joint dof 0 (or its nearest limit if 0 is outside
 * them); a free root at the rig origin with the identity rotation. */
void mc_model_rest_pose(const mc_model *model, double *pose);
/* into's dofs of the joints marked in `joints` (njoints entries) set to
 * from's; the others left as they are. */
void mc_model_copy_dofs(const mc_model *model, const bool *joints, const double *from, double *into);
void mc_model_fk(const mc_model *model, const double *pose, mc_fk *fk);

/* d mu_q / d p_k for every Gaussian q and dof k: J[q * ndof + k]. */
void mc_model_gauss_jacobian(const mc_model *model, const double *pose, const mc_fk *fk, mc_vec3 *J);
/* d (joint position) / d p_k: J[j * ndof + k]. */
void mc_model_joint_jacobian(const mc_model *model, const double *pose, const mc_fk *fk, mc_vec3 *J);
/* Chain rule: adds sum_q dE/dmu_q . dmu_q/dp into dE_dpose (ndof). */
void mc_model_backprop(const mc_model *model, const double *pose, const mc_fk *fk,
		       const mc_vec3 *dE_dmu, double *dE_dpose);

/* Clamps a pose into the joint limits.  A non-finite joint dof is reset to
 * its rest value; the free root's dofs are left as they are. */
void mc_model_clamp_pose(const mc_model *model, double *pose);

/* Per-dof limits for the whole pose vector (ndof each); the free root's
 * dofs get -INFINITY / INFINITY. */
void mc_model_dof_limits(const mc_model *model, double *lower, double *upper);

/* Marks in_subtree[j] (njoints entries) for `joint` and all its
 * descendants; returns how many joints are marked (0 for a bad index). */
int mc_model_subtree(const mc_model *model, int joint, bool *in_subtree);

/* The joint that dof k belongs to, or -1 for the free root's six dofs and
 * for k out of range. */
int mc_model_dof_joint(const mc_model *model, int k);

/* A readable name for dof k: "root.tx" .. "root.rz" for the free root,
 * else "<joint>.<axis>" (e.g. "left_elbow.x"), with the dof's index in its
 * joint appended when a joint uses the same axis twice ("neck.x2"). */
void mc_model_dof_name(const mc_model *model, int k, char *buf, int cap);

#endif
