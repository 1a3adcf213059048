/* mc_tracker: per-frame stochastic gradient tracking (thesis ch. 6.2.3).
 *
 * Per frame: convert the views to HSV at the working resolution, predict the
 * pose from the last two, choose candidate pixels near the predicted body,
 * then run a fixed budget of gradient iterations.  Each iteration samples a
 * random subset of the candidate pixels per camera; the data term and its
 * gradient with respect to the Gaussians come from the OpenCL backend (or
 * the reference implementation); the host does kinematics, the chain rule
 * and the priors, and takes a step conditioned per parameter by how far it
 * moves the Gaussians, with momentum (docs/TRACKER.md).  The settings are
 * in mc_tracker_settings.c, the pixels (views, candidates, samples) in
 * mc_pixels.c, the actor calibration in mc_calibrate.c. */
#include "track/mc_tracker.h"

#include "base/mc_time.h"
#include "body/mc_fit_joints.h"
#include "track/mc_tracker_internal.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Tracking quality (data energy relative to the calibrated baseline) below
 * which the state is uncertain, and lost. */
#define QUALITY_UNCERTAIN 0.6
#define QUALITY_LOST 0.3


/* On an egocentric rig the cameras sit in front of the wearer's face and
 * look down: the head itself is behind them or at the very edge of the
 * image.  Gaussians rigidly attached to the root (no dof in between) are
 * therefore left out of the image energy. */
static void hide_head_gaussians(mc_tracker *t)
{
	for (int j = 0; j < t->model.njoints; j++) {
		int p = t->model.joints[j].parent;
		t->fixed_joint[j] = !t->model.root_free && (p < 0 || (t->fixed_joint[p] && t->model.joints[j].ndof == 0));
	}
	for (int q = 0; q < t->model.ngauss; q++)
		t->hidden[q] = t->fixed_joint[t->model.gauss[q].joint];
}

/* The Gaussians at a pose; hidden ones get zero magnitude, which the energy
 * culls on every ray.  With a calibrated background colour, the energy adds
 * B d(I, background) per pixel (mc_calibrate.c, calibrate_background). */
void mc_trk_make_scene(const mc_tracker *t, const mc_fk *fk, mc_scene *scene)
{
	mc_scene_from_model(&t->model, fk, scene);
	for (int q = 0; q < scene->n; q++)
		if (t->hidden[q])
			scene->c[q] = 0;
	scene->background = t->has_background;
	memcpy(scene->background_hsv, t->background_hsv, sizeof(t->background_hsv));
}


static int alloc_buffers(mc_tracker *t, mc_err *err)
{
	int max_pixels = 0;
	for (int c = 0; c < t->rig.ncams; c++) {
		if (mc_raytable_build(&t->rig.cams[c], t->s.width, t->s.height, &t->rays[c], err) < 0)
			return mc_err_prefix(err, "camera '%s'", t->rig.cams[c].name);
		int n = t->s.width * t->s.height;
		t->rgb[c] = calloc((size_t)n * 3, sizeof(float));
		t->hsv[c] = calloc((size_t)n * 3, sizeof(float));
		t->candidates[c] = malloc(sizeof(int) * n);
		t->samples[c] = malloc(sizeof(int) * n);
		if (!t->rgb[c] || !t->hsv[c] || !t->candidates[c] || !t->samples[c])
			return mc_err_set(err, "tracker: out of memory");
		max_pixels = n > max_pixels ? n : max_pixels;
	}
	t->mask = malloc((size_t)max_pixels);
	t->fkp = malloc(sizeof(*t->fkp));
	/* Jacobians of the Gaussian centres (levers) or of the joints
	 * (detections) with respect to every dof */
	int rows = t->model.ngauss > MC_MAX_JOINTS ? t->model.ngauss : MC_MAX_JOINTS;
	t->jacobian = malloc(sizeof(mc_vec3) * (size_t)rows * (size_t)(t->model.ndof > 0 ? t->model.ndof : 1));
	return t->mask && t->jacobian && t->fkp ? 0 : mc_err_set(err, "tracker: out of memory");
}

mc_tracker *mc_tracker_create(const mc_rig *rig, const mc_model *model, const mc_tracker_settings *s, mc_err *err)
{
	if (mc_trk_validate_settings(s, err) < 0)
		return NULL;
	if (rig->ncams < 1 || rig->ncams > MC_MAX_CAMERAS) {
		mc_err_set(err, "tracker: the rig has %d cameras", rig->ncams);
		return NULL;
	}
	mc_tracker *t = calloc(1, sizeof(*t));
	if (!t) {
		mc_err_set(err, "tracker: out of memory");
		return NULL;
	}
	t->rig = *rig;
	t->model = *model;
	t->s = *s;
	t->rng = s->seed ? s->seed : 1;
	/* Outside-in, the body moves through the world: the head-mounted
	 * model's fixed root becomes a free one. */
	if (rig->kind == MC_RIG_OUTSIDE_IN && mc_model_make_root_free(&t->model, err) < 0)
		goto fail;
	hide_head_gaussians(t);
	mc_trk_find_other_sides(t);
	mc_trk_find_unpulled(t);
	if (alloc_buffers(t, err) < 0)
		goto fail;
	if (s->backend == MC_BACKEND_OPENCL) {
		t->cl = mc_cl_energy_create(s->cl_platform, s->cl_device, t->rays, rig->ncams, err);
		if (!t->cl)
			goto fail;
		snprintf(t->device, sizeof(t->device), "%s", mc_cl_energy_device(t->cl));
	} else {
		snprintf(t->device, sizeof(t->device), "reference (C, double, 1 thread)");
	}
	mc_model_rest_pose(&t->model, t->pose);
	mc_tracker_set_pose(t, t->pose);
	return t;
fail:
	mc_tracker_destroy(t);
	return NULL;
}

int mc_tracker_set_budget(mc_tracker *t, int iterations, double pixel_fraction, double dropout, double step,
			  double momentum, mc_err *err)
{
	mc_tracker_settings s = t->s;
	s.iterations = iterations;
	s.pixel_fraction = pixel_fraction;
	s.dropout = dropout;
	s.step = step;
	s.momentum = momentum;
	if (mc_trk_validate_settings(&s, err) < 0)
		return -1;
	t->s = s;
	return 0;
}

void mc_tracker_destroy(mc_tracker *t)
{
	if (!t)
		return;
	for (int c = 0; c < MC_MAX_CAMERAS; c++) {
		if (c < t->rig.ncams)
			mc_raytable_free(&t->rays[c]);
		free(t->rgb[c]);
		free(t->hsv[c]);
		free(t->candidates[c]);
		free(t->samples[c]);
	}
	free(t->mask);
	free(t->jacobian);
	free(t->fkp);
	mc_pose_prior_free(t->prior);
	mc_trk_init_free(t);
	if (t->cl)
		mc_cl_energy_destroy(t->cl);
	free(t);
}

int mc_tracker_load_pose_prior(mc_tracker *t, const char *path, mc_err *err)
{
	mc_pose_prior *p = mc_pose_prior_load(path, &t->model, err);
	if (!p)
		return -1;
	mc_pose_prior_free(t->prior);
	t->prior = p;
	return 0;
}

void mc_tracker_set_keypoint_poll(mc_tracker *t, mc_keypoint_poll poll, void *ctx)
{
	t->kp_poll = poll;
	t->kp_poll_ctx = ctx;
}

void mc_tracker_set_pose(mc_tracker *t, const double *pose)
{
	memcpy(t->pose, pose, sizeof(double) * t->model.ndof);
	mc_model_clamp_pose(&t->model, t->pose);
	memcpy(t->prev, t->pose, sizeof(t->prev));
	memcpy(t->prev2, t->pose, sizeof(t->prev2));
	memcpy(t->anchor, t->pose, sizeof(t->anchor));
	t->history = 0;
}

const double *mc_tracker_pose(const mc_tracker *t)
{
	return t->pose;
}

const mc_model *mc_tracker_model(const mc_tracker *t)
{
	return &t->model;
}

const char *mc_tracker_device_name(const mc_tracker *t)
{
	return t->device;
}

int mc_tracker_start_from_detections(mc_tracker *t, unsigned flags, mc_err *err)
{
	return mc_trk_init_start(t, flags, err);
}

unsigned mc_tracker_actor_version(const mc_tracker *t)
{
	return t->actor_version;
}

void mc_tracker_get_init_info(const mc_tracker *t, mc_tracker_init_info *out)
{
	const mc_trk_init *in = &t->init;
	*out = (mc_tracker_init_info){in->waiting, in->shape_done, in->nshape, in->inits, in->refits, in->refit_tries,
				      in->turns, in->last_joints, in->scale};
}

int mc_tracker_init_from_joints(mc_tracker *t, const char *const *names, const mc_vec3 *positions, int n,
				mc_err *err)
{
	double pose[MC_MAX_DOF] = {0};
	if (mc_fit_joints(&t->model, pose, names, positions, n, err) < 0)
		return -1;
	mc_tracker_set_pose(t, pose);
	return 0;
}

/* ---- energy ------------------------------------------------------------ */

/* The reference backend's E_color of camera `cam` (-1: every camera). */
static double reference_data_term(mc_tracker *t, const mc_scene *scene, int cam, double dropout, mc_vec3 *dmu)
{
	double E = 0, w[MC_MAX_GAUSSIANS];
	unsigned char active[MC_MAX_GAUSSIANS];
	for (int c = 0; c < t->rig.ncams; c++) {
		if (cam >= 0 && c != cam)
			continue;
		const mc_raytable *rt = &t->rays[c];
		for (int i = 0; i < t->nsamples[c]; i++) {
			int p = t->samples[c][i];
			double pix[3] = {t->hsv[c][3 * p], t->hsv[c][3 * p + 1], t->hsv[c][3 * p + 2]};
			for (int q = 0; q < scene->n; q++) {
				w[q] = mc_hsv_dissimilarity(scene->hsv[q], pix);
				active[q] = dropout <= 0 || mc_rng_uniform(&t->rng) >= dropout;
			}
			double w_bg = scene->background ? mc_hsv_dissimilarity(scene->background_hsv, pix) : 0;
			E += mc_ray_weighted_visibility_bg(scene, rt->origin, rt->dir[p], w, w_bg, active, dmu, NULL);
		}
	}
	return E;
}

/* E_color of every camera's samples, added into *E, and its gradient with
 * respect to the Gaussian centres (the sigmas' is not wanted): added into
 * dmu[q], or with per_camera camera c's into dmu[c * scene->n + q].  The
 * dropout draw depends on the seed, camera and pixel only. */
static int color_data_term(mc_tracker *t, const mc_scene *scene, double dropout, uint32_t seed, bool per_camera,
			   double *E, mc_vec3 *dmu, mc_err *err)
{
	if (!t->cl) {
		if (!per_camera)
			*E += reference_data_term(t, scene, -1, dropout, dmu);
		for (int c = 0; per_camera && c < t->rig.ncams; c++)
			*E += reference_data_term(t, scene, c, dropout, dmu + (size_t)c * (size_t)scene->n);
		return 0;
	}
	const int *pix[MC_MAX_CAMERAS];
	for (int c = 0; c < t->rig.ncams; c++)
		pix[c] = t->samples[c];
	double e = 0;
	int rc = per_camera ? mc_cl_energy_eval_cameras(t->cl, scene, pix, t->nsamples, dropout, seed, &e, dmu, err)
			    : mc_cl_energy_eval(t->cl, scene, pix, t->nsamples, dropout, seed, &e, dmu, NULL, err);
	if (rc < 0)
		return -1;
	*E += e;
	return 0;
}

/* Takes the share `cut` out of each Gaussian's gradient g (camera `cam`'s
 * colour term) where it would move the Gaussian nearer that camera along
 * its line of sight.  One image says where a Gaussian lies across the
 * view; along the view its colour term mostly says that a nearer Gaussian
 * covers more pixels, which pays wherever the scene's colours resemble
 * its own.  The pull away from the camera stays: it is what brings back a
 * limb lost in front of the cameras (docs/TRACKER.md, "Colours along the
 * line of sight"). */
static void cut_along_sight(const mc_tracker *t, const mc_scene *scene, int cam, double cut, mc_vec3 *g)
{
	mc_vec3 o = t->rig.cams[cam].rig_from_cam.t;
	for (int q = 0; q < scene->n; q++) {
		mc_vec3 sight = mc_v3_sub(scene->mu[q], o);
		double len = mc_v3_norm(sight);
		/* the descent step -g moves the Gaussian nearer where g.sight > 0 */
		double along = len > 1e-9 ? mc_v3_dot(g[q], sight) / (len * len) : 0;
		if (along > 0)
			g[q] = mc_v3_axpy(-cut * along, sight, g[q]);
	}
}

/* E_color over this iteration's samples, as a mean per sampled pixel, and
 * its gradient with respect to the Gaussian centres. */
int mc_trk_data_term(mc_tracker *t, const mc_scene *scene, int nsampled, double dropout, double *E, mc_vec3 *dmu,
		     mc_err *err)
{
	memset(dmu, 0, sizeof(mc_vec3) * scene->n);
	*E = 0;
	if (nsampled == 0)
		return 0;
	uint32_t seed = t->cl ? (uint32_t)mc_rng_next(&t->rng) : 0;
	double cut = t->s.color_sight_cut;
	if (!(cut > 0)) {
		if (color_data_term(t, scene, dropout, seed, false, E, dmu, err) < 0)
			return -1;
	} else {
		mc_vec3 g[MC_MAX_CAMERAS * MC_MAX_GAUSSIANS];
		memset(g, 0, sizeof(mc_vec3) * (size_t)t->rig.ncams * (size_t)scene->n);
		if (color_data_term(t, scene, dropout, seed, true, E, g, err) < 0)
			return -1;
		for (int c = 0; c < t->rig.ncams; c++) {
			mc_vec3 *gc = g + (size_t)c * (size_t)scene->n;
			cut_along_sight(t, scene, c, cut, gc);
			for (int q = 0; q < scene->n; q++)
				dmu[q] = mc_v3_add(dmu[q], gc[q]);
		}
	}
	double inv = 1.0 / nsampled;
	*E *= inv;
	for (int q = 0; q < scene->n; q++)
		dmu[q] = mc_v3_scale(dmu[q], inv);
	return 0;
}

/* ---- optimisation -------------------------------------------------------- */

/* Per-parameter step conditioning: each dof k gets a lever L_k = sum_q
 * |d mu_q / d p_k|^2, the squared motion of the Gaussians it moves.  The
 * gradient per unit of Gaussian motion, r_k = g_k / sqrt(L_k), is divided by
 * its running RMS over all dofs, so that one iteration moves the Gaussians
 * by about `step` metres whatever the energy's scale, and a dof with a weak
 * (noisy) gradient moves less than one with a strong gradient.  Momentum
 * smooths the stochastic gradients. */
typedef struct {
	double lever[MC_MAX_DOF];
	double velocity[MC_MAX_DOF];
	double mean_sq; /* running mean of r_k^2 */
	int steps;
} step_state;

static void compute_levers(const mc_tracker *t, const double *pose, step_state *st)
{
	int nd = t->model.ndof;
	mc_vec3 *J = t->jacobian;
	mc_fk fk;
	for (int k = 0; k < nd; k++)
		st->lever[k] = 1e-4; /* keeps dofs that move nothing finite */
	mc_model_fk(&t->model, pose, &fk);
	mc_model_gauss_jacobian(&t->model, pose, &fk, J);
	for (int q = 0; q < t->model.ngauss; q++)
		for (int k = 0; k < nd; k++)
			st->lever[k] += mc_v3_norm2(J[q * nd + k]);
}

static void conditioned_step(const mc_tracker *t, step_state *st, const double *grad, double step, double *pose)
{
	const double beta = 0.9;
	int nd = t->model.ndof;
	double r[MC_MAX_DOF], sq = 0;
	for (int k = 0; k < nd; k++) {
		r[k] = grad[k] / sqrt(st->lever[k]);
		sq += r[k] * r[k];
	}
	st->steps++;
	st->mean_sq = beta * st->mean_sq + (1 - beta) * sq / nd;
	double rms = sqrt(st->mean_sq / (1 - pow(beta, st->steps)));
	if (!(rms > 0))
		return;
	for (int k = 0; k < nd; k++) {
		double d = -step * r[k] / rms / sqrt(st->lever[k]);
		st->velocity[k] = t->s.momentum * st->velocity[k] + d;
		pose[k] += st->velocity[k];
	}
	mc_model_clamp_pose(&t->model, pose);
}

static void predict(const mc_tracker *t, double *pred)
{
	for (int k = 0; k < t->model.ndof; k++)
		pred[k] = t->history >= 2 ? t->prev[k] + 0.25 * (t->prev[k] - t->prev2[k]) : t->prev[k];
	mc_model_clamp_pose(&t->model, pred);
}

/* The colour term of iteration `it` of `iters`, weighted by lambda_color
 * (skipped, with its pixel sampling, when that is 0).  The first three
 * quarters, whose steps are the larger, may sample fewer pixels
 * (early_pixel_share). */
static int color_term(mc_tracker *t, const mc_scene *scene, int it, int iters, double *E, mc_vec3 *dmu,
		      mc_err *err)
{
	if (t->s.lambda_color <= 0) {
		*E = 0;
		memset(dmu, 0, sizeof(mc_vec3) * scene->n);
		return 0;
	}
	double share = it < iters * 3 / 4 ? t->s.early_pixel_share : 1.0;
	int ns = mc_trk_sample_pixels(t, t->s.pixel_fraction * share);
	if (mc_trk_data_term(t, scene, ns, t->s.dropout, E, dmu, err) < 0)
		return -1;
	for (int q = 0; q < scene->n; q++)
		dmu[q] = mc_v3_scale(dmu[q], t->s.lambda_color);
	*E *= t->s.lambda_color;
	return 0;
}

/* The floor prior (outside-in only): lambda_floor * d^2 for each visible
 * Gaussian whose lowest point (centre less one sigma) is d below z = 0,
 * its gradient added to dmu.  Energies are per sampled pixel, like the
 * colour term's, so one weight suits any resolution. */
static void floor_term(const mc_tracker *t, const mc_scene *scene, mc_vec3 *dmu)
{
	if (t->s.lambda_floor <= 0 || t->rig.kind != MC_RIG_OUTSIDE_IN)
		return;
	for (int q = 0; q < scene->n; q++) {
		double below = scene->sigma[q] - scene->mu[q].z;
		if (below > 0 && !t->hidden[q])
			dmu[q].z -= 2 * t->s.lambda_floor * below;
	}
}

/* The frame set's keypoints: those given to mc_tracker_track. */
static void keypoints_given(mc_tracker *t, const mc_keypoint *kp, int nkp)
{
	mc_trk_frame_keypoints *k = t->fkp;
	k->ngiven = kp && nkp > 0 ? (nkp < MC_TRK_MAX_KEYPOINTS ? nkp : MC_TRK_MAX_KEYPOINTS) : 0;
	if (k->ngiven)
		memcpy(k->given, kp, sizeof(*kp) * (size_t)k->ngiven);
	k->nrays = mc_trk_prepare_keypoints(t, k->given, k->ngiven, k->rays, k->cam);
}

int mc_keypoints_at_poll(void *ctx, int iteration, mc_keypoint *kp, int cap)
{
	mc_keypoints_at *l = ctx;
	if (iteration < l->at || l->nkp <= 0)
		return 0;
	int n = l->nkp < cap ? l->nkp : cap;
	memcpy(kp, l->kp, sizeof(*kp) * (size_t)n);
	l->nkp = 0;
	return n;
}

/* Before iteration `it`: keypoints that came since (mc_tracker_set_keypoint_poll).
 * Returns whether any came. */
static bool keypoints_poll(mc_tracker *t, int it)
{
	mc_trk_frame_keypoints *k = t->fkp;
	int room = MC_TRK_MAX_KEYPOINTS - k->ngiven;
	if (!t->kp_poll || room <= 0)
		return false;
	int got = t->kp_poll(t->kp_poll_ctx, it, k->given + k->ngiven, room);
	if (got <= 0)
		return false;
	k->ngiven += got < room ? got : room;
	k->nrays = mc_trk_prepare_keypoints(t, k->given, k->ngiven, k->rays, k->cam);
	return true;
}

/* Runs the iteration budget from `pose` (in/out). Returns the mean data
 * energy per pixel over the last quarter of the iterations. */
static int optimise(mc_tracker *t, double *pose, const double *pred, double *final_E, mc_err *err)
{
	const mc_trk_frame_keypoints *kp = t->fkp;
	step_state st;
	memset(&st, 0, sizeof(st));
	compute_levers(t, pose, &st);
	int iters = t->s.iterations, tail = iters / 4 > 0 ? iters / 4 : 1, ntail = 0;
	double Etail = 0;
	mc_vec3 dmu[MC_MAX_GAUSSIANS];
	for (int it = 0; it < iters; it++) {
		mc_fk fk;
		mc_scene scene;
		double grad[MC_MAX_DOF] = {0}, E;
		/* Keypoints that join in the first half of the budget (mocapd's
		 * detector is often a few ms late) get the ray fit too, from and
		 * held to the pose reached so far. */
		if (keypoints_poll(t, it) && it < iters / 2) {
			double now[MC_MAX_DOF];
			memcpy(now, pose, sizeof(now));
			if (mc_trk_ray_fit(t, now, pose, err) < 0)
				return -1;
		}
		mc_model_fk(&t->model, pose, &fk);
		mc_trk_make_scene(t, &fk, &scene);
		if (color_term(t, &scene, it, iters, &E, dmu, err) < 0)
			return -1;
		floor_term(t, &scene, dmu);
		mc_model_backprop(&t->model, pose, &fk, dmu, grad);
		mc_energy_pose(&t->model, pose, t->s.lambda_limit, t->s.lambda_pose, grad);
		mc_energy_smooth(t->model.ndof, pose, pred, t->s.lambda_smooth, grad);
		if (t->prior && t->s.lambda_prior > 0)
			mc_pose_prior_energy(t->prior, pose, t->s.lambda_prior, grad);
		/* the same pseudo-Huber pull, toward the calibration pose */
		if (t->s.lambda_anchor > 0)
			mc_energy_smooth(t->model.ndof, pose, t->anchor, t->s.lambda_anchor, grad);
		mc_trk_detection_term(t, pose, &fk, kp->rays, kp->nrays, grad);
		if (it >= iters - tail) {
			Etail += E;
			ntail++;
		}
		/* The step shrinks linearly to a fifth over the budget. */
		double step = t->s.step * (1.0 - 0.8 * it / (double)iters);
		conditioned_step(t, &st, grad, step, pose);
	}
	*final_E = ntail ? Etail / ntail : 0;
	return 0;
}

int mc_trk_pose_energy(mc_tracker *t, const double *pose, double *E, mc_err *err)
{
	mc_fk fk;
	mc_scene scene;
	mc_vec3 dmu[MC_MAX_GAUSSIANS];
	mc_model_fk(&t->model, pose, &fk);
	mc_trk_make_scene(t, &fk, &scene);
	mc_trk_choose_candidates(t, &fk);
	int ns = mc_trk_sample_pixels(t, 0.25);
	return mc_trk_data_term(t, &scene, ns, 0.0, E, dmu, err);
}

/* ---- tracking ------------------------------------------------------------ */

/* The joints of a pose: names, parents, positions, orientations. */
static void skeleton_joints(const mc_tracker *t, const double *pose, mc_skeleton *out)
{
	mc_fk fk;
	mc_model_fk(&t->model, pose, &fk);
	out->njoints = t->model.njoints;
	for (int j = 0; j < t->model.njoints; j++) {
		mc_skeleton_joint *sj = &out->joints[j];
		snprintf(sj->name, sizeof(sj->name), "%s", t->model.joints[j].name);
		sj->parent = t->model.joints[j].parent;
		sj->position = fk.rig_from_joint[j].t;
		sj->orientation = mc_quat_from_m3(fk.rig_from_joint[j].R);
	}
}

static void fill_skeleton(const mc_tracker *t, const double *pose, mc_skeleton *out)
{
	skeleton_joints(t, pose, out);
	mc_trk_joint_confidence(t, pose, out);
}

static mc_track_state state_from_quality(double quality)
{
	if (!(quality >= QUALITY_LOST))
		return MC_TRACK_LOST;
	return quality >= QUALITY_UNCERTAIN ? MC_TRACK_OK : MC_TRACK_UNCERTAIN;
}

static bool pose_finite(const double *p, int n)
{
	for (int k = 0; k < n; k++)
		if (!isfinite(p[k]))
			return false;
	return true;
}

/* The skeleton while waiting for a first pose: the rest pose, no confidence. */
static void initialising_skeleton(const mc_tracker *t, mc_skeleton *out)
{
	out->state = MC_TRACK_INITIALISING;
	skeleton_joints(t, t->pose, out);
	for (int j = 0; j < out->njoints; j++)
		out->joints[j].confidence = 0;
}

/* Whether every view of the frame set came with keypoints. */
static bool keypoints_from_every_view(const mc_tracker *t)
{
	const mc_trk_frame_keypoints *k = t->fkp;
	for (int c = 0; c < t->rig.ncams; c++) {
		bool any = false;
		for (int i = 0; i < k->nrays && !any; i++)
			any = k->cam[i] == c;
		if (t->present[c] && !any)
			return false;
	}
	return true;
}

/* Keypoints that place a body: on an outside-in rig (cameras around the
 * body, their keypoints checked against each other over wide baselines),
 * rays that passed that check for at least PLACE_BODY_JOINTS joints.  (On
 * the head rig, whose detector is far weaker on new scenes, following the
 * keypoints through lost frame sets made the held-out scoop_val 1.9 cm
 * worse.) */
#define PLACE_BODY_JOINTS 8
static bool keypoints_place_body(const mc_tracker *t)
{
	const mc_trk_frame_keypoints *k = t->fkp;
	if (!t->model.root_free)
		return false;
	bool seen[MC_MAX_JOINTS] = {false};
	int joints = 0;
	for (int i = 0; i < k->nrays; i++)
		if (k->rays[i].weight > 0 && !seen[k->rays[i].joint]) {
			seen[k->rays[i].joint] = true;
			joints++;
		}
	return joints >= PLACE_BODY_JOINTS;
}

static int track_frame_set(mc_tracker *t, const mc_frame_view *views, int nviews, const mc_keypoint *kp, int nkp,
			   mc_skeleton *out, mc_err *err)
{
	uint64_t start = mc_now_ns();
	memset(out, 0, sizeof(*out));
	for (int c = 0; c < nviews && c < t->rig.ncams; c++)
		if (mc_trk_view_usable(&views[c]) && views[c].timestamp_ns > out->timestamp_ns)
			out->timestamp_ns = views[c].timestamp_ns;
	int present = mc_trk_load_views(t, views, nviews);
	keypoints_given(t, kp, nkp);
	mc_trk_frame_keypoints *fkp = t->fkp;
	/* The detections' step (re-fit when lost or stuck, the actor's size)
	 * triangulates the frame set's keypoints across cameras.  When some
	 * view's are not here yet and a poll may bring them during the
	 * iterations (mocapd at 30 fps: each camera's detection ends a few ms
	 * into the tracking), it is taken after the iterations with those
	 * that came, else it would hardly ever run. */
	bool late_step = present > 0 && t->kp_poll && !t->init.waiting && !keypoints_from_every_view(t);
	int waiting = late_step ? 0
		      : present > 0 ? mc_trk_init_step(t, views, nviews, fkp->rays, fkp->cam, fkp->nrays, err)
				    : (t->init.waiting ? 1 : 0);
	if (waiting < 0)
		return -1;
	if (waiting) {
		mc_trk_update_trust(t);
		initialising_skeleton(t, out);
		out->track_ms = mc_ms_since(start);
		return 0;
	}

	double pred[MC_MAX_DOF], pose[MC_MAX_DOF], E = 0, quality = 0;
	predict(t, pred);
	memcpy(pose, pred, sizeof(pose));
	if (present > 0) {
		mc_fk fk;
		mc_model_fk(&t->model, pred, &fk);
		mc_trk_choose_candidates(t, &fk);
		if (mc_trk_ray_fit(t, pred, pose, err) < 0 || optimise(t, pose, pred, &E, err) < 0)
			return -1;
		quality = E / t->baseline;
		out->iterations = t->s.iterations;
	}
	/* The state is read off the colour energy; without the colour term
	 * (lambda_color 0) there is none to read, and the pose is kept. */
	out->state = t->s.lambda_color > 0 ? state_from_quality(quality) : MC_TRACK_OK;
	bool finite = pose_finite(pose, t->model.ndof);
	if (!finite)
		out->state = MC_TRACK_LOST;
	/* A lost state keeps the last good pose, unless the keypoints place
	 * the body: then the pose they pulled is kept.  The colours, learnt
	 * once, can fit badly while the detector still sees the person (a
	 * dancer turned, other light): on the held-out salsa_train, 48 of 150
	 * frame sets read lost, and the pose stood still while she danced on
	 * (docs/TRACKER.md, "Lost, with keypoints"). */
	if (out->state != MC_TRACK_LOST || (finite && present > 0 && keypoints_place_body(t))) {
		memcpy(t->prev2, t->prev, sizeof(t->prev2));
		memcpy(t->prev, pose, sizeof(t->prev));
		memcpy(t->pose, pose, sizeof(t->pose));
		t->history = t->history < 2 ? t->history + 1 : 2;
	} else {
		/* Keep the last good pose and forget the velocity, so that real
		 * frames restart from where the body was last seen. */
		memcpy(t->prev2, t->prev, sizeof(t->prev2));
		t->history = 0;
	}
	/* A re-fit here sets the pose published for this frame set (it beat
	 * the tracked one on this frame set's images) and the next one's start. */
	if (late_step && mc_trk_init_step(t, views, nviews, fkp->rays, fkp->cam, fkp->nrays, err) < 0)
		return -1;
	out->energy = E;
	mc_trk_update_trust(t);
	fill_skeleton(t, t->pose, out);
	mc_trk_init_after(t, out);
	out->track_ms = mc_ms_since(start);
	return 0;
}

/* The tracker's stored poses: the current one, the history, the anchor
 * and those kept for measuring the actor's size. */
static int stored_poses(mc_tracker *t, double **poses)
{
	int n = 0;
	poses[n++] = t->pose;
	poses[n++] = t->prev;
	poses[n++] = t->prev2;
	poses[n++] = t->anchor;
	for (int i = 0; i < t->init.nshape && i < MC_TRK_SHAPE_FRAMES; i++)
		poses[n++] = t->init.shape_pose[i];
	return n;
}

/* While a frame set is tracked, a free root's rotation dofs start from
 * zero: the current rotation moves into the model's root_base and every
 * stored pose is re-expressed against it.  The rotation vector then never
 * nears its wrap at pi, where the prediction and the smoothness prior
 * (which work on the vector) would break.  Outside this call the base is
 * folded back (zero), so that mc_tracker_model and mc_tracker_pose, and
 * the actor and pose files made from them, are plain. */
int mc_tracker_track(mc_tracker *t, const mc_frame_view *views, int nviews, const mc_keypoint *kp, int nkp,
		     mc_skeleton *out, mc_err *err)
{
	double *poses[4 + MC_TRK_SHAPE_FRAMES];
	int n = stored_poses(t, poses);
	mc_model_recentre_root(&t->model, poses, n);
	int rc = track_frame_set(t, views, nviews, kp, nkp, out, err);
	mc_model_fold_root_base(&t->model, poses, n);
	return rc;
}
