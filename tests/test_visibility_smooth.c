/* The smoothness claim of thesis fig. 4.1 (ch. 4.1, 4.5.1): the visibility
 * of a sphere (one Gaussian) seen by the central pixel is smooth in the
 * sphere's position, with a continuous derivative at occlusion boundaries,
 * also where two boundaries meet (a sphere passing behind another one's
 * edge), unlike binary or partial-coverage visibility.
 *
 * Orthographic-like setup: one ray (the central pixel) along +z; spheres
 * of the thesis' smoothness m = 0.1 (mc_sphere_to_gaussian); positions in
 * metres.  Each scenario samples the visibility finely, compares the
 * analytic derivative with central differences, and checks that the
 * derivative has no jumps: its largest change between neighbouring samples
 * shrinks in proportion to the sample spacing (bounded second derivative),
 * a test that a kink fails (checked on partial-coverage visibility). */
#include "energy/mc_energy.h"
#include "body/mc_model.h"
#include "test_util.h"

#include <string.h>

#define M_SMOOTH 0.1

static const mc_vec3 ray_o = {0, 0, 0}, ray_n = {0, 0, 1};

/* A 1D function with its derivative, sampled at x. */
typedef double (*func1d)(double x, const void *ctx, double *dfdx);

/* Largest change of the derivative between samples spaced dx over [a, b],
 * divided by dx: an estimate of max |f''| that grows like 1/dx where f'
 * jumps. */
static double max_second_difference(func1d f, const void *ctx, double a, double b, double dx)
{
	double prev = 0, worst = 0;
	int n = (int)((b - a) / dx + 0.5);
	for (int i = 0; i <= n; i++) {
		double d;
		f(a + i * dx, ctx, &d);
		if (i > 0)
			worst = fmax(worst, fabs(d - prev) / dx);
		prev = d;
	}
	return worst;
}

/* True when f' is continuous around x0: refining the spacing by 8 near x0
 * leaves the second-difference bound about the same (a jump J in f'
 * would multiply it by about 8). */
static bool derivative_continuous_at(func1d f, const void *ctx, double x0, double half_width, double dx)
{
	double coarse = max_second_difference(f, ctx, x0 - half_width, x0 + half_width, dx);
	double fine = max_second_difference(f, ctx, x0 - half_width, x0 + half_width, dx / 8);
	printf("    around %+.3f: max |f''| estimate %.4g at step %.2g, %.4g at step %.2g\n", x0, coarse, dx, fine,
	       dx / 8);
	return fine < 1.5 * coarse + 1e-12;
}

/* Samples f on [a, b]: analytic derivative against central differences,
 * and f itself against the integral of its derivative between samples
 * (trapezoid rule), which a jump in f (e.g. hard culling) would break; the
 * samples are dense enough (12000 over the range) that the smooth culling
 * edge of even a large threshold stays far below the bound.
 * Returns the range of f through lo/hi. */
static void check_derivative(func1d f, const void *ctx, double a, double b, int n, const char *what, double *lo,
			     double *hi)
{
	double dmax = 0, errmax = 0, gapmax = 0, h = 1e-6, dx = (b - a) / n, v_prev = 0, d_prev = 0;
	*lo = INFINITY, *hi = -INFINITY;
	for (int i = 0; i <= n; i++) {
		double x = a + i * dx, d, dummy;
		double v = f(x, ctx, &d);
		double fd = (f(x + h, ctx, &dummy) - f(x - h, ctx, &dummy)) / (2 * h);
		dmax = fmax(dmax, fabs(d));
		errmax = fmax(errmax, fabs(d - fd));
		if (i > 0)
			gapmax = fmax(gapmax, fabs(v - v_prev - 0.5 * (d + d_prev) * dx));
		v_prev = v, d_prev = d;
		*lo = fmin(*lo, v), *hi = fmax(*hi, v);
	}
	printf("  %s: V in [%.4f, %.4f], max |dV/dx| %.4f, max |analytic - central difference| %.3g, "
	       "max step residual %.3g\n",
	       what, *lo, *hi, dmax, errmax, gapmax);
	CHECK_MSG(errmax < 1e-6 * dmax, "%s: derivative error %g", what, errmax);
	CHECK_MSG(gapmax < 1e-6 * (*hi - *lo), "%s: V jumps by %g between samples", what, gapmax);
}

/* ---- scenario 1 (fig. 4.1): a sphere moves vertically behind the edge
 * of an occluder; the central ray grazes the occluder's edge ---- */

typedef struct {
	mc_scene scene; /* [0] occluder, [1] moving sphere */
	double z;       /* the moving sphere's depth */
} two_spheres;

static double behind_edge(double y, const void *ctx, double *dvdy)
{
	two_spheres sc = *(const two_spheres *)ctx;
	sc.scene.mu[1] = mc_v3(0, y, sc.z);
	double w[2] = {0, 1};
	mc_vec3 dmu[2] = {{0, 0, 0}, {0, 0, 0}};
	double v = mc_ray_weighted_visibility(&sc.scene, ray_o, ray_n, w, NULL, dmu, NULL);
	*dvdy = dmu[1].y;
	return v;
}

/* ---- scenario 2: the occluder slides off the ray in front of a fixed
 * sphere (disocclusion through the transmittance) ---- */

static double occluder_slides(double y, const void *ctx, double *dvdy)
{
	two_spheres sc = *(const two_spheres *)ctx;
	sc.scene.mu[0] = mc_v3(0, y, sc.scene.mu[0].z);
	double w[2] = {0, 1};
	mc_vec3 dmu[2] = {{0, 0, 0}, {0, 0, 0}};
	double v = mc_ray_weighted_visibility(&sc.scene, ray_o, ray_n, w, NULL, dmu, NULL);
	*dvdy = dmu[0].y;
	return v;
}

/* ---- the detector's own check: partial pixel coverage of a solid sphere
 * (fig. 4.1's dashed line) is continuous but has kinks ---- */

typedef struct {
	double radius, pixel;
} coverage;

static double partial_coverage(double y, const void *ctx, double *dvdy)
{
	const coverage *c = ctx;
	double t = 0.5 + (c->radius - fabs(y)) / c->pixel; /* share of the pixel covered */
	if (t <= 0 || t >= 1) {
		*dvdy = 0;
		return t <= 0 ? 0 : 1;
	}
	*dvdy = (y > 0 ? -1 : 1) / c->pixel;
	return t;
}

static void sphere(mc_scene *s, int q, double radius, mc_vec3 centre)
{
	CHECK(mc_sphere_to_gaussian(radius, M_SMOOTH, &s->sigma[q], &s->c[q]) == 0);
	s->mu[q] = centre;
}

int main(void)
{
	const double r_occ = 0.5, r = 0.3;
	two_spheres sc;
	memset(&sc, 0, sizeof(sc));
	sc.scene.n = 2;
	sc.scene.background = false;
	sphere(&sc.scene, 0, r_occ, mc_v3(0, -r_occ, 4)); /* its upper edge on the ray */
	sphere(&sc.scene, 1, r, mc_v3(0, 0, 6));
	sc.z = 6;
	double lo, hi;

	printf("scenario 1: a sphere (r = %.2f) moves vertically behind the edge of an occluder (r = %.2f)\n", r,
	       r_occ);
	check_derivative(behind_edge, &sc, -1.5, 1.5, 12000, "moving sphere", &lo, &hi);
	CHECK(lo >= 0 && hi > 0.2);
	/* the double boundaries: the sphere's edges cross the ray where the
	 * occluder's edge is; and where the sphere is culled (c' = MC_CULL_MAGNITUDE) */
	double cull_y = sc.scene.sigma[1] * sqrt(2 * log(sc.scene.c[1] / MC_CULL_MAGNITUDE));
	double marks[4] = {-r, r, -cull_y, cull_y};
	for (int i = 0; i < 4; i++)
		CHECK(derivative_continuous_at(behind_edge, &sc, marks[i], 0.1, 1e-3));
	/* partly hidden: the occluder's edge dims it */
	double d, alone, with;
	with = behind_edge(0, &sc, &d);
	two_spheres single = sc;
	single.scene.c[0] = 0;
	alone = behind_edge(0, &single, &d);
	printf("  centred on the ray: V = %.3f with the occluder, %.3f without\n", with, alone);
	CHECK(with < 0.8 * alone && with > 0.1 * alone);

	printf("scenario 2: the occluder slides off the ray in front of a fixed sphere\n");
	sc.scene.mu[1] = mc_v3(0, 0, 6);
	check_derivative(occluder_slides, &sc, -1.5, 1.5, 12000, "fixed sphere", &lo, &hi);
	CHECK(lo < 0.05 && hi > 0.8); /* from hidden to visible */
	double occ_cull = sc.scene.sigma[0] * sqrt(2 * log(sc.scene.c[0] / MC_CULL_MAGNITUDE));
	double marks2[3] = {r_occ, r_occ + r, occ_cull};
	for (int i = 0; i < 3; i++)
		CHECK(derivative_continuous_at(occluder_slides, &sc, marks2[i], 0.1, 1e-3));

	printf("detector check: partial pixel coverage of a solid sphere has kinks at y = +-(r -+ pixel/2)\n");
	coverage cov = {r, 0.05};
	CHECK(!derivative_continuous_at(partial_coverage, &cov, r - 0.025, 0.1, 1e-3));
	CHECK(!derivative_continuous_at(partial_coverage, &cov, -r - 0.025, 0.1, 1e-3));
	return mc_test_finish("test_visibility_smooth");
}
