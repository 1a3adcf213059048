/* mc_fit_joints: the body model fitted to another skeleton's joint positions.
 *
 * Frame 0's ground truth, an `init_joints` file or a recorded take give
 * joints by name.  Their limb joints and neck are anatomical landmarks that
 * every skeleton places alike; `spine`, `pelvis` and `head_top` are not:
 * one motion-capture skeleton puts its pelvis at hip height, another a hand
 * above, its spine anywhere along the back (docs/TRACKER.md, "Starting from
 * given joints").  So the fit first uses the landmarks alone, and takes the
 * spine and pelvis in only where they sit within MC_FIT_JOINTS_AGREE_M of
 * where that fit puts the model's own. */
#ifndef MC_FIT_JOINTS_H
#define MC_FIT_JOINTS_H

#include "base/mc_error.h"
#include "body/mc_model.h"

/* Given spine and pelvis this close to the landmark fit's are the model's
 * kind of spine and pelvis (the dev clips: 6-8 cm; skeletons with the
 * pelvis at hip height: 18-22 cm). */
#define MC_FIT_JOINTS_AGREE_M 0.12

/* Sets model's bone scales, its left/right pairs' widths (the offsets of
 * the shoulders and hips across the body), the root placement
 * (rig_from_root for a fixed root) and pose (model->ndof values, out) from
 * n named joint positions in the rig frame; names the model lacks are
 * ignored.  Returns the RMS residual of the fit kept (metres), or a
 * negative value with err set and model as it was. */
double mc_fit_joints(mc_model *model, double *pose, const char *const *names, const mc_vec3 *positions, int n,
		     mc_err *err);

/* Sets the distance between joint `left` (a "left_" joint) and its other
 * side, both on one parent (the shoulders, the hips), to width metres:
 * the part of each offset across the pair is stretched, with the
 * Gaussians those bones scale, and the pair's midpoint stays.  Returns -1
 * (model unchanged) for no such pair or a width outside 0.5-2 times the
 * present one. */
int mc_fit_joints_set_pair_width(mc_model *model, int left, double width);

/* That pair's distance now (metres; 0 for no such pair). */
double mc_fit_joints_pair_width(const mc_model *model, int left);

/* Whether a joint of this name is one of the landmarks (not spine, pelvis
 * or head_top). */
bool mc_fit_joints_is_landmark(const char *name);

#endif
