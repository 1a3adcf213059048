/* mc_energy: the reference (plain C, double precision) image formation model
 * and tracking energy of the thesis, with analytic gradients.
 *
 * Thesis references: ray Gaussians and transmittance ch. 4.2.2 (eq. 4.3-4.6),
 * Gaussian visibility 4.2.3 (eq. 4.10, K = {-4..0}, lambda = sigma),
 * background visibility eq. 5.5, colour term eq. 4.13 / 6.4 with the HSV
 * dissimilarity of 6.2.1, detection term 6.2.2, priors eq. 6.2 and 6.3.
 *
 * Gradients are with respect to the Gaussian centres mu_q and standard
 * deviations sigma_q; mc_model_backprop() carries them to the pose.
 *
 * docs/ENERGY.md has the exact formulas and derivatives, including three
 * departures from the thesis: samples near or behind the camera are faded
 * out, culling (c' < MC_CULL_MAGNITUDE) fades in over [C, 2C] so that the
 * energy is smooth, and B integrates from the camera (T at infinity).
 * Ray directions must be unit length. */
#ifndef MC_ENERGY_H
#define MC_ENERGY_H

#include "base/mc_math.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"

#define MC_VIS_SAMPLES 5      /* K = {-4, ..., 0} */
/* Rays with c'_q below this (per metre) skip Gaussian q, which fades in up
 * to twice that.  The thesis' 1e-5 kept Gaussians out to 5.5 sigma; 1e-2
 * leaves out optical depths under 1.5e-3 and halves the Gaussians per ray
 * (docs/ENERGY.md, "Culling threshold").  Defined at build time to compare
 * thresholds (make BUILD=build-x OPT="-O2 -DMC_CULL_MAGNITUDE=1e-5"). */
#ifndef MC_CULL_MAGNITUDE
#define MC_CULL_MAGNITUDE 1e-2
#endif

/* The Gaussians of one evaluation, in the rig frame. */
typedef struct {
	int n;
	mc_vec3 mu[MC_MAX_GAUSSIANS];
	double sigma[MC_MAX_GAUSSIANS];
	double c[MC_MAX_GAUSSIANS];
	double hsv[MC_MAX_GAUSSIANS][3]; /* albedo, HSV each in [0, 1] */
	/* Background colour model: when set, the colour energy of a pixel adds
	 * B d(I, background_hsv), B the ray's background visibility (eq. 5.5),
	 * so that covering a pixel that looks like the background costs and
	 * explaining one that does not pays (docs/ENERGY.md, "Background"). */
	bool background;
	double background_hsv[3];
} mc_scene;

/* Fills a scene from a model's Gaussians at a posed fk. */
void mc_scene_from_model(const mc_model *model, const mc_fk *fk, mc_scene *scene);

/* Colour conversions and the dissimilarity d(m, i) in [-1, 1] of ch. 6.2.1
 * (m: model albedo, i: image colour, both HSV in [0, 1]). */
void mc_rgb_to_hsv(const double rgb[3], double hsv[3]);
void mc_hsv_to_rgb(const double hsv[3], double rgb[3]);
double mc_hsv_dissimilarity(const double m_hsv[3], const double i_hsv[3]);

/* Per-ray quantities.  vis[q] = V_q (eq. 4.10; 0 for Gaussians culled on
 * this ray), *background = B (eq. 5.5, may be NULL).  vis must hold
 * scene->n doubles. */
void mc_ray_visibility(const mc_scene *scene, mc_vec3 o, mc_vec3 n, double *vis, double *background);
/* V_q of one Gaussian q only (cheaper than mc_ray_visibility). */
double mc_ray_visibility_of(const mc_scene *scene, mc_vec3 o, mc_vec3 n, int q);
/* Transmittance T(s) along the ray (eq. 4.6); 1 for s <= 0. */
double mc_ray_transmittance(const mc_scene *scene, mc_vec3 o, mc_vec3 n, double s);
/* Rendered colour: sum_q V_q albedo_q + B * bg_rgb. */
void mc_ray_render_rgb(const mc_scene *scene, const double albedo_rgb[][3], mc_vec3 o, mc_vec3 n,
		       const double bg_rgb[3], double out_rgb[3]);

/* sum_q w[q] V_q along one ray; adds its gradient into dmu/dsigma (each
 * scene->n long, may be NULL).  `active` (may be NULL) masks Gaussians out
 * of the sum and of the occlusion (stochastic dropout). */
double mc_ray_weighted_visibility(const mc_scene *scene, mc_vec3 o, mc_vec3 n, const double *w,
				  const unsigned char *active, mc_vec3 *dmu, double *dsigma);
/* The same plus w_background * B, B the background visibility of the ray
 * (over the active Gaussians), with its gradient. */
double mc_ray_weighted_visibility_bg(const mc_scene *scene, mc_vec3 o, mc_vec3 n, const double *w,
				     double w_background, const unsigned char *active, mc_vec3 *dmu,
				     double *dsigma);

/* One camera's image at the working resolution of its ray table. */
typedef struct {
	const mc_raytable *rays;
	const float *hsv; /* 3 floats per working pixel, HSV in [0, 1] */
} mc_view;

/* E_color over a set of pixels of one view (pixel indices into the ray
 * table; NULL = every valid pixel), with the background term when
 * scene->background is set.  Adds gradients into dmu/dsigma. */
double mc_energy_color(const mc_scene *scene, const mc_view *view, const int *pixels, int npixels,
		       mc_vec3 *dmu, double *dsigma);

/* A 2D detection: joint-attached Gaussian `gauss` of the scene should be
 * seen along the ray (o, n) through the detected pixel, with confidence conf. */
typedef struct {
	int gauss;
	mc_vec3 o, n;
	double conf;
} mc_detection_ray;

/* Checks detections against a scene (Gaussian index in range, finite
 * confidence >= 0, finite origin, unit direction); the message names the
 * detection and the field.  mc_energy_detection skips what this rejects. */
int mc_detections_check(const mc_scene *scene, const mc_detection_ray *det, int ndet, mc_err *err);

/* E_detection = -weight * sum_k conf_k V_{gauss_k}(o_k, n_k), each V computed
 * with the whole scene as occluders. */
double mc_energy_detection(const mc_scene *scene, const mc_detection_ray *det, int ndet, double weight,
			   mc_vec3 *dmu, double *dsigma);

/* E_pose (eq. 6.2): lambda_limit * squared limit violations of the joint
 * dofs + lambda_pose * sum pseudo-Huber(p) over joint dofs (root dofs are
 * not penalised).  Adds into grad (ndof, may be NULL). */
double mc_energy_pose(const mc_model *model, const double *pose, double lambda_limit, double lambda_pose,
		      double *grad);
/* E_smooth (eq. 6.3): lambda * sum pseudo-Huber(pred - p), pred = p(t-1) +
 * 0.25 (p(t-1) - p(t-2)) computed by the caller. */
double mc_energy_smooth(int ndof, const double *pose, const double *pred, double lambda, double *grad);

#endif
