/* The body model fitted to another skeleton's joints (see the header). */
#include "body/mc_fit_joints.h"

#include "body/mc_ik.h"

#include <math.h>
#include <string.h>

/* Joints whose place differs from skeleton to skeleton; the first
 * NCHECKED are compared with the model's (spine_pelvis_miss). */
static const char *const NOT_LANDMARKS[] = {"spine", "pelvis", "head_top"};
#define NCHECKED 2
/* The bones from the neck down to the hips, scaled as one. */
static const char *const TORSO_BONES[] = {"spine", "pelvis", "left_hip", "right_hip"};
#define NTORSO (int)(sizeof(TORSO_BONES) / sizeof(TORSO_BONES[0]))
/* A torso scale outside this is no human's: the bones keep the limbs'. */
#define TORSO_SCALE_MIN 0.5
#define TORSO_SCALE_MAX 2.0
/* A pair's width outside this share of the model's is no human's. */
#define PAIR_WIDTH_MIN 0.5
#define PAIR_WIDTH_MAX 2.0

bool mc_fit_joints_is_landmark(const char *name)
{
	for (size_t i = 0; i < sizeof(NOT_LANDMARKS) / sizeof(NOT_LANDMARKS[0]); i++)
		if (!strcmp(name, NOT_LANDMARKS[i]))
			return false;
	return true;
}

static const mc_ik_target *target_of(const mc_model *m, const mc_ik_target *t, int n, const char *name)
{
	return mc_ik_find_target(t, n, mc_model_find_joint(m, name));
}

/* Where the rest pose puts the neck and the hips' midpoint, with every
 * torso bone at scale 1: their distance is the torso's rest length. */
static double torso_rest_length(const mc_model *model, const int *bone)
{
	mc_model m = *model;
	for (int i = 0; i < NTORSO; i++)
		m.bone_scale[bone[i]] = 1.0;
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(&m, pose);
	mc_fk fk;
	mc_model_fk(&m, pose, &fk);
	int neck = mc_model_find_joint(&m, "neck");
	mc_vec3 hips = mc_v3_scale(mc_v3_add(fk.rig_from_joint[bone[2]].t, fk.rig_from_joint[bone[3]].t), 0.5);
	return mc_v3_norm(mc_v3_sub(hips, fk.rig_from_joint[neck].t));
}

/* Without a spine and pelvis to measure them by, the torso's bones take
 * one scale: the given neck's distance to the given hips' midpoint over the
 * model's.  (mc_ik_fit_bone_scale would give them the limbs' median, and a
 * long-legged actor need not have a long back.) */
static void scale_torso(mc_model *m, const mc_ik_target *t, int n)
{
	const mc_ik_target *neck = target_of(m, t, n, "neck"), *lh = target_of(m, t, n, "left_hip"),
			   *rh = target_of(m, t, n, "right_hip");
	int bone[NTORSO];
	for (int i = 0; i < NTORSO; i++)
		if ((bone[i] = mc_model_find_joint(m, TORSO_BONES[i])) < 0)
			return;
	if (!neck || !lh || !rh)
		return;
	double rest = torso_rest_length(m, bone);
	mc_vec3 hips = mc_v3_scale(mc_v3_add(lh->position, rh->position), 0.5);
	double s = mc_v3_norm(mc_v3_sub(hips, neck->position)) / rest;
	if (!(rest > 1e-3) || !(s >= TORSO_SCALE_MIN && s <= TORSO_SCALE_MAX))
		return;
	for (int i = 0; i < NTORSO; i++)
		m->bone_scale[bone[i]] = s;
}

/* v with its part along unit vector `across` times w. */
static mc_vec3 stretch_across(mc_vec3 v, mc_vec3 across, double w)
{
	return mc_v3_add(v, mc_v3_scale(across, (w - 1) * mc_v3_dot(v, across)));
}

/* Joint j's rest offset, and the Gaussians its bone scales, stretched
 * across the pair by w. */
static void widen(mc_model *m, int j, mc_vec3 across, double w)
{
	m->joints[j].offset = stretch_across(m->joints[j].offset, across, w);
	for (int g = 0; g < m->ngauss; g++)
		if (m->gauss[g].scale_joint == j)
			m->gauss[g].offset = stretch_across(m->gauss[g].offset, across, w);
}

/* The vector from joint left's other side to it, both on one parent (0
 * for no such pair). */
static mc_vec3 pair_across(const mc_model *m, int left)
{
	int r = left >= 0 && left < m->njoints ? mc_model_other_side(m, left) : -1;
	if (r < 0 || strncmp(m->joints[left].name, "left_", 5) || m->joints[r].parent != m->joints[left].parent)
		return mc_v3(0, 0, 0);
	return mc_v3_sub(mc_v3_scale(m->joints[left].offset, m->bone_scale[left]),
			 mc_v3_scale(m->joints[r].offset, m->bone_scale[r]));
}

double mc_fit_joints_pair_width(const mc_model *m, int left)
{
	return mc_v3_norm(pair_across(m, left));
}

int mc_fit_joints_set_pair_width(mc_model *m, int left, double width)
{
	mc_vec3 across = pair_across(m, left);
	double now = mc_v3_norm(across), w = width / now;
	if (!(now > 1e-3) || !(w >= PAIR_WIDTH_MIN && w <= PAIR_WIDTH_MAX))
		return -1;
	across = mc_v3_scale(across, 1 / now);
	widen(m, left, across, w);
	widen(m, mc_model_other_side(m, left), across, w);
	return 0;
}

/* The width of each left/right pair on one parent (the shoulders on the
 * neck, the hips on the pelvis) from the given pair's distance.  A bone's
 * one scale keeps the model's direction from the parent, and skeletons
 * differ in it: with the scale from the bone's length (or the torso's) the
 * model's hips were 1.7-5.5 cm wider than the dev and held-out clips'
 * skeletons, and the shoulders up to 6.6 cm.  Only the pair's spread
 * changes: its midpoint stays where the scales put it. */
static void fit_pair_widths(mc_model *m, const mc_ik_target *t, int n)
{
	for (int l = 0; l < m->njoints; l++) {
		int r = mc_model_other_side(m, l);
		const mc_ik_target *gl = mc_ik_find_target(t, n, l), *gr = r >= 0 ? mc_ik_find_target(t, n, r) : NULL;
		if (gl && gr)
			mc_fit_joints_set_pair_width(m, l, mc_v3_norm(mc_v3_sub(gl->position, gr->position)));
	}
}

static double solve(mc_model *m, double *pose, const mc_ik_target *t, int n, bool fit_bone_scale, mc_err *err)
{
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.iterations = 200;
	o.fit_bone_scale = fit_bone_scale;
	mc_model_rest_pose(m, pose);
	return mc_ik_solve(m, pose, t, n, &o, err);
}

/* How far the fitted model's spine or pelvis is from the given one, at most
 * (0 when neither is given). */
static double spine_pelvis_miss(const mc_model *m, const double *pose, const mc_ik_target *t, int n)
{
	mc_fk fk;
	mc_model_fk(m, pose, &fk);
	double worst = 0;
	for (int k = 0; k < NCHECKED; k++) {
		const mc_ik_target *g = target_of(m, t, n, NOT_LANDMARKS[k]);
		if (g)
			worst = fmax(worst, mc_v3_norm(mc_v3_sub(fk.rig_from_joint[g->joint].t, g->position)));
	}
	return worst;
}

/* The landmarks alone (the other joints weigh 0): bone scales from them and
 * the torso's, then the pose.  Negative where they are too few. */
static double fit_landmarks(mc_model *m, double *pose, const mc_ik_target *t, int n, mc_err *err)
{
	mc_ik_target landmarks[MC_MAX_JOINTS];
	int nl = 0;
	for (int i = 0; i < n; i++)
		if (t[i].weight > 0)
			landmarks[nl++] = t[i];
	if (nl < 3)
		return -1;
	mc_ik_fit_bone_scale(m, landmarks, nl);
	scale_torso(m, landmarks, nl);
	fit_pair_widths(m, landmarks, nl);
	return solve(m, pose, t, n, false, err);
}

double mc_fit_joints(mc_model *model, double *pose, const char *const *names, const mc_vec3 *positions, int n,
		     mc_err *err)
{
	mc_ik_target t[MC_MAX_JOINTS];
	int nt = 0;
	for (int i = 0; i < n && nt < MC_MAX_JOINTS; i++) {
		int j = mc_model_find_joint(model, names[i]);
		if (j >= 0)
			t[nt++] = (mc_ik_target){j, positions[i], mc_fit_joints_is_landmark(names[i]) ? 1.0 : 0.0, {0, 0, 0}};
	}
	mc_model before = *model;
	mc_err landmark_err = {{0}};
	double rms = fit_landmarks(model, pose, t, nt, &landmark_err);
	if (rms >= 0 && spine_pelvis_miss(model, pose, t, nt) > MC_FIT_JOINTS_AGREE_M)
		return rms;
	/* The given spine and pelvis are the model's kind (or the landmarks
	 * alone could not be fitted): every joint counts. */
	*model = before;
	for (int i = 0; i < nt; i++)
		t[i].weight = 1.0;
	mc_ik_fit_bone_scale(model, t, nt);
	fit_pair_widths(model, t, nt);
	rms = solve(model, pose, t, nt, false, err);
	if (rms < 0)
		*model = before; /* targets the solve refused leave the actor as it was */
	return rms;
}
