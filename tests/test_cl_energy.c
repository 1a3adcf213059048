/* Tests of core/energy/mc_cl: the OpenCL colour energy and its gradient against the
 * double-precision reference of core/energy/mc_energy.c on random scenes and on a
 * person seen by a head-mounted fisheye pair, over every pixel, pixel
 * subsets and with dropout; each camera's gradient apart from one launch;
 * missing cameras, device selection and argument errors.
 * Skips (77) when no OpenCL platform is present. */
#include "cl_scene.h"
#include "energy/mc_cl.h"
#include "test_util.h"

#include <string.h>

/* ---- reference: core/energy/mc_energy.c in double ---- */

/* A camera: ray table and image. */
typedef struct {
	mc_raytable rays;
	float *hsv;
} view;

/* E over pixel lists of several views (pixels NULL or pixels[c] NULL: every
 * pixel).  Without dropout this is mc_energy_color(); with dropout the
 * same sum through mc_ray_weighted_visibility_bg() with the backend's
 * dropout decisions as the `active` mask.  *abs_energy = sum |d_q| V_q
 * (+ |d_bg| B), the scale of the tolerances. */
static double ref_energy(const mc_scene *sc, const view *v, int nv, int *const *pixels, const int *npixels,
			 double dropout, uint32_t seed, mc_vec3 *dmu, double *dsigma, double *abs_energy)
{
	double E = 0;
	*abs_energy = 0;
	for (int c = 0; c < nv; c++) {
		const mc_raytable *t = &v[c].rays;
		const int *list = pixels ? pixels[c] : NULL;
		int n = list ? npixels[c] : t->width * t->height;
		if (dropout == 0) {
			mc_view view = {t, v[c].hsv};
			E += mc_energy_color(sc, &view, list, n, dmu, dsigma);
		}
		for (int i = 0; i < n; i++) {
			int px = list ? list[i] : i;
			if (!t->valid[px])
				continue;
			double w[MC_MAX_GAUSSIANS], wabs[MC_MAX_GAUSSIANS], ihsv[3];
			unsigned char keep[MC_MAX_GAUSSIANS];
			for (int k = 0; k < 3; k++)
				ihsv[k] = v[c].hsv[3 * px + k];
			for (int q = 0; q < sc->n; q++) {
				w[q] = mc_hsv_dissimilarity(sc->hsv[q], ihsv);
				wabs[q] = fabs(w[q]);
				keep[q] = !mc_cl_dropped(seed, c, px, q, dropout);
			}
			double wbg = sc->background ? mc_hsv_dissimilarity(sc->background_hsv, ihsv) : 0;
			if (dropout > 0)
				E += mc_ray_weighted_visibility_bg(sc, t->origin, t->dir[px], w, wbg, keep, dmu, dsigma);
			*abs_energy += mc_ray_weighted_visibility_bg(sc, t->origin, t->dir[px], wabs, fabs(wbg), keep,
								     NULL, NULL);
		}
	}
	return E;
}

/* ---- comparison helpers ---- */

typedef struct {
	double E, absE;
	mc_vec3 dmu[MC_MAX_GAUSSIANS];
	double dsigma[MC_MAX_GAUSSIANS];
} result;

static double max_abs_mu(const result *r, int n)
{
	double m = 0;
	for (int q = 0; q < n; q++)
		m = fmax(m, fmax(fabs(r->dmu[q].x), fmax(fabs(r->dmu[q].y), fabs(r->dmu[q].z))));
	return m;
}

static double max_abs_sigma(const result *r, int n)
{
	double m = 0;
	for (int q = 0; q < n; q++)
		m = fmax(m, fabs(r->dsigma[q]));
	return m;
}

/* Agreement within `rel`: the energy relative to sum |d_q V_q| (the energy
 * is a sum of terms of both signs), each gradient component relative to the
 * largest component of its kind. */
static void check_agree(const char *what, const result *cl, const result *ref, int n, double rel)
{
	double emax = rel * fmax(ref->absE, 1e-12);
	CHECK_MSG(fabs(cl->E - ref->E) <= emax, "%s: energy %.9g vs reference %.9g (sum |dV| %.6g)", what, cl->E,
		  ref->E, ref->absE);
	double gmu = rel * max_abs_mu(ref, n), gsg = rel * max_abs_sigma(ref, n);
	double worst_mu = 0, worst_sg = 0;
	for (int q = 0; q < n; q++) {
		mc_vec3 dd = mc_v3_sub(cl->dmu[q], ref->dmu[q]);
		worst_mu = fmax(worst_mu, fmax(fabs(dd.x), fmax(fabs(dd.y), fabs(dd.z))));
		worst_sg = fmax(worst_sg, fabs(cl->dsigma[q] - ref->dsigma[q]));
	}
	CHECK_MSG(worst_mu <= gmu, "%s: dE/dmu differs by %.3g, tolerance %.3g", what, worst_mu, gmu);
	CHECK_MSG(worst_sg <= gsg, "%s: dE/dsigma differs by %.3g, tolerance %.3g", what, worst_sg, gsg);
	printf("  %-34s E %12.6g (ref %12.6g)  max rel. error: E %.1e, dmu %.1e, dsigma %.1e\n", what, cl->E,
	       ref->E, fabs(cl->E - ref->E) / fmax(ref->absE, 1e-12), worst_mu / fmax(max_abs_mu(ref, n), 1e-30),
	       worst_sg / fmax(max_abs_sigma(ref, n), 1e-30));
}

static void eval_cl(mc_cl_energy *e, const mc_scene *sc, const int *const *pixels, const int *npixels,
		    double dropout, uint32_t seed, result *r)
{
	memset(r, 0, sizeof(*r));
	mc_err err = {{0}};
	int rc = mc_cl_energy_eval(e, sc, pixels, npixels, dropout, seed, &r->E, r->dmu, r->dsigma, &err);
	CHECK_MSG(rc == 0, "mc_cl_energy_eval: %s", err.msg);
}

static void eval_ref(const mc_scene *sc, const view *v, int nv, int *const *pixels, const int *npixels,
		     double dropout, uint32_t seed, result *r)
{
	memset(r, 0, sizeof(*r));
	r->E = ref_energy(sc, v, nv, pixels, npixels, dropout, seed, r->dmu, r->dsigma, &r->absE);
}

static mc_cl_energy *open_backend(const view *v, int nv)
{
	mc_raytable t[MC_MAX_CAMERAS] = {{0}};
	for (int c = 0; c < nv; c++)
		t[c] = v[c].rays;
	mc_err err = {{0}};
	mc_cl_energy *e = mc_cl_energy_create(-1, -1, t, nv, &err);
	if (!e) {
		if (strstr(err.msg, "no platform"))
			TEST_SKIP("%s", err.msg);
		fprintf(stderr, "mc_cl_energy_create: %s\n", err.msg);
		exit(1);
	}
	for (int c = 0; c < nv; c++) {
		int rc = mc_cl_energy_set_image(e, c, v[c].hsv, &err);
		CHECK_MSG(rc == 0, "set_image: %s", err.msg);
	}
	return e;
}

/* A pinhole camera at the origin (table_pinhole) with a random image. */
static void view_pinhole(view *v, int w, int h, double f, unsigned long long *rng)
{
	table_pinhole(&v->rays, w, h, f, mc_v3(0, 0, 0));
	v->hsv = image_random(&v->rays, rng);
}

/* The head-mounted fisheye pair (tables_ego, w x w pixels) into t, and views
 * of it with random images. */
static void views_ego(view v[2], mc_raytable t[2], int w, unsigned long long *rng)
{
	tables_ego(t, w);
	for (int c = 0; c < 2; c++) {
		v[c].rays = t[c];
		v[c].hsv = image_random(&t[c], rng);
	}
}

/* Frees the ray tables and images of nv views. */
static void views_free(view *v, int nv)
{
	for (int c = 0; c < nv; c++) {
		table_free(&v[c].rays);
		free(v[c].hsv);
	}
}

/* A person in a random pose (scene_human, limbs up to `pose` rad off the
 * rest pose) before the head-mounted pair with random images. */
typedef struct {
	unsigned long long rng;
	view v[2];
	mc_raytable t[2];
	mc_scene sc;
} ego_person;

static void ego_person_init(ego_person *p, unsigned long long seed, int w, double pose)
{
	p->rng = seed;
	views_ego(p->v, p->t, w, &p->rng);
	scene_human(&p->sc, pose, &p->rng);
}

/* A backend for p's views with the given launch settings, the images
 * set; NULL (counted as a failure) when it cannot be made. */
static mc_cl_energy *open_with(const ego_person *p, const mc_cl_options *o)
{
	mc_err err = {{0}};
	mc_cl_energy *e = mc_cl_energy_create_opts(-1, -1, p->t, 2, o, &err);
	CHECK_MSG(e != NULL, "%s", err.msg);
	for (int c = 0; e && c < 2; c++)
		CHECK(mc_cl_energy_set_image(e, c, p->v[c].hsv, &err) == 0);
	return e;
}

/* ---- the tests ---- */

static void test_random_scenes(void)
{
	unsigned long long rng = 1234;
	view v;
	view_pinhole(&v, 40, 30, 32, &rng);
	mc_cl_energy *e = open_backend(&v, 1);
	printf("device: %s\n", mc_cl_energy_device(e));
	static result cl, ref;
	for (int it = 0; it < 6; it++) {
		mc_scene sc;
		scene_random(&sc, 4 + it * 7, &rng);
		if (it == 5) {
			/* out-of-range colours, read as the reference reads them:
			 * hue wrapped, saturation and value clamped */
			sc.hsv[0][0] = 1.25, sc.hsv[1][1] = 1.5, sc.hsv[2][2] = -0.25, sc.hsv[3][0] = -0.4;
		}
		eval_cl(e, &sc, NULL, NULL, 0, 0, &cl);
		eval_ref(&sc, &v, 1, NULL, NULL, 0, 0, &ref);
		char what[64];
		snprintf(what, sizeof(what), "random scene, %d Gaussians", sc.n);
		check_agree(what, &cl, &ref, sc.n, 1e-3);
		CHECK(ref.absE > 0);
		/* with a background colour model (B d(I, background) per pixel),
		 * without and with dropout */
		sc.background = true;
		scene_random_hsv(&rng, sc.background_hsv);
		eval_cl(e, &sc, NULL, NULL, 0, 0, &cl);
		eval_ref(&sc, &v, 1, NULL, NULL, 0, 0, &ref);
		snprintf(what, sizeof(what), "background, %d Gaussians", sc.n);
		check_agree(what, &cl, &ref, sc.n, 1e-3);
		eval_cl(e, &sc, NULL, NULL, 0.3, 77 + it, &cl);
		eval_ref(&sc, &v, 1, NULL, NULL, 0.3, 77 + it, &ref);
		snprintf(what, sizeof(what), "background, dropout, %d Gaussians", sc.n);
		check_agree(what, &cl, &ref, sc.n, 1e-3);
	}
	/* Gaussians around the camera centre: samples behind the camera are
	 * dropped, those in the band around it faded (docs/ENERGY.md). */
	for (int it = 0; it < 3; it++) {
		mc_scene sc;
		scene_random(&sc, 12, &rng);
		for (int q = 0; q < sc.n; q++) {
			sc.mu[q] = mc_v3_scale(sc.mu[q], 0.3);
			sc.mu[q].z = scene_uniform(&rng, -0.15, 0.3);
		}
		eval_cl(e, &sc, NULL, NULL, 0, 0, &cl);
		eval_ref(&sc, &v, 1, NULL, NULL, 0, 0, &ref);
		check_agree("random scene near the camera", &cl, &ref, sc.n, 1e-3);
	}
	mc_cl_energy_destroy(e);
	views_free(&v, 1);
}

/* Gaussian 0 lies at the culling edge for every ray (C < c0 < 2C, where
 * the reference fades it in; docs/ENERGY.md "Culling"), behind an occluder
 * (1) and in front of another Gaussian (2).  Each Gaussian's gradient must
 * agree relative to its own size, so that the small edge terms count. */
static void test_culling_edge(void)
{
	unsigned long long rng = 11;
	view v;
	/* 16 x 16 rays within +-0.004 rad of the optical axis */
	view_pinhole(&v, 16, 16, 2000, &rng);
	mc_cl_energy *e = open_backend(&v, 1);
	mc_scene sc;
	memset(&sc, 0, sizeof(sc));
	sc.n = 3;
	sc.background = false;
	/* c0 = C at r = sigma sqrt(2 ln(c / C)), 2C a little nearer: placed
	 * where c0 = 1.5 C, mid-band for every ray */
	sc.mu[0] = mc_v3(0.1 * sqrt(2 * log(10 / (1.5 * MC_CULL_MAGNITUDE))), 0, 2.0), sc.sigma[0] = 0.1, sc.c[0] = 10;
	sc.mu[1] = mc_v3(0.01, 0, 1.5), sc.sigma[1] = 0.3, sc.c[1] = 2;
	sc.mu[2] = mc_v3(0, 0.02, 2.5), sc.sigma[2] = 0.1, sc.c[2] = 10;
	for (int q = 0; q < 3; q++)
		scene_random_hsv(&rng, sc.hsv[q]);
	static result cl, ref;
	eval_cl(e, &sc, NULL, NULL, 0, 0, &cl);
	eval_ref(&sc, &v, 1, NULL, NULL, 0, 0, &ref);
	check_agree("culling edge", &cl, &ref, sc.n, 1e-3);
	for (int q = 0; q < sc.n; q++) {
		double size = fmax(mc_v3_norm(ref.dmu[q]), fabs(ref.dsigma[q]));
		double err = fmax(mc_v3_norm(mc_v3_sub(cl.dmu[q], ref.dmu[q])), fabs(cl.dsigma[q] - ref.dsigma[q]));
		CHECK_MSG(size > 0 && err <= 1e-3 * size, "culling edge: Gaussian %d: gradient error %.3g of %.3g", q,
			  err, size);
	}
	mc_cl_energy_destroy(e);
	views_free(&v, 1);
}

/* A head-mounted stereo rig and a person in random poses: every pixel, then
 * random pixel subsets, then with dropout (the same decisions on both
 * sides), then with one camera missing. */
static void test_human(void)
{
	unsigned long long rng = 99;
	view v[2];
	mc_raytable t[2];
	views_ego(v, t, 48, &rng);
	mc_cl_energy *e = open_backend(v, 2);
	static result cl, ref;
	for (int pose = 0; pose < 3; pose++) {
		mc_scene sc;
		scene_human(&sc, 0.4 * pose, &rng);
		char what[64];
		snprintf(what, sizeof(what), "person, pose %d, all pixels", pose);
		eval_cl(e, &sc, NULL, NULL, 0, 0, &cl);
		eval_ref(&sc, v, 2, NULL, NULL, 0, 0, &ref);
		check_agree(what, &cl, &ref, sc.n, 1e-3);

		/* A random subset (with repeats) of each camera's pixels. */
		int npix[2] = {700, 500}, *pix[2];
		for (int c = 0; c < 2; c++) {
			pix[c] = malloc(sizeof(int) * (size_t)npix[c]);
			for (int i = 0; i < npix[c]; i++)
				pix[c][i] = (int)(mc_test_rand(&rng) * t[c].width * t[c].height);
		}
		snprintf(what, sizeof(what), "person, pose %d, pixel subset", pose);
		eval_cl(e, &sc, (const int *const *)pix, npix, 0, 0, &cl);
		eval_ref(&sc, v, 2, pix, npix, 0, 0, &ref);
		check_agree(what, &cl, &ref, sc.n, 1e-3);

		snprintf(what, sizeof(what), "person, pose %d, dropout 0.3", pose);
		eval_cl(e, &sc, (const int *const *)pix, npix, 0.3, 1000 + pose, &cl);
		eval_ref(&sc, v, 2, pix, npix, 0.3, 1000 + pose, &ref);
		check_agree(what, &cl, &ref, sc.n, 1e-3);
		for (int c = 0; c < 2; c++)
			free(pix[c]);
	}

	/* Camera 1 missing: only camera 0 counts. */
	mc_scene sc;
	scene_human(&sc, 0.3, &rng);
	mc_err err;
	CHECK(mc_cl_energy_set_image(e, 1, NULL, &err) == 0);
	eval_cl(e, &sc, NULL, NULL, 0, 0, &cl);
	eval_ref(&sc, v, 1, NULL, NULL, 0, 0, &ref);
	check_agree("person, camera 1 missing", &cl, &ref, sc.n, 1e-3);
	CHECK(mc_cl_energy_set_image(e, 1, v[1].hsv, &err) == 0);

	mc_cl_energy_destroy(e);
	views_free(v, 2);
}

/* The kernel with every vector width (1: the GPU path), assorted
 * work-group shapes, and host memory shared with the device or copied to
 * and from buffers gives the reference's numbers.  48x48 views: more
 * pixels than the backend first makes room for, so the upload grows. */
static void test_launch_settings(void)
{
	static ego_person p;
	ego_person_init(&p, 21, 48, 0.5);
	static result cl, ref;
	eval_ref(&p.sc, p.v, 2, NULL, NULL, 0, 0, &ref);
	static const mc_cl_options settings[] = {
		{1, 0, 0, false}, {4, 3, 5, false}, {8, 1, 1, true}, {16, 8, 0, false}, {16, 8, 0, true}, {16, 2, 64, false},
	};
	for (size_t i = 0; i < sizeof(settings) / sizeof(settings[0]); i++) {
		mc_cl_energy *e = open_with(&p, &settings[i]);
		if (!e)
			continue;
		mc_cl_options got;
		mc_cl_energy_config(e, &got);
		CHECK(got.vector_width == settings[i].vector_width);
		CHECK(!settings[i].work_group_size || got.work_group_size == settings[i].work_group_size);
		CHECK(!settings[i].copy_buffers || got.copy_buffers);
		eval_cl(e, &p.sc, NULL, NULL, 0, 0, &cl);
		char what[96];
		snprintf(what, sizeof(what), "VW %d, work-group %d, groups <= %d, %s", got.vector_width,
			 got.work_group_size, got.max_groups, got.copy_buffers ? "buffers" : "shared memory");
		check_agree(what, &cl, &ref, p.sc.n, 1e-3);
		mc_cl_energy_destroy(e);
	}
	mc_err err = {{0}};
	mc_cl_options bad = {3, 0, 0, false};
	CHECK(mc_cl_energy_create_opts(-1, -1, p.t, 2, &bad, &err) == NULL);
	CHECK_MSG(strstr(err.msg, "vector_width 3"), "%s", err.msg);
	bad = (mc_cl_options){0, 1 << 20, 0, false};
	CHECK(mc_cl_energy_create_opts(-1, -1, p.t, 2, &bad, &err) == NULL);
	CHECK_MSG(strstr(err.msg, "work_group_size 1048576"), "%s", err.msg);
	views_free(p.v, 2);
}

/* mc_cl_energy_eval_cameras: each camera's gradient is the reference's
 * over that camera's pixels alone, and the energy is over both, also
 * when the launch may have a single work-group (each camera still gets
 * one of its own). */
static void test_per_camera(void)
{
	static ego_person p;
	ego_person_init(&p, 8, 40, 0.4);
	int npix[2] = {900, 300}, *pix[2];
	for (int c = 0; c < 2; c++) {
		pix[c] = malloc(sizeof(int) * (size_t)npix[c]);
		for (int i = 0; i < npix[c]; i++)
			pix[c][i] = (int)(mc_test_rand(&p.rng) * p.t[c].width * p.t[c].height);
	}
	static result both, ref[2], cl[2];
	eval_ref(&p.sc, p.v, 2, pix, npix, 0.3, 17, &both);
	for (int c = 0; c < 2; c++) {
		int only[2] = {c == 0 ? npix[0] : 0, c == 1 ? npix[1] : 0};
		eval_ref(&p.sc, p.v, 2, pix, only, 0.3, 17, &ref[c]);
	}
	static const mc_cl_options settings[] = {{0, 0, 0, false}, {16, 8, 1, false}, {8, 3, 5, true}};
	for (size_t i = 0; i < sizeof(settings) / sizeof(settings[0]); i++) {
		mc_cl_energy *e = open_with(&p, &settings[i]);
		if (!e)
			continue;
		mc_err err = {{0}};
		static mc_vec3 dmu[2 * MC_MAX_GAUSSIANS];
		memset(dmu, 0, sizeof(dmu));
		double E = 0;
		CHECK_MSG(mc_cl_energy_eval_cameras(e, &p.sc, (const int *const *)pix, npix, 0.3, 17, &E, dmu, &err) ==
				  0,
			  "%s", err.msg);
		CHECK_MSG(fabs(E - both.E) <= 1e-3 * both.absE, "energy %.9g vs reference %.9g", E, both.E);
		for (int c = 0; c < 2; c++) {
			memset(&cl[c], 0, sizeof(cl[c]));
			cl[c].E = ref[c].E; /* the energy is checked over both cameras above */
			memcpy(cl[c].dmu, dmu + c * p.sc.n, sizeof(mc_vec3) * (size_t)p.sc.n);
			memcpy(cl[c].dsigma, ref[c].dsigma, sizeof(double) * (size_t)p.sc.n);
			char what[64];
			snprintf(what, sizeof(what), "camera %d's gradient, groups <= %d", c, settings[i].max_groups);
			check_agree(what, &cl[c], &ref[c], p.sc.n, 1e-3);
		}
		mc_cl_energy_destroy(e);
	}
	for (int c = 0; c < 2; c++)
		free(pix[c]);
	views_free(p.v, 2);
}

static void test_dropout(void)
{
	static ego_person p;
	ego_person_init(&p, 5, 32, 0.2);
	mc_cl_energy *e = open_backend(p.v, 2);
	static result full, r;
	eval_cl(e, &p.sc, NULL, NULL, 0, 0, &full);
	CHECK(full.E != 0);

	/* Everything dropped: nothing is seen. */
	eval_cl(e, &p.sc, NULL, NULL, 1.0, 77, &r);
	CHECK(r.E == 0);
	CHECK(max_abs_mu(&r, p.sc.n) == 0 && max_abs_sigma(&r, p.sc.n) == 0);

	/* The hash drops about the requested fraction. */
	long dropped = 0, total = 0;
	for (int px = 0; px < 2000; px++)
		for (int q = 0; q < p.sc.n; q++, total++)
			dropped += mc_cl_dropped(42, px & 1, px, q, 0.25);
	double frac = (double)dropped / total;
	CHECK_MSG(fabs(frac - 0.25) < 0.01, "dropped fraction %.4f for p = 0.25", frac);

	/* Over many seeds the energy at p = 0.5 is finite, varies with the seed,
	 * and its mean differs from the full energy (fewer occluders, fewer
	 * contributors). */
	double sum = 0, sum2 = 0;
	int nseeds = 40;
	for (int s = 0; s < nseeds; s++) {
		eval_cl(e, &p.sc, NULL, NULL, 0.5, (uint32_t)s, &r);
		CHECK(isfinite(r.E));
		sum += r.E;
		sum2 += r.E * r.E;
	}
	double mean = sum / nseeds, sd = sqrt(fmax(0, sum2 / nseeds - mean * mean));
	printf("  dropout 0.5 over %d seeds: mean E %.6g (sd %.3g), full E %.6g\n", nseeds, mean, sd, full.E);
	CHECK(isfinite(mean) && sd > 0);
	CHECK(fabs(mean - full.E) > 3 * sd / sqrt(nseeds));
	mc_cl_energy_destroy(e);
	views_free(p.v, 2);
}

static void test_errors(void)
{
	unsigned long long rng = 3;
	view v;
	view_pinhole(&v, 8, 6, 8, &rng);
	mc_err err = {{0}};

	CHECK(mc_cl_energy_create(99, -1, &v.rays, 1, &err) == NULL);
	CHECK_MSG(strstr(err.msg, "platform 99 does not exist"), "%s", err.msg);
	CHECK(mc_cl_energy_create(0, 99, &v.rays, 1, &err) == NULL);
	CHECK_MSG(strstr(err.msg, "device 99 does not exist on platform 0"), "%s", err.msg);
	CHECK(mc_cl_energy_create(-1, 0, &v.rays, 1, &err) == NULL);
	CHECK_MSG(strstr(err.msg, "without a platform"), "%s", err.msg);
	CHECK(mc_cl_energy_create(-2, -1, &v.rays, 1, &err) == NULL);
	CHECK(mc_cl_energy_create(-1, -1, &v.rays, 0, &err) == NULL);
	CHECK_MSG(strstr(err.msg, "ncams 0"), "%s", err.msg);

	/* Explicit indices that exist work, and name the device. */
	mc_cl_energy *e = mc_cl_energy_create(0, 0, &v.rays, 1, &err);
	CHECK_MSG(e != NULL, "%s", err.msg);
	if (!e)
		return;
	CHECK(strchr(mc_cl_energy_device(e), ':') != NULL);
	/* Cameras start missing: nothing to see. */
	mc_scene sc;
	scene_random(&sc, 5, &rng);
	double E = 1;
	CHECK(mc_cl_energy_eval(e, &sc, NULL, NULL, 0, 0, &E, NULL, NULL, &err) == 0 && E == 0);

	CHECK(mc_cl_energy_set_image(e, 1, v.hsv, &err) == -1);
	CHECK_MSG(strstr(err.msg, "camera 1 out of range"), "%s", err.msg);
	v.hsv[3 * 5 + 1] = NAN;
	CHECK(mc_cl_energy_set_image(e, 0, v.hsv, &err) == -1);
	CHECK_MSG(strstr(err.msg, "pixel 5: saturation is not finite"), "%s", err.msg);
	v.hsv[3 * 5 + 1] = 0.5f;
	CHECK(mc_cl_energy_set_image(e, 0, v.hsv, &err) == 0);

	int bad[2] = {3, 48}, nbad = 2;
	const int *pl[1] = {bad};
	CHECK(mc_cl_energy_eval(e, &sc, pl, &nbad, 0, 0, &E, NULL, NULL, &err) == -1);
	CHECK_MSG(strstr(err.msg, "pixels[1] = 48 out of range"), "%s", err.msg);
	sc.sigma[2] = 0;
	CHECK(mc_cl_energy_eval(e, &sc, NULL, NULL, 0, 0, &E, NULL, NULL, &err) == -1);
	CHECK_MSG(strstr(err.msg, "gaussian 2: sigma"), "%s", err.msg);
	sc.sigma[2] = 0.1;
	sc.hsv[1][2] = INFINITY;
	CHECK(mc_cl_energy_eval(e, &sc, NULL, NULL, 0, 0, &E, NULL, NULL, &err) == -1);
	CHECK_MSG(strstr(err.msg, "gaussian 1: value is not finite"), "%s", err.msg);
	sc.hsv[1][2] = 0.5;
	CHECK(mc_cl_energy_eval(e, &sc, NULL, NULL, 1.5, 0, &E, NULL, NULL, &err) == -1);
	CHECK_MSG(strstr(err.msg, "dropout"), "%s", err.msg);
	CHECK(mc_cl_energy_eval(e, &sc, NULL, NULL, 0, 0, &E, NULL, NULL, &err) == 0);
	/* An empty scene and an empty pixel list give 0. */
	sc.n = 0;
	sc.background = false;
	CHECK(mc_cl_energy_eval(e, &sc, NULL, NULL, 0, 0, &E, NULL, NULL, &err) == 0 && E == 0);
	mc_cl_energy_destroy(e);
	views_free(&v, 1);
}

int main(void)
{
	test_random_scenes();
	test_culling_edge();
	test_human();
	test_launch_settings();
	test_per_camera();
	test_dropout();
	test_errors();
	return mc_test_finish("test_cl_energy");
}
