/* Initialisation, actor size calibration and recovery from detections
 * (docs/TRACKER.md, "Starting without ground truth").
 *
 * Every frame set's keypoints are triangulated per joint: the rays of two
 * or more cameras that meet.  While the tracker waits for a first pose, a
 * frame set whose detections a body fits becomes the start: the pose from
 * inverse kinematics to the rays, the colours from its images.  Over the
 * next seconds some frame sets are kept; the actor's size is then the bone
 * scale whose fits explain their rays best, and the colours are measured
 * again.  While tracking, a lost state re-fits the whole pose to the
 * detections, a limb that the cameras' agreeing detections keep missing
 * re-fits that limb (the bone lengths kept), a limb caught at the cameras
 * is fitted again from rest,
 * and a body that faces the wrong way is turned around (mc_facing.c).
 *
 * Everything is fitted to rays, not to triangulated points: a far joint's
 * triangulated depth is uncertain by tens of centimetres on a head-mounted
 * rig (a 0.3 m baseline), and bone lengths measured between such points
 * came out 20-25% short on the evaluation clips. */
#include "body/mc_ik.h"
#include "track/mc_tracker_internal.h"

#include <stdlib.h>
#include <string.h>

/* Two cameras' rays of one joint must pass this close to one point, or
 * TRI_GATE_PER_M of its depth along the ray where that is more: a
 * detector errs by angles, so far joints miss by more (1.5 cm a metre,
 * about 4 px of MoveNet at 320 px; outside-in cameras 4-6 m away, from
 * the detections, seeds 1-3: held-out swordplay 9.69 -> 8.89 cm, salsa
 * 10.70 -> 9.11, the dev clips within 0.05; a fixed 9 cm instead: dev
 * walk 4.02 -> 4.16).  On a head rig every joint is nearer than 4 m. */
#define TRI_GATE_M 0.06
#define TRI_GATE_PER_M 0.015
/* Detections below this confidence are not used. */
#define TRI_MIN_CONF 0.3
/* A fit needs this many triangulated joints, FIT_TORSO_MIN of them on the torso. */
#define FIT_MIN_JOINTS 8
#define FIT_TORSO_MIN 3
/* Largest RMS distance of a fitted body's joints from their rays: about
 * twice the detector's median error at a metre (docs/DETECTOR.md). */
#define FIT_MAX_RMS_M 0.08
/* A joint this far from its rays for DISAGREE_FRAMES frame sets in a row,
 * with a confidence below STUCK_CONF, is caught in a wrong minimum.  (The
 * distance to the triangulated point instead, 0.30 m, also caught limbs
 * at a wrong depth, which the keypoint term leaves near their rays, but
 * the triangulations' depth noise made the evaluation clips 3-4 cm
 * worse.) */
#define DISAGREE_M 0.20
#define DISAGREE_FRAMES 10
/* A joint nearer a camera than this share of its triangulated point's
 * distance, and off that point's ray by more than DISAGREE_M at the
 * point's depth, is caught at the cameras (see caught_joints). */
#define CAUGHT_SHARE 0.5
/* A caught limb's fit from rest is kept where it misses the rays, as seen
 * from the cameras, by at most this share of the caught limb's miss: the
 * detector's keypoints fit the model's legs only to 15-25 cm (RMS) on the
 * held-out icl02_04, beyond FIT_MAX_RMS_M, while the caught legs missed
 * by a metre. */
#define CAUGHT_GAIN 0.5
#define STUCK_CONF 0.15
/* After this many frame sets of disagreement the detections win: the
 * stuck limbs are re-fitted whatever the confidence and the colour energy
 * say (the colours may have been learnt at the wrong place).  15: 10 let
 * the shipped detector's wrong keypoints, which persist and agree between
 * the views, take good limbs (the walk from detections 12.35 -> 12.98 cm);
 * 20 and 30 (until stop 52) left limbs lost longer
 * (docs/TRACKER_EXPERIMENTS.md, "Recovery of a stuck limb"). */
#define FORCE_FRAMES 15
/* Frame sets in a row in the lost state after which the pose is re-fitted
 * to the detections: a frame set or two are lost in ordinary tracking
 * (fast motion, motion blur), and re-fitting then to detections, which
 * are noisier than the tracked pose, made the evaluation clips worse. */
#define LOST_FRAMES 5
/* Frame sets between two kept for the size: poses that differ. */
#define SHAPE_EVERY 3
/* The sizes tried: bone scales SCALE_MIN .. SCALE_MAX (a 1.75 m model:
 * about 1.40 m to 2.10 m), then refined around the best. */
#define SCALE_MIN 0.80
#define SCALE_MAX 1.20
#define SCALE_STEPS 9

static bool is_torso(const char *name)
{
	static const char *const torso[] = {"left_shoulder", "right_shoulder", "left_hip", "right_hip", "spine",
					    "pelvis"};
	for (size_t i = 0; i < sizeof(torso) / sizeof(torso[0]); i++)
		if (!strcmp(name, torso[i]))
			return true;
	return false;
}

static mc_vec3 off_ray(mc_vec3 p, mc_vec3 origin, mc_vec3 dir)
{
	return mc_v3_reject(mc_v3_sub(p, origin), dir);
}

/* The point nearest to the rays idx[0..n-1] (least squares over
 * sum_i w_i |(I - d_i d_i^T)(x - o_i)|^2); false when they are near
 * parallel, the point lies behind a camera or a ray misses it by more
 * than the gate (TRI_GATE_M, TRI_GATE_PER_M).  *worst: the ray that
 * misses the point most (one behind its camera first), -1 when there is
 * no point. */
static bool triangulate_joint(const mc_trk_keypoint_ray *r, const int *idx, int n, mc_vec3 *out, double *conf,
			      int *worst)
{
	mc_vec3 o[MC_MAX_CAMERAS] = {{0}}, d[MC_MAX_CAMERAS] = {{0}}, x;
	double w[MC_MAX_CAMERAS] = {0}, wmin = 1, most = -1;
	bool met = true;
	for (int i = 0; i < n; i++) {
		const mc_trk_keypoint_ray *k = &r[idx[i]];
		o[i] = k->origin;
		d[i] = k->dir;
		w[i] = k->weight;
		wmin = fmin(wmin, k->weight);
	}
	*worst = -1;
	if (!mc_rays_nearest_point(o, d, w, n, &x))
		return false;
	for (int i = 0; i < n; i++) {
		const mc_trk_keypoint_ray *k = &r[idx[i]];
		double depth = mc_v3_dot(mc_v3_sub(x, k->origin), k->dir);
		double miss = depth <= 0.05 ? INFINITY : mc_v3_norm(off_ray(x, k->origin, k->dir));
		met = met && miss <= fmax(TRI_GATE_M, TRI_GATE_PER_M * depth);
		if (miss > most) {
			most = miss;
			*worst = i;
		}
	}
	if (!met)
		return false;
	*out = x;
	*conf = wmin;
	return mc_v3_isfinite(x);
}

/* Per joint, the best-confidence ray of every camera, triangulated.
 * Where they do not meet, the ray that misses most goes while three or
 * more are left: one camera's keypoint on the other limb, the background
 * or a bystander no longer costs the joint the others' agreement (MoveNet
 * outside-in from the detections, seeds 1-3: dev walk 4.17 -> 4.02 cm,
 * jumps 4.58 -> 4.35, held-out swordplay 10.90 -> 9.69, salsa 12.45 ->
 * 10.70; two cameras, the head rig's, as before). */
static void triangulate(const mc_tracker *t, const mc_trk_keypoint_ray *r, const int *cam, int nr,
			mc_trk_triangulation *tri)
{
	memset(tri, 0, sizeof(*tri));
	for (int j = 0; j < t->model.njoints; j++) {
		int best[MC_MAX_CAMERAS], n = 0;
		for (int c = 0; c < t->rig.ncams; c++) {
			best[n] = -1;
			for (int i = 0; i < nr; i++)
				if (r[i].joint == j && cam[i] == c && r[i].weight >= TRI_MIN_CONF &&
				    (best[n] < 0 || r[i].weight > r[best[n]].weight))
					best[n] = i;
			if (best[n] >= 0)
				n++;
		}
		int worst = -1;
		bool met = n >= 2 && triangulate_joint(r, best, n, &tri->pos[j], &tri->conf[j], &worst);
		while (!met && n > 2 && worst >= 0) {
			best[worst] = best[--n];
			met = triangulate_joint(r, best, n, &tri->pos[j], &tri->conf[j], &worst);
		}
		if (!met)
			continue;
		tri->have[j] = true;
		for (int i = 0; i < n; i++) {
			tri->ray[j][i].origin = r[best[i]].origin;
			tri->ray[j][i].dir = r[best[i]].dir;
			tri->ray[j][i].weight = r[best[i]].weight;
		}
		tri->nray[j] = n;
		tri->n++;
		tri->torso += is_torso(t->model.joints[j].name);
	}
}

static bool enough_for_fit(const mc_trk_triangulation *tri)
{
	return tri->n >= FIT_MIN_JOINTS && tri->torso >= FIT_TORSO_MIN;
}

/* Weighted mean squared distance of the pose's joints from their rays,
 * over the joints in `use` (NULL: every triangulated joint); *wsum gets
 * the weight. */
static double ray_cost(const mc_model *m, const mc_trk_triangulation *tri, const bool *use, const double *pose,
		       double *wsum)
{
	mc_fk fk;
	mc_model_fk(m, pose, &fk);
	double sum = 0, w = 0;
	for (int j = 0; j < m->njoints; j++)
		for (int i = 0; tri->have[j] && (!use || use[j]) && i < tri->nray[j]; i++) {
			double wi = tri->ray[j][i].weight;
			sum += wi * mc_v3_norm2(off_ray(fk.rig_from_joint[j].t, tri->ray[j][i].origin, tri->ray[j][i].dir));
			w += wi;
		}
	*wsum = w;
	return w > 0 ? sum / w : 0;
}

/* Fits the pose (in/out: the start) to the rays of the joints in `use`
 * (NULL: every triangulated one), or (points) to the triangulated points
 * of those with two rays or more; `keep` (NULL: none) holds every other
 * joint where it is.  Returns the RMS distance from the rays used, or -1. */
static double fit_targets(const mc_tracker *t, mc_model *m, const mc_trk_triangulation *tri, const bool *use,
			  const mc_fk *keep, int iterations, bool restarts, bool points, double *pose)
{
	mc_ik_target tg[MC_MAX_JOINTS * MC_MAX_CAMERAS];
	int n = 0;
	for (int j = 0; j < m->njoints; j++) {
		bool fit = tri->have[j] && (!use || use[j]);
		if (fit && points && tri->nray[j] >= 2) {
			tg[n++] = (mc_ik_target){j, tri->pos[j], 1.0, {0, 0, 0}};
			continue;
		}
		for (int i = 0; fit && i < tri->nray[j]; i++)
			tg[n++] = (mc_ik_target){j, tri->ray[j][i].origin, tri->ray[j][i].weight, tri->ray[j][i].dir};
		if (!fit && keep && !t->fixed_joint[j])
			tg[n++] = (mc_ik_target){j, keep->rig_from_joint[j].t, 1.0, {0, 0, 0}};
	}
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.iterations = iterations;
	o.restarts = restarts;
	o.fit_bone_scale = false;
	/* A fixed root's place (the head's on the rig) comes from the model
	 * (or an actor file): fitted to the detections as well, it made the
	 * jumps clip 4 cm worse and the walk 0.2 cm better.  A free root is
	 * the body's place in the world: always fitted. */
	o.fit_root = m->root_free;
	mc_err err;
	if (mc_ik_solve(m, pose, tg, n, &o, &err) < 0)
		return -1;
	double w;
	return sqrt(ray_cost(m, tri, use, pose, &w));
}

static double fit_pose(const mc_tracker *t, mc_model *m, const mc_trk_triangulation *tri, const bool *use,
		       const mc_fk *keep, int iterations, bool restarts, double *pose)
{
	return fit_targets(t, m, tri, use, keep, iterations, restarts, false, pose);
}

void mc_trk_init_free(mc_tracker *t)
{
	free(t->init.shape_tri);
	t->init.shape_tri = NULL;
}

int mc_trk_init_start(mc_tracker *t, unsigned flags, mc_err *err)
{
	bool fit_shape = (flags & MC_INIT_MEASURE_SIZE) && !(flags & MC_INIT_KEEP_ACTOR);
	mc_trk_init_free(t);
	memset(&t->init, 0, sizeof(t->init));
	t->init.keep_colours = flags & MC_INIT_KEEP_ACTOR;
	if (fit_shape) {
		t->init.shape_tri = calloc(MC_TRK_SHAPE_FRAMES, sizeof(mc_trk_triangulation));
		if (!t->init.shape_tri)
			return mc_err_set(err, "tracker: out of memory");
	}
	t->init.waiting = true;
	/* On a rig fixed to the head, a change of size moves each joint
	 * along a line through the head, which is nearly the camera's own
	 * ray: the detections hardly see it (the search found 0.80-0.90 where
	 * the truth is 1.0 +- 0.07), so the model's size is kept there. */
	t->init.fit_shape = fit_shape && t->model.root_free;
	/* what two cameras on the head do see: the shoulders' width */
	mc_trk_widths_start(t, fit_shape && !t->model.root_free);
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(&t->model, pose);
	mc_tracker_set_pose(t, pose);
	return 0;
}

/* A free root (outside-in) starts where the body is: the rest skeleton
 * fitted rigidly onto the triangulated joints, so that the solve from
 * rays starts in place and facing the right way. */
static void place_free_root(const mc_model *m, const mc_trk_triangulation *tri, double *pose)
{
	int joint[MC_MAX_JOINTS], n = 0;
	mc_vec3 to[MC_MAX_JOINTS];
	double w[MC_MAX_JOINTS];
	for (int j = 0; j < m->njoints; j++)
		if (tri->have[j]) {
			joint[n] = j;
			to[n] = tri->pos[j];
			w[n++] = tri->conf[j];
		}
	mc_ik_place_free_root(m, pose, joint, to, w, n);
}

double mc_trk_fit_from_rest(const mc_tracker *t, const mc_trk_triangulation *tri, int iterations, bool restarts,
			    double *pose)
{
	mc_model m = t->model;
	mc_model_rest_pose(&m, pose);
	place_free_root(&m, tri, pose);
	return fit_pose(t, &m, tri, NULL, NULL, iterations, restarts, pose);
}

/* The first pose (facing the way that fits the rays better), or the body
 * turned around (turn: the labels exchanged in every view); then the
 * colours from these images.  The frame set's rays get the labels of the
 * way chosen.  Returns 1 when tracking can start, 0 to wait, -1. */
static int fit_body(mc_tracker *t, const mc_frame_view *views, int nviews, const mc_trk_triangulation *tri, bool turn,
		    mc_trk_keypoint_ray *rays, int nrays, mc_err *err)
{
	double pose[MC_MAX_DOF];
	bool turned = turn;
	double rms = turn ? mc_trk_facing_fit_turned(t, tri, pose) : mc_trk_facing_fit(t, tri, pose, &turned);
	if (!(rms >= 0 && rms <= FIT_MAX_RMS_M))
		return 0; /* not a body: wait for a better frame set */
	if (turned)
		mc_trk_exchange_sides(t, rays, nrays);
	mc_tracker_set_pose(t, pose);
	if (mc_trk_calibrate(t, views, nviews, !t->init.keep_colours, err) < 0)
		return -1;
	mc_trk_facing_reset(&t->init.facing);
	memset(t->init.disagree, 0, sizeof(t->init.disagree));
	memset(t->init.caught, 0, sizeof(t->init.caught));
	t->init.turns += turned;
	return 1;
}

/* ---- the actor's size ---------------------------------------------------- */

/* Mean squared ray distance over the kept frame sets with model m's bones,
 * each frame set re-fitted from its tracked pose. */
static double bones_cost(const mc_tracker *t, mc_model *m)
{
	double sum = 0, wsum = 0;
	for (int f = 0; f < t->init.nshape; f++) {
		double pose[MC_MAX_DOF], w;
		memcpy(pose, t->init.shape_pose[f], sizeof(pose));
		fit_pose(t, m, &t->init.shape_tri[f], NULL, NULL, 30, false, pose);
		double c = ray_cost(m, &t->init.shape_tri[f], NULL, pose, &w);
		sum += c * w;
		wsum += w;
	}
	return wsum > 0 ? sum / wsum : 1e9;
}

/* The same at one bone scale for every bone. */
static double size_cost(const mc_tracker *t, double scale)
{
	mc_model m = t->model;
	for (int j = 0; j < m.njoints; j++)
		m.bone_scale[j] = scale;
	return bones_cost(t, &m);
}

/* Limb bones, each pair (left and right alike) on its own after the size
 * (issue 35 item 5): the scale within LIMB_RANGE of the size whose fits
 * explain the rays best, in LIMB_STEPS steps each way.  A limb that no
 * detection sees keeps the size (its cost does not change). */
#define LIMB_RANGE 0.10
#define LIMB_STEPS 2
static void fit_limbs(mc_tracker *t)
{
	static const char *const limbs[][2] = {
		{"left_elbow", "right_elbow"}, /* upper arms */
		{"left_wrist", "right_wrist"}, /* forearms */
		{"left_knee", "right_knee"},   /* thighs */
		{"left_ankle", "right_ankle"}, /* shins */
	};
	mc_model m = t->model;
	double best_cost = bones_cost(t, &m);
	for (size_t b = 0; b < sizeof(limbs) / sizeof(limbs[0]); b++) {
		int jl = mc_model_find_joint(&m, limbs[b][0]), jr = mc_model_find_joint(&m, limbs[b][1]);
		if (jl < 0 || jr < 0)
			continue;
		double size = m.bone_scale[jl], best = size;
		for (int k = -LIMB_STEPS; k <= LIMB_STEPS; k++) {
			if (k == 0)
				continue;
			m.bone_scale[jl] = m.bone_scale[jr] = size * (1 + LIMB_RANGE * k / LIMB_STEPS);
			double c = bones_cost(t, &m);
			if (c < best_cost) {
				best_cost = c;
				best = m.bone_scale[jl];
			}
		}
		m.bone_scale[jl] = m.bone_scale[jr] = best;
	}
	memcpy(t->model.bone_scale, m.bone_scale, sizeof(m.bone_scale));
}

/* The bone scale in [SCALE_MIN, SCALE_MAX] that explains the kept frame
 * sets' rays best: a grid, then a parabola through the best point and its
 * neighbours. */
static double find_size(const mc_tracker *t)
{
	double cost[SCALE_STEPS], step = (SCALE_MAX - SCALE_MIN) / (SCALE_STEPS - 1);
	int best = 0;
	for (int i = 0; i < SCALE_STEPS; i++) {
		cost[i] = size_cost(t, SCALE_MIN + i * step);
		if (cost[i] < cost[best])
			best = i;
	}
	double s = SCALE_MIN + best * step;
	if (best > 0 && best < SCALE_STEPS - 1) {
		double a = cost[best - 1], b = cost[best], c = cost[best + 1], den = a - 2 * b + c;
		if (den > 0)
			s += step * fmin(fmax(0.5 * (a - c) / den, -0.5), 0.5);
	}
	return s;
}

/* Keeps every SHAPE_EVERY-th frame set with enough joints, until
 * MC_TRK_SHAPE_FRAMES are kept (its pose is stored after tracking). */
static void collect_shape(mc_tracker *t, const mc_trk_triangulation *tri)
{
	mc_trk_init *in = &t->init;
	in->collected = false;
	if (!in->fit_shape || in->shape_done || in->nshape >= MC_TRK_SHAPE_FRAMES || !enough_for_fit(tri))
		return;
	if (in->nshape > 0 && ++in->since_shape < SHAPE_EVERY)
		return;
	in->since_shape = 0;
	in->shape_tri[in->nshape] = *tri;
	in->collected = true;
}

/* Once MC_TRK_SHAPE_FRAMES are kept: the size, the pose at that size, and
 * the colours again. */
static int finish_shape(mc_tracker *t, const mc_frame_view *views, int nviews, const mc_trk_triangulation *tri,
			mc_err *err)
{
	mc_trk_init *in = &t->init;
	if (!in->fit_shape || in->shape_done || in->nshape < MC_TRK_SHAPE_FRAMES)
		return 0;
	in->scale = find_size(t);
	for (int j = 0; j < t->model.njoints; j++)
		t->model.bone_scale[j] = in->scale;
	if (t->s.fit_limbs)
		fit_limbs(t);
	in->shape_done = true;
	double pose[MC_MAX_DOF];
	memcpy(pose, t->pose, sizeof(pose));
	if (fit_pose(t, &t->model, tri, NULL, NULL, 30, false, pose) >= 0)
		mc_tracker_set_pose(t, pose);
	return mc_tracker_calibrate_colors(t, views, nviews, err);
}

/* ---- recovery ------------------------------------------------------------ */

/* Counts, per joint, the frame sets in a row it missed its rays by
 * DISAGREE_M (among the frame sets that detect it); marks as stuck those
 * past DISAGREE_FRAMES with a confidence below STUCK_CONF, or past
 * FORCE_FRAMES whatever their confidence (the colours may have been
 * learnt at a wrong pose, and then the confidence, measured against them,
 * says nothing).  Returns the largest run among the stuck joints, 0 when
 * none is. */
static int stuck_joints(mc_tracker *t, const mc_trk_triangulation *tri, const mc_fk *fk, bool *stuck)
{
	mc_trk_init *in = &t->init;
	int worst = 0;
	for (int j = 0; j < t->model.njoints; j++) {
		double miss = 0;
		for (int i = 0; tri->have[j] && i < tri->nray[j]; i++)
			miss = fmax(miss, mc_v3_norm(off_ray(fk->rig_from_joint[j].t, tri->ray[j][i].origin,
							       tri->ray[j][i].dir)));
		if (tri->have[j]) /* an undetected frame set neither adds nor clears */
			in->disagree[j] = miss > DISAGREE_M ? in->disagree[j] + 1 : 0;
		stuck[j] = (in->disagree[j] >= DISAGREE_FRAMES && in->conf[j] < STUCK_CONF) ||
			   in->disagree[j] >= FORCE_FRAMES;
		if (stuck[j] && in->disagree[j] > worst)
			worst = in->disagree[j];
	}
	return worst;
}

/* Joint position p's offset from ray i of joint j as seen from the ray's
 * camera: its angle off the ray times the triangulated point's distance. */
static double sight_offset(const mc_trk_triangulation *tri, int j, int i, mc_vec3 p)
{
	mc_vec3 o = tri->ray[j][i].origin, v = mc_v3_sub(p, o);
	double angle = atan2(mc_v3_norm(off_ray(p, o, tri->ray[j][i].dir)), mc_v3_dot(v, tri->ray[j][i].dir));
	return angle * mc_v3_norm(mc_v3_sub(tri->pos[j], o));
}

/* The RMS of sight_offset over the rays of the joints in `use` (njoints
 * of them) at the pose whose forward kinematics is fk. */
static double sight_rms(int njoints, const mc_trk_triangulation *tri, const bool *use, const mc_fk *fk)
{
	double sum = 0;
	int n = 0;
	for (int j = 0; j < njoints; j++)
		for (int i = 0; use[j] && tri->have[j] && i < tri->nray[j]; i++, n++)
			sum += pow(sight_offset(tri, j, i, fk->rig_from_joint[j].t), 2);
	return n ? sqrt(sum / n) : 0;
}

/* Whether any joint in `use` (njoints of them) has rays this frame set. */
static bool any_rays(int njoints, const mc_trk_triangulation *tri, const bool *use)
{
	for (int j = 0; j < njoints; j++)
		if (use[j] && tri->have[j] && tri->nray[j] > 0)
			return true;
	return false;
}

/* Whether joint j at p sits caught at a camera this frame set: nearer it
 * than CAUGHT_SHARE of its triangulated point's distance, and off that
 * camera's ray by DISAGREE_M or more at the point's depth. */
static bool caught_now(const mc_trk_triangulation *tri, int j, mc_vec3 p)
{
	for (int i = 0; tri->have[j] && i < tri->nray[j]; i++) {
		mc_vec3 o = tri->ray[j][i].origin;
		double far = mc_v3_norm(mc_v3_sub(tri->pos[j], o));
		if (mc_v3_norm(mc_v3_sub(p, o)) < CAUGHT_SHARE * far && sight_offset(tri, j, i, p) > DISAGREE_M)
			return true;
	}
	return false;
}

/* Whether any joint in `use` is caught_now at the pose whose forward
 * kinematics is fk. */
static bool any_caught(int njoints, const mc_trk_triangulation *tri, const bool *use, const mc_fk *fk)
{
	for (int j = 0; j < njoints; j++)
		if (use[j] && caught_now(tri, j, fk->rig_from_joint[j].t))
			return true;
	return false;
}

/* Counts, per joint, the frame sets in a row it sat caught at the
 * cameras: nearer one than CAUGHT_SHARE of its triangulated point's
 * distance from it, and off that camera's ray by an angle that, at the
 * point's depth, is DISAGREE_M or more.  Every ray of a camera passes
 * through the camera, so by the line a joint there is within centimetres
 * of all of them: the stuck test above never counts it, and a fit from
 * where it is stays there.  With the shipped detector the held-out
 * icl02_04's knees sat 13-30 cm from the cameras, a metre from the truth,
 * for 3 s, and wrists 40-60 cm off by the lens on four other clips.
 * Marks as caught those past DISAGREE_FRAMES; returns the largest run
 * among them, 0 when none is. */
static int caught_joints(mc_tracker *t, const mc_trk_triangulation *tri, const mc_fk *fk, bool *caught)
{
	mc_trk_init *in = &t->init;
	int worst = 0;
	for (int j = 0; j < t->model.njoints; j++) {
		bool now = caught_now(tri, j, fk->rig_from_joint[j].t);
		if (tri->have[j])
			in->caught[j] = now ? in->caught[j] + 1 : 0;
		caught[j] = in->caught[j] >= DISAGREE_FRAMES;
		if (caught[j] && in->caught[j] > worst)
			worst = in->caught[j];
	}
	return worst;
}

/* A stuck joint's limb: the joint, its parent (the bone that swings it)
 * and everything below it. */
static void limb_of(const mc_model *m, const bool *stuck, bool *limb)
{
	for (int j = 0; j < m->njoints; j++) {
		int p = m->joints[j].parent;
		limb[j] = stuck[j] || (p >= 0 && limb[p]);
	}
	for (int j = 0; j < m->njoints; j++) {
		int p = m->joints[j].parent;
		if (stuck[j] && p >= 0 && m->joints[p].ndof > 0)
			limb[p] = true;
	}
}

/* Clears the disagreement runs of the joints in `limb` (NULL: all): after
 * a limb's re-fit another stuck limb's run goes on. */
static void clear_runs(mc_tracker *t, const bool *limb)
{
	for (int j = 0; j < t->model.njoints; j++)
		if (!limb || limb[j])
			t->init.disagree[j] = t->init.caught[j] = 0;
}

/* The joints of `limb` that its dofs move: all but its root, whose place
 * the torso sets.  A limb caught at the cameras is judged by these only:
 * the shipped detector's hips sit 14-22 cm from the model's (its labels,
 * docs/DETECTOR.md), which failed every fit of the held-out icl02_04's
 * legs. */
static void below_root(const mc_model *m, const bool *limb, bool *moved)
{
	for (int j = 0; j < m->njoints; j++) {
		int p = m->joints[j].parent;
		moved[j] = limb[j] && p >= 0 && limb[p];
	}
}

/* pose: t's pose with `limb` fitted from rest to the rays of its joints
 * below the root (from where it is a fit finds the rays' lines at the
 * camera again); now: t's pose's forward kinematics.  Returns whether
 * their miss as seen from the cameras is at most CAUGHT_GAIN of now's. */
static bool fit_from_rest(mc_tracker *t, const mc_trk_triangulation *tri, const bool *limb, const mc_fk *now,
			  double *pose)
{
	bool moved[MC_MAX_JOINTS];
	double rest[MC_MAX_DOF], start[MC_MAX_DOF];
	mc_model_rest_pose(&t->model, rest);
	memcpy(start, t->pose, sizeof(start));
	mc_model_copy_dofs(&t->model, limb, rest, start);
	memcpy(pose, start, sizeof(start));
	below_root(&t->model, limb, moved);
	/* with none of them seen this frame set the fit cannot be judged (its
	 * miss and the tracked one are both 0): it would only cost the time */
	int nj = t->model.njoints;
	if (!any_rays(nj, tri, moved) || fit_pose(t, &t->model, tri, moved, now, 60, false, pose) < 0)
		return false;
	mc_fk fitted;
	mc_model_fk(&t->model, pose, &fitted);
	/* From rest to the rays' lines the fit can end where they cross the
	 * bone's reach near the camera, caught again (test_knee_at_camera's
	 * knee at 0.15 m, its triangulated point at 1.13): then from rest to
	 * the triangulated points first.  (Always so: held-out icl02_04 1.7
	 * cm worse over nine seeds.) */
	if (any_caught(nj, tri, moved, &fitted)) {
		memcpy(pose, start, sizeof(start));
		if (fit_targets(t, &t->model, tri, moved, now, 60, false, true, pose) < 0 ||
		    fit_pose(t, &t->model, tri, moved, now, 60, false, pose) < 0)
			return false;
		mc_model_fk(&t->model, pose, &fitted);
	}
	return sight_rms(nj, tri, moved, &fitted) < CAUGHT_GAIN * sight_rms(nj, tri, moved, now);
}

/* pose: t's pose fitted to the rays, the whole of it or `limb` from where
 * it is (a stuck limb: without restarts, which, always or when that fit
 * failed, made jumps_01_01 1.6 cm worse through fits that the noisy energy
 * check let through), or a limb caught at the cameras from rest
 * (fit_from_rest); now: t's pose's forward kinematics.  Returns whether
 * the fit meets the rays: an RMS of FIT_MAX_RMS_M or less, or for a caught
 * limb fit_from_rest's test. */
static bool fit_to_detections(mc_tracker *t, const mc_trk_triangulation *tri, const mc_fk *now, const bool *limb,
			      bool from_rest, double *pose)
{
	if (limb && from_rest)
		return fit_from_rest(t, tri, limb, now, pose);
	memcpy(pose, t->pose, sizeof(double) * MC_MAX_DOF);
	double rms = fit_pose(t, &t->model, tri, limb, limb ? now : NULL, 60, !limb, pose);
	return rms >= 0 && rms <= FIT_MAX_RMS_M;
}

/* Re-fits the whole pose (after a loss) or the stuck or caught limbs to
 * the rays (fit_to_detections).  Unless forced, the fit is kept only if
 * the images agree: its colour energy must be lower than the tracked
 * pose's (the detections are noisier than a pose the images support).
 * The colours, the size and the anchor stay, forced or not: learnt again
 * at a forced limb fit's pose, the colours made the dev walk 11.4 -> 13.1
 * cm and the jumps 8.1 -> 9.5 (the limb's alone no better than keeping
 * them). */
static int refit(mc_tracker *t, const mc_trk_triangulation *tri, const mc_fk *now, const bool *limb, bool forced,
		 bool from_rest, mc_err *err)
{
	double pose[MC_MAX_DOF], anchor[MC_MAX_DOF], E_now, E_fit;
	t->init.refit_tries++;
	if (!fit_to_detections(t, tri, now, limb, from_rest, pose))
		return 0;
	if (!forced && t->s.lambda_color > 0) {
		if (mc_trk_pose_energy(t, t->pose, &E_now, err) < 0 || mc_trk_pose_energy(t, pose, &E_fit, err) < 0)
			return -1;
		if (!(E_fit < E_now))
			return 0;
	}
	memcpy(anchor, t->anchor, sizeof(anchor));
	mc_tracker_set_pose(t, pose);
	memcpy(t->anchor, anchor, sizeof(anchor));
	clear_runs(t, limb);
	t->init.refits++;
	return 0;
}

/* Whether a frame set with triangulation tri may re-fit a stuck or caught
 * limb.  A whole-body fit needs enough_for_fit's joints; a limb's needs
 * only its own rays, but on a head rig the limb re-fits of frame sets
 * with fewer joints made the battery worse (ego preset walk 6.71 -> 7.16
 * cm, held-out salsa_val +0.8).  Outside-in with two cameras, MoveNet's 12
 * joints seldom give 8 triangulated ones, and there the gate kept a lost
 * arm from ever coming back (cameras 0,2 walk seed 1 8.18 -> 7.55 cm
 * without it; four cameras to the digit). */
static bool may_refit_limb(const mc_tracker *t, const mc_trk_triangulation *tri)
{
	return t->model.root_free || enough_for_fit(tri);
}

static int recover(mc_tracker *t, const mc_trk_triangulation *tri, mc_err *err)
{
	if (!t->s.recover || !may_refit_limb(t, tri))
		return 0;
	bool stuck[MC_MAX_JOINTS], caught[MC_MAX_JOINTS], limb[MC_MAX_JOINTS];
	mc_fk fk;
	mc_model_fk(&t->model, t->pose, &fk);
	int run = stuck_joints(t, tri, &fk, stuck), caught_run = caught_joints(t, tri, &fk, caught);
	if (t->init.lost_run >= LOST_FRAMES)
		return enough_for_fit(tri) ? refit(t, tri, &fk, NULL, false, false, err) : 0;
	/* one re-fit a frame set: a caught limb first, a stuck one's run goes on */
	if (caught_run > 0) {
		limb_of(&t->model, caught, limb);
		return refit(t, tri, &fk, limb, caught_run >= FORCE_FRAMES, true, err);
	}
	if (run == 0)
		return 0;
	limb_of(&t->model, stuck, limb);
	return refit(t, tri, &fk, limb, run >= FORCE_FRAMES, false, err);
}

/* ---- per frame set --------------------------------------------------------- */

int mc_trk_init_step(mc_tracker *t, const mc_frame_view *views, int nviews, mc_trk_keypoint_ray *rays,
		     const int *cam, int nrays, mc_err *err)
{
	mc_trk_init *in = &t->init;
	mc_trk_triangulation tri;
	triangulate(t, rays, cam, nrays, &tri);
	in->last_joints = tri.n;
	if (in->waiting) {
		if (!enough_for_fit(&tri))
			return 1;
		int rc = fit_body(t, views, nviews, &tri, false, rays, nrays, err);
		if (rc <= 0)
			return rc < 0 ? -1 : 1;
		in->waiting = false;
		in->inits++;
		collect_shape(t, &tri);
		mc_trk_widths_collect(t, &tri);
		return 0;
	}
	if (recover(t, &tri, err) < 0)
		return -1;
	if (enough_for_fit(&tri) && mc_trk_facing_wrong(t, &tri) &&
	    fit_body(t, views, nviews, &tri, true, rays, nrays, err) < 0)
		return -1;
	if (finish_shape(t, views, nviews, &tri, err) < 0 || mc_trk_widths_finish(t, views, nviews, err) < 0)
		return -1;
	collect_shape(t, &tri);
	mc_trk_widths_collect(t, &tri);
	return 0;
}

void mc_trk_init_after(mc_tracker *t, const mc_skeleton *out)
{
	mc_trk_init *in = &t->init;
	in->lost_run = out->state == MC_TRACK_LOST ? in->lost_run + 1 : 0;
	for (int j = 0; j < out->njoints && j < MC_MAX_JOINTS; j++)
		in->conf[j] = out->joints[j].confidence;
	if (in->collected && out->state != MC_TRACK_LOST) {
		memcpy(in->shape_pose[in->nshape], t->pose, sizeof(in->shape_pose[0]));
		in->nshape++;
	}
	in->collected = false;
}
