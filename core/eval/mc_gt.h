/* mc_gt: the one reader of ground-truth joint files (gt.json of the
 * evaluation clips, ../shared/data/README.md): fps, the actor's height,
 * the joint names and, per frame, each joint's 3D position under one key
 * (`joints_left_cam` for head-mounted clips, `joints_world` for outside-in
 * ones).  Used by the clip reader, mocap-render and the daemon's
 * initialisation from a joints file. */
#ifndef MC_GT_H
#define MC_GT_H

#include "base/mc_error.h"
#include "base/mc_math.h"
#include "body/mc_model.h"

#define MC_GT_MAX_JOINTS 32

typedef struct {
	double fps;          /* 30 when the file does not say */
	double height_m;     /* 0 when the file does not say */
	int njoints;
	char joint_names[MC_GT_MAX_JOINTS][MC_JOINT_NAME_MAX];
	int nframes;
	mc_vec3 *joints;     /* nframes * njoints positions, metres */
} mc_gt;

/* Reads `path`.  The joints are those of `joint_names` when the file has
 * it (each required in every frame), otherwise the keys of frame 0's
 * `joints_key` object.  Errors name the file and the field. */
int mc_gt_load(const char *path, const char *joints_key, mc_gt *gt, mc_err *err);
void mc_gt_free(mc_gt *gt);

/* Index of a joint by name, or -1. */
int mc_gt_joint(const mc_gt *gt, const char *name);

/* Frame k, joint j. */
static inline mc_vec3 mc_gt_at(const mc_gt *gt, int k, int j)
{
	return gt->joints[k * gt->njoints + j];
}

#endif
