/* The default model at the bundled demo clip's first pose (its frame 0's
 * ground truth, fitted by inverse kinematics) and the clip's head rig,
 * with each camera's rays and an RGB image at a working size: the
 * synthetic scenes of test_tracker.c and test_tracker_sight.c. */
#ifndef MC_DEMO_POSE_FIXTURE_H
#define MC_DEMO_POSE_FIXTURE_H

#include "body/mc_ik.h"
#include "eval/mc_clip.h"

#include <stdint.h>
#include <stdlib.h>

static inline int demo_first_pose(mc_rig *rig, mc_model *model, double *pose, mc_err *err)
{
	mc_clip clip;
	if (mc_clip_open("tests/data/ego_demo", false, &clip, err) < 0)
		return -1;
	*rig = clip.rig;
	if (mc_model_load("config/models/default.json", model, err) < 0) {
		mc_clip_close(&clip);
		return -1;
	}
	mc_ik_target targets[MC_CLIP_MAX_JOINTS];
	int n = 0;
	for (int j = 0; j < clip.gt.njoints; j++) {
		int mj = mc_model_find_joint(model, clip.gt.joint_names[j]);
		if (mj >= 0)
			targets[n++] = (mc_ik_target){mj, mc_clip_gt(&clip, 0, j), 1.0, {0, 0, 0}};
	}
	mc_clip_close(&clip);
	mc_ik_options o;
	mc_ik_options_default(&o);
	mc_model_rest_pose(model, pose);
	return mc_ik_solve(model, pose, targets, n, &o, err) < 0 ? -1 : 0;
}

/* Each of the rig's two cameras' rays at w x h, and a black RGB image. */
static inline int demo_views_open(const mc_rig *rig, int w, int h, mc_raytable rays[2], uint8_t *img[2], mc_err *err)
{
	for (int c = 0; c < 2; c++) {
		if (mc_raytable_build(&rig->cams[c], w, h, &rays[c], err) < 0)
			return -1;
		img[c] = calloc((size_t)w * h * 3, 1);
	}
	return 0;
}

static inline void demo_views_close(mc_raytable rays[2], uint8_t *img[2])
{
	for (int c = 0; c < 2; c++) {
		mc_raytable_free(&rays[c]);
		free(img[c]);
	}
}

#endif
