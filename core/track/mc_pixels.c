/* mc_pixels: which pixels the tracker looks at.  Each view resampled to the
 * working resolution (RGB and HSV, a blank camera left out), the candidate
 * pixels near the predicted body, and the random sample of them that each
 * gradient iteration evaluates (docs/TRACKER.md). */
#include "track/mc_tracker_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Extra angular margin (metres at the Gaussian) around each Gaussian when
 * choosing candidate pixels: covers the motion within one frame. */
#define CANDIDATE_MARGIN_M 0.06
/* A camera whose value channel varies less than this is blank. */
#define BLANK_STDDEV 0.02


/* Box-filters a packed RGB24 view down (or nearest-samples up) to the
 * working resolution, as floats in [0, 1]. */
static void resample_rgb(const mc_frame_view *v, int W, int H, float *out)
{
	double sx = (double)v->width / W, sy = (double)v->height / H;
	for (int j = 0; j < H; j++) {
		int y0 = (int)(j * sy), y1 = (int)((j + 1) * sy);
		if (y1 <= y0)
			y1 = y0 + 1;
		if (y1 > v->height)
			y1 = v->height;
		for (int i = 0; i < W; i++) {
			int x0 = (int)(i * sx), x1 = (int)((i + 1) * sx);
			if (x1 <= x0)
				x1 = x0 + 1;
			if (x1 > v->width)
				x1 = v->width;
			double acc[3] = {0, 0, 0};
			int n = 0;
			for (int y = y0; y < y1; y++) {
				const uint8_t *row = v->rgb + (size_t)y * v->stride;
				for (int x = x0; x < x1; x++, n++)
					for (int k = 0; k < 3; k++)
						acc[k] += row[3 * x + k];
			}
			float *o = out + 3 * ((size_t)j * W + i);
			for (int k = 0; k < 3; k++)
				o[k] = (float)(n ? acc[k] / (255.0 * n) : 0.0);
		}
	}
}

bool mc_trk_view_usable(const mc_frame_view *v)
{
	return v && v->rgb && v->width > 0 && v->height > 0 && v->stride >= 3 * v->width;
}

/* Converts the views; returns how many cameras carry a usable, non-blank image. */
int mc_trk_load_views(mc_tracker *t, const mc_frame_view *views, int nviews)
{
	int W = t->s.width, H = t->s.height, present = 0;
	for (int c = 0; c < t->rig.ncams; c++) {
		t->present[c] = false;
		if (c >= nviews || !mc_trk_view_usable(&views[c]))
			continue;
		const float *rgb_c = t->rgb[c];
		resample_rgb(&views[c], W, H, t->rgb[c]);
		double sum = 0, sum2 = 0;
		int n = 0;
		for (int p = 0; p < W * H; p++) {
			double rgb[3] = {rgb_c[3 * p], rgb_c[3 * p + 1], rgb_c[3 * p + 2]}, hsv[3];
			mc_rgb_to_hsv(rgb, hsv);
			for (int k = 0; k < 3; k++)
				t->hsv[c][3 * p + k] = (float)hsv[k];
			if (t->rays[c].valid[p]) {
				sum += hsv[2];
				sum2 += hsv[2] * hsv[2];
				n++;
			}
		}
		double var = n ? sum2 / n - (sum / n) * (sum / n) : 0;
		if (!(sqrt(fmax(var, 0)) > BLANK_STDDEV))
			continue; /* blank or constant: no evidence */
		t->present[c] = true;
		present++;
		if (t->cl) {
			mc_err err;
			if (mc_cl_energy_set_image(t->cl, c, t->hsv[c], &err) < 0) {
				t->present[c] = false;
				present--;
			}
		}
	}
	return present;
}

/* ---- candidate pixels -------------------------------------------------- */

static void rasterize_disc(unsigned char *mask, int W, int H, double cu, double cv, double r)
{
	int i0 = (int)floor(cu - r), i1 = (int)ceil(cu + r);
	int j0 = (int)floor(cv - r), j1 = (int)ceil(cv + r);
	i0 = i0 < 0 ? 0 : i0;
	j0 = j0 < 0 ? 0 : j0;
	i1 = i1 >= W ? W - 1 : i1;
	j1 = j1 >= H ? H - 1 : j1;
	for (int j = j0; j <= j1; j++)
		for (int i = i0; i <= i1; i++)
			if ((i - cu) * (i - cu) + (j - cv) * (j - cv) <= r * r)
				mask[j * W + i] = 1;
}

/* Native pixel -> working pixel coordinates (see mc_raytable). */
static void to_working(const mc_raytable *rt, double u, double v, double *wu, double *wv)
{
	*wu = (u + 0.5) / rt->scale_x - 0.5;
	*wv = (v + 0.5) / rt->scale_y - 0.5;
}

int mc_trk_working_pixel(const mc_tracker *t, int c, mc_vec3 p_rig)
{
	const mc_camera *cam = &t->rig.cams[c];
	const mc_raytable *rt = &t->rays[c];
	double u, v, wu, wv;
	if (!mc_camera_project_rig(cam, p_rig, &u, &v))
		return -1;
	to_working(rt, u, v, &wu, &wv);
	int x = (int)lround(wu), y = (int)lround(wv);
	if (x < 0 || y < 0 || x >= rt->width || y >= rt->height || !rt->valid[y * rt->width + x])
		return -1;
	return y * rt->width + x;
}

/* Marks the working pixels whose rays pass within 3 sigma + margin of a
 * Gaussian: only they can see the body, so only they are sampled. */
static void mark_gaussian(const mc_camera *cam, const mc_raytable *rt, mc_vec3 p, double radius, unsigned char *mask)
{
	double dist = mc_v3_norm(p);
	if (dist < 1e-6)
		return;
	if (radius >= dist) { /* the camera is inside the Gaussian */
		memset(mask, 1, (size_t)rt->width * rt->height);
		return;
	}
	double alpha = asin(radius / dist);
	mc_vec3 d = mc_v3_scale(p, 1.0 / dist);
	mc_vec3 any = fabs(d.x) < 0.9 ? mc_v3(1, 0, 0) : mc_v3(0, 1, 0);
	mc_vec3 e1 = mc_v3_normalize(mc_v3_cross(d, any)), e2 = mc_v3_cross(d, e1);
	double u, v, cu, cv, r = 0;
	bool centre = mc_camera_project(cam, d, &u, &v);
	if (centre)
		to_working(rt, u, v, &cu, &cv);
	double ex[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
	double pu[4], pv[4];
	int np = 0;
	for (int k = 0; k < 4; k++) {
		mc_vec3 e = mc_v3_add(mc_v3_scale(e1, ex[k][0]), mc_v3_scale(e2, ex[k][1]));
		mc_vec3 q = mc_v3_add(mc_v3_scale(d, cos(alpha)), mc_v3_scale(e, sin(alpha)));
		if (mc_camera_project(cam, q, &u, &v)) {
			to_working(rt, u, v, &pu[np], &pv[np]);
			np++;
		}
	}
	if (!np)
		return;
	if (!centre) { /* centre outside the field of view: use the edge points */
		cu = cv = 0;
		for (int k = 0; k < np; k++) {
			cu += pu[k] / np;
			cv += pv[k] / np;
		}
	}
	for (int k = 0; k < np; k++)
		r = fmax(r, hypot(pu[k] - cu, pv[k] - cv));
	rasterize_disc(mask, rt->width, rt->height, cu, cv, r + 1.5);
}

/* Adds to t->mask camera c's pixels near the Gaussians at fk (those
 * `only` marks; NULL: all), hidden ones left out. */
static void mark_body(mc_tracker *t, int c, const mc_fk *fk, const bool *only)
{
	const mc_camera *cam = &t->rig.cams[c];
	mc_xform cam_from_rig = mc_xform_inverse(cam->rig_from_cam);
	for (int q = 0; q < t->model.ngauss; q++) {
		if (t->hidden[q] || (only && !only[q]))
			continue;
		mc_vec3 p = mc_xform_apply(cam_from_rig, fk->mu[q]);
		mark_gaussian(cam, &t->rays[c], p, 3 * t->model.gauss[q].sigma + CANDIDATE_MARGIN_M, t->mask);
	}
}

/* The valid pixels t->mask marks, into out; the count. */
static int masked_pixels(const mc_tracker *t, int c, int *out)
{
	const mc_raytable *rt = &t->rays[c];
	int n = 0;
	for (int p = 0; p < rt->width * rt->height; p++)
		if (t->mask[p] && rt->valid[p])
			out[n++] = p;
	return n;
}

void mc_trk_choose_candidates(mc_tracker *t, const mc_fk *fk)
{
	for (int c = 0; c < t->rig.ncams; c++) {
		memset(t->mask, 0, (size_t)t->rays[c].width * t->rays[c].height);
		mark_body(t, c, fk, NULL);
		t->ncandidates[c] = masked_pixels(t, c, t->candidates[c]);
	}
}

/* A share of pixels[0..n) into out, drawn by a partial Fisher-Yates
 * shuffle (in place), so that no pixel is drawn twice; the count. */
static int draw_pixels(mc_tracker *t, int *pixels, int n, double fraction, int *out)
{
	int k = (int)ceil(fraction * n);
	for (int i = 0; i < k; i++) {
		int j = i + (int)(mc_rng_next(&t->rng) % (uint64_t)(n - i));
		int chosen = pixels[j];
		pixels[j] = pixels[i];
		pixels[i] = chosen;
		out[i] = chosen;
	}
	return k;
}

/* Draws this iteration's pixels from each camera's candidates. */
int mc_trk_sample_pixels(mc_tracker *t, double fraction)
{
	int total = 0;
	for (int c = 0; c < t->rig.ncams; c++) {
		int n = t->present[c] ? t->ncandidates[c] : 0;
		t->nsamples[c] = draw_pixels(t, t->candidates[c], n, fraction, t->samples[c]);
		total += t->nsamples[c];
	}
	return total;
}

int mc_trk_sample_near(mc_tracker *t, const mc_fk *a, const mc_fk *b, const bool *gauss, double fraction)
{
	int total = 0;
	for (int c = 0; c < t->rig.ncams; c++) {
		t->nsamples[c] = 0;
		if (!t->present[c])
			continue;
		memset(t->mask, 0, (size_t)t->rays[c].width * t->rays[c].height);
		mark_body(t, c, a, gauss);
		mark_body(t, c, b, gauss);
		int n = masked_pixels(t, c, t->samples[c]);
		t->nsamples[c] = draw_pixels(t, t->samples[c], n, fraction, t->samples[c]);
		total += t->nsamples[c];
	}
	return total;
}
