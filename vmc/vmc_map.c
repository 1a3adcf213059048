/* vmc_map: the skeleton as Unity humanoid bones.  The formulas, with
 * A_j the orientation of joint j (space_from_joint), M = body_from_unity,
 * G = unity_from_space and C_b the bone's rest-to-T-pose turn:
 *   U_b = G A_rot(b) C_b^T M            the bone's Unity world rotation
 *   L_b = U_parent^T U_b                 its local rotation (sent)
 *   local_pos_b = M^T C_parent d_b       d_b: rest offset parent -> bone
 * so that U_parent local_pos_b = G A_rot(parent) d_b = G (p_b - p_parent)
 * whenever d_b is rigid in the parent's rotation joint.  docs/VMC.md. */
#include "vmc_map.h"

#include <ini.h>
#include <stdio.h>
#include <string.h>

static const struct {
	const char *name;
	int parent;
	const char *joint; /* default position joint, "" = not mapped */
} bones[VMC_NBONES] = {
	[VMC_HIPS] = {"Hips", -1, "pelvis"},
	[VMC_SPINE] = {"Spine", VMC_HIPS, "spine"},
	[VMC_CHEST] = {"Chest", VMC_SPINE, ""},
	[VMC_UPPER_CHEST] = {"UpperChest", VMC_CHEST, ""},
	[VMC_NECK] = {"Neck", VMC_UPPER_CHEST, "neck"},
	[VMC_HEAD] = {"Head", VMC_NECK, "head"},
	[VMC_LEFT_SHOULDER] = {"LeftShoulder", VMC_UPPER_CHEST, ""},
	[VMC_LEFT_UPPER_ARM] = {"LeftUpperArm", VMC_LEFT_SHOULDER, "left_shoulder"},
	[VMC_LEFT_LOWER_ARM] = {"LeftLowerArm", VMC_LEFT_UPPER_ARM, "left_elbow"},
	[VMC_LEFT_HAND] = {"LeftHand", VMC_LEFT_LOWER_ARM, "left_wrist"},
	[VMC_RIGHT_SHOULDER] = {"RightShoulder", VMC_UPPER_CHEST, ""},
	[VMC_RIGHT_UPPER_ARM] = {"RightUpperArm", VMC_RIGHT_SHOULDER, "right_shoulder"},
	[VMC_RIGHT_LOWER_ARM] = {"RightLowerArm", VMC_RIGHT_UPPER_ARM, "right_elbow"},
	[VMC_RIGHT_HAND] = {"RightHand", VMC_RIGHT_LOWER_ARM, "right_wrist"},
	[VMC_LEFT_UPPER_LEG] = {"LeftUpperLeg", VMC_HIPS, "left_hip"},
	[VMC_LEFT_LOWER_LEG] = {"LeftLowerLeg", VMC_LEFT_UPPER_LEG, "left_knee"},
	[VMC_LEFT_FOOT] = {"LeftFoot", VMC_LEFT_LOWER_LEG, "left_ankle"},
	[VMC_LEFT_TOES] = {"LeftToes", VMC_LEFT_FOOT, "left_toe"},
	[VMC_RIGHT_UPPER_LEG] = {"RightUpperLeg", VMC_HIPS, "right_hip"},
	[VMC_RIGHT_LOWER_LEG] = {"RightLowerLeg", VMC_RIGHT_UPPER_LEG, "right_knee"},
	[VMC_RIGHT_FOOT] = {"RightFoot", VMC_RIGHT_LOWER_LEG, "right_ankle"},
	[VMC_RIGHT_TOES] = {"RightToes", VMC_RIGHT_FOOT, "right_toe"},
};

const char *vmc_bone_name(int bone)
{
	return bone >= 0 && bone < VMC_NBONES ? bones[bone].name : NULL;
}

int vmc_bone_find(const char *name)
{
	for (int b = 0; b < VMC_NBONES; b++)
		if (strcmp(bones[b].name, name) == 0)
			return b;
	return -1;
}

int vmc_bone_unity_parent(int bone)
{
	return bone >= 0 && bone < VMC_NBONES ? bones[bone].parent : -1;
}

void vmc_bone_table_default(vmc_bone_table *t)
{
	memset(t, 0, sizeof(*t));
	for (int b = 0; b < VMC_NBONES; b++)
		snprintf(t->pos[b], sizeof(t->pos[b]), "%s", bones[b].joint);
}

/* ---- the bone file ---- */

typedef struct {
	vmc_bone_table *table;
	const char *path;
	mc_err *err;
	int failed;
	int line;
} bone_file;

static int on_bone_key(void *user, const char *section, const char *key, const char *value)
{
	bone_file *f = user;
	if (f->failed)
		return 0;
	f->line++;
	if (strcmp(section, "bones") != 0) {
		f->failed = mc_err_set(f->err, "%s: [%s] %s: unknown section (the file has one: [bones])", f->path,
				       section, key);
		return 0;
	}
	int b = vmc_bone_find(key);
	if (b < 0) {
		f->failed = mc_err_set(f->err, "%s: [bones] %s: not a Unity humanoid bone (docs/VMC.md lists them)",
				       f->path, key);
		return 0;
	}
	char pos[MOCAP_NAME_MAX] = "", rot[MOCAP_NAME_MAX] = "", extra[8] = "";
	int n = sscanf(value, "%63s %63s %7s", pos, rot, extra);
	if (n == 3) {
		f->failed = mc_err_set(f->err, "%s: [bones] %s: expected `joint [rotation_joint]`, got '%s'", f->path,
				       key, value);
		return 0;
	}
	snprintf(f->table->pos[b], sizeof(f->table->pos[b]), "%s", n >= 1 ? pos : "");
	snprintf(f->table->rot[b], sizeof(f->table->rot[b]), "%s", n >= 2 ? rot : "");
	f->table->given[b] = true;
	return 1;
}

int vmc_bone_table_load(vmc_bone_table *t, const char *path, mc_err *err)
{
	FILE *fp = fopen(path, "r");
	if (!fp)
		return mc_err_set(err, "%s: cannot open the bone file", path);
	bone_file f = {.table = t, .path = path, .err = err};
	int rc = ini_parse_file(fp, on_bone_key, &f);
	fclose(fp);
	if (f.failed)
		return -1;
	if (rc != 0)
		return mc_err_set(err, "%s: line %d: not `Bone = joint [rotation_joint]` under [bones]", path, rc);
	return 0;
}

/* ---- building the map ---- */

static int find_joint(const mocap_skeleton_def *sk, const char *name)
{
	for (int j = 0; j < sk->njoints; j++)
		if (strcmp(sk->joints[j].name, name) == 0)
			return j;
	return -1;
}

/* Joint positions of the rest pose, in the (common) joint frame. */
static void rest_positions(const mocap_skeleton_def *sk, mc_vec3 *rest)
{
	for (int j = 0; j < sk->njoints; j++) {
		const mocap_joint_def *d = &sk->joints[j];
		mc_vec3 off = mc_v3(d->rest_offset[0], d->rest_offset[1], d->rest_offset[2]);
		rest[j] = d->parent >= 0 ? mc_v3_add(rest[d->parent], off) : off;
	}
}

static int depth(const mocap_skeleton_def *sk, int j)
{
	int n = 0;
	for (; sk->joints[j].parent >= 0; j = sk->joints[j].parent)
		n++;
	return n;
}

/* The joints whose frames carry the path a -> b (each edge's parent),
 * appended to frames[*n]. */
static void path_frames(const mocap_skeleton_def *sk, int a, int b, int *frames, int *n, int cap)
{
	int da = depth(sk, a), db = depth(sk, b);
	while (a != b) {
		int *x = da >= db ? &a : &b;
		int p = sk->joints[*x].parent;
		if (*n < cap)
			frames[(*n)++] = p;
		*x = p;
		if (x == &a)
			da--;
		else
			db--;
	}
}

/* The index in m->bone of the nearest present Unity ancestor, or -1. */
static int present_parent(const int *slot, int b)
{
	for (int p = bones[b].parent; p >= 0; p = bones[p].parent)
		if (slot[p] >= 0)
			return slot[p];
	return -1;
}

/* The rotation joint: the joint whose frame carries the segments to the
 * bone's children; the bone's own joint when it is one of them (joints
 * without dofs share their parent's frame) or when it has no children. */
static int auto_rot_joint(const mocap_skeleton_def *sk, const vmc_map *m, int i)
{
	int frames[64], n = 0, j = m->bone[i].pos_joint;
	for (int c = i + 1; c < m->nbones; c++)
		if (m->bone[c].parent == i)
			path_frames(sk, j, m->bone[c].pos_joint, frames, &n, 64);
	for (int k = 0; k < n; k++)
		if (frames[k] == j)
			return j;
	return n > 0 ? frames[0] : j;
}

static void add_conf_joint(vmc_bone *b, int j)
{
	for (int k = 0; k < b->nconf; k++)
		if (b->conf_joint[k] == j)
			return;
	if (b->nconf < VMC_MAX_CONF_JOINTS)
		b->conf_joint[b->nconf++] = j;
}

/* The smallest rotation turning unit vector a onto unit vector b. */
static mc_mat3 turn_onto(mc_vec3 a, mc_vec3 b)
{
	mc_vec3 axis = mc_v3_cross(a, b);
	double s = mc_v3_norm(axis), c = mc_v3_dot(a, b);
	if (s < 1e-9)
		return mc_m3_identity(); /* aligned (an arm exactly opposite the T-pose is not a body) */
	return mc_m3_axis_angle(mc_v3_scale(axis, 1 / s), atan2(s, c));
}

static mc_vec3 m3_col(mc_mat3 a, int c) { return mc_v3(a.m[0][c], a.m[1][c], a.m[2][c]); }

/* body_from_unity from the rest pose: up from the Hips to the highest
 * spine bone, right from left to right leg (or arm). */
static int body_axes(vmc_map *m, const int *slot, const mc_vec3 *rest, mc_err *err)
{
	static const int tops[] = {VMC_HEAD, VMC_NECK, VMC_UPPER_CHEST, VMC_CHEST, VMC_SPINE};
	static const int pairs[][2] = {{VMC_LEFT_UPPER_LEG, VMC_RIGHT_UPPER_LEG}, {VMC_LEFT_UPPER_ARM, VMC_RIGHT_UPPER_ARM}};
	mc_vec3 hips = rest[m->bone[0].pos_joint], up = mc_v3(0, 0, 0), right = mc_v3(0, 0, 0);
	for (size_t k = 0; k < sizeof(tops) / sizeof(tops[0]) && mc_v3_norm(up) < 1e-6; k++)
		if (slot[tops[k]] >= 0)
			up = mc_v3_sub(rest[m->bone[slot[tops[k]]].pos_joint], hips);
	if (mc_v3_norm(up) < 1e-6)
		return mc_err_set(err, "bones: no Spine, Neck or Head above the Hips in the rest pose (no up direction)");
	up = mc_v3_normalize(up);
	for (size_t k = 0; k < 2 && mc_v3_norm(right) < 1e-6; k++)
		if (slot[pairs[k][0]] >= 0 && slot[pairs[k][1]] >= 0)
			right = mc_v3_reject(mc_v3_sub(rest[m->bone[slot[pairs[k][1]]].pos_joint],
						      rest[m->bone[slot[pairs[k][0]]].pos_joint]),
					     up);
	if (mc_v3_norm(right) < 1e-6)
		return mc_err_set(err, "bones: no left and right UpperLeg or UpperArm apart in the rest pose (no right direction)");
	right = mc_v3_normalize(right);
	mc_vec3 fwd = mc_v3_cross(up, right);
	mc_vec3 cols[3] = {right, up, fwd};
	for (int r = 0; r < 3; r++)
		for (int c = 0; c < 3; c++)
			m->body_from_unity.m[r][c] = mc_v3_get(cols[c], r);
	return 0;
}

/* T-pose turns: upper and lower arms onto the body's left or right, upper
 * and lower legs straight down; hands follow their lower arm. */
static void tpose_turns(vmc_map *m, const int *slot, const mc_vec3 *rest)
{
	static const struct { int bone, child, side; } limbs[] = {
		{VMC_LEFT_UPPER_ARM, VMC_LEFT_LOWER_ARM, -1},   {VMC_LEFT_LOWER_ARM, VMC_LEFT_HAND, -1},
		{VMC_RIGHT_UPPER_ARM, VMC_RIGHT_LOWER_ARM, 1},  {VMC_RIGHT_LOWER_ARM, VMC_RIGHT_HAND, 1},
		{VMC_LEFT_UPPER_LEG, VMC_LEFT_LOWER_LEG, 0},    {VMC_LEFT_LOWER_LEG, VMC_LEFT_FOOT, 0},
		{VMC_RIGHT_UPPER_LEG, VMC_RIGHT_LOWER_LEG, 0},  {VMC_RIGHT_LOWER_LEG, VMC_RIGHT_FOOT, 0},
	};
	mc_vec3 right = m3_col(m->body_from_unity, 0), up = m3_col(m->body_from_unity, 1);
	for (size_t k = 0; k < sizeof(limbs) / sizeof(limbs[0]); k++) {
		int b = slot[limbs[k].bone], c = slot[limbs[k].child];
		if (b < 0 || c < 0)
			continue;
		mc_vec3 seg = mc_v3_sub(rest[m->bone[c].pos_joint], rest[m->bone[b].pos_joint]);
		if (mc_v3_norm(seg) < 1e-6)
			continue;
		mc_vec3 target = limbs[k].side ? mc_v3_scale(right, limbs[k].side) : mc_v3_scale(up, -1);
		m->bone[b].tpose = turn_onto(mc_v3_normalize(seg), target);
	}
	static const int hands[][2] = {{VMC_LEFT_HAND, VMC_LEFT_LOWER_ARM}, {VMC_RIGHT_HAND, VMC_RIGHT_LOWER_ARM}};
	for (int k = 0; k < 2; k++)
		if (slot[hands[k][0]] >= 0 && slot[hands[k][1]] >= 0)
			m->bone[slot[hands[k][0]]].tpose = m->bone[slot[hands[k][1]]].tpose;
}

/* The bones present in the skeleton, in Unity order, with their joints. */
static int place_bones(vmc_map *m, int *slot, const mocap_skeleton_def *sk, const vmc_bone_table *t, mc_err *err)
{
	for (int b = 0; b < VMC_NBONES; b++) {
		slot[b] = -1;
		if (!t->pos[b][0]) {
			if (b == VMC_HIPS)
				return mc_err_set(err, "bones: Hips: must name a joint (every bone hangs from it)");
			continue;
		}
		int j = find_joint(sk, t->pos[b]);
		if (j < 0) {
			/* The default table names the project's joints; a model
			 * without one (e.g. no separate head joint) sends fewer bones. */
			if (b == VMC_HIPS || t->given[b])
				return mc_err_set(err, "bones: %s: the skeleton has no joint '%s'", bones[b].name, t->pos[b]);
			continue;
		}
		vmc_bone *o = &m->bone[m->nbones];
		memset(o, 0, sizeof(*o));
		o->id = b;
		o->pos_joint = j;
		o->rot_joint = -1;
		if (t->rot[b][0] && (o->rot_joint = find_joint(sk, t->rot[b])) < 0)
			return mc_err_set(err, "bones: %s: the skeleton has no joint '%s'", bones[b].name, t->rot[b]);
		o->parent = present_parent(slot, b);
		o->tpose = mc_m3_identity();
		slot[b] = m->nbones++;
	}
	return 0;
}

int vmc_map_build(vmc_map *m, const mocap_skeleton_def *sk, const vmc_bone_table *t, vmc_rest rest, mc_err *err)
{
	memset(m, 0, sizeof(*m));
	m->skeleton_id = sk->id;
	int slot[VMC_NBONES];
	mc_vec3 rest_pos[MOCAP_MAX_JOINTS];
	if (sk->njoints < 1 || sk->njoints > MOCAP_MAX_JOINTS)
		return mc_err_set(err, "skeleton: %d joints", sk->njoints);
	rest_positions(sk, rest_pos);
	if (place_bones(m, slot, sk, t, err) < 0 || body_axes(m, slot, rest_pos, err) < 0)
		return -1;
	if (rest == VMC_REST_TPOSE)
		tpose_turns(m, slot, rest_pos);
	mc_mat3 unity_from_body = mc_m3_transpose(m->body_from_unity);
	for (int i = 0; i < m->nbones; i++) {
		vmc_bone *b = &m->bone[i];
		if (b->rot_joint < 0)
			b->rot_joint = auto_rot_joint(sk, m, i);
		add_conf_joint(b, b->rot_joint);
		for (int c = i + 1; c < m->nbones; c++)
			if (m->bone[c].parent == i)
				add_conf_joint(b, m->bone[c].pos_joint);
		b->rest_local = mc_quat_identity();
		if (b->parent < 0)
			continue;
		const vmc_bone *p = &m->bone[b->parent];
		mc_vec3 d = mc_v3_sub(rest_pos[b->pos_joint], rest_pos[p->pos_joint]);
		b->local_pos = mc_m3_apply(unity_from_body, mc_m3_apply(p->tpose, d));
		/* At the rest pose every A is the same: L = M^T C_p C_b^T M. */
		mc_mat3 l = mc_m3_mul(mc_m3_mul(unity_from_body, mc_m3_mul(p->tpose, mc_m3_transpose(b->tpose))),
				      m->body_from_unity);
		b->rest_local = mc_quat_from_m3(l);
	}
	return 0;
}

/* ---- per frame ---- */

static mc_mat3 m3_rows(mc_vec3 r0, mc_vec3 r1, mc_vec3 r2)
{
	mc_mat3 a = {{{r0.x, r0.y, r0.z}, {r1.x, r1.y, r1.z}, {r2.x, r2.y, r2.z}}};
	return a;
}

static mc_quat joint_quat(const mocap_skeleton_frame *f, int j)
{
	const double *q = f->joints[j].orientation;
	return mc_quat_normalize((mc_quat){q[0], q[1], q[2], q[3]});
}

static mc_vec3 joint_pos(const mocap_skeleton_frame *f, int j)
{
	const double *p = f->joints[j].position;
	return mc_v3(p[0], p[1], p[2]);
}

mc_mat3 vmc_unity_from_space(const vmc_map *m, const mocap_skeleton_frame *f, vmc_up up)
{
	switch (up) {
	case VMC_UP_Y:
		return m3_rows(mc_v3(1, 0, 0), mc_v3(0, 1, 0), mc_v3(0, 0, -1));
	case VMC_UP_Z:
		return m3_rows(mc_v3(1, 0, 0), mc_v3(0, 0, 1), mc_v3(0, 1, 0));
	case VMC_UP_HEAD:
	default:
		/* G = M^T A_root^T: the root joint's body axes become Unity's. */
		return mc_m3_mul(mc_m3_transpose(m->body_from_unity), mc_m3_transpose(mc_quat_to_m3(joint_quat(f, 0))));
	}
}

/* U_b = G A_rot(b) C_b^T M for every bone. */
static void unity_rotations(const vmc_map *m, const mocap_skeleton_frame *f, mc_mat3 g, mc_mat3 *u)
{
	for (int i = 0; i < m->nbones; i++) {
		const vmc_bone *b = &m->bone[i];
		mc_mat3 a = mc_quat_to_m3(joint_quat(f, b->rot_joint));
		u[i] = mc_m3_mul(mc_m3_mul(g, a), mc_m3_mul(mc_m3_transpose(b->tpose), m->body_from_unity));
	}
}

static mc_vec3 hips_world(const vmc_map *m, const mocap_skeleton_frame *f, mc_mat3 g, double floor_height)
{
	mc_vec3 p = mc_m3_apply(g, joint_pos(f, m->bone[0].pos_joint));
	p.y -= floor_height;
	return p;
}

void vmc_map_pose(const vmc_map *m, const mocap_skeleton_frame *f, vmc_up up, double floor_height,
		  vmc_bone_pose *out)
{
	mc_mat3 g = vmc_unity_from_space(m, f, up), u[VMC_NBONES];
	unity_rotations(m, f, g, u);
	for (int i = 0; i < m->nbones; i++) {
		const vmc_bone *b = &m->bone[i];
		mc_mat3 l = b->parent < 0 ? u[i] : mc_m3_mul(mc_m3_transpose(u[b->parent]), u[i]);
		out[i].rot = mc_quat_from_m3(mc_m3_orthonormalize(l));
		out[i].pos = b->parent < 0 ? hips_world(m, f, g, floor_height) : b->local_pos;
		float c = 1;
		for (int k = 0; k < b->nconf; k++)
			if (f->joints[b->conf_joint[k]].confidence < c)
				c = f->joints[b->conf_joint[k]].confidence;
		out[i].confidence = c;
	}
}

double vmc_map_residual(const vmc_map *m, const mocap_skeleton_frame *f, vmc_up up, double floor_height,
			const vmc_bone_pose *poses)
{
	mc_mat3 g = vmc_unity_from_space(m, f, up), world[VMC_NBONES];
	mc_vec3 pos[VMC_NBONES];
	double worst = 0;
	for (int i = 0; i < m->nbones; i++) {
		const vmc_bone *b = &m->bone[i];
		mc_mat3 l = mc_quat_to_m3(poses[i].rot);
		if (b->parent < 0) {
			world[i] = l;
			pos[i] = poses[i].pos;
		} else {
			world[i] = mc_m3_mul(world[b->parent], l);
			pos[i] = mc_v3_add(pos[b->parent], mc_m3_apply(world[b->parent], poses[i].pos));
		}
		mc_vec3 want = mc_m3_apply(g, joint_pos(f, b->pos_joint));
		want.y -= floor_height;
		double e = mc_v3_norm(mc_v3_sub(pos[i], want));
		if (e > worst)
			worst = e;
	}
	return worst;
}

/* ---- low confidence ---- */

static mc_quat quat_slerp(mc_quat a, mc_quat b, double s)
{
	double d = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
	if (d < 0) { /* the short way round */
		b = (mc_quat){-b.w, -b.x, -b.y, -b.z};
		d = -d;
	}
	double wa = 1 - s, wb = s;
	if (d < 0.9995) {
		double th = acos(d), st = sin(th);
		wa = sin((1 - s) * th) / st;
		wb = sin(s * th) / st;
	}
	return mc_quat_normalize((mc_quat){wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y,
					   wa * a.z + wb * b.z});
}

void vmc_hold_apply(vmc_hold *h, const vmc_map *m, vmc_bone_pose *poses, float min_confidence, vmc_low mode,
		    double ease_s, uint64_t t_ns)
{
	double dt = h->t_ns && t_ns > h->t_ns ? (double)(t_ns - h->t_ns) * 1e-9 : 0;
	double ease = ease_s > 0 ? 1 - exp(-dt / ease_s) : 1;
	h->t_ns = t_ns;
	for (int i = 0; i < m->nbones; i++) {
		vmc_bone_pose *p = &poses[i];
		if (p->confidence >= min_confidence) {
			h->have[i] = true;
			h->last[i] = p->rot;
			if (i == 0)
				h->hips_pos = p->pos;
			continue;
		}
		if (!h->have[i]) /* nothing good yet: send what there is */
			continue;
		if (i == 0)
			p->pos = h->hips_pos; /* the root stays where it was last seen */
		if (mode == VMC_LOW_REST && i > 0)
			h->last[i] = quat_slerp(h->last[i], m->bone[i].rest_local, ease);
		p->rot = h->last[i];
	}
}
