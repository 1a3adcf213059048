#include "eval/mc_clip.h"

#include "image/mc_image.h"

#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static bool file_exists(const char *dir, const char *name)
{
	char path[1200];
	snprintf(path, sizeof(path), "%s/%s", dir, name);
	return access(path, F_OK) == 0;
}

/* The rig and the frame folders of each layout. */
static int open_rig(const char *dir, bool use_ocam, mc_clip *clip, mc_err *err)
{
	char path[1200];
	if (file_exists(dir, "cameras.json")) {
		clip->layout = MC_CLIP_OUTSIDE;
		snprintf(path, sizeof(path), "%s/cameras.json", dir);
		if (mc_rig_import_cameras_json(path, &clip->rig, err) < 0)
			return -1;
		for (int c = 0; c < clip->rig.ncams; c++)
			snprintf(clip->cam_dir[c], sizeof(clip->cam_dir[c]), "cam%d", c);
	} else {
		clip->layout = MC_CLIP_EGO;
		snprintf(path, sizeof(path), "%s/calib.json", dir);
		if (!file_exists(dir, "calib.json"))
			return mc_err_set(err, "%s: not a clip (neither calib.json nor cameras.json is there)", dir);
		if (mc_rig_import_ego_calib(path, use_ocam, &clip->rig, err) < 0)
			return -1;
		snprintf(clip->cam_dir[0], sizeof(clip->cam_dir[0]), "left");
		snprintf(clip->cam_dir[1], sizeof(clip->cam_dir[1]), "right");
	}
	for (int c = 0; c < clip->rig.ncams; c++)
		clip->cam_index[c] = c;
	return 0;
}

/* The frame sets of a clip without gt.json: as many as every camera has
 * consecutive frames from 00000.jpg. */
static int count_frames(const mc_clip *clip)
{
	int n = 0;
	for (;; n++)
		for (int c = 0; c < clip->rig.ncams; c++) {
			char name[MC_CAMERA_NAME_MAX + 16];
			snprintf(name, sizeof(name), "%s/%05d.jpg", clip->cam_dir[c], n);
			if (!file_exists(clip->dir, name))
				return n;
		}
}

/* Real footage comes without ground truth: the clip can be tracked, not
 * scored (has_gt false, no joints, fps MC_CLIP_DEFAULT_FPS). */
static int open_without_gt(mc_clip *clip, mc_err *err)
{
	clip->gt.fps = MC_CLIP_DEFAULT_FPS;
	clip->gt.nframes = count_frames(clip);
	if (clip->gt.nframes == 0)
		return mc_err_set(err, "%s: no gt.json and no frames (%s/00000.jpg)", clip->dir, clip->cam_dir[0]);
	return 0;
}

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
	if (open_rig(dir, use_ocam, clip, err) < 0)
		return -1;
	if (!file_exists(dir, "gt.json"))
		return open_without_gt(clip, err);
	snprintf(path, sizeof(path), "%s/gt.json", dir);
	if (mc_gt_load(path, clip->layout == MC_CLIP_OUTSIDE ? "joints_world" : "joints_left_cam", &clip->gt, err) < 0) {
		mc_clip_close(clip);
		return -1;
	}
	clip->has_gt = true;
	return 0;
}

int mc_clip_select_cameras(mc_clip *clip, const char *list, mc_err *err)
{
	mc_clip orig = *clip;
	bool used[MC_MAX_CAMERAS] = {false};
	int n = 0;
	const char *p = list;
	while (*p) {
		char *end;
		long c = strtol(p, &end, 10);
		if (end == p || (*end && *end != ',') || c < 0 || c >= orig.rig.ncams || used[c])
			return mc_err_set(err, "--cameras '%s': expected distinct camera indices 0..%d separated by commas",
					  list, orig.rig.ncams - 1);
		used[c] = true;
		clip->rig.cams[n] = orig.rig.cams[c];
		clip->cam_index[n] = orig.cam_index[c];
		snprintf(clip->cam_dir[n], sizeof(clip->cam_dir[n]), "%s", orig.cam_dir[c]);
		n++;
		p = *end ? end + 1 : end;
	}
	if (n == 0)
		return mc_err_set(err, "--cameras: no camera given");
	clip->rig.ncams = n;
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

int mc_clip_load_frame(const mc_clip *clip, int k, mc_frame_view views[MC_MAX_CAMERAS], mc_err *err)
{
	memset(views, 0, sizeof(mc_frame_view) * MC_MAX_CAMERAS);
	mc_image_conv *conv = mc_image_conv_new(err);
	if (!conv)
		return -1;
	int rc = 0;
	for (int c = 0; c < clip->rig.ncams && rc == 0; c++) {
		char path[1200];
		uint8_t *rgb = NULL;
		int w = 0, h = 0;
		snprintf(path, sizeof(path), "%s/%s/%05d.jpg", clip->dir, clip->cam_dir[c], k);
		rc = mc_image_load(conv, path, &rgb, &w, &h, err);
		if (rc == 0)
			views[c] = (mc_frame_view){w, h, 3 * w, rgb, (uint64_t)(k * 1e9 / clip->gt.fps)};
	}
	mc_image_conv_free(conv);
	if (rc < 0)
		mc_clip_free_frame(views);
	return rc;
}

void mc_clip_free_frame(mc_frame_view views[MC_MAX_CAMERAS])
{
	for (int c = 0; c < MC_MAX_CAMERAS; c++) {
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
	mc_frame_view views[MC_MAX_CAMERAS];
	if (mc_clip_load_frame(clip, 0, views, err) < 0)
		return -1;
	int rc = mc_tracker_calibrate_colors(t, views, clip->rig.ncams, err);
	mc_clip_free_frame(views);
	return rc;
}
