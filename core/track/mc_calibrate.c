/* Actor calibration (thesis 5.3.2): each Gaussian's colour from one frame
 * set at a known pose, the background colour, and the baseline energy that
 * the tracking quality is measured against (the last two also for an actor
 * whose colours come from an actor file). */
#include "track/mc_tracker_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Visibility summed over the calibration frame's pixels below which a
 * Gaussian's own colour estimate is not trusted (about 3 pixels seen whole). */
#define MIN_COLOUR_EVIDENCE 3.0
/* Calibration pixels with background visibility above this are background. */
#define BACKGROUND_MIN_B 0.9
/* The baseline energy is at most this (a similarity: negative). */
#define BASELINE_MIN_E -1e-3

/* ---- actor colour calibration (thesis 5.3.2) ----------------------------- */

typedef struct {
	float rgb[3];
	float weight;
	float dist;
} colour_sample;

typedef struct {
	colour_sample *s;
	int n, cap;
} colour_samples;

static int push_sample(colour_samples *cs, const float *rgb, double weight)
{
	if (cs->n == cs->cap) {
		int cap = cs->cap ? cs->cap * 2 : 256;
		colour_sample *s = realloc(cs->s, sizeof(*s) * cap);
		if (!s)
			return -1;
		cs->s = s;
		cs->cap = cap;
	}
	colour_sample *x = &cs->s[cs->n++];
	memcpy(x->rgb, rgb, sizeof(x->rgb));
	x->weight = (float)weight;
	return 0;
}

static void weighted_mean(const colour_sample *s, int n, double mean[3])
{
	double w = 0;
	mean[0] = mean[1] = mean[2] = 0;
	for (int i = 0; i < n; i++) {
		for (int k = 0; k < 3; k++)
			mean[k] += s[i].weight * s[i].rgb[k];
		w += s[i].weight;
	}
	for (int k = 0; k < 3 && w > 0; k++)
		mean[k] /= w;
}

static int by_distance(const void *a, const void *b)
{
	float x = ((const colour_sample *)a)->dist, y = ((const colour_sample *)b)->dist;
	return (x > y) - (x < y);
}

/* Visibility-weighted mean, then the same after dropping the half of the
 * weight that lies farthest from it. Returns false without samples. */
static bool robust_colour(colour_samples *cs, double out[3])
{
	if (cs->n == 0)
		return false;
	double mean[3], total = 0, kept = 0;
	weighted_mean(cs->s, cs->n, mean);
	for (int i = 0; i < cs->n; i++) {
		colour_sample *x = &cs->s[i];
		x->dist = (float)(pow(x->rgb[0] - mean[0], 2) + pow(x->rgb[1] - mean[1], 2) + pow(x->rgb[2] - mean[2], 2));
		total += x->weight;
	}
	qsort(cs->s, cs->n, sizeof(colour_sample), by_distance);
	int n = 0;
	while (n < cs->n && kept < 0.5 * total)
		kept += cs->s[n++].weight;
	weighted_mean(cs->s, n ? n : 1, out);
	return true;
}

static double total_weight(const colour_samples *cs)
{
	double w = 0;
	for (int i = 0; i < cs->n; i++)
		w += cs->s[i].weight;
	return w;
}

/* A Gaussian seen too little in the calibration frame (e.g. a foot hidden
 * behind the body) would take its colour from a few fringe pixels, often
 * the floor, and then be drawn to the floor.  It borrows instead the
 * evidence-weighted colour of the Gaussians on the nearest joint up the
 * chain that were seen well: clothing is mostly continuous along a limb. */
static void borrow_colours(mc_model *m, const double *evidence)
{
	double rgb[MC_MAX_GAUSSIANS][3];
	for (int q = 0; q < m->ngauss; q++)
		memcpy(rgb[q], m->gauss[q].rgb, sizeof(rgb[q]));
	for (int q = 0; q < m->ngauss; q++) {
		if (evidence[q] >= MIN_COLOUR_EVIDENCE)
			continue;
		for (int j = m->gauss[q].joint; j >= 0; j = m->joints[j].parent) {
			double sum[3] = {0, 0, 0}, w = 0;
			for (int r = 0; r < m->ngauss; r++)
				if (m->gauss[r].joint == j && evidence[r] >= MIN_COLOUR_EVIDENCE) {
					for (int k = 0; k < 3; k++)
						sum[k] += evidence[r] * rgb[r][k];
					w += evidence[r];
				}
			if (w > 0) {
				for (int k = 0; k < 3; k++)
					m->gauss[q].rgb[k] = sum[k] / w;
				break;
			}
		}
	}
}

/* Collects, per Gaussian, the calibration pixels it explains, and the
 * pixels no Gaussian explains (the background around the body). */
static int collect_colours(mc_tracker *t, int nviews, const mc_scene *scene, colour_samples *per_gauss,
			   colour_samples *background)
{
	double vis[MC_MAX_GAUSSIANS], B;
	for (int c = 0; c < t->rig.ncams && c < nviews; c++) {
		if (!t->present[c])
			continue;
		const float *rgb = t->rgb[c]; /* resampled by mc_trk_load_views */
		const mc_raytable *rt = &t->rays[c];
		for (int i = 0; i < t->ncandidates[c]; i++) {
			int p = t->candidates[c][i];
			mc_ray_visibility(scene, rt->origin, rt->dir[p], vis, &B);
			for (int q = 0; q < scene->n; q++)
				if (vis[q] > 0.05 && push_sample(&per_gauss[q], &rgb[3 * p], vis[q]) < 0)
					return -1;
			if (B > BACKGROUND_MIN_B && push_sample(background, &rgb[3 * p], 1.0) < 0)
				return -1;
		}
	}
	return 0;
}


/* The background colour model: the robust mean colour of the calibration
 * pixels that no body Gaussian explains.  The energy then adds
 * B d(I, background) per pixel, B the ray's background visibility: covering
 * a pixel that looks like the background costs, and explaining one that
 * does not pays, which the overlap energy alone lacks (docs/TRACKER.md). */
static void calibrate_background(mc_tracker *t, colour_samples *background)
{
	double rgb[3];
	t->has_background = robust_colour(background, rgb);
	if (t->has_background)
		mc_rgb_to_hsv(rgb, t->background_hsv);
}

/* The mean data energy per candidate pixel at the calibration pose, every
 * candidate, no dropout: the reference for the tracking quality. */
static int measure_baseline(mc_tracker *t, double *E_out, mc_err *err)
{
	mc_fk fk;
	mc_scene scene;
	mc_vec3 dmu[MC_MAX_GAUSSIANS];
	double E;
	mc_model_fk(&t->model, t->pose, &fk);
	mc_trk_make_scene(t, &fk, &scene);
	int ns = mc_trk_sample_pixels(t, 1.0);
	if (mc_trk_data_term(t, &scene, ns, 0.0, &E, dmu, err) < 0)
		return -1;
	t->baseline = E < BASELINE_MIN_E ? E : BASELINE_MIN_E;
	*E_out = E;
	return 0;
}

/* The baseline, and the background colour term only where it is a model
 * of the background: one colour for a background of several (a hall's
 * green walls and purple floor) is like none of them, its term then adds
 * more than the body's own colours take off, and the energy at the
 * calibration pose itself is not negative.  There it is dropped: without
 * a baseline every frame set would read lost (docs/BENCHMARKS.md,
 * "Held-out clips"). */
static int measure_baseline_and_background(mc_tracker *t, mc_err *err)
{
	double E;
	if (measure_baseline(t, &E, err) < 0)
		return -1;
	if (E < BASELINE_MIN_E || !t->has_background)
		return 0;
	t->has_background = false;
	return measure_baseline(t, &E, err);
}

int mc_tracker_calibrate_colors(mc_tracker *t, const mc_frame_view *views, int nviews, mc_err *err)
{
	return mc_trk_calibrate(t, views, nviews, true, err);
}

int mc_trk_calibrate(mc_tracker *t, const mc_frame_view *views, int nviews, bool colours, mc_err *err)
{
	colour_samples *per_gauss = calloc(MC_MAX_GAUSSIANS, sizeof(colour_samples));
	colour_samples background = {0};
	int rc = -1;
	t->has_background = false;
	if (!per_gauss) {
		mc_err_set(err, "tracker: out of memory");
		goto out;
	}
	if (mc_trk_load_views(t, views, nviews) == 0) {
		mc_err_set(err, "tracker: colour calibration needs at least one usable, non-blank view");
		goto out;
	}
	mc_fk fk;
	mc_scene scene;
	mc_model_fk(&t->model, t->pose, &fk);
	mc_trk_make_scene(t, &fk, &scene);
	mc_trk_choose_candidates(t, &fk);
	if (collect_colours(t, nviews, &scene, per_gauss, &background) < 0) {
		mc_err_set(err, "tracker: out of memory");
		goto out;
	}
	double evidence[MC_MAX_GAUSSIANS];
	for (int q = 0; colours && q < t->model.ngauss; q++) {
		evidence[q] = total_weight(&per_gauss[q]);
		if (evidence[q] >= MIN_COLOUR_EVIDENCE)
			robust_colour(&per_gauss[q], t->model.gauss[q].rgb);
	}
	if (colours)
		borrow_colours(&t->model, evidence);
	calibrate_background(t, &background);
	mc_trk_gaussian_evidence(t, t->pose, t->evidence0);
	rc = measure_baseline_and_background(t, err);
	if (rc == 0)
		t->actor_version++; /* the actor in use changed, or (colours kept) started */
out:
	for (int q = 0; per_gauss && q < MC_MAX_GAUSSIANS; q++)
		free(per_gauss[q].s);
	free(per_gauss);
	free(background.s);
	return rc;
}

