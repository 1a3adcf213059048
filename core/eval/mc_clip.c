#include "eval/mc_clip.h"

#include "image/mc_image.h"

#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int mc_clip_open(const char *dir, bool use_ocam, mc_clip *clip, mc_err *err)
{
	memset(clip, 0, sizeof(*clip));
	char path[1200];
	snprintf(clip->dir, sizeof(clip->dir), "%s", dir);
	snprintf(path, sizeof(path), "%s", dir);
	size_t n = strlen(path);
	while (n > 1 && path[n - 1] == '/')
		path[--n] = '\0';
	snprintf(clip->name, sizeof(clip->name), "%s", basename(path));
	snprintf(path, sizeof(path), "%s/calib.json", dir);
	if (mc_rig_import_ego_calib(path, use_ocam, &clip->rig, err) < 0)
		return -1;
	snprintf(path, sizeof(path), "%s/gt.json", dir);
	if (mc_gt_load(path, "joints_left_cam", &clip->gt, err) < 0) {
		mc_clip_close(clip);
		return -1;
	}
	return 0;
}

void mc_clip_close(mc_clip *clip)
{
	mc_gt_free(&clip->gt);
}

int mc_clip_joint(const mc_clip *clip, const char *name)
{
	return mc_gt_joint(&clip->gt, name);
}

int mc_clip_load_frame(const mc_clip *clip, int k, mc_frame_view views[2], mc_err *err)
{
	static const char *const cams[2] = {"left", "right"};
	memset(views, 0, sizeof(mc_frame_view) * 2);
	mc_image_conv *conv = mc_image_conv_new(err);
	if (!conv)
		return -1;
	int rc = 0;
	for (int c = 0; c < 2 && rc == 0; c++) {
		char path[1200];
		uint8_t *rgb = NULL;
		int w = 0, h = 0;
		snprintf(path, sizeof(path), "%s/%s/%05d.jpg", clip->dir, cams[c], k);
		rc = mc_image_load(conv, path, &rgb, &w, &h, err);
		if (rc == 0)
			views[c] = (mc_frame_view){w, h, 3 * w, rgb, (uint64_t)(k * 1e9 / clip->gt.fps)};
	}
	mc_image_conv_free(conv);
	if (rc < 0)
		mc_clip_free_frame(views);
	return rc;
}

void mc_clip_free_frame(mc_frame_view views[2])
{
	for (int c = 0; c < 2; c++) {
		free((void *)views[c].rgb);
		views[c].rgb = NULL;
	}
}

int mc_clip_init_tracker(const mc_clip *clip, mc_tracker *t, mc_err *err)
{
	const char *names[MC_CLIP_MAX_JOINTS];
	for (int j = 0; j < clip->gt.njoints; j++)
		names[j] = clip->gt.joint_names[j];
	if (mc_tracker_init_from_joints(t, names, clip->gt.joints, clip->gt.njoints, err) < 0)
		return -1;
	mc_frame_view views[2];
	if (mc_clip_load_frame(clip, 0, views, err) < 0)
		return -1;
	int rc = mc_tracker_calibrate_colors(t, views, 2, err);
	mc_clip_free_frame(views);
	return rc;
}

static double gaussian_noise(uint64_t *rng)
{
	double u1 = ((mc_rng_next(rng) >> 11) + 0.5) * 0x1.0p-53, u2 = mc_rng_uniform(rng); /* u1 in (0, 1) */
	return sqrt(-2 * log(u1)) * cos(2 * M_PI * u2);
}

int mc_clip_simulated_keypoints(const mc_clip *clip, const mc_model *m, const char *const *joints, int njoints, int k,
				double noise_px, uint64_t *rng, mc_keypoint *kp, int cap)
{
	int n = 0;
	for (int e = 0; e < njoints; e++) {
		int g = mc_clip_joint(clip, joints[e]), j = mc_model_find_joint(m, joints[e]);
		for (int c = 0; c < clip->rig.ncams && g >= 0 && j >= 0 && n < cap; c++) {
			const mc_camera *cam = &clip->rig.cams[c];
			mc_vec3 p = mc_xform_apply(mc_xform_inverse(cam->rig_from_cam), mc_clip_gt(clip, k, g));
			double u, v;
			bool seen = mc_camera_project(cam, p, &u, &v);
			if (!seen || mc_rng_uniform(rng) < MC_CLIP_SIMULATED_MISS)
				continue;
			kp[n++] = (mc_keypoint){c, j, u + noise_px * gaussian_noise(rng), v + noise_px * gaussian_noise(rng),
						1.0};
		}
	}
	return n;
}
