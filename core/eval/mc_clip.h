/* mc_clip: reading an evaluation clip in either layout of ../shared/data:
 *   head-mounted (ego/<clip>): calib.json, gt.json with joints_left_cam,
 *     left/%05d.jpg and right/%05d.jpg; rig frame = left camera frame;
 *   outside-in (outside/<clip>): cameras.json, gt.json with joints_world,
 *     camK/%05d.jpg per camera; rig frame = world frame (z up, floor z = 0).
 * The layout is detected from the files.  Used by the benchmark and the
 * tests. */
#ifndef MC_CLIP_H
#define MC_CLIP_H

#include "base/mc_error.h"
#include "eval/mc_gt.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "track/mc_tracker.h"

#define MC_CLIP_MAX_JOINTS MC_GT_MAX_JOINTS

typedef enum {
	MC_CLIP_EGO = 0,     /* head-mounted stereo fisheye */
	MC_CLIP_OUTSIDE = 1, /* static cameras around the actor */
} mc_clip_layout;

typedef struct {
	char dir[1024];
	char name[256];
	mc_clip_layout layout;
	mc_rig rig;          /* the cameras in use; rig frame as above */
	/* the folder of rig camera c's frames, and its index in the clip
	 * (cameras left out by mc_clip_select_cameras are not in the rig) */
	char cam_dir[MC_MAX_CAMERAS][MC_CAMERA_NAME_MAX];
	int cam_index[MC_MAX_CAMERAS];
	mc_gt gt;            /* gt.json: fps, joints in the rig frame */
	bool has_gt;         /* gt.json was read (the clip can be scored); see mc_clip_open */
} mc_clip;

/* Opens a clip of either layout: calib.json (use_ocam: the fitted OCam
 * polynomial instead of the equidistant model) or cameras.json, and gt.json.
 * A clip without gt.json (real footage) opens with has_gt false, no
 * ground-truth joints (mc_clip_joint is -1 for every name), gt.nframes the
 * frame sets found on disk and gt.fps MC_CLIP_DEFAULT_FPS (the caller may
 * set the true rate). */
#define MC_CLIP_DEFAULT_FPS 30.0
int mc_clip_open(const char *dir, bool use_ocam, mc_clip *clip, mc_err *err);

/* Keeps only the clip cameras listed in `list`, comma-separated indices
 * into the clip's cameras as opened (e.g. "0,2"), in that order.  Errors
 * name the bad entry. */
int mc_clip_select_cameras(mc_clip *clip, const char *list, mc_err *err);
void mc_clip_close(mc_clip *clip);

/* Index of a ground-truth joint by name, or -1. */
int mc_clip_joint(const mc_clip *clip, const char *name);
/* Ground truth of frame k, joint j. */
static inline mc_vec3 mc_clip_gt(const mc_clip *clip, int k, int j)
{
	return mc_gt_at(&clip->gt, k, j);
}

/* Decodes frame k of every rig camera into views[0 .. rig.ncams - 1]
 * (RGB24, buffers malloc'ed; release with mc_clip_free_frame). */
int mc_clip_load_frame(const mc_clip *clip, int k, mc_frame_view views[MC_MAX_CAMERAS], mc_err *err);
void mc_clip_free_frame(mc_frame_view views[MC_MAX_CAMERAS]);

/* Initialises a tracker as the evaluation protocol allows: bone lengths,
 * root placement and pose from the ground truth of frame 0, and the actor's
 * colours from the images of frame 0. */
int mc_clip_init_tracker(const mc_clip *clip, mc_tracker *t, mc_err *err);

/* A simulated 2D detector, for tests and mocap-bench --simulated-detector
 * (never the evaluation protocol): the named joints of frame k projected
 * from the ground truth into every camera, with Gaussian noise of noise_px
 * native pixels per axis, MC_CLIP_SIMULATED_MISS of them missed.  Returns
 * the number of keypoints written (at most cap).  mc_simdet.c, which adds
 * the gross errors of real detectors. */
#define MC_CLIP_SIMULATED_MISS 0.15
int mc_clip_simulated_keypoints(const mc_clip *clip, const mc_model *m, const char *const *joints, int njoints, int k,
				double noise_px, uint64_t *rng, mc_keypoint *kp, int cap);

#endif
