/* Tests of core/energy/mc_energy: the image formation model (projection to the ray,
 * transmittance, Gaussian and background visibility), the HSV dissimilarity
 * and every energy term's analytic gradient against central finite
 * differences, on random scenes with occlusion and disocclusion. */
#include "energy/mc_energy.h"
#include "test_util.h"

#include <string.h>

/* ---- random scenes ---- */

static double urand(unsigned long long *rng, double lo, double hi)
{
	return lo + (hi - lo) * mc_test_rand(rng);
}

static mc_vec3 rand_unit(unsigned long long *rng)
{
	for (;;) {
		mc_vec3 v = mc_v3(urand(rng, -1, 1), urand(rng, -1, 1), urand(rng, -1, 1));
		double l = mc_v3_norm(v);
		if (l > 0.1 && l < 1)
			return mc_v3_scale(v, 1 / l);
	}
}

/* Two unit vectors perpendicular to n. */
static void perp_basis(mc_vec3 n, mc_vec3 *a, mc_vec3 *b)
{
	mc_vec3 t = fabs(n.x) < 0.9 ? mc_v3(1, 0, 0) : mc_v3(0, 1, 0);
	*a = mc_v3_normalize(mc_v3_cross(n, t));
	*b = mc_v3_cross(n, *a);
}

typedef enum {
	SCENE_SCATTERED,  /* around the ray, some occluding each other */
	SCENE_LINED_UP,   /* all nearly on the ray, overlapping in depth */
	SCENE_NEAR_CAMERA, /* some around and behind the camera */
	SCENE_DISOCCLUSION, /* an opaque occluder half hiding Gaussians behind it */
	SCENE_KINDS
} scene_kind;

static const char *scene_kind_name[SCENE_KINDS] = {"scattered", "lined-up", "near-camera", "disocclusion"};

/* Places Gaussian q at depth m along (o, n) with lateral offset (x, y). */
static void place(mc_scene *s, int q, mc_vec3 o, mc_vec3 n, double m, double x, double y, double sigma, double c)
{
	mc_vec3 a, b;
	perp_basis(n, &a, &b);
	s->mu[q] = mc_v3_add(mc_v3_axpy(m, n, o), mc_v3_add(mc_v3_scale(a, x), mc_v3_scale(b, y)));
	s->sigma[q] = sigma;
	s->c[q] = c;
}

/* A scene of n Gaussians, all zero, and no background model. */
static void empty_scene(mc_scene *s, int n)
{
	memset(s, 0, sizeof(*s));
	s->n = n;
	s->background = false;
}

static void random_scene(scene_kind kind, int n, unsigned long long *rng, mc_vec3 o, mc_vec3 dir, mc_scene *s)
{
	empty_scene(s, n);
	for (int q = 0; q < n; q++) {
		double sigma = urand(rng, 0.04, 0.25);
		/* sigma c between thin (0.2) and very dense (20) */
		double c = exp(urand(rng, log(0.2), log(20))) / sigma;
		double lat = kind == SCENE_LINED_UP ? 0.1 : 1.5;
		double m = urand(rng, 0.8, 3.0);
		if (kind == SCENE_LINED_UP)
			m = 1.0 + 0.12 * q + urand(rng, 0, 0.05);
		if (kind == SCENE_NEAR_CAMERA && q % 2 == 0)
			m = urand(rng, -0.4, 0.6);
		double x = urand(rng, -lat, lat) * sigma, y = urand(rng, -lat, lat) * sigma;
		if (kind == SCENE_DISOCCLUSION && q == 0) {
			m = 1.0, x = y = 0, sigma = 0.2, c = 40; /* opaque, on the ray */
		} else if (kind == SCENE_DISOCCLUSION) {
			m = urand(rng, 1.5, 2.5);
			x = urand(rng, 0.5, 2.5) * 0.2; /* behind the occluder's edge */
		}
		place(s, q, o, dir, m, x, y, sigma, c);
		for (int ch = 0; ch < 3; ch++)
			s->hsv[q][ch] = mc_test_rand(rng);
	}
}

/* c'_q of eq. 4.4 (before culling), recomputed here. */
static double ray_magnitude(const mc_scene *s, int q, mc_vec3 o, mc_vec3 n)
{
	mc_vec3 d = mc_v3_sub(s->mu[q], o);
	double m = mc_v3_dot(d, n);
	return s->c[q] * exp(-(mc_v3_norm2(d) - m * m) / (2 * s->sigma[q] * s->sigma[q]));
}

/* ---- generic finite-difference check of dE/dmu, dE/dsigma ---- */


typedef double (*energy_fn)(const mc_scene *s, const void *ctx, mc_vec3 *dmu, double *dsigma);

typedef struct {
	double max_rel;  /* largest relative error over non-negligible entries */
	int checked, negligible;
} fd_stats;

static fd_stats fd_all;

/* Compares analytic and central-difference derivatives.  An entry is
 * negligible when both are below 1e-6 of the largest analytic entry of the
 * scene: there the finite difference's rounding noise (about 1e-16 of the
 * summed energy terms over h) is comparable with the entry itself, so only
 * the absolute difference is bounded. */
static void compare(const char *what, int q, int comp, double an, double fd, double scale, fd_stats *st)
{
	double mag = fmax(fabs(an), fabs(fd));
	if (mag <= 1e-6 * scale) {
		st->negligible++;
		CHECK_MSG(fabs(an - fd) <= 1e-6 * scale, "%s: q %d comp %d: analytic %.6g fd %.6g", what, q, comp, an,
			  fd);
		return;
	}
	double rel = fabs(an - fd) / mag;
	st->checked++;
	if (rel > st->max_rel)
		st->max_rel = rel;
	CHECK_MSG(rel < 1e-4, "%s: q %d comp %d: analytic %.10g fd %.10g rel %.3g scale %.3g", what, q, comp, an, fd, rel, scale);
}

/* Five-point central difference, f' = (8 (f(x+h) - f(x-h)) - (f(x+2h) -
 * f(x-2h))) / 12h, truncation O(h^4): with h = 1e-3 sigma both truncation
 * and rounding stay near 1e-12 of the gradient's scale. */
static const double fd_offsets[4] = {-2, -1, 1, 2};

static double central_difference(const double e[4], double h)
{
	return (8 * (e[2] - e[1]) - (e[3] - e[0])) / (12 * h);
}

/* hrel: step relative to sigma_q (1e-3 suits the energy's usual scale). */
static void fd_check_step(const char *what, const mc_scene *s0, energy_fn fn, const void *ctx, double hrel)
{
	mc_vec3 dmu[MC_MAX_GAUSSIANS] = {{0, 0, 0}};
	double dsigma[MC_MAX_GAUSSIANS] = {0};
	double e0 = fn(s0, ctx, dmu, dsigma);
	double e1 = fn(s0, ctx, NULL, NULL);
	CHECK_MSG(fabs(e0 - e1) <= 1e-12 * fmax(1, fabs(e0)), "%s: energy with and without gradient differ", what);
	double scale = 0;
	for (int q = 0; q < s0->n; q++)
		scale = fmax(scale, fmax(mc_v3_norm(dmu[q]), fabs(dsigma[q])));
	mc_scene s = *s0;
	for (int q = 0; q < s0->n; q++) {
		/* the energy varies on the scale of sigma_q in mu_q and sigma_q */
		double h = hrel * s0->sigma[q];
		for (int comp = 0; comp < 4; comp++) {
			double *x = comp == 0 ? &s.mu[q].x : comp == 1 ? &s.mu[q].y : comp == 2 ? &s.mu[q].z : &s.sigma[q];
			double x0 = *x, e[4];
			for (int j = 0; j < 4; j++) {
				*x = x0 + fd_offsets[j] * h;
				e[j] = fn(&s, ctx, NULL, NULL);
			}
			*x = x0;
			double an = comp < 3 ? mc_v3_get(dmu[q], comp) : dsigma[q];
			compare(what, q, comp, an, central_difference(e, h), scale, &fd_all);
		}
	}
}

static void fd_check(const char *what, const mc_scene *s0, energy_fn fn, const void *ctx)
{
	fd_check_step(what, s0, fn, ctx, 1e-3);
}

/* ---- energies under test, as energy_fn ---- */

typedef struct {
	mc_vec3 o, n;
	const double *w;
	const unsigned char *active;
	double w_background;
} ray_ctx;

static double weighted_vis_fn(const mc_scene *s, const void *ctx, mc_vec3 *dmu, double *dsigma)
{
	const ray_ctx *r = ctx;
	if (r->w_background != 0)
		return mc_ray_weighted_visibility_bg(s, r->o, r->n, r->w, r->w_background, r->active, dmu, dsigma);
	return mc_ray_weighted_visibility(s, r->o, r->n, r->w, r->active, dmu, dsigma);
}

typedef struct {
	const mc_view *view;
	const int *pixels;
	int npixels;
} color_ctx;

static double color_fn(const mc_scene *s, const void *ctx, mc_vec3 *dmu, double *dsigma)
{
	const color_ctx *c = ctx;
	return mc_energy_color(s, c->view, c->pixels, c->npixels, dmu, dsigma);
}

typedef struct {
	const mc_detection_ray *det;
	int ndet;
} det_ctx;

static double detection_fn(const mc_scene *s, const void *ctx, mc_vec3 *dmu, double *dsigma)
{
	const det_ctx *d = ctx;
	return mc_energy_detection(s, d->det, d->ndet, 1.0 / 3, dmu, dsigma);
}

/* ---- tests ---- */

static void test_weighted_visibility_gradients(void)
{
	unsigned long long rng = 7;
	for (int kind = 0; kind < SCENE_KINDS; kind++) {
		for (int trial = 0; trial < 12; trial++) {
			mc_vec3 o = mc_v3(urand(&rng, -1, 1), urand(&rng, -1, 1), urand(&rng, -1, 1));
			mc_vec3 n = rand_unit(&rng);
			mc_scene s;
			int ng = 3 + (int)(mc_test_rand(&rng) * 8);
			random_scene(kind, ng, &rng, o, n, &s);
			double w[MC_MAX_GAUSSIANS];
			unsigned char active[MC_MAX_GAUSSIANS];
			for (int q = 0; q < s.n; q++) {
				w[q] = mc_test_rand(&rng) < 0.2 ? 0 : urand(&rng, -1, 1);
				active[q] = mc_test_rand(&rng) < 0.8;
			}
			char what[64];
			ray_ctx ctx = {o, n, w, NULL, 0};
			snprintf(what, sizeof(what), "weighted visibility (%s)", scene_kind_name[kind]);
			fd_check(what, &s, weighted_vis_fn, &ctx);
			ctx.active = active;
			snprintf(what, sizeof(what), "weighted visibility, dropout (%s)", scene_kind_name[kind]);
			fd_check(what, &s, weighted_vis_fn, &ctx);
			ctx.w_background = urand(&rng, -1, 1);
			snprintf(what, sizeof(what), "weighted visibility, background (%s)", scene_kind_name[kind]);
			fd_check(what, &s, weighted_vis_fn, &ctx);
		}
	}
}

/* A small pinhole-like ray table looking at the origin from o. */
typedef struct {
	mc_raytable rt;
	mc_vec3 dir[12];
	uint8_t valid[12];
	float hsv[36];
} small_view;

static void small_view_init(small_view *v, mc_vec3 o, unsigned long long *rng)
{
	memset(v, 0, sizeof(*v));
	v->rt.width = 4;
	v->rt.height = 3;
	v->rt.scale_x = v->rt.scale_y = 1;
	v->rt.origin = o;
	v->rt.dir = v->dir;
	v->rt.valid = v->valid;
	mc_vec3 fwd = mc_v3_normalize(mc_v3_scale(o, -1)), a, b;
	perp_basis(fwd, &a, &b);
	for (int j = 0; j < 3; j++)
		for (int i = 0; i < 4; i++) {
			int p = j * 4 + i;
			v->dir[p] = mc_v3_normalize(mc_v3_add(fwd, mc_v3_add(mc_v3_scale(a, 0.05 * (i - 1.5)),
									     mc_v3_scale(b, 0.05 * (j - 1)))));
			v->valid[p] = p != 5; /* one invalid pixel */
			v->rt.nvalid += v->valid[p];
		}
	for (int k = 0; k < 36; k++)
		v->hsv[k] = (float)mc_test_rand(rng);
}

static void test_color_energy(void)
{
	unsigned long long rng = 11;
	for (int trial = 0; trial < 10; trial++) {
		mc_vec3 o = mc_v3(urand(&rng, -0.2, 0.2), urand(&rng, -0.2, 0.2), -2.0);
		small_view sv;
		small_view_init(&sv, o, &rng);
		mc_view view = {&sv.rt, sv.hsv};
		mc_scene s;
		random_scene(trial % 2 ? SCENE_SCATTERED : SCENE_DISOCCLUSION, 6, &rng, o, sv.dir[6], &s);
		color_ctx all = {&view, NULL, 0};
		fd_check("color energy", &s, color_fn, &all);

		/* E over every valid pixel = sum of single-pixel energies, each
		 * = sum_q d(I, a_q) V_q; the invalid pixel contributes nothing. */
		double sum = 0, direct = 0;
		for (int p = 0; p < 12; p++) {
			sum += mc_energy_color(&s, &view, &p, 1, NULL, NULL);
			if (!sv.valid[p])
				continue;
			double vis[MC_MAX_GAUSSIANS], b, ihsv[3] = {sv.hsv[3 * p], sv.hsv[3 * p + 1], sv.hsv[3 * p + 2]};
			mc_ray_visibility(&s, o, sv.dir[p], vis, &b);
			for (int q = 0; q < s.n; q++)
				direct += mc_hsv_dissimilarity(s.hsv[q], ihsv) * vis[q];
		}
		double e = mc_energy_color(&s, &view, NULL, 0, NULL, NULL);
		CHECK_NEAR(e, sum, 1e-12 * fmax(1, fabs(e)));
		CHECK_NEAR(e, direct, 1e-12 * fmax(1, fabs(e)));
		int subset[4] = {0, 3, 5, 11};
		color_ctx sub = {&view, subset, 4};
		fd_check("color energy, pixel subset", &s, color_fn, &sub);

		/* With a background colour: each pixel adds B d(I, background). */
		s.background = true;
		for (int k = 0; k < 3; k++)
			s.background_hsv[k] = mc_test_rand(&rng);
		double with_bg = mc_energy_color(&s, &view, NULL, 0, NULL, NULL), expect = direct;
		for (int p = 0; p < 12; p++) {
			if (!sv.valid[p])
				continue;
			double vis[MC_MAX_GAUSSIANS], b, ihsv[3] = {sv.hsv[3 * p], sv.hsv[3 * p + 1], sv.hsv[3 * p + 2]};
			mc_ray_visibility(&s, o, sv.dir[p], vis, &b);
			expect += b * mc_hsv_dissimilarity(s.background_hsv, ihsv);
		}
		CHECK_NEAR(with_bg, expect, 1e-12 * fmax(1, fabs(expect)));
		/* B d(I, bg) adds about 1 per pixel to the energy, and the finite
		 * difference's rounding noise with it: a step of 3e-3 sigma
		 * balances that noise against the truncation error (1e-3 and 1e-2
		 * each leave one entry just above 1e-4). */
		fd_check_step("color energy, background", &s, color_fn, &all, 3e-3);
	}
}

static void test_detection_energy(void)
{
	unsigned long long rng = 13;
	mc_vec3 o = mc_v3(0, 0, 0);
	for (int trial = 0; trial < 10; trial++) {
		mc_scene s;
		random_scene(SCENE_DISOCCLUSION, 5, &rng, o, mc_v3(0, 0, 1), &s);
		mc_detection_ray det[3];
		for (int k = 0; k < 3; k++) {
			int q = k + 1; /* the Gaussians behind the occluder */
			/* a ray through a point near the Gaussian's centre */
			mc_vec3 target = mc_v3_add(s.mu[q], mc_v3_scale(rand_unit(&rng), 0.5 * s.sigma[q]));
			det[k] = (mc_detection_ray){q, o, mc_v3_normalize(target), urand(&rng, 0.2, 1)};
		}
		mc_err err;
		CHECK(mc_detections_check(&s, det, 3, &err) == 0);
		det_ctx ctx = {det, 3};
		fd_check("detection energy", &s, detection_fn, &ctx);
		/* value: -weight sum conf V_gauss, V with the whole scene occluding */
		double expect = 0;
		for (int k = 0; k < 3; k++) {
			double vis[MC_MAX_GAUSSIANS], b;
			mc_ray_visibility(&s, det[k].o, det[k].n, vis, &b);
			expect -= det[k].conf * vis[det[k].gauss] / 3;
		}
		CHECK_NEAR(mc_energy_detection(&s, det, 3, 1.0 / 3, NULL, NULL), expect, 1e-12);
	}
	/* bad detections are reported, naming the detection and field, and skipped */
	mc_scene s;
	random_scene(SCENE_SCATTERED, 3, &rng, o, mc_v3(0, 0, 1), &s);
	mc_detection_ray bad[2] = {{1, o, mc_v3(0, 0, 1), 0.5}, {7, o, mc_v3(0, 0, 1), 0.5}};
	mc_err err;
	CHECK(mc_detections_check(&s, bad, 2, &err) == -1);
	CHECK(strstr(err.msg, "detection 1") && strstr(err.msg, "gauss"));
	CHECK_NEAR(mc_energy_detection(&s, bad, 2, 1, NULL, NULL), mc_energy_detection(&s, bad, 1, 1, NULL, NULL),
		   0);
	bad[1] = (mc_detection_ray){0, o, mc_v3(0, 0, 2), 0.5};
	CHECK(mc_detections_check(&s, bad, 2, &err) == -1 && strstr(err.msg, "direction"));
	bad[1] = (mc_detection_ray){0, o, mc_v3(0, 0, 1), NAN};
	CHECK(mc_detections_check(&s, bad, 2, &err) == -1 && strstr(err.msg, "conf"));
}

/* A hand-made model: free root (6 dofs), a 3-dof joint and a 1-dof joint. */
static void small_model(mc_model *m)
{
	memset(m, 0, sizeof(*m));
	m->njoints = 3;
	m->root_free = true;
	m->joints[0] = (mc_joint){.name = "pelvis", .parent = -1, .ndof = 0, .dof0 = 6};
	m->joints[1] = (mc_joint){.name = "left_hip", .parent = 0, .ndof = 3, .axis = {0, 1, 2},
				  .lower = {-1.0, -0.5, -0.3}, .upper = {1.5, 0.5, 0.3}, .dof0 = 6};
	m->joints[2] = (mc_joint){.name = "left_knee", .parent = 1, .ndof = 1, .axis = {0},
				  .lower = {0.0}, .upper = {2.5}, .dof0 = 9};
	m->ndof = 10;
}

static double pose_energy_at(const mc_model *m, const double *p, double *grad)
{
	return mc_energy_pose(m, p, 0.1, 1e-4, grad);
}

static void test_pose_energy(void)
{
	mc_model m;
	small_model(&m);
	unsigned long long rng = 17;
	for (int trial = 0; trial < 50; trial++) {
		double p[10], g[10] = {0};
		for (int k = 0; k < 10; k++)
			p[k] = urand(&rng, -3, 3); /* often outside the limits */
		pose_energy_at(&m, p, g);
		for (int k = 0; k < 10; k++) {
			double p0 = p[k], h = 1e-6;
			p[k] = p0 + h;
			double ep = pose_energy_at(&m, p, NULL);
			p[k] = p0 - h;
			double em = pose_energy_at(&m, p, NULL);
			p[k] = p0;
			double fd = (ep - em) / (2 * h);
			if (k < 6)
				CHECK(g[k] == 0 && fd == 0); /* root dofs are not penalised */
			else
				CHECK_NEAR(g[k], fd, 1e-4 * fmax(fabs(fd), 1e-4));
		}
	}
	/* value: inside the limits only the pseudo-Huber prior; outside, the
	 * squared violation */
	double p[10] = {5, 5, 5, 5, 5, 5, 0.5, 0, 0, 0};
	CHECK_NEAR(pose_energy_at(&m, p, NULL), 1e-4 * (sqrt(1.25) - 1), 1e-15);
	p[6] = 2.0; /* 0.5 over the upper limit */
	CHECK_NEAR(pose_energy_at(&m, p, NULL), 0.1 * 0.25 + 1e-4 * (sqrt(5) - 1), 1e-15);
	p[6] = 0, p[9] = -0.2; /* 0.2 under the lower limit */
	CHECK_NEAR(pose_energy_at(&m, p, NULL), 0.1 * 0.04 + 1e-4 * (sqrt(1.04) - 1), 1e-15);
}

static void test_smooth_energy(void)
{
	unsigned long long rng = 19;
	for (int trial = 0; trial < 20; trial++) {
		double p[8], pred[8], g[8] = {0};
		for (int k = 0; k < 8; k++)
			p[k] = urand(&rng, -2, 2), pred[k] = urand(&rng, -2, 2);
		mc_energy_smooth(8, p, pred, 0.1, g);
		for (int k = 0; k < 8; k++) {
			double p0 = p[k], h = 1e-6;
			p[k] = p0 + h;
			double ep = mc_energy_smooth(8, p, pred, 0.1, NULL);
			p[k] = p0 - h;
			double em = mc_energy_smooth(8, p, pred, 0.1, NULL);
			p[k] = p0;
			CHECK_NEAR(g[k], (ep - em) / (2 * h), 1e-4 * fmax(fabs(g[k]), 1e-4));
		}
	}
	double p[2] = {1, 2}, pred[2] = {1, 0};
	CHECK_NEAR(mc_energy_smooth(2, p, pred, 0.1, NULL), 0.1 * (sqrt(5) - 1), 1e-15);
	CHECK(mc_energy_smooth(2, pred, pred, 0.1, NULL) == 0);
}

/* Density of the 3D scene at a point (eq. 4.1). */
static double density_at(const mc_scene *s, mc_vec3 x)
{
	double d = 0;
	for (int q = 0; q < s->n; q++)
		d += s->c[q] * exp(-mc_v3_norm2(mc_v3_sub(x, s->mu[q])) / (2 * s->sigma[q] * s->sigma[q]));
	return d;
}

/* Integral of f over [0, S] by composite Simpson with n (even) intervals. */
static double simpson_density(const mc_scene *s, mc_vec3 o, mc_vec3 n, double S, int steps)
{
	double h = S / steps, sum = 0;
	for (int i = 0; i <= steps; i++) {
		double wgt = (i == 0 || i == steps) ? 1 : (i % 2 ? 4 : 2);
		sum += wgt * density_at(s, mc_v3_axpy(i * h, n, o));
	}
	return sum * h / 3;
}

/* Eq. 4.6 against a direct numerical integral of the 3D density along the
 * ray (eq. 4.2), which checks the projection eq. 4.4 too; and the identity
 * the continuous model guarantees: int_0^S T D ds = 1 - T(S). */
static void test_transmittance(void)
{
	unsigned long long rng = 23;
	for (int trial = 0; trial < 20; trial++) {
		mc_vec3 o = mc_v3(urand(&rng, -1, 1), 0, 0), n = rand_unit(&rng);
		mc_scene s;
		random_scene(trial % 2 ? SCENE_NEAR_CAMERA : SCENE_SCATTERED, 6, &rng, o, n, &s);
		double prev = 1;
		for (double S = 0.25; S <= 4; S += 0.25) {
			double T = mc_ray_transmittance(&s, o, n, S);
			double depth = simpson_density(&s, o, n, S, 4000);
			/* culled or faded Gaussians (c' < 2e-5) make up at most this much depth */
			double cull_slack = 0;
			for (int q = 0; q < s.n; q++)
				if (ray_magnitude(&s, q, o, n) < 2 * MC_CULL_MAGNITUDE)
					cull_slack += 2.6 * s.sigma[q] * 2 * MC_CULL_MAGNITUDE;
			CHECK_MSG(fabs(-log(T) - depth) < 1e-8 * fmax(1, depth) + cull_slack,
				  "T(%g) = %.12g, exp(-integral) = %.12g", S, T, exp(-depth));
			CHECK(T <= prev + 1e-15); /* non-increasing with depth */
			prev = T;
		}
		CHECK(mc_ray_transmittance(&s, o, n, -1) == 1 && mc_ray_transmittance(&s, o, n, 0) == 1);

		/* int_0^S T(s) D(s) ds + T(S) = 1, D the density on the ray */
		double S = 6, h = S / 6000, integral = 0;
		for (int i = 0; i <= 6000; i++) {
			double t = i * h, wgt = (i == 0 || i == 6000) ? 1 : (i % 2 ? 4 : 2);
			integral += wgt * mc_ray_transmittance(&s, o, n, t) * density_at(&s, mc_v3_axpy(t, n, o));
		}
		integral *= h / 3;
		double vis[MC_MAX_GAUSSIANS], b;
		mc_ray_visibility(&s, o, n, vis, &b);
		CHECK_NEAR(integral + mc_ray_transmittance(&s, o, n, S), 1, 1e-6);
		/* B is T at infinity */
		CHECK_NEAR(b, mc_ray_transmittance(&s, o, n, 50), 1e-12);
	}
}

/* What the sampled model does and does not guarantee about sum_q V_q + B
 * (docs/ENERGY.md, "Visibility budget"). */
static void test_visibility_budget(void)
{
	mc_vec3 o = mc_v3(0, 0, 0), n = mc_v3(0, 0, 1);
	mc_scene s;
	empty_scene(&s, 1);
	s.mu[0] = mc_v3(0, 0, 3);
	s.sigma[0] = 0.1;
	/* eq. 5.5's closed form holds for a Gaussian well in front */
	s.c[0] = 13;
	double v, b;
	mc_ray_visibility(&s, o, n, &v, &b);
	CHECK_NEAR(b, exp(-sqrt(2 * M_PI) * 0.1 * 13), 1e-12);
	/* thin medium: V / (sigma c') -> sum_k exp(-k^2/2), 1 - B -> sqrt(2 pi) sigma c' */
	double ksum = 0;
	for (int k = 0; k <= 4; k++)
		ksum += exp(-0.5 * k * k);
	/* (a narrow Gaussian, so that c' stays clear of the culling band) */
	s.c[0] = 4 * MC_CULL_MAGNITUDE;
	s.sigma[0] = 1e-4 / s.c[0];
	mc_ray_visibility(&s, o, n, &v, &b);
	CHECK_NEAR(v / 1e-4, ksum, 1e-3);
	CHECK_NEAR((1 - b) / 1e-4, sqrt(2 * M_PI), 1e-3);
	s.sigma[0] = 0.1;
	/* A single Gaussian from thin to dense (sigma c' up to 10, beyond the
	 * opacity of the thesis' m = 0.1 model): 0.87 <= V + B <= 1 */
	double lo = 2, hi = 0;
	const double x_min = fmax(1e-3, 2.5 * MC_CULL_MAGNITUDE * 0.1); /* clear of the culling band */
	for (double x = x_min; x <= 10; x *= 1.05) {
		s.c[0] = x / 0.1;
		mc_ray_visibility(&s, o, n, &v, &b);
		lo = fmin(lo, v + b), hi = fmax(hi, v + b);
		CHECK(v > 0 && b > 0 && b < 1);
	}
	printf("single Gaussian, sigma c' in [%g, 10]: V + B in [%.4f, %.4f]\n", x_min, lo, hi);
	CHECK(lo > 0.87 && hi <= 1.0);
	/* an opaque occluder passes on almost nothing: the Gaussians behind it
	 * and the background are all but invisible, V_occluder + B ~ 1 */
	s.n = 2;
	s.background = false;
	s.c[0] = 30; /* sigma c' = 3 */
	s.mu[1] = mc_v3(0, 0, 4);
	s.sigma[1] = 0.1;
	s.c[1] = 30;
	double vis[2];
	mc_ray_visibility(&s, o, n, vis, &b);
	CHECK(vis[1] < 1e-3 && b < 1e-3);
	CHECK_NEAR(vis[0] + vis[1] + b, 1, 0.01);
}

static void test_occlusion(void)
{
	mc_vec3 o = mc_v3(0, 0, 0), n = mc_v3(0, 0, 1);
	mc_scene s;
	empty_scene(&s, 2);
	s.mu[0] = mc_v3(0, 0, 2), s.sigma[0] = 0.2, s.c[0] = 50;   /* opaque, in front */
	s.mu[1] = mc_v3(0, 0, 4), s.sigma[1] = 0.2, s.c[1] = 50;   /* behind it */
	double both[2], b, alone[2], b_alone;
	mc_ray_visibility(&s, o, n, both, &b);
	mc_scene single = s;
	single.n = 1;
	single.mu[0] = s.mu[1];
	mc_ray_visibility(&single, o, n, alone, &b_alone);
	CHECK(alone[0] > 0.5);
	CHECK(both[1] < 1e-3 * alone[0]);
	CHECK(both[0] > 0.5);
	/* the one behind does not dim the one in front */
	single.mu[0] = s.mu[0];
	mc_ray_visibility(&single, o, n, alone, &b_alone);
	CHECK_NEAR(both[0], alone[0], 1e-9);
	/* moved aside so that a ray through it passes 4 sigma from the
	 * occluder, the back Gaussian shows */
	s.mu[1] = mc_v3(1.6, 0, 4);
	mc_ray_visibility(&s, o, mc_v3_normalize(mc_v3(0.4, 0, 1)), both, &b);
	CHECK(both[1] > 0.5);
	/* a Gaussian entirely behind the camera is not seen, nor occludes */
	s.mu[1] = mc_v3(0, 0, -2);
	mc_ray_visibility(&s, o, n, both, &b);
	CHECK(both[1] == 0);
	CHECK_NEAR(both[0], alone[0], 1e-9);
	/* rendering is the visibility-weighted albedo plus background */
	double albedo[2][3] = {{1, 0, 0}, {0, 1, 0}}, bg[3] = {0, 0, 1}, rgb[3];
	mc_ray_render_rgb(&s, (const double(*)[3])albedo, o, n, bg, rgb);
	CHECK_NEAR(rgb[0], both[0], 1e-12);
	CHECK_NEAR(rgb[1], both[1], 1e-12);
	CHECK_NEAR(rgb[2], b, 1e-12);
}

/* Culling: below c' = MC_CULL_MAGNITUDE a Gaussian is skipped on the ray,
 * above twice that it counts fully, and in between it is faded in so that
 * visibility and its gradient stay continuous (no jump at the threshold). */
static void test_culling_edge(void)
{
	mc_vec3 o = mc_v3(0, 0, 0), n = mc_v3(0, 0, 1);
	mc_scene s;
	empty_scene(&s, 2);
	s.mu[0] = mc_v3(0, 0, 2), s.sigma[0] = 0.1, s.c[0] = 5;   /* on the ray */
	s.sigma[1] = 0.1, s.c[1] = 1e4;                         /* in front, sideways */
	double w[2] = {0.5, 1};
	/* lateral offset where the unculled c'_1 equals r * MC_CULL_MAGNITUDE */
#define OFFSET_AT(r) (0.1 * sqrt(2 * log(1e4 / ((r)*MC_CULL_MAGNITUDE))))
	double vis[2], b;
	s.mu[1] = mc_v3(OFFSET_AT(0.99), 0, 1.0);
	mc_ray_visibility(&s, o, n, vis, &b);
	CHECK(vis[1] == 0);
	double alone[2];
	mc_scene single = s;
	single.n = 1;
	mc_ray_visibility(&single, o, n, alone, &b);
	CHECK(vis[0] == alone[0]); /* nor does it occlude */
	s.mu[1] = mc_v3(OFFSET_AT(2.01), 0, 1.0);
	mc_ray_visibility(&s, o, n, vis, &b);
	double full = 2.01 * MC_CULL_MAGNITUDE * 0.1; /* sigma c' */
	/* alone on the ray: V = sum_k a e^{-k^2/2} T(s_k), T(s_k) = exp(-a
	 * sqrt(pi/2) (1 + erf(k / sqrt2))) */
	double expect = 0;
	for (int k = -4; k <= 0; k++)
		expect += full * exp(-0.5 * k * k) * exp(-full * sqrt(M_PI / 2) * (1 + erf(k / sqrt(2.0))));
	CHECK_NEAR(vis[1], expect, 1e-3 * expect);
	/* across the band, finely sampled: continuous value and derivative */
	double x0 = OFFSET_AT(2.2), x1 = OFFSET_AT(0.9);
	double prev_v = -1, prev_d = 0, max_jump_v = 0, max_jump_d = 0, dmax = 0;
	int steps = 2000;
	for (int i = 0; i <= steps; i++) {
		s.mu[1] = mc_v3(x0 + (x1 - x0) * i / steps, 0, 1.0);
		mc_vec3 dmu[2] = {{0, 0, 0}, {0, 0, 0}};
		double ds[2] = {0, 0};
		double e = mc_ray_weighted_visibility(&s, o, n, w, NULL, dmu, ds);
		if (i > 0) {
			max_jump_v = fmax(max_jump_v, fabs(e - prev_v));
			max_jump_d = fmax(max_jump_d, fabs(dmu[1].x - prev_d));
		}
		dmax = fmax(dmax, fabs(dmu[1].x));
		prev_v = e, prev_d = dmu[1].x;
	}
	/* a step of (x1 - x0) / steps moves E by at most |dE/dx| times that */
	CHECK(max_jump_v <= 1.01 * dmax * (x1 - x0) / steps);
	CHECK(max_jump_d < 0.05 * dmax);
	/* and the gradient matches finite differences inside the band, where
	 * c' changes by 4% per 1e-3 sigma of sigma: smaller steps */
	for (double r = 1.1; r < 2; r += 0.2) {
		s.mu[1] = mc_v3(OFFSET_AT(r), 0.01, 1.0);
		ray_ctx ctx = {o, n, w, NULL, 0};
		fd_check_step("weighted visibility, culling band", &s, weighted_vis_fn, &ctx, 1e-5);
	}
#undef OFFSET_AT
}

/* A Gaussian masked out by `active` behaves as if it were not in the scene. */
static void test_dropout_mask(void)
{
	unsigned long long rng = 29;
	for (int trial = 0; trial < 20; trial++) {
		mc_vec3 o = mc_v3(0, 0, 0), n = rand_unit(&rng);
		mc_scene s, reduced;
		random_scene(trial % 2 ? SCENE_LINED_UP : SCENE_SCATTERED, 7, &rng, o, n, &s);
		int drop = trial % 7;
		unsigned char active[MC_MAX_GAUSSIANS];
		double w[MC_MAX_GAUSSIANS], wr[MC_MAX_GAUSSIANS];
		memset(&reduced, 0, sizeof(reduced));
		for (int q = 0, r = 0; q < s.n; q++) {
			active[q] = q != drop;
			w[q] = urand(&rng, -1, 1);
			if (q == drop)
				continue;
			reduced.mu[r] = s.mu[q], reduced.sigma[r] = s.sigma[q], reduced.c[r] = s.c[q];
			wr[r++] = w[q];
			reduced.n = r;
		}
		mc_vec3 dmu[MC_MAX_GAUSSIANS] = {{0, 0, 0}}, dmur[MC_MAX_GAUSSIANS] = {{0, 0, 0}};
		double ds[MC_MAX_GAUSSIANS] = {0}, dsr[MC_MAX_GAUSSIANS] = {0};
		double e = mc_ray_weighted_visibility(&s, o, n, w, active, dmu, ds);
		double er = mc_ray_weighted_visibility(&reduced, o, n, wr, NULL, dmur, dsr);
		CHECK_NEAR(e, er, 1e-14);
		CHECK(mc_v3_norm(dmu[drop]) == 0 && ds[drop] == 0);
		for (int q = 0, r = 0; q < s.n; q++) {
			if (q == drop)
				continue;
			CHECK_NEAR(mc_v3_norm(mc_v3_sub(dmu[q], dmur[r])), 0, 1e-12);
			CHECK_NEAR(ds[q], dsr[r], 1e-12);
			r++;
		}
	}
}

static void test_hsv(void)
{
	unsigned long long rng = 31;
	for (int i = 0; i < 10000; i++) {
		double rgb[3] = {mc_test_rand(&rng), mc_test_rand(&rng), mc_test_rand(&rng)}, hsv[3], back[3];
		if (i % 10 == 0)
			rgb[1] = rgb[2] = rgb[0]; /* greys */
		mc_rgb_to_hsv(rgb, hsv);
		CHECK(hsv[0] >= 0 && hsv[0] < 1 && hsv[1] >= 0 && hsv[1] <= 1 && hsv[2] >= 0 && hsv[2] <= 1);
		mc_hsv_to_rgb(hsv, back);
		for (int c = 0; c < 3; c++)
			CHECK_NEAR(back[c], rgb[c], 1e-12);
	}
	double red[3] = {1, 0, 0}, green[3] = {0, 1, 0}, blue[3] = {0, 0, 1}, grey[3] = {0.5, 0.5, 0.5}, hsv[3];
	mc_rgb_to_hsv(red, hsv);
	CHECK(hsv[0] == 0 && hsv[1] == 1 && hsv[2] == 1);
	mc_rgb_to_hsv(green, hsv);
	CHECK_NEAR(hsv[0], 1.0 / 3, 1e-15);
	mc_rgb_to_hsv(blue, hsv);
	CHECK_NEAR(hsv[0], 2.0 / 3, 1e-15);
	mc_rgb_to_hsv(grey, hsv);
	CHECK(hsv[1] == 0 && hsv[2] == 0.5);
	double magenta_ish[3] = {1, 0, 0.1};
	mc_rgb_to_hsv(magenta_ish, hsv);
	CHECK(hsv[0] > 0.9 && hsv[0] < 1); /* wraps to just below 1, not negative */
}

static void test_dissimilarity(void)
{
	unsigned long long rng = 37;
	for (int i = 0; i < 10000; i++) {
		double m[3] = {mc_test_rand(&rng), mc_test_rand(&rng), mc_test_rand(&rng)};
		double im[3] = {mc_test_rand(&rng), mc_test_rand(&rng), mc_test_rand(&rng)};
		if (i % 7 == 0)
			m[1] = 0; /* grey model colours: w_s = 0 */
		CHECK_NEAR(mc_hsv_dissimilarity(m, m), -1, 1e-15);
		double d = mc_hsv_dissimilarity(m, im);
		CHECK(d >= -1 && d <= 1);
	}
	/* saturated model colour: opposite hue is maximally dissimilar, and d
	 * grows with the hue distance */
	double m[3] = {0.0, 1, 1}, opp[3] = {0.5, 1, 1};
	CHECK_NEAR(mc_hsv_dissimilarity(m, opp), 1, 1e-15);
	double prev = -1;
	for (double dh = 0.02; dh <= 0.5; dh += 0.02) {
		double im[3] = {dh, 1, 1};
		double d = mc_hsv_dissimilarity(m, im);
		CHECK(d > prev);
		prev = d;
	}
	/* hue wraps around: 0.02 vs 0.98 is as close as 0.50 vs 0.54 */
	double a[3] = {0.02, 0.9, 0.8}, b[3] = {0.98, 0.9, 0.8}, c[3] = {0.50, 0.9, 0.8}, e[3] = {0.54, 0.9, 0.8};
	CHECK_NEAR(mc_hsv_dissimilarity(a, b), mc_hsv_dissimilarity(c, e), 1e-12);
	CHECK(mc_hsv_dissimilarity(a, b) < mc_hsv_dissimilarity(a, c));
	/* grey model colour (s = 0): hue is ignored */
	double g[3] = {0.0, 0.0, 0.7}, gh[3] = {0.6, 0.0, 0.7};
	CHECK_NEAR(mc_hsv_dissimilarity(g, gh), -1, 1e-15);
	/* black model colour: only value (and saturation) matter, white is far */
	double k[3] = {0.3, 0.0, 0.0}, white[3] = {0.8, 0.0, 1.0};
	CHECK(mc_hsv_dissimilarity(k, white) == 1);
	/* out-of-range input is clamped, never NaN */
	double wild[3] = {-3.2, 2, -1}, wild2[3] = {7.7, -1, 3};
	CHECK(isfinite(mc_hsv_dissimilarity(wild, wild2)));
}

int main(void)
{
	test_hsv();
	test_dissimilarity();
	test_transmittance();
	test_visibility_budget();
	test_occlusion();
	test_dropout_mask();
	test_culling_edge();
	test_weighted_visibility_gradients();
	test_color_energy();
	test_detection_energy();
	test_pose_energy();
	test_smooth_energy();
	printf("finite differences: %d entries checked (max relative error %.3g), %d negligible\n", fd_all.checked,
	       fd_all.max_rel, fd_all.negligible);
	CHECK(fd_all.checked > 1000);
	return mc_test_finish("test_energy");
}
