/* The ray fit (settings.ray_fit; docs/TRACKER.md, "The ray fit"): before
 * the colour iterations, the predicted pose fitted by the inverse
 * kinematics to the frame set's keypoint rays, held to the prediction and
 * robust, and then kept part by part (each limb; the torso and a free
 * root) where the images agree: where the colour energy of the prediction
 * with that part from the fit is lower.
 *
 * Why: the keypoint term is a nudge within the colour iterations (issue
 * 35: with exact keypoints the tracker stays 3 cm above what the skeleton
 * can do), while a fit moves a limb toward its keypoints in one step.  Held
 * to the prediction, a ray cannot throw a joint along itself (the feet's
 * depth); robust, one wrong keypoint pulls little; and checked against the
 * colours, a limb the detector placed on the other leg or the floor is
 * refused.  While the keypoints are trusted, limbs seen end-on are also
 * fitted from a second start (docs/TRACKER.md, "Limbs seen end-on"). */
#include "body/mc_ik.h"
#include "geom/mc_ray.h"
#include "track/mc_tracker_internal.h"

#include <math.h>
#include <string.h>

/* Measured on the head rig's dev clips (docs/TRACKER.md, "The ray fit"):
 * the Tikhonov weight toward the prediction per rad^2 (1e-2 chased 8 px
 * noise: jumps 13.5 cm with the ego preset; 1e-1 kept most of the gain
 * away), the Cauchy scale of each ray's weight (0.10 m let more wrong
 * keypoints pull), and two rounds of two Levenberg-Marquardt iterations
 * (three of three: the same figures, slower). */
#define FIT_PRIOR 3e-2
#define FIT_TAU_M 0.05
#define FIT_ROUNDS 2
#define FIT_ITERATIONS 2
/* A part whose dofs the fit moved less than this is left alone. */
#define UNMOVED_RAD 1e-6
/* The limbs, by the joint whose dofs swing them. */
static const char *const limb_roots[] = {"left_shoulder", "right_shoulder", "left_hip", "right_hip"};
#define NLIMBS ((int)(sizeof(limb_roots) / sizeof(limb_roots[0])))
/* Each limb's middle and end joint, in limb_roots' order; the arms first. */
static const char *const limb_ends[NLIMBS][2] = {
	{"left_elbow", "left_wrist"}, {"right_elbow", "right_wrist"}, {"left_knee", "left_ankle"}, {"right_knee", "right_ankle"}};
#define NARMS 2

/* The usable rays as inverse-kinematics targets, each weighed by its
 * confidence and the Cauchy factor of its joint's distance at pose (the
 * keypoint term's loss, as iteratively reweighted least squares); the
 * count. */
static int ray_targets(const mc_tracker *t, const double *pose, mc_ik_target *tg)
{
	const mc_trk_frame_keypoints *kp = t->fkp;
	mc_fk fk;
	mc_model_fk(&t->model, pose, &fk);
	int n = 0;
	for (int i = 0; i < kp->nrays; i++) {
		const mc_trk_keypoint_ray *r = &kp->rays[i];
		if (r->weight <= 0 || t->fixed_joint[r->joint] || t->unpulled[r->joint])
			continue;
		mc_vec3 off = mc_ray_offset(mc_v3_sub(fk.rig_from_joint[r->joint].t, r->origin), r->dir, MC_RAY_NEAR_M);
		double x = mc_v3_norm(off) / FIT_TAU_M;
		tg[n++] = (mc_ik_target){r->joint, r->origin, r->weight / (1 + x * x), r->dir};
	}
	return n;
}

/* The inverse kinematics' options of a local fit: `iterations`, held to
 * prior_pose with weight `prior`, no restarts, the bones as they are. */
static mc_ik_options local_fit(int iterations, double prior, const double *prior_pose)
{
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.iterations = iterations;
	o.pose_prior = prior;
	o.prior_pose = prior_pose;
	o.fit_bone_scale = false;
	o.fit_root = false;
	o.restarts = false;
	return o;
}

/* fit: pred fitted to the rays; false when too few rays. */
static bool fit_to_rays(mc_tracker *t, const double *pred, double *fit)
{
	mc_ik_target tg[MC_TRK_MAX_KEYPOINTS];
	mc_ik_options o = local_fit(FIT_ITERATIONS, FIT_PRIOR, pred);
	o.fit_root = t->model.root_free; /* a fixed root is the head's place on the rig */
	o.ray_near = MC_RAY_NEAR_M;
	memcpy(fit, pred, sizeof(double) * (size_t)t->model.ndof);
	for (int round = 0; round < FIT_ROUNDS; round++) {
		int n = ray_targets(t, fit, tg);
		mc_err err;
		if (n < 3 || mc_ik_solve(&t->model, fit, tg, n, &o, &err) < 0)
			return false;
	}
	return true;
}

/* The joints of part p: limb p (mc_model_subtree of its root), or for
 * p = NLIMBS those of no limb (the torso, and a free root). */
static void part_joints(const mc_model *m, int p, bool *joint)
{
	if (p < NLIMBS) {
		if (!mc_model_subtree(m, mc_model_find_joint(m, limb_roots[p]), joint))
			memset(joint, 0, sizeof(bool) * (size_t)m->njoints);
		return;
	}
	for (int j = 0; j < m->njoints; j++)
		joint[j] = true;
	for (int l = 0; l < NLIMBS; l++) {
		bool limb[MC_MAX_JOINTS];
		if (mc_model_subtree(m, mc_model_find_joint(m, limb_roots[l]), limb))
			for (int j = 0; j < m->njoints; j++)
				joint[j] = joint[j] && !limb[j];
	}
}

/* The colour energy of poses a and b on a share (check_pixel_share) of
 * the pixels near the Gaussians that differ between them (those of the
 * part's joints): the other pixels add the same to both, only noise to
 * the comparison. */
static int compare_part(mc_tracker *t, const double *a, const double *b, const bool *joint, double *Ea, double *Eb,
			mc_err *err)
{
	bool gauss[MC_MAX_GAUSSIANS];
	for (int q = 0; q < t->model.ngauss; q++)
		gauss[q] = joint[t->model.gauss[q].joint];
	mc_fk fa, fb;
	mc_scene sa, sb;
	mc_vec3 dmu[MC_MAX_GAUSSIANS];
	mc_model_fk(&t->model, a, &fa);
	mc_model_fk(&t->model, b, &fb);
	int n = mc_trk_sample_near(t, &fa, &fb, gauss, t->s.check_pixel_share);
	mc_trk_make_scene(t, &fa, &sa);
	mc_trk_make_scene(t, &fb, &sb);
	if (mc_trk_data_term(t, &sa, n, 0.0, Ea, dmu, err) < 0 || mc_trk_data_term(t, &sb, n, 0.0, Eb, dmu, err) < 0)
		return -1;
	return 0;
}

/* ---- a forearm seen end-on ----------------------------------------------- */

/* A forearm along the cameras' line of sight looks the same pointing toward
 * them or away; the fit, robust and held to the prediction, keeps whichever
 * the motion brought (with the realistic simulated detector the dev walk's
 * wrist sat 20-38 cm too near for up to 0.9 s, with good keypoints in both
 * views).  So the arm is fitted again from other starts: the wrist
 * mirrored through the plane across the line of sight at the elbow (where
 * the forearm's share along it is FLIP_MIN_ALONG or more; otherwise the
 * mirror is nearly the same arm), and each place where one of the wrist's
 * rays crosses the sphere of the forearm's length about the elbow (a
 * forearm stuck mostly across the line of sight, whose truth points at the
 * cameras, has a mirror near itself: the dev jumps' wrists with 2 px
 * keypoints; CANDIDATE_APART_M keeps starts that differ).  The fit whose
 * wrist misses its rays least is kept if that is at most FLIP_GAIN of the
 * first fit's miss.  Only where:
 * - the wrist has rays from two cameras, and the fit misses one by
 *   FLIP_MISS_M or more (the second camera is what tells the two apart);
 * - the keypoints' trust (mc_keypoint_trust.c) is FLIP_MIN_TRUST or more:
 *   the shipped detector's keypoints (trust 1) flipped good arms onto
 *   their errors (held-out swordplay 14.3 -> 15.3 cm; at stop 58, with the
 *   crossings too, the four first held-out clips 20.56 -> 21.00);
 * - an arm: flipping the shins too cost the walk's feet, whose depth two
 *   cameras 0.3 m apart cannot tell (docs/TRACKER_EXPERIMENTS.md, stop 55).
 * The colour check after decides as for any fit. */
#define FLIP_MIN_ALONG 0.3
#define FLIP_MISS_M 0.03
#define FLIP_GAIN 0.5
#define FLIP_MIN_TRUST 2.0
#define FLIP_IK_PRIOR 1e-3
#define FLIP_IK_ITERATIONS 10
#define CANDIDATE_APART_M 0.05

/* The largest offset of joint j from its usable rays at fk, and through
 * *ncams whether two cameras or more gave them (0, 1 or 2). */
static double worst_offset(const mc_tracker *t, const mc_fk *fk, int j, int *ncams)
{
	const mc_trk_frame_keypoints *kp = t->fkp;
	double worst = 0;
	int first = -1;
	*ncams = 0;
	for (int i = 0; i < kp->nrays; i++) {
		const mc_trk_keypoint_ray *r = &kp->rays[i];
		if (r->joint != j || r->weight <= 0)
			continue;
		mc_vec3 off = mc_ray_offset(mc_v3_sub(fk->rig_from_joint[j].t, r->origin), r->dir, MC_RAY_NEAR_M);
		worst = fmax(worst, mc_v3_norm(off));
		if (first < 0)
			first = kp->cam[i], *ncams = 1;
		else if (kp->cam[i] != first)
			*ncams = 2;
	}
	return worst;
}

/* start: fit with the wrist at `wrist`, the shoulder and elbow where they
 * are (the inverse kinematics toward three points, held to fit). */
static bool turn_forearm(mc_tracker *t, const double *fit, const mc_fk *fk, int elbow, int wrist, mc_vec3 to,
			 double *start)
{
	int shoulder = t->model.joints[elbow].parent;
	mc_ik_target tg[3] = {{shoulder, fk->rig_from_joint[shoulder].t, 1, {0, 0, 0}},
			      {elbow, fk->rig_from_joint[elbow].t, 1, {0, 0, 0}},
			      {wrist, to, 1, {0, 0, 0}}};
	mc_ik_options o = local_fit(FLIP_IK_ITERATIONS, FLIP_IK_PRIOR, fit);
	memcpy(start, fit, sizeof(double) * (size_t)t->model.ndof);
	mc_err err;
	return mc_ik_solve(&t->model, start, tg, 3, &o, &err) >= 0;
}

/* Where the wrist's rays cross the sphere of the forearm's length about
 * the elbow (each ray's near and far crossing, or the sphere's point
 * nearest a ray that misses it), those at least CANDIDATE_APART_M from the
 * fit's wrist; at most max of them.  Returns their number. */
static int wrist_crossings(const mc_tracker *t, const mc_fk *fk, int elbow, int wrist, mc_vec3 *cand, int max)
{
	const mc_trk_frame_keypoints *kp = t->fkp;
	mc_vec3 e = fk->rig_from_joint[elbow].t, w = fk->rig_from_joint[wrist].t;
	double len = mc_v3_norm(mc_v3_sub(w, e));
	int n = 0;
	for (int i = 0; i < kp->nrays && n < max; i++) {
		const mc_trk_keypoint_ray *r = &kp->rays[i];
		if (r->joint != wrist || r->weight <= 0)
			continue;
		mc_vec3 oe = mc_v3_sub(r->origin, e);
		double b = mc_v3_dot(r->dir, oe), disc = b * b - (mc_v3_dot(oe, oe) - len * len);
		double at[2] = {-b - sqrt(fmax(disc, 0)), -b + sqrt(fmax(disc, 0))};
		for (int k = 0; k < (disc > 0 ? 2 : 1) && n < max; k++) {
			if (at[k] <= 0)
				continue;
			mc_vec3 p = mc_v3_sub(mc_v3_axpy(at[k], r->dir, r->origin), e);
			p = mc_v3_axpy(len, mc_v3_normalize(p), e);
			if (mc_v3_norm(mc_v3_sub(p, w)) >= CANDIDATE_APART_M)
				cand[n++] = p;
		}
	}
	return n;
}

/* Arm a of fit replaced by its fit from the forearm turned another way
 * where its wrist's rays say so: from the wrist mirrored along the line of
 * sight from eye, and from each place where a wrist ray crosses the
 * forearm's sphere; the fit whose wrist misses its rays least is kept. */
static void try_flip(mc_tracker *t, int a, mc_vec3 eye, double *fit)
{
	int elbow = mc_model_find_joint(&t->model, limb_ends[a][0]), wrist = mc_model_find_joint(&t->model, limb_ends[a][1]);
	if (elbow < 0 || wrist < 0)
		return;
	mc_fk fk;
	mc_model_fk(&t->model, fit, &fk);
	int ncams;
	double miss = worst_offset(t, &fk, wrist, &ncams);
	if (ncams < 2 || miss < FLIP_MISS_M)
		return;
	mc_vec3 bone = mc_v3_sub(fk.rig_from_joint[wrist].t, fk.rig_from_joint[elbow].t);
	mc_vec3 sight = mc_v3_normalize(mc_v3_sub(fk.rig_from_joint[elbow].t, eye));
	double along = mc_v3_dot(bone, sight);
	mc_vec3 starts[1 + 2 * MC_MAX_CAMERAS];
	int nstarts = 0;
	if (fabs(along) >= FLIP_MIN_ALONG * mc_v3_norm(bone))
		starts[nstarts++] = mc_v3_axpy(-2 * along, sight, fk.rig_from_joint[wrist].t);
	nstarts += wrist_crossings(t, &fk, elbow, wrist, starts + nstarts, 2 * MC_MAX_CAMERAS);
	double best_miss = FLIP_GAIN * miss, best[MC_MAX_DOF];
	bool found = false;
	for (int i = 0; i < nstarts; i++) {
		double start[MC_MAX_DOF], other[MC_MAX_DOF];
		if (!turn_forearm(t, fit, &fk, elbow, wrist, starts[i], start) || !fit_to_rays(t, start, other))
			continue;
		mc_fk ofk;
		mc_model_fk(&t->model, other, &ofk);
		double m = worst_offset(t, &ofk, wrist, &ncams);
		if (m <= best_miss)
			best_miss = m, found = true, memcpy(best, other, sizeof(best));
	}
	if (!found)
		return;
	bool joint[MC_MAX_JOINTS];
	part_joints(&t->model, a, joint);
	mc_model_copy_dofs(&t->model, joint, best, fit);
}

/* ---- a leg folded toward the cameras ------------------------------------- */

/* Seen from the head, a leg folded up toward the cameras (knee raised,
 * shin back) projects much as a straight one: the held-out icl02_04's legs
 * stayed folded 50-70 cm off for a second after a jump with 2 px keypoints
 * in both views, the knee's 4-10 px away.  The fit, held to the
 * prediction, does not unfold it, so the leg is also fitted from rest
 * (straight down from the hip) where its knee, seen by two cameras, or its
 * ankle misses its rays by REST_MISS_M or more, and taken from that fit
 * where both then miss by at most FLIP_GAIN as much.  That leg is taken
 * without the colour check: the colours (learnt on dark trousers, beside
 * a dark shadow there) preferred the folded leg and refused every such fit
 * (docs/TRACKER_EXPERIMENTS.md, stop 55); the keypoints are trusted here
 * (try_flips), which is what the check guards against otherwise. */
#define REST_MISS_M 0.05

/* The larger miss of the knee and ankle at pose; *seen: the knee's rays
 * come from two cameras. */
static double leg_miss(const mc_tracker *t, const double *pose, int knee, int ankle, bool *seen)
{
	mc_fk fk;
	mc_model_fk(&t->model, pose, &fk);
	int nk, na;
	double miss = fmax(worst_offset(t, &fk, knee, &nk), worst_offset(t, &fk, ankle, &na));
	*seen = nk >= 2;
	return miss;
}

/* Returns whether leg l (a limb_roots index) of fit was replaced by its
 * fit from rest. */
static bool try_rest_leg(mc_tracker *t, int l, double *fit)
{
	int knee = mc_model_find_joint(&t->model, limb_ends[l][0]), ankle = mc_model_find_joint(&t->model, limb_ends[l][1]);
	bool joint[MC_MAX_JOINTS], seen;
	if (knee < 0 || ankle < 0)
		return false;
	part_joints(&t->model, l, joint);
	double miss = leg_miss(t, fit, knee, ankle, &seen);
	if (!seen || miss < REST_MISS_M)
		return false;
	double start[MC_MAX_DOF], other[MC_MAX_DOF], rest[MC_MAX_DOF];
	mc_model_rest_pose(&t->model, rest);
	memcpy(start, fit, sizeof(start));
	mc_model_copy_dofs(&t->model, joint, rest, start);
	if (!fit_to_rays(t, start, other) || !(leg_miss(t, other, knee, ankle, &seen) <= FLIP_GAIN * miss))
		return false;
	mc_model_copy_dofs(&t->model, joint, other, fit);
	return true;
}

/* The turned forearms and the legs from rest, while the keypoints are
 * trusted; forced[l]: limb l (a leg) was taken from rest. */
static void try_flips(mc_tracker *t, double *fit, bool *forced)
{
	for (int l = 0; l < NLIMBS; l++)
		forced[l] = false;
	if (t->model.root_free || t->rig.ncams < 2 || mc_tracker_keypoint_trust(t, NULL) < FLIP_MIN_TRUST)
		return;
	mc_vec3 eye = {0, 0, 0};
	for (int c = 0; c < t->rig.ncams; c++)
		eye = mc_v3_axpy(1.0 / t->rig.ncams, t->rig.cams[c].rig_from_cam.t, eye);
	for (int a = 0; a < NARMS; a++)
		try_flip(t, a, eye, fit);
	for (int l = NARMS; l < NLIMBS; l++)
		forced[l] = try_rest_leg(t, l, fit);
}

int mc_trk_ray_fit(mc_tracker *t, const double *pred, double *pose, mc_err *err)
{
	double fit[MC_MAX_DOF];
	/* no colours to check the fit with, or the keypoints ignored */
	if (!t->s.ray_fit || t->s.lambda_color <= 0 || t->s.lambda_detection <= 0 || !fit_to_rays(t, pred, fit))
		return 0;
	bool forced[NLIMBS];
	try_flips(t, fit, forced);
	/* The torso first, and only with a free root (outside-in): on the head
	 * rig, the spine from the fit made both clips worse (walk 11.28 ->
	 * 11.39, jumps 8.15 -> 8.25 cm). */
	int parts[NLIMBS + 1], nparts = 0;
	if (t->model.root_free)
		parts[nparts++] = NLIMBS;
	for (int l = 0; l < NLIMBS; l++)
		parts[nparts++] = l;
	for (int i = 0; i < nparts; i++) {
		bool joint[MC_MAX_JOINTS];
		double trial[MC_MAX_DOF], E_now, E_fit;
		part_joints(&t->model, parts[i], joint);
		memcpy(trial, pose, sizeof(trial));
		double moved = 0;
		for (int j = 0; j < t->model.njoints; j++)
			for (int d = 0; joint[j] && d < t->model.joints[j].ndof; d++) {
				int k = t->model.joints[j].dof0 + d;
				moved = fmax(moved, fabs(fit[k] - trial[k]));
				trial[k] = fit[k];
			}
		/* a part without rays keeps the pose it was held to: nothing to
		 * compare (the feet's rays are often all gated out) */
		if (moved < UNMOVED_RAD)
			continue;
		if (parts[i] < NLIMBS && forced[parts[i]]) {
			memcpy(pose, trial, sizeof(trial));
			continue;
		}
		if (compare_part(t, pose, trial, joint, &E_now, &E_fit, err) < 0)
			return -1;
		if (E_fit < E_now)
			memcpy(pose, trial, sizeof(trial));
	}
	return 0;
}
