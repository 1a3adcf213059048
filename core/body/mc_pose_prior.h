/* mc_pose_prior: a learned prior over the body model's joint angles, a
 * Gaussian mixture trained on motion capture (tools/prior/train_prior.py,
 * docs/TRACKER.md "Pose prior").  It says which limb and spine angles people
 * take, so that what two close cameras cannot see (a foot's depth, a hidden
 * arm) settles on a human pose rather than anywhere within the limits.
 *
 * The file (config/models/pose_prior.json) names the dofs it covers by
 * mc_model_dof_name ("left_knee.x"); loading maps them onto a model's pose
 * vector, fixed or free root alike, and refuses a model that lacks one.
 *
 * Energy: with nll(p) = -log sum_k w_k N(x; mu_k, P_k^-1) + const, x the
 * covered dofs of p, P_k = L_k L_k^T, and the constant making nll about 0 at
 * the likeliest component's mean,
 *     E(p) = c log(1 + nll / c),  c = MC_PRIOR_ROBUST_NATS
 * (nll itself where it is below 0).  The robust form pulls like the
 * mixture near the poses it knows and ever less far from them: a motion
 * unlike any in the training clips is left to the images (measured in
 * docs/TRACKER.md, "Pose prior").  Plain arithmetic, double precision. */
#ifndef MC_POSE_PRIOR_H
#define MC_POSE_PRIOR_H

#include "base/mc_error.h"
#include "body/mc_model.h"

#define MC_PRIOR_MAX_COMPONENTS 32
#define MC_PRIOR_ROBUST_NATS 10.0

typedef struct mc_pose_prior mc_pose_prior;

/* NULL with err naming the file and the field (or the dof the model
 * lacks). */
mc_pose_prior *mc_pose_prior_load(const char *path, const mc_model *model, mc_err *err);
mc_pose_prior *mc_pose_prior_parse(const char *json_text, const char *origin, const mc_model *model, mc_err *err);
void mc_pose_prior_free(mc_pose_prior *p);

/* How many dofs and components it has. */
int mc_pose_prior_ndofs(const mc_pose_prior *p);
int mc_pose_prior_ncomponents(const mc_pose_prior *p);

/* lambda * E(pose); adds lambda * dE/dpose into grad (the model's ndof
 * entries; may be NULL). */
double mc_pose_prior_energy(const mc_pose_prior *p, const double *pose, double lambda, double *grad);

#endif
