/* motion_take: takes in, walks out as take poses (motion_take.h). */
#include "motion_take.h"

#include <stdlib.h>
#include <string.h>

int motion_db_add_take(mc_motion_db *db, const char *dir, const char *cls, mc_err *err)
{
	take_poses t;
	if (take_poses_load(dir, NULL, &t, err))
		return -1;
	int map[MC_MOTION_JOINTS], rc = -1;
	mc_vec3 *src = NULL;
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		map[j] = -1;
		for (int k = 0; k < t.def.njoints; k++)
			if (strcmp(t.def.joints[k].name, mc_motion_joint_name(j)) == 0)
				map[j] = k;
		if (map[j] < 0) {
			mc_err_set(err, "%s: the take's skeleton has no joint '%s'", dir, mc_motion_joint_name(j));
			goto out;
		}
	}
	if (t.nposes < 2) {
		mc_err_set(err, "%s: %d poses, need at least 2", dir, t.nposes);
		goto out;
	}
	src = malloc(sizeof(*src) * (size_t)t.nposes * MC_MOTION_JOINTS);
	if (!src) {
		mc_err_set(err, "%s: out of memory", dir);
		goto out;
	}
	for (int i = 0; i < t.nposes; i++)
		for (int j = 0; j < MC_MOTION_JOINTS; j++) {
			const double *p = t.poses[i].joints[map[j]].position;
			src[(size_t)i * MC_MOTION_JOINTS + j] = mc_v3(p[0], p[1], p[2]);
		}
	/* poses come at the camera rate: the mean interval is the frame time */
	double span = (double)(t.poses[t.nposes - 1].capture_ns - t.poses[0].capture_ns) * 1e-9;
	double dt = span > 0 ? span / (t.nposes - 1) : 1.0 / 30;
	const char *name = strrchr(dir, '/');
	name = name && name[1] ? name + 1 : dir;
	rc = mc_motion_db_add_positions(db, name, cls, src, t.nposes, dt, err);
	if (rc)
		mc_err_prefix(err, "%s", dir);
out:
	free(src);
	take_poses_free(&t);
	return rc;
}

/* World axes (z up, y forward) to BVH axes (y up): a proper rotation. */
static mc_vec3 to_bvh(mc_vec3 v) { return mc_v3(v.x, v.z, -v.y); }

static mc_mat3 axes(void)
{
	mc_mat3 C = {{{1, 0, 0}, {0, 0, 1}, {0, -1, 0}}};
	return C;
}

void motion_take_def(const mc_motion_skel *s, take_def *d)
{
	memset(d, 0, sizeof(*d));
	d->id = 1;
	d->njoints = MC_MOTION_JOINTS;
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		snprintf(d->joints[j].name, sizeof(d->joints[j].name), "%s", mc_motion_joint_name(j));
		d->joints[j].parent = s->parent[j];
		mc_vec3 o = to_bvh(s->offset[j]);
		d->joints[j].offset[0] = o.x;
		d->joints[j].offset[1] = o.y;
		d->joints[j].offset[2] = o.z;
	}
}

void motion_take_pose(const mc_motion_skel *s, const mc_vec3 *pose, take_pose *out)
{
	mc_mat3 R[MC_MOTION_JOINTS], C = axes(), Ct = mc_m3_transpose(C);
	mc_motion_orientations(s, pose, R);
	out->njoints = MC_MOTION_JOINTS;
	out->def_id = 1;
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		mc_vec3 p = to_bvh(pose[j]);
		out->joints[j].position[0] = p.x;
		out->joints[j].position[1] = p.y;
		out->joints[j].position[2] = p.z;
		mc_quat q = mc_quat_from_m3(mc_m3_mul(C, mc_m3_mul(R[j], Ct)));
		out->joints[j].orientation[0] = q.w;
		out->joints[j].orientation[1] = q.x;
		out->joints[j].orientation[2] = q.y;
		out->joints[j].orientation[3] = q.z;
		out->joints[j].confidence = 1;
	}
}
