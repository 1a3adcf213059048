#include "eval/mc_clip.h"

#include "image/mc_image.h"
#include "base/mc_json.h"

#include <jansson.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int read_joint_names(const char *path, json_t *root, mc_clip *clip, mc_err *err)
{
	json_t *names = json_object_get(root, "joint_names");
	if (!json_is_array(names) || json_array_size(names) == 0 || json_array_size(names) > MC_CLIP_MAX_JOINTS)
		return mc_err_set(err, "%s: joint_names: expected an array of 1..%d names", path, MC_CLIP_MAX_JOINTS);
	clip->njoints = (int)json_array_size(names);
	for (int j = 0; j < clip->njoints; j++) {
		const char *s = json_string_value(json_array_get(names, j));
		if (!s || strlen(s) >= MC_JOINT_NAME_MAX)
			return mc_err_set(err, "%s: joint_names[%d]: expected a short string", path, j);
		snprintf(clip->joint_names[j], MC_JOINT_NAME_MAX, "%s", s);
	}
	return 0;
}

static int read_frames(const char *path, json_t *root, mc_clip *clip, mc_err *err)
{
	json_t *frames = json_object_get(root, "frames");
	if (!json_is_array(frames) || json_array_size(frames) == 0)
		return mc_err_set(err, "%s: frames: expected a non-empty array", path);
	clip->nframes = (int)json_array_size(frames);
	clip->joints = calloc((size_t)clip->nframes * clip->njoints, sizeof(mc_vec3));
	if (!clip->joints)
		return mc_err_set(err, "%s: out of memory", path);
	for (int k = 0; k < clip->nframes; k++) {
		json_t *jl = json_object_get(json_array_get(frames, k), "joints_left_cam");
		for (int j = 0; j < clip->njoints; j++) {
			char where[1400];
			snprintf(where, sizeof(where), "%.1200s: frames[%d].joints_left_cam", path, k);
			if (mc_json_vec3(jl, clip->joint_names[j], where, &clip->joints[k * clip->njoints + j], true, err) < 0)
				return -1;
		}
	}
	return 0;
}

static int read_gt(const char *path, mc_clip *clip, mc_err *err)
{
	json_t *root;
	if (mc_json_load_file(path, &root, err) < 0)
		return -1;
	json_t *fps = json_object_get(root, "fps");
	clip->fps = json_is_number(fps) && json_number_value(fps) > 0 ? json_number_value(fps) : 30.0;
	int rc = read_joint_names(path, root, clip, err);
	if (rc == 0)
		rc = read_frames(path, root, clip, err);
	json_decref(root);
	return rc;
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
	snprintf(path, sizeof(path), "%s/calib.json", dir);
	if (mc_rig_import_ego_calib(path, use_ocam, &clip->rig, err) < 0)
		return -1;
	snprintf(path, sizeof(path), "%s/gt.json", dir);
	if (read_gt(path, clip, err) < 0) {
		mc_clip_close(clip);
		return -1;
	}
	return 0;
}

void mc_clip_close(mc_clip *clip)
{
	free(clip->joints);
	clip->joints = NULL;
}

int mc_clip_joint(const mc_clip *clip, const char *name)
{
	for (int j = 0; j < clip->njoints; j++)
		if (!strcmp(clip->joint_names[j], name))
			return j;
	return -1;
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
			views[c] = (mc_frame_view){w, h, 3 * w, rgb, (uint64_t)(k * 1e9 / clip->fps)};
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
	for (int j = 0; j < clip->njoints; j++)
		names[j] = clip->joint_names[j];
	if (mc_tracker_init_from_joints(t, names, clip->joints, clip->njoints, err) < 0)
		return -1;
	mc_frame_view views[2];
	if (mc_clip_load_frame(clip, 0, views, err) < 0)
		return -1;
	int rc = mc_tracker_calibrate_colors(t, views, 2, err);
	mc_clip_free_frame(views);
	return rc;
}
