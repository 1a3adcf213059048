/* mc_motion: the retargeted frame database (mc_motion.h). */
#include "motion/mc_motion.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const joint_names[MC_MOTION_JOINTS] = {
	"pelvis", "spine", "neck", "head_top",
	"left_shoulder", "left_elbow", "left_wrist",
	"right_shoulder", "right_elbow", "right_wrist",
	"left_hip", "left_knee", "left_ankle", "left_toe",
	"right_hip", "right_knee", "right_ankle", "right_toe",
};

static const int joint_parent[MC_MOTION_JOINTS] = {
	-1, MC_MJ_PELVIS, MC_MJ_SPINE, MC_MJ_NECK,
	MC_MJ_NECK, MC_MJ_LSHOULDER, MC_MJ_LELBOW,
	MC_MJ_NECK, MC_MJ_RSHOULDER, MC_MJ_RELBOW,
	MC_MJ_PELVIS, MC_MJ_LHIP, MC_MJ_LKNEE, MC_MJ_LANKLE,
	MC_MJ_PELVIS, MC_MJ_RHIP, MC_MJ_RKNEE, MC_MJ_RANKLE,
};

const char *mc_motion_joint_name(int j)
{
	return j >= 0 && j < MC_MOTION_JOINTS ? joint_names[j] : NULL;
}

/* Model axes (x right, y down, z forward) to world axes (x right, y
 * forward, z up): a proper rotation. */
static mc_vec3 model_to_world(mc_vec3 v) { return mc_v3(v.x, v.z, -v.y); }

void mc_motion_skel_default(mc_motion_skel *s)
{
	/* config/models/default.json's rest offsets, summed along the chains
	 * that the model routes through head and neck, in world axes. */
	static const double off[MC_MOTION_JOINTS][3] = {
		{0, 0, 0},         {0, 0, 0.22},      {0, 0, 0.28},   {0, 0, 0.115},
		{-0.205, 0, -0.13}, {0, 0, -0.30},    {0, 0, -0.24},
		{0.205, 0, -0.13},  {0, 0, -0.30},    {0, 0, -0.24},
		{-0.1, 0.03, -0.1}, {0, 0, -0.50},    {0, 0, -0.48},  {0, 0.14, -0.05},
		{0.1, 0.03, -0.1},  {0, 0, -0.50},    {0, 0, -0.48},  {0, 0.14, -0.05},
	};
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		s->parent[j] = joint_parent[j];
		s->offset[j] = mc_v3(off[j][0], off[j][1], off[j][2]);
	}
}

int mc_motion_skel_from_model(const mc_model *m, mc_motion_skel *s, mc_err *err)
{
	int idx[MC_MOTION_JOINTS];
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		idx[j] = mc_model_find_joint(m, joint_names[j]);
		if (idx[j] < 0)
			return mc_err_set(err, "model '%s': no joint '%s'", m->name, joint_names[j]);
	}
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(m, pose);
	mc_fk *fk = malloc(sizeof(*fk));
	if (!fk)
		return mc_err_set(err, "out of memory");
	mc_model_fk(m, pose, fk);
	mc_mat3 root_from_rig = mc_m3_transpose(fk->rig_from_joint[0].R);
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		s->parent[j] = joint_parent[j];
		if (joint_parent[j] < 0) {
			s->offset[j] = mc_v3(0, 0, 0);
			continue;
		}
		mc_vec3 d = mc_v3_sub(fk->rig_from_joint[idx[j]].t, fk->rig_from_joint[idx[joint_parent[j]]].t);
		s->offset[j] = model_to_world(mc_m3_apply(root_from_rig, d));
	}
	free(fk);
	return 0;
}

void mc_motion_skel_rest(const mc_motion_skel *s, mc_vec3 *pos)
{
	for (int j = 0; j < MC_MOTION_JOINTS; j++)
		pos[j] = s->parent[j] < 0 ? mc_v3(0, 0, 0) : mc_v3_add(pos[s->parent[j]], s->offset[j]);
}

void mc_motion_db_init(mc_motion_db *db, double fps, const mc_motion_skel *s)
{
	memset(db, 0, sizeof(*db));
	db->fps = fps;
	if (s)
		db->skel = *s;
	else
		mc_motion_skel_default(&db->skel);
}

void mc_motion_db_free(mc_motion_db *db)
{
	free(db->clips);
	free(db->pos);
	free(db->clip_of);
	memset(db, 0, sizeof(*db));
}

/* ---- floor frames ---- */

mc_floor_frame mc_motion_floor_frame(const mc_vec3 *pose)
{
	mc_vec3 side = mc_v3_sub(pose[MC_MJ_LHIP], pose[MC_MJ_RHIP]);
	/* facing = side turned by -90 degrees about z: (x, y) -> (y, -x) */
	mc_floor_frame f = {pose[MC_MJ_PELVIS].x, pose[MC_MJ_PELVIS].y, atan2(-side.x, side.y)};
	return f;
}

mc_vec3 mc_floor_to_world(mc_floor_frame f, mc_vec3 l)
{
	double a = f.heading - M_PI / 2, c = cos(a), s = sin(a);
	return mc_v3(c * l.x - s * l.y + f.x, s * l.x + c * l.y + f.y, l.z);
}

mc_vec3 mc_floor_from_world(mc_floor_frame f, mc_vec3 w)
{
	double a = f.heading - M_PI / 2, c = cos(a), s = sin(a);
	double x = w.x - f.x, y = w.y - f.y;
	return mc_v3(c * x + s * y, -s * x + c * y, w.z);
}

/* ---- joint frames ----
 * A joint's frame is built from its primary direction (the bone to its
 * first child; for the neck, the spine's continuation, so that the neck
 * carries the shoulders like a chest) and the body's left-right line (the
 * hips for the legs and pelvis, the shoulders for the upper body). */

static int first_child(const mc_motion_skel *s, int j)
{
	for (int k = j + 1; k < MC_MOTION_JOINTS; k++)
		if (s->parent[k] == j)
			return k;
	return -1;
}

static bool lower_body(int j) { return j == MC_MJ_PELVIS || j >= MC_MJ_LHIP; }

/* Orthonormal frame, columns (e1 along a, e2 the part of b across a, e1 x
 * e2); falls back on c when b is nearly along a. */
static mc_mat3 frame_of(mc_vec3 a, mc_vec3 b, mc_vec3 c)
{
	mc_vec3 e1 = mc_v3_normalize(a);
	mc_vec3 e2 = mc_v3_reject(b, e1);
	if (mc_v3_norm(e2) < 0.3 * mc_v3_norm(b))
		e2 = mc_v3_reject(c, e1);
	e2 = mc_v3_normalize(e2);
	mc_vec3 e3 = mc_v3_cross(e1, e2);
	mc_mat3 F = {{{e1.x, e2.x, e3.x}, {e1.y, e2.y, e3.y}, {e1.z, e2.z, e3.z}}};
	return F;
}

static mc_vec3 primary_dir(const mc_motion_skel *s, const mc_vec3 *p, int j)
{
	if (j == MC_MJ_NECK)
		return mc_v3_sub(p[MC_MJ_NECK], p[MC_MJ_SPINE]);
	return mc_v3_sub(p[first_child(s, j)], p[j]);
}

/* The rotation of joint j's frame from rest to pose: primary direction
 * dir0 at rest, dir1 in the pose; the left-right line from `sides`. */
static mc_mat3 joint_rotation(const mc_vec3 *rest, const mc_vec3 *sides, int j, mc_vec3 dir0, mc_vec3 dir1)
{
	int l = lower_body(j) ? MC_MJ_LHIP : MC_MJ_LSHOULDER, r = lower_body(j) ? MC_MJ_RHIP : MC_MJ_RSHOULDER;
	mc_vec3 side0 = mc_v3_sub(rest[l], rest[r]), side1 = mc_v3_sub(sides[l], sides[r]);
	mc_vec3 fwd0 = mc_v3_cross(side0, mc_v3_sub(rest[MC_MJ_NECK], rest[MC_MJ_PELVIS]));
	mc_vec3 fwd1 = mc_v3_cross(side1, mc_v3_sub(sides[MC_MJ_NECK], sides[MC_MJ_PELVIS]));
	return mc_m3_mul(frame_of(dir1, side1, fwd1), mc_m3_transpose(frame_of(dir0, side0, fwd0)));
}

void mc_motion_fix_lengths(const mc_motion_skel *s, mc_vec3 *pose)
{
	/* Each bone keeps the direction it had before its parent moved; the
	 * hips and shoulders, second children of the pelvis and the neck, sit
	 * rigidly in their parent's frame, so that one rotation per joint
	 * poses the whole skeleton (mc_motion_orientations, BVH). */
	mc_vec3 orig[MC_MOTION_JOINTS], rest[MC_MOTION_JOINTS];
	memcpy(orig, pose, sizeof(orig));
	mc_motion_skel_rest(s, rest);
	for (int j = 1; j < MC_MOTION_JOINTS; j++) {
		int p = s->parent[j];
		if (first_child(s, p) != j) {
			mc_mat3 R = joint_rotation(rest, orig, p, primary_dir(s, rest, p), primary_dir(s, pose, p));
			pose[j] = mc_v3_add(pose[p], mc_m3_apply(R, s->offset[j]));
			continue;
		}
		mc_vec3 d = mc_v3_sub(orig[j], orig[p]);
		double n = mc_v3_norm(d), len = mc_v3_norm(s->offset[j]);
		d = n > 1e-9 ? mc_v3_scale(d, len / n) : s->offset[j];
		pose[j] = mc_v3_add(pose[p], d);
	}
}

void mc_motion_orientations(const mc_motion_skel *s, const mc_vec3 *pose, mc_mat3 *R)
{
	mc_vec3 rest[MC_MOTION_JOINTS];
	mc_motion_skel_rest(s, rest);
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		if (j != MC_MJ_NECK && first_child(s, j) < 0)
			R[j] = R[s->parent[j]];
		else
			R[j] = joint_rotation(rest, pose, j, primary_dir(s, rest, j), primary_dir(s, pose, j));
	}
}

mc_mat3 mc_motion_head_rotation(const mc_motion_skel *s, const mc_vec3 *pose)
{
	mc_vec3 rest[MC_MOTION_JOINTS];
	mc_motion_skel_rest(s, rest);
	return joint_rotation(rest, pose, MC_MJ_NECK, mc_v3_sub(rest[MC_MJ_HEAD_TOP], rest[MC_MJ_NECK]),
			      mc_v3_sub(pose[MC_MJ_HEAD_TOP], pose[MC_MJ_NECK]));
}

/* ---- adding clips ---- */

static double leg_length(const mc_vec3 *p)
{
	return mc_v3_norm(mc_v3_sub(p[MC_MJ_LKNEE], p[MC_MJ_LHIP])) +
	       mc_v3_norm(mc_v3_sub(p[MC_MJ_LANKLE], p[MC_MJ_LKNEE])) +
	       mc_v3_norm(mc_v3_sub(p[MC_MJ_RKNEE], p[MC_MJ_RHIP])) +
	       mc_v3_norm(mc_v3_sub(p[MC_MJ_RANKLE], p[MC_MJ_RKNEE]));
}

static double max_step(const mc_vec3 *a, const mc_vec3 *b)
{
	double m = 0;
	for (int j = 0; j < MC_MOTION_JOINTS; j++)
		m = fmax(m, mc_v3_norm(mc_v3_sub(b[j], a[j])));
	return m;
}

static int grow(mc_motion_db *db, int nnew, mc_err *err)
{
	size_t n = (size_t)db->nframes + (size_t)nnew;
	mc_vec3 *pos = realloc(db->pos, n * MC_MOTION_JOINTS * sizeof(*pos));
	if (pos)
		db->pos = pos;
	int *co = realloc(db->clip_of, n * sizeof(*co));
	if (co)
		db->clip_of = co;
	mc_motion_clip *cl = realloc(db->clips, (size_t)(db->nclips + 1) * sizeof(*cl));
	if (cl)
		db->clips = cl;
	if (!pos || !co || !cl)
		return mc_err_set(err, "out of memory for %zu frames", n);
	return 0;
}

int mc_motion_db_add_positions(mc_motion_db *db, const char *name, const char *cls, const mc_vec3 *src, int nsrc,
			       double src_dt, mc_err *err)
{
	if (nsrc < 2 || !(src_dt > 0))
		return mc_err_set(err, "%s: needs at least 2 frames and a positive frame time", name);
	/* One scale for the clip: the target's leg length over the source's
	 * (the first frame's: bones are rigid in the sources). */
	mc_vec3 rest[MC_MOTION_JOINTS];
	mc_motion_skel_rest(&db->skel, rest);
	double src_leg = leg_length(src);
	if (!(src_leg > 0))
		return mc_err_set(err, "%s: degenerate legs in frame 0", name);
	double scale = leg_length(rest) / src_leg;
	/* A converter's stock pose in front of the motion (01_01's first
	 * frame) is no motion: drop leading frames that jump to the next. */
	while (nsrc > 2 && max_step(src, src + MC_MOTION_JOINTS) * scale > MC_MOTION_LEAD_JUMP_M) {
		src += MC_MOTION_JOINTS;
		nsrc--;
	}
	double duration = (nsrc - 1) * src_dt;
	int n = (int)floor(duration * db->fps + 1e-6) + 1; /* timestamps round to ns */
	if (n < 2)
		return mc_err_set(err, "%s: shorter than two frames at %g fps", name, db->fps);
	if (grow(db, n, err))
		return -1;
	mc_vec3 *out = db->pos + (size_t)db->nframes * MC_MOTION_JOINTS;
	for (int k = 0; k < n; k++) {
		double t = k / db->fps / src_dt;
		int a = (int)floor(t);
		if (a >= nsrc - 1)
			a = nsrc - 2;
		double w = fmin(t - a, 1);
		mc_vec3 *o = out + (size_t)k * MC_MOTION_JOINTS;
		for (int j = 0; j < MC_MOTION_JOINTS; j++) {
			mc_vec3 p = mc_v3_add(mc_v3_scale(src[(size_t)a * MC_MOTION_JOINTS + j], 1 - w),
					      mc_v3_scale(src[(size_t)(a + 1) * MC_MOTION_JOINTS + j], w));
			if (!mc_v3_isfinite(p))
				return mc_err_set(err, "%s: frame %d: joint %s is not finite", name, a, joint_names[j]);
			o[j] = mc_v3_scale(p, scale);
		}
		mc_motion_fix_lengths(&db->skel, o);
	}
	/* The floor: the lowest foot joint over the clip. */
	double floor_z = INFINITY;
	static const int feet[] = {MC_MJ_LANKLE, MC_MJ_LTOE, MC_MJ_RANKLE, MC_MJ_RTOE};
	for (int k = 0; k < n; k++)
		for (int i = 0; i < 4; i++)
			floor_z = fmin(floor_z, out[(size_t)k * MC_MOTION_JOINTS + feet[i]].z);
	for (size_t i = 0; i < (size_t)n * MC_MOTION_JOINTS; i++)
		out[i].z -= floor_z;
	mc_motion_clip *c = &db->clips[db->nclips];
	memset(c, 0, sizeof(*c));
	snprintf(c->name, sizeof(c->name), "%s", name);
	snprintf(c->cls, sizeof(c->cls), "%s", cls ? cls : "");
	c->first = db->nframes;
	c->nframes = n;
	for (int k = 0; k < n; k++)
		db->clip_of[db->nframes + k] = db->nclips;
	db->nclips++;
	db->nframes += n;
	return 0;
}

/* BVH axes (x left, y up, z forward at rest) to world axes (z up). */
static mc_vec3 bvh_to_world(mc_vec3 v) { return mc_v3(-v.x, v.z, v.y); }

static bool rest_frame(const mc_bvh *b, int f)
{
	const double *v = mc_bvh_frame(b, f);
	for (int j = 0; j < b->njoints; j++)
		for (int c = 0; c < b->joints[j].nchannels; c++)
			if (b->joints[j].channels[c] >= MC_BVH_XROT && fabs(v[b->joints[j].channel0 + c]) > 1e-6)
				return false;
	return true;
}

static const char *base_name(const char *path)
{
	const char *s = strrchr(path, '/');
	return s ? s + 1 : path;
}

/* The Daz-friendly conversion of the CMU database (shared/data/mocap-train
 * cmu_daz/), in the order of joint_names.  It has no joint at the top of
 * the head: head_top is put 10 file units (about 0.1 m) above the head
 * joint, along the head's rest up axis. */
static const char *const daz_names[MC_MOTION_JOINTS] = {
	"hip", "chest", "head", NULL,
	"lShldr", "lForeArm", "lHand", "rShldr", "rForeArm", "rHand",
	"lThigh", "lShin", "lFoot", "lFoot_End", "rThigh", "rShin", "rFoot", "rFoot_End",
};
#define DAZ_HEAD_TOP_UNITS 10.0

/* map[j]: the BVH joint of joint j, -1 for the Daz head top.  The two CMU
 * namings of body/mc_bvh.h first, then the Daz one. */
static int map_joints(const mc_bvh *b, int *map, mc_err *err)
{
	int idx[MC_BVH_CMU_JOINTS];
	mc_err cmu_err;
	if (mc_bvh_map_cmu(b, idx, &cmu_err) == 0) {
		for (int j = 0; j < MC_MOTION_JOINTS; j++)
			for (int i = 0; i < MC_BVH_CMU_JOINTS; i++)
				if (strcmp(mc_bvh_cmu_joint_name(i), joint_names[j]) == 0)
					map[j] = idx[i];
		return 0;
	}
	if (mc_bvh_find(b, "hip") < 0) /* not Daz either: the CMU message */
		return mc_err_set(err, "%s (nor the Daz naming: no joint 'hip')", cmu_err.msg);
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		map[j] = daz_names[j] ? mc_bvh_find(b, daz_names[j]) : -1;
		if (daz_names[j] && map[j] < 0)
			return mc_err_set(err, "no joint '%s' (for %s) in this skeleton of the Daz naming", daz_names[j],
					  joint_names[j]);
	}
	return 0;
}

int mc_motion_db_add_bvh(mc_motion_db *db, const char *path, const char *cls, mc_err *err)
{
	mc_bvh b;
	if (mc_bvh_load(path, &b, err))
		return -1;
	int map[MC_MOTION_JOINTS];
	int rc = -1;
	mc_vec3 *src = NULL;
	mc_xform *x = NULL;
	if (map_joints(&b, map, err)) {
		mc_err_prefix(err, "%s", path);
		goto out;
	}
	int f0 = 0;
	while (f0 < b.nframes && rest_frame(&b, f0))
		f0++;
	int n = b.nframes - f0;
	src = malloc(sizeof(*src) * (size_t)(n > 0 ? n : 1) * MC_MOTION_JOINTS);
	x = malloc(sizeof(*x) * (size_t)b.njoints);
	if (!src || !x) {
		mc_err_set(err, "%s: out of memory", path);
		goto out;
	}
	int head = map[MC_MJ_NECK];
	for (int f = 0; f < n; f++) {
		mc_bvh_fk(&b, f0 + f, x);
		for (int j = 0; j < MC_MOTION_JOINTS; j++) {
			mc_vec3 p = map[j] >= 0 ? x[map[j]].t : mc_xform_apply(x[head], mc_v3(0, DAZ_HEAD_TOP_UNITS, 0));
			src[(size_t)f * MC_MOTION_JOINTS + j] = bvh_to_world(p);
		}
	}
	rc = mc_motion_db_add_positions(db, base_name(path), cls, src, n, b.frame_time, err);
	if (rc)
		mc_err_prefix(err, "%s", path);
out:
	free(src);
	free(x);
	mc_bvh_free(&b);
	return rc;
}
