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

/* The output skeleton: the 18 joints and a head joint at the neck that
 * carries head_top (the neck's own frame carries the shoulders). */
#define OUT_JOINTS (MC_MOTION_JOINTS + 1)
#define OUT_HEAD 3
static int src_of(int o) { return o < OUT_HEAD ? o : (o == OUT_HEAD ? -1 : o - 1); }
static int out_of(int j) { return j < OUT_HEAD ? j : j + 1; }

void motion_take_def(const mc_motion_skel *s, take_def *d)
{
	memset(d, 0, sizeof(*d));
	d->id = 1;
	d->njoints = OUT_JOINTS;
	for (int o = 0; o < OUT_JOINTS; o++) {
		int j = src_of(o);
		take_joint_def *jd = &d->joints[o];
		snprintf(jd->name, sizeof(jd->name), "%s", j < 0 ? "head" : mc_motion_joint_name(j));
		jd->parent = j < 0 ? out_of(MC_MJ_NECK) : (j == MC_MJ_HEAD_TOP ? OUT_HEAD : (s->parent[j] < 0 ? -1 : out_of(s->parent[j])));
		mc_vec3 off = to_bvh(j < 0 ? mc_v3(0, 0, 0) : s->offset[j]);
		jd->offset[0] = off.x;
		jd->offset[1] = off.y;
		jd->offset[2] = off.z;
	}
}

void motion_take_pose(const mc_motion_skel *s, const mc_vec3 *pose, take_pose *out)
{
	mc_mat3 R[MC_MOTION_JOINTS], C = axes(), Ct = mc_m3_transpose(C);
	mc_motion_orientations(s, pose, R);
	mc_mat3 head = mc_motion_head_rotation(s, pose);
	out->njoints = OUT_JOINTS;
	out->def_id = 1;
	for (int o = 0; o < OUT_JOINTS; o++) {
		int j = src_of(o);
		mc_vec3 p = to_bvh(pose[j < 0 ? MC_MJ_NECK : j]);
		out->joints[o].position[0] = p.x;
		out->joints[o].position[1] = p.y;
		out->joints[o].position[2] = p.z;
		mc_mat3 Rw = j < 0 || j == MC_MJ_HEAD_TOP ? head : R[j];
		mc_quat q = mc_quat_from_m3(mc_m3_mul(C, mc_m3_mul(Rw, Ct)));
		out->joints[o].orientation[0] = q.w;
		out->joints[o].orientation[1] = q.x;
		out->joints[o].orientation[2] = q.y;
		out->joints[o].orientation[3] = q.z;
		out->joints[o].confidence = 1;
	}
}
