/* mc_model: kinematic skeleton and sum-of-Gaussians body model.
 *
 * A model is a tree of joints, each with 0-3 revolute degrees of freedom
 * about axes of its own local frame, and isotropic Gaussians rigidly attached
 * to joints.  The model file format is JSON, documented in docs/FORMATS.md.
 *
 * Pose vector layout (mc_model.ndof doubles):
 *   free root (outside-in): p[0..2] root translation in the rig (world)
 *                           frame, p[3..5] root rotation vector;
 *   fixed root (egocentric): no root dofs; the root (head) sits at
 *                           model->rig_from_root, fixed to the rig;
 *   then each joint's dofs, at joints[j].dof0, in joint order.
 * Joint j's frame is parent_frame * T(bone_scale[j] * offset_j) * R_axis0(p) R_axis1(p) ...
 */
#ifndef MC_MODEL_H
#define MC_MODEL_H

#include "mc_error.h"
#include "mc_math.h"

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
	int ndof;
	int ngauss;
	mc_gauss_def gauss[MC_MAX_GAUSSIANS];
	double smoothness_m;      /* thesis 4.3, default 0.1 */
	double bone_scale[MC_MAX_JOINTS]; /* per-actor, 1 = as loaded */
} mc_model;

/* Results of forward kinematics at one pose, in the rig frame. */
typedef struct {
	mc_xform rig_from_joint[MC_MAX_JOINTS];
	mc_vec3 mu[MC_MAX_GAUSSIANS];
	/* For every pose dof k: its rotation axis and pivot in the rig frame
	 * (revolute dofs), used by Jacobians. */
	mc_vec3 dof_axis[MC_MAX_DOF];
	mc_vec3 dof_pivot[MC_MAX_DOF];
} mc_fk;

int mc_model_load(const char *path, mc_model *model, mc_err *err);
int mc_model_parse(const char *json_text, const char *origin, mc_model *model, mc_err *err);
int mc_model_save(const mc_model *model, const char *path, mc_err *err);

/* Index of a joint by name, or -1. */
int mc_model_find_joint(const mc_model *model, const char *name);

/* Gaussian (c, sigma) standing for a sphere of radius r at smoothness m:
 * 1 - V at the centre equals m and the visibility's inflection point lies at
 * distance r from the centre (thesis 4.3), solved numerically. */
int mc_sphere_to_gaussian(double radius, double m, double *sigma, double *c);

/* Recomputes every Gaussian's sigma and c from its radius and smoothness_m. */
int mc_model_update_gaussians(mc_model *model, mc_err *err);

void mc_model_rest_pose(const mc_model *model, double *pose);
void mc_model_fk(const mc_model *model, const double *pose, mc_fk *fk);

/* d mu_q / d p_k for every Gaussian q and dof k: J[q * ndof + k]. */
void mc_model_gauss_jacobian(const mc_model *model, const double *pose, const mc_fk *fk, mc_vec3 *J);
/* d (joint position) / d p_k: J[j * ndof + k]. */
void mc_model_joint_jacobian(const mc_model *model, const double *pose, const mc_fk *fk, mc_vec3 *J);
/* Chain rule: adds sum_q dE/dmu_q . dmu_q/dp into dE_dpose (ndof). */
void mc_model_backprop(const mc_model *model, const double *pose, const mc_fk *fk,
		       const mc_vec3 *dE_dmu, double *dE_dpose);

/* Clamps a pose into the joint limits. */
void mc_model_clamp_pose(const mc_model *model, double *pose);

#endif
