#include "eval/mc_gt.h"

#include "base/mc_json.h"

#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int add_name(mc_gt *gt, const char *s, const char *where, mc_err *err)
{
	if (gt->njoints >= MC_GT_MAX_JOINTS)
		return mc_err_set(err, "%s: more than %d joints", where, MC_GT_MAX_JOINTS);
	if (!s || !*s || strlen(s) >= MC_JOINT_NAME_MAX)
		return mc_err_set(err, "%s: expected a joint name of 1..%d characters", where, MC_JOINT_NAME_MAX - 1);
	snprintf(gt->joint_names[gt->njoints++], MC_JOINT_NAME_MAX, "%s", s);
	return 0;
}

/* The joints: `joint_names`, or else the keys of frame 0's joints object. */
static int read_names(const char *path, json_t *root, json_t *frame0, const char *key, mc_gt *gt, mc_err *err)
{
	char where[1400];
	json_t *names = json_object_get(root, "joint_names");
	if (names) {
		if (!json_is_array(names) || json_array_size(names) == 0)
			return mc_err_set(err, "%s: joint_names: expected an array of 1..%d names", path, MC_GT_MAX_JOINTS);
		for (size_t j = 0; j < json_array_size(names); j++) {
			mc_json_path_index(where, sizeof(where), path, "joint_names", j);
			if (add_name(gt, json_string_value(json_array_get(names, j)), where, err))
				return -1;
		}
		return 0;
	}
	snprintf(where, sizeof(where), "%.1200s: frames[0]", path);
	json_t *joints;
	if (mc_json_object(frame0, key, where, &joints, true, err))
		return -1;
	snprintf(where, sizeof(where), "%.1200s: frames[0].%s", path, key);
	const char *name;
	json_t *value;
	json_object_foreach(joints, name, value)
	{
		(void)value;
		if (add_name(gt, name, where, err))
			return -1;
	}
	if (gt->njoints == 0)
		return mc_err_set(err, "%s: no joints", where);
	return 0;
}

static int read_frame(const char *path, json_t *frame, int k, const char *key, mc_gt *gt, mc_err *err)
{
	char where[1400];
	mc_json_path_index(where, sizeof(where), path, "frames", (size_t)k);
	if (!json_is_object(frame))
		return mc_err_set(err, "%s: expected an object", where);
	json_t *joints;
	if (mc_json_object(frame, key, where, &joints, true, err))
		return -1;
	snprintf(where + strlen(where), sizeof(where) - strlen(where), ".%s", key);
	for (int j = 0; j < gt->njoints; j++)
		if (mc_json_vec3(joints, gt->joint_names[j], where, &gt->joints[k * gt->njoints + j], true, err) < 0)
			return -1;
	return 0;
}

static double positive_number(json_t *root, const char *key, double fallback)
{
	json_t *v = json_object_get(root, key);
	return json_is_number(v) && json_number_value(v) > 0 ? json_number_value(v) : fallback;
}

int mc_gt_load(const char *path, const char *joints_key, mc_gt *gt, mc_err *err)
{
	memset(gt, 0, sizeof(*gt));
	json_t *root, *frames;
	if (mc_json_load_file(path, &root, err) < 0)
		return -1;
	int rc = -1;
	if (mc_json_array(root, "frames", path, 1, 1000000, &frames, true, err))
		goto out;
	gt->fps = positive_number(root, "fps", 30.0);
	gt->height_m = positive_number(root, "height_m", 0);
	if (read_names(path, root, json_array_get(frames, 0), joints_key, gt, err))
		goto out;
	gt->nframes = (int)json_array_size(frames);
	gt->joints = calloc((size_t)gt->nframes * (size_t)gt->njoints, sizeof(mc_vec3));
	if (!gt->joints) {
		mc_err_set(err, "%s: out of memory for %d frames", path, gt->nframes);
		goto out;
	}
	for (int k = 0; k < gt->nframes; k++)
		if (read_frame(path, json_array_get(frames, (size_t)k), k, joints_key, gt, err))
			goto out;
	rc = 0;
out:
	json_decref(root);
	if (rc)
		mc_gt_free(gt);
	return rc;
}

void mc_gt_free(mc_gt *gt)
{
	free(gt->joints);
	gt->joints = NULL;
	gt->nframes = 0;
}

int mc_gt_joint(const mc_gt *gt, const char *name)
{
	for (int j = 0; j < gt->njoints; j++)
		if (!strcmp(gt->joint_names[j], name))
			return j;
	return -1;
}
