/* mc_energy: reference image formation model and energy (plain C, double).
 *
 * The formulas and their derivatives are written out in docs/ENERGY.md; the
 * comments here cite the thesis equations and the sections of that page.
 *
 * Per ray, the Gaussians that take part (active and not culled) are first
 * projected to 1D Gaussians along the ray (ray_project, eq. 4.4).  Everything
 * else -- transmittance (eq. 4.6), Gaussian visibility (eq. 4.10),
 * background visibility (eq. 5.5) and the gradients -- works on that
 * projected set only, so a dropped or culled Gaussian neither contributes
 * nor occludes. */
#include "energy/mc_energy.h"

#include <math.h>
#include <string.h>

#define SQRT_PI_2 1.25331413731550025121   /* sqrt(pi / 2) */
#define SQRT_2 1.41421356237309504880

/* One Gaussian projected onto one ray (thesis eq. 4.3-4.4). */
typedef struct {
	int q;          /* index in the scene */
	mc_vec3 d;      /* mu_q - o */
	double m;       /* mu'_q = d.n, depth of the 1D mean along the ray */
	double r2;      /* |d|^2 - m^2, squared distance of mu_q from the ray */
	double sigma;   /* sigma'_q = sigma_q */
	double c;       /* c'_q = c_q exp(-r2 / (2 sigma^2)) f(c'_q / C), culling faded in */
	double c0;      /* c_q exp(-r2 / (2 sigma^2)) before the fade */
	double dc;      /* d c' / d c0, the fade's chain factor */
	double a;       /* sqrt(pi/2) sigma c', scale of the erf terms */
	double erf0;    /* erf(m / (sqrt2 sigma)) = -erf(-m / (sqrt2 sigma)) */
	double v, ev;   /* v = m / (sqrt2 sigma), ev = exp(-v^2) (gradient only) */
} ray_gauss;

typedef struct {
	int n;
	ray_gauss g[MC_MAX_GAUSSIANS];
} ray_set;

/* Sample offsets k of K = {-4..0} and their Gaussian factors exp(-k^2/2):
 * G_q(s_k) = c'_q exp(-k^2/2) for s_k = mu'_q + k sigma_q. */
static const double sample_k[MC_VIS_SAMPLES] = {-4, -3, -2, -1, 0};
static const double sample_w[MC_VIS_SAMPLES] = {
	3.35462627902511838821e-04, /* exp(-8)   */
	1.11089965382423206e-02,    /* exp(-4.5) */
	1.35335283236612691894e-01, /* exp(-2)   */
	6.06530659712633423604e-01, /* exp(-0.5) */
	1.0,
};

/* Culling (thesis 4.2.3) with a smooth edge: a ray Gaussian of magnitude
 * c' < C = MC_CULL_MAGNITUDE is skipped, and between C and 2C it is faded
 * in by f(r) = smootherstep(r - 1), r = c' / C, so that the energy stays C2
 * in the Gaussians' parameters (docs/ENERGY.md, "Culling").  Returns the
 * faded magnitude c' f(r) and its derivative f(r) + r f'(r). */
static double cull_fade(double c, double *dfade)
{
	double x = c / MC_CULL_MAGNITUDE - 1;
	if (x >= 1) {
		*dfade = 1;
		return c;
	}
	double x2 = x * x, y = 1 - x;
	double f = x2 * x * (x * (6 * x - 15) + 10), df_dx = 30 * x2 * y * y;
	*dfade = f + (x + 1) * df_dx;
	return c * f;
}

static bool gauss_active(const unsigned char *active, int q)
{
	return active == NULL || active[q] != 0;
}

/* Projects the scene onto the ray (o, n), n unit length (eq. 4.4), and
 * drops Gaussians masked out by `active` or with c'_q <= MC_CULL_MAGNITUDE
 * (thesis 4.2.3; faded in up to twice that, see cull_fade).  Non-positive
 * sigma or c never take part. */
static void ray_project(const mc_scene *scene, mc_vec3 o, mc_vec3 n, const unsigned char *active,
			ray_set *rs)
{
	rs->n = 0;
	for (int q = 0; q < scene->n; q++) {
		if (!gauss_active(active, q) || !(scene->sigma[q] > 0) || !(scene->c[q] > 0))
			continue;
		ray_gauss g;
		g.q = q;
		g.d = mc_v3_sub(scene->mu[q], o);
		g.m = mc_v3_dot(g.d, n);
		g.r2 = fmax(0.0, mc_v3_norm2(g.d) - g.m * g.m);
		g.sigma = scene->sigma[q];
		g.c0 = scene->c[q] * exp(-g.r2 / (2 * g.sigma * g.sigma));
		if (!(g.c0 > MC_CULL_MAGNITUDE))
			continue;
		g.c = cull_fade(g.c0, &g.dc);
		g.a = SQRT_PI_2 * g.sigma * g.c;
		g.v = g.m / (SQRT_2 * g.sigma);
		g.erf0 = erf(g.v);
		g.ev = exp(-g.v * g.v);
		rs->g[rs->n++] = g;
	}
}

/* Optical depth of one ray Gaussian from the camera to depth s: the
 * integral of its 1D density over [0, s] (the summand of eq. 4.6),
 * A_p(s) = a_p (erf((s - mu'_p) / (sqrt2 sigma_p)) + erf(mu'_p / (sqrt2 sigma_p))). */
static double gauss_depth(const ray_gauss *g, double s)
{
	return g->a * (erf((s - g->m) / (SQRT_2 * g->sigma)) + g->erf0);
}

/* T(s) = exp(-sum_p A_p(s)) (eq. 4.6), for s >= 0. */
static double ray_set_transmittance(const ray_set *rs, double s)
{
	double depth = 0;
	for (int p = 0; p < rs->n; p++)
		depth += gauss_depth(&rs->g[p], s);
	return exp(-depth);
}

/* Where a visibility sample lies relative to the camera (docs/ENERGY.md,
 * "Samples near the camera").  The thesis' samples s_k = mu' + k lambda may
 * fall behind the camera (s < 0) for Gaussians close to it, where eq. 4.6
 * gives T > 1 and light that never reaches the camera would be counted.
 * Within a band of width lambda around the camera, x = s / lambda + 1/2 in
 * (0, 1), the sample is faded out by h(x) = x^3 (6x^2 - 15x + 10) and T is
 * read at t = lambda (x^3 - x^4 / 2), a soft clamp of s to >= 0 with
 * dt/ds = 3x^2 - 2x^3.  Both are C2 across the band's edges.  Outside the
 * band (s >= lambda/2) this is exactly the thesis' sample; behind it
 * (s <= -lambda/2) the sample is dropped. */
typedef struct {
	double h, dh_ds, dh_dl; /* sample weight and its derivatives (s, lambda) */
	double t, dt_ds, dt_dl; /* depth at which T is read */
} sample_pos;

static sample_pos near_camera(double s, double lambda)
{
	sample_pos sp;
	double x = s / lambda + 0.5;
	if (x >= 1) {
		sp = (sample_pos){1, 0, 0, s, 1, 0};
	} else if (x <= 0) {
		sp = (sample_pos){0, 0, 0, 0, 0, 0};
	} else {
		double x2 = x * x, y = 1 - x;
		double dh_dx = 30 * x2 * y * y;
		sp.h = x2 * x * (x * (6 * x - 15) + 10);
		sp.dh_ds = dh_dx / lambda;
		sp.dh_dl = -dh_dx * s / (lambda * lambda);
		sp.t = lambda * x2 * x * (1 - 0.5 * x);
		sp.dt_ds = x2 * (3 - 2 * x);
		sp.dt_dl = 1.5 * x2 * y * y;
	}
	return sp;
}

/* V_q = sum_k lambda_q h_k T(t_k) G_q(s_k), lambda_q = sigma_q (eq. 4.10
 * with the near-camera rule; h_k = 1, t_k = s_k away from the camera). */
static double ray_set_visibility(const ray_set *rs, int i)
{
	const ray_gauss *g = &rs->g[i];
	double v = 0;
	for (int k = 0; k < MC_VIS_SAMPLES; k++) {
		sample_pos sp = near_camera(g->m + sample_k[k] * g->sigma, g->sigma);
		if (sp.h > 0)
			v += sample_w[k] * sp.h * ray_set_transmittance(rs, sp.t);
	}
	return g->sigma * g->c * v;
}

/* B = T(infinity) = exp(-sum_q a_q (1 + erf(mu'_q / (sqrt2 sigma_q)))): the
 * exact integral of eq. 5.5 over the ray in front of the camera; it equals
 * eq. 5.5's closed form exp(-sqrt(2 pi) sum_q sigma_q c'_q) for Gaussians
 * well in front of the camera (erf -> 1). */
static double ray_set_background(const ray_set *rs)
{
	double depth = 0;
	for (int p = 0; p < rs->n; p++)
		depth += rs->g[p].a * (1 + rs->g[p].erf0);
	return exp(-depth);
}

void mc_ray_visibility(const mc_scene *scene, mc_vec3 o, mc_vec3 n, double *vis, double *background)
{
	ray_set rs;
	ray_project(scene, o, n, NULL, &rs);
	for (int q = 0; q < scene->n; q++)
		vis[q] = 0;
	for (int i = 0; i < rs.n; i++)
		vis[rs.g[i].q] = ray_set_visibility(&rs, i);
	if (background)
		*background = ray_set_background(&rs);
}

double mc_ray_visibility_of(const mc_scene *scene, mc_vec3 o, mc_vec3 n, int q)
{
	ray_set rs;
	ray_project(scene, o, n, NULL, &rs);
	for (int i = 0; i < rs.n; i++)
		if (rs.g[i].q == q)
			return ray_set_visibility(&rs, i);
	return 0; /* culled on this ray */
}

double mc_ray_transmittance(const mc_scene *scene, mc_vec3 o, mc_vec3 n, double s)
{
	if (s <= 0)
		return 1; /* no medium between the camera and itself */
	ray_set rs;
	ray_project(scene, o, n, NULL, &rs);
	return ray_set_transmittance(&rs, s);
}

void mc_ray_render_rgb(const mc_scene *scene, const double albedo_rgb[][3], mc_vec3 o, mc_vec3 n,
		       const double bg_rgb[3], double out_rgb[3])
{
	ray_set rs;
	ray_project(scene, o, n, NULL, &rs);
	double b = ray_set_background(&rs);
	for (int ch = 0; ch < 3; ch++)
		out_rgb[ch] = b * bg_rgb[ch];
	for (int i = 0; i < rs.n; i++) {
		double v = ray_set_visibility(&rs, i);
		for (int ch = 0; ch < 3; ch++)
			out_rgb[ch] += v * albedo_rgb[rs.g[i].q][ch];
	}
}

/* ---- gradient of E = sum_q w_q V_q (docs/ENERGY.md, "Gradient") ----
 *
 * Accumulated per ray Gaussian p with respect to its own 1D parameters:
 * gm = dE/dmu'_p, gs = dE/dsigma_p (explicit, c'_p held fixed),
 * gc = dE/dc'_p; ray_set_scatter then applies the chain rule of eq. 4.4. */
typedef struct {
	double gm[MC_MAX_GAUSSIANS], gs[MC_MAX_GAUSSIANS], gc[MC_MAX_GAUSSIANS];
} ray_grad;

/* Per-sample scratch: each ray Gaussian's u = (s - mu') / (sqrt2 sigma),
 * exp(-u^2), erf(u) and A_p(s) at the current sample depth s. */
typedef struct {
	double u[MC_MAX_GAUSSIANS], eu[MC_MAX_GAUSSIANS], erfu[MC_MAX_GAUSSIANS], A[MC_MAX_GAUSSIANS];
} sample_terms;

/* Fills the per-Gaussian terms at depth s and returns T(s). */
static double sample_eval(const ray_set *rs, double s, sample_terms *st)
{
	double depth = 0;
	for (int p = 0; p < rs->n; p++) {
		const ray_gauss *g = &rs->g[p];
		st->u[p] = (s - g->m) / (SQRT_2 * g->sigma);
		st->eu[p] = exp(-st->u[p] * st->u[p]);
		st->erfu[p] = erf(st->u[p]);
		st->A[p] = g->a * (st->erfu[p] + g->erf0);
		depth += st->A[p];
	}
	return exp(-depth);
}

/* Adds the gradient of one visibility sample term
 * beta = w_i exp(-k^2/2) h_k sigma_i c'_i T(t_k), s_k = mu'_i + k sigma_i,
 * where st holds the terms at t_k and T = T(t_k). */
static void sample_backprop(const ray_set *rs, int i, double k, double wk, const sample_pos *sp, double T,
			    const sample_terms *st, ray_grad *gr)
{
	const ray_gauss *gi = &rs->g[i];
	double beta = wk * sp->h * gi->sigma * gi->c * T;
	/* the factor sigma_i c'_i */
	gr->gc[i] += wk * sp->h * gi->sigma * T;
	gr->gs[i] += wk * sp->h * gi->c * T;
	/* T(t) = exp(-sum_p A_p(t)): dT = -T sum_p dA_p, t held fixed */
	double density = 0; /* D(t) = sum_p G_p(t) = dA/dt */
	for (int p = 0; p < rs->n; p++) {
		const ray_gauss *g = &rs->g[p];
		double G = g->c * st->eu[p];
		density += G;
		gr->gm[p] -= beta * (g->c * g->ev - G);                  /* dA_p/dmu'_p */
		gr->gs[p] -= beta * (st->A[p] / g->sigma                  /* dA_p/dsigma_p */
				     - SQRT_2 * g->c * (st->u[p] * st->eu[p] + g->v * g->ev));
		gr->gc[p] -= beta * SQRT_PI_2 * g->sigma * (st->erfu[p] + g->erf0); /* dA_p/dc'_p */
	}
	/* h and t depend on the sample depth s and on lambda = sigma_i */
	double dE_dt = -beta * density;
	double dE_dh = wk * gi->sigma * gi->c * T;
	double dE_ds = dE_dt * sp->dt_ds + dE_dh * sp->dh_ds;
	gr->gs[i] += dE_dt * sp->dt_dl + dE_dh * sp->dh_dl;
	/* s_k moves with mu'_i (ds/dmu' = 1) and sigma_i (ds/dsigma = k) */
	gr->gm[i] += dE_ds;
	gr->gs[i] += k * dE_ds;
}

/* Chain rule of eq. 4.4 into the scene's dmu, dsigma.  With the unfaded
 * magnitude c0 = c_q exp(-r2 / (2 sigma^2)): dmu'/dmu = n,
 * dc0/dmu = -c0 (d - mu' n) / sigma^2, dc0/dsigma = c0 r2 / sigma^3, and
 * dc'/dc0 = g->dc. */
static void ray_set_scatter(const ray_set *rs, mc_vec3 n, const ray_grad *gr, mc_vec3 *dmu, double *dsigma)
{
	for (int p = 0; p < rs->n; p++) {
		const ray_gauss *g = &rs->g[p];
		double s2 = g->sigma * g->sigma;
		double gc0 = gr->gc[p] * g->dc * g->c0; /* dE/dc0 times c0 */
		mc_vec3 perp = mc_v3_axpy(-g->m, n, g->d); /* d - mu' n */
		if (dmu) {
			mc_vec3 d = mc_v3_axpy(gr->gm[p], n, mc_v3_scale(perp, -gc0 / s2));
			dmu[g->q] = mc_v3_add(dmu[g->q], d);
		}
		if (dsigma)
			dsigma[g->q] += gr->gs[p] + gc0 * g->r2 / (s2 * g->sigma);
	}
}

/* w_bg B, B = T(infinity) = exp(-sum_p A_p(infinity)): the background
 * term.  Its gradient is that of a visibility sample read at infinite
 * depth, where erf(u) = 1 and exp(-u^2) = 0. */
static double background_backprop(const ray_set *rs, double w_bg, ray_grad *gr)
{
	double e = w_bg * ray_set_background(rs);
	for (int p = 0; gr && p < rs->n; p++) {
		const ray_gauss *g = &rs->g[p];
		double A = g->a * (1 + g->erf0);
		gr->gm[p] -= e * g->c * g->ev;                                     /* dA_p/dmu'_p */
		gr->gs[p] -= e * (A / g->sigma - SQRT_2 * g->c * g->v * g->ev); /* dA_p/dsigma_p */
		gr->gc[p] -= e * SQRT_PI_2 * g->sigma * (1 + g->erf0);            /* dA_p/dc'_p */
	}
	return e;
}

/* sum_i w[i] V_i + w_bg B over the ray set (w indexed like rs->g), adding
 * the gradient into dmu/dsigma when either is given. */
static double ray_set_weighted(const ray_set *rs, const double *w, double w_bg, mc_vec3 n, mc_vec3 *dmu,
			       double *dsigma)
{
	bool want_grad = dmu || dsigma;
	ray_grad gr;
	if (want_grad)
		memset(&gr, 0, sizeof(gr));
	sample_terms st;
	double e = 0;
	for (int i = 0; i < rs->n; i++) {
		if (w[i] == 0)
			continue; /* contributes nothing; still occludes through T */
		if (!want_grad) {
			e += w[i] * ray_set_visibility(rs, i);
			continue;
		}
		for (int k = 0; k < MC_VIS_SAMPLES; k++) {
			sample_pos sp = near_camera(rs->g[i].m + sample_k[k] * rs->g[i].sigma, rs->g[i].sigma);
			if (!(sp.h > 0))
				continue;
			double T = sample_eval(rs, sp.t, &st);
			double wk = w[i] * sample_w[k];
			e += wk * sp.h * rs->g[i].sigma * rs->g[i].c * T;
			sample_backprop(rs, i, sample_k[k], wk, &sp, T, &st, &gr);
		}
	}
	if (w_bg != 0)
		e += background_backprop(rs, w_bg, want_grad ? &gr : NULL);
	if (want_grad)
		ray_set_scatter(rs, n, &gr, dmu, dsigma);
	return e;
}

double mc_ray_weighted_visibility_bg(const mc_scene *scene, mc_vec3 o, mc_vec3 n, const double *w,
				     double w_background, const unsigned char *active, mc_vec3 *dmu,
				     double *dsigma)
{
	ray_set rs;
	ray_project(scene, o, n, active, &rs);
	double wr[MC_MAX_GAUSSIANS];
	for (int i = 0; i < rs.n; i++)
		wr[i] = w[rs.g[i].q];
	return ray_set_weighted(&rs, wr, w_background, n, dmu, dsigma);
}

double mc_ray_weighted_visibility(const mc_scene *scene, mc_vec3 o, mc_vec3 n, const double *w,
				  const unsigned char *active, mc_vec3 *dmu, double *dsigma)
{
	return mc_ray_weighted_visibility_bg(scene, o, n, w, 0, active, dmu, dsigma);
}

/* ---- colour ---- */

void mc_rgb_to_hsv(const double rgb[3], double hsv[3])
{
	double r = rgb[0], g = rgb[1], b = rgb[2];
	double mx = fmax(r, fmax(g, b)), mn = fmin(r, fmin(g, b)), delta = mx - mn;
	double h = 0;
	if (delta > 0) {
		if (mx == r)
			h = (g - b) / delta;
		else if (mx == g)
			h = 2 + (b - r) / delta;
		else
			h = 4 + (r - g) / delta;
		h /= 6;
		if (h < 0)
			h += 1;
		if (h >= 1)
			h -= 1;
	}
	hsv[0] = h;
	hsv[1] = mx > 0 ? delta / mx : 0;
	hsv[2] = mx;
}

void mc_hsv_to_rgb(const double hsv[3], double rgb[3])
{
	double h = hsv[0] - floor(hsv[0]), s = hsv[1], v = hsv[2];
	double h6 = h * 6;
	int sector = (int)h6;
	if (sector > 5)
		sector = 5;
	double f = h6 - sector;
	double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
	double out[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
	memcpy(rgb, out[sector], sizeof(out[sector]));
}

static double clamp01(double x)
{
	return x < 0 ? 0 : (x > 1 ? 1 : x);
}

/* phi(x) = 1 - (1 - x)^4 (8x + 2): a smooth step from phi(0) = -1 to
 * phi(1) = 1 with phi'(0) = phi'(1) = 0. */
static double smooth_step(double x)
{
	double y = 1 - x, y2 = y * y;
	return 1 - y2 * y2 * (8 * x + 2);
}

/* Squared minimal angular hue distance, normalised to [0, 1]: hues are in
 * [0, 1) turns, the distance around the circle is at most 1/2. */
static double hue_distance2(double h1, double h2)
{
	double dh = fabs(h1 - h2);
	dh -= floor(dh);
	dh = fmin(dh, 1 - dh);
	return 4 * dh * dh;
}

double mc_hsv_dissimilarity(const double m_hsv[3], const double i_hsv[3])
{
	double ms = clamp01(m_hsv[1]), mv = clamp01(m_hsv[2]);
	double is = clamp01(i_hsv[1]), iv = clamp01(i_hsv[2]);
	/* saturated: hue, plus the saturation difference, because the hue of
	 * a grey pixel is undefined (0, i.e. red, for pure grey) and must not
	 * match a saturated model colour (a departure from ch. 6.2.1) */
	double d_s = fmin(1.0, hue_distance2(m_hsv[0], i_hsv[0]) + fabs(ms - is));
	double d_d = 2 * (mv - iv) * (mv - iv);         /* dark: value */
	double d_g = fabs(mv - iv) + fabs(ms - is);     /* grey: value + saturation */
	double w_s = sqrt(ms), w_d = fmax(0, 0.5 - mv), w_g = fmax(0, 0.5 - ms);
	double z = w_s + w_d + w_g;
	/* z >= 1/2 for every model colour in range (w_s = 0 forces w_g = 1/2);
	 * the guard only keeps NaN out for degenerate input. */
	if (!(z > 0))
		return smooth_step(clamp01(d_g));
	return smooth_step(clamp01((w_s * d_s + w_d * d_d + w_g * d_g) / z));
}

/* ---- energy terms ---- */

void mc_scene_from_model(const mc_model *model, const mc_fk *fk, mc_scene *scene)
{
	scene->n = model->ngauss;
	scene->background = false;
	for (int q = 0; q < model->ngauss; q++) {
		const mc_gauss_def *g = &model->gauss[q];
		scene->mu[q] = fk->mu[q];
		scene->sigma[q] = g->sigma;
		scene->c[q] = g->c;
		mc_rgb_to_hsv(g->rgb, scene->hsv[q]);
	}
}

/* E_color of one pixel: sum_q d(I, a_q) V_q (eq. 4.13), plus
 * B d(I, background) with a background colour model. */
static double pixel_color_energy(const mc_scene *scene, mc_vec3 o, mc_vec3 n, const float *pix_hsv,
				 mc_vec3 *dmu, double *dsigma)
{
	double i_hsv[3] = {pix_hsv[0], pix_hsv[1], pix_hsv[2]};
	ray_set rs;
	ray_project(scene, o, n, NULL, &rs);
	double w[MC_MAX_GAUSSIANS]; /* only for the Gaussians on this ray */
	for (int i = 0; i < rs.n; i++)
		w[i] = mc_hsv_dissimilarity(scene->hsv[rs.g[i].q], i_hsv);
	double w_bg = scene->background ? mc_hsv_dissimilarity(scene->background_hsv, i_hsv) : 0;
	return ray_set_weighted(&rs, w, w_bg, n, dmu, dsigma);
}

double mc_energy_color(const mc_scene *scene, const mc_view *view, const int *pixels, int npixels,
		       mc_vec3 *dmu, double *dsigma)
{
	const mc_raytable *rt = view->rays;
	int total = rt->width * rt->height;
	int count = pixels ? npixels : total;
	double e = 0;
	for (int j = 0; j < count; j++) {
		int pix = pixels ? pixels[j] : j;
		if (pix < 0 || pix >= total || !rt->valid[pix])
			continue;
		e += pixel_color_energy(scene, rt->origin, rt->dir[pix], view->hsv + 3 * (size_t)pix, dmu, dsigma);
	}
	return e;
}

int mc_detections_check(const mc_scene *scene, const mc_detection_ray *det, int ndet, mc_err *err)
{
	for (int k = 0; k < ndet; k++) {
		if (det[k].gauss < 0 || det[k].gauss >= scene->n)
			return mc_err_set(err, "detection %d: gauss %d: not a Gaussian of the scene (0..%d)", k,
					  det[k].gauss, scene->n - 1);
		if (!isfinite(det[k].conf) || det[k].conf < 0)
			return mc_err_set(err, "detection %d: conf: must be a finite number >= 0", k);
		if (!mc_v3_isfinite(det[k].o) || fabs(mc_v3_norm(det[k].n) - 1) > 1e-6)
			return mc_err_set(err, "detection %d: ray: origin must be finite and direction unit length",
					  k);
	}
	return 0;
}

double mc_energy_detection(const mc_scene *scene, const mc_detection_ray *det, int ndet, double weight,
			   mc_vec3 *dmu, double *dsigma)
{
	double w[MC_MAX_GAUSSIANS] = {0};
	double e = 0;
	for (int k = 0; k < ndet; k++) {
		int q = det[k].gauss;
		if (q < 0 || q >= scene->n || !(det[k].conf > 0))
			continue; /* mc_detections_check reports these */
		/* Only the detected Gaussian is weighted, but every Gaussian of the
		 * scene occludes it: a detection of a hidden joint pulls less. */
		w[q] = -weight * det[k].conf;
		e += mc_ray_weighted_visibility(scene, det[k].o, det[k].n, w, NULL, dmu, dsigma);
		w[q] = 0;
	}
	return e;
}

/* Pseudo-Huber loss huber(x) = sqrt(1 + x^2) - 1 and its derivative. */
static double huber(double x, double *dx)
{
	double r = sqrt(1 + x * x);
	*dx = x / r;
	return r - 1;
}

double mc_energy_pose(const mc_model *model, const double *pose, double lambda_limit, double lambda_pose,
		      double *grad)
{
	double e = 0;
	for (int j = 0; j < model->njoints; j++) {
		const mc_joint *jt = &model->joints[j];
		for (int a = 0; a < jt->ndof; a++) {
			int k = jt->dof0 + a;
			double p = pose[k];
			double over = fmax(0, p - jt->upper[a]), under = fmax(0, jt->lower[a] - p);
			double dh;
			e += lambda_limit * (over * over + under * under) + lambda_pose * huber(p, &dh);
			if (grad)
				grad[k] += lambda_limit * 2 * (over - under) + lambda_pose * dh;
		}
	}
	return e;
}

double mc_energy_smooth(int ndof, const double *pose, const double *pred, double lambda, double *grad)
{
	double e = 0;
	for (int k = 0; k < ndof; k++) {
		double dh;
		e += lambda * huber(pred[k] - pose[k], &dh);
		if (grad)
			grad[k] -= lambda * dh;
	}
	return e;
}
