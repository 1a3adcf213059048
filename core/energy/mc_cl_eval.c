/* OpenCL backend of the colour energy, per frame and per evaluation: the
 * camera images, the Gaussian records and pixel indices packed for the
 * kernel, one launch, and the per-work-group sums added up in double.
 * Set-up is in mc_cl.c, the device choice in mc_cl_device.c. */
#include "energy/mc_cl_internal.h"

#include <math.h>
#include <string.h>

/* ---- per frame and per evaluation ---- */

/* An HSV channel as the reference reads it (mc_hsv_dissimilarity): hue in
 * turns, wrapped into [0, 1); saturation and value clamped to [0, 1]. */
static float hsv_channel(double v, int k)
{
	if (k == 0)
		return (float)(v - floor(v));
	return (float)(v < 0 ? 0 : v > 1 ? 1 : v);
}

static const char *const hsv_names[3] = {"hue", "saturation", "value"};

int mc_cl_energy_set_image(mc_cl_energy *e, int cam, const float *hsv, mc_err *err)
{
	if (cam < 0 || cam >= e->ncams)
		return mc_err_set(err, "mc_cl_energy_set_image: camera %d out of range 0..%d", cam, e->ncams - 1);
	if (!hsv) {
		e->has_image[cam] = false;
		return 0;
	}
	for (int i = 0; i < e->cam_npix[cam]; i++) {
		for (int k = 0; k < 3; k++) {
			float v = hsv[3 * i + k];
			if (!isfinite(v))
				return mc_err_set(err, "mc_cl_energy_set_image: camera %d: pixel %d: %s is not finite", cam, i,
						  hsv_names[k]);
			e->image_host[i].s[k] = hsv_channel(v, k);
		}
		e->image_host[i].s[3] = 0.0f;
	}
	cl_int rc = clEnqueueWriteBuffer(e->queue, e->image, CL_TRUE, sizeof(cl_float4) * (size_t)e->cam_first[cam],
					 sizeof(cl_float4) * (size_t)e->cam_npix[cam], e->image_host, 0, NULL, NULL);
	if (rc != CL_SUCCESS)
		return mc_cl_fail(err, "clEnqueueWriteBuffer(image)", rc);
	e->has_image[cam] = true;
	return 0;
}

/* An albedo (HSV) as the kernel's record: (h, s, v, w_s) and (w_d, w_g,
 * 0, 0), the dissimilarity weights of thesis 6.2.1 normalised.  Returns
 * -1, or the index of the first channel that is not finite. */
static int albedo_record(const double m[3], cl_float4 *alb, cl_float4 *wdg)
{
	float hsv[3];
	for (int k = 0; k < 3; k++) {
		if (!isfinite(m[k]))
			return k;
		hsv[k] = hsv_channel(m[k], k);
	}
	/* Z > 0 always, as w_g = 0.5 where m_s = 0. */
	double ws = sqrt(hsv[1]), wd = fmax(0, 0.5 - hsv[2]), wg = fmax(0, 0.5 - hsv[1]);
	double z = ws + wd + wg;
	*alb = (cl_float4){{hsv[0], hsv[1], hsv[2], (float)(ws / z)}};
	*wdg = (cl_float4){{(float)(wd / z), (float)(wg / z), 0, 0}};
	return -1;
}

/* Gaussian records for the kernel (layout in color_energy.cl). */
static int pack_scene(mc_cl_energy *e, const mc_scene *scene, mc_err *err)
{
	if (scene->n < 0 || scene->n > MC_MAX_GAUSSIANS)
		return mc_err_set(err, "mc_cl_energy_eval: scene: %d Gaussians, at most %d", scene->n, MC_MAX_GAUSSIANS);
	/* Lanes past the last Gaussian never pass the culling test. */
	float *soa = (float *)&e->input_host[4 * MC_MAX_GAUSSIANS];
	for (int q = scene->n; q < MC_MAX_GAUSSIANS; q++) {
		soa[q] = soa[MC_MAX_GAUSSIANS + q] = soa[2 * MC_MAX_GAUSSIANS + q] = 0;
		soa[3 * MC_MAX_GAUSSIANS + q] = -1;
	}
	for (int q = 0; q < scene->n; q++) {
		double s = scene->sigma[q], c = scene->c[q];
		const double *m = scene->hsv[q];
		if (!mc_v3_isfinite(scene->mu[q]))
			return mc_err_set(err, "mc_cl_energy_eval: scene: gaussian %d: mu is not finite", q);
		if (!(s > 0) || !isfinite(s))
			return mc_err_set(err, "mc_cl_energy_eval: scene: gaussian %d: sigma = %g, must be positive", q, s);
		if (!(c >= 0) || !isfinite(c))
			return mc_err_set(err, "mc_cl_energy_eval: scene: gaussian %d: c = %g, must be >= 0", q, c);
		cl_float4 alb, wdg;
		int bad = albedo_record(m, &alb, &wdg);
		if (bad >= 0)
			return mc_err_set(err, "mc_cl_energy_eval: scene: gaussian %d: %s is not finite", q, hsv_names[bad]);
		/* c' = c exp(-r2 / (2 sigma^2)) < MC_CULL_MAGNITUDE  <=>  r2 > r2_max */
		double r2max = c > MC_CULL_MAGNITUDE ? 2 * s * s * log(c / MC_CULL_MAGNITUDE) : -1;
		soa[q] = (float)scene->mu[q].x;
		soa[MC_MAX_GAUSSIANS + q] = (float)scene->mu[q].y;
		soa[2 * MC_MAX_GAUSSIANS + q] = (float)scene->mu[q].z;
		soa[3 * MC_MAX_GAUSSIANS + q] = (float)r2max;
		cl_float4 *g = &e->input_host[4 * q];
		*g++ = (cl_float4){{(float)scene->mu[q].x, (float)scene->mu[q].y, (float)scene->mu[q].z, (float)s}};
		*g++ = (cl_float4){{(float)c, (float)r2max, 0, 0}};
		*g++ = alb;
		*g = wdg;
	}
	e->bg_albedo = e->bg_weights = (cl_float4){{0, 0, 0, 0}};
	if (scene->background) {
		int bad = albedo_record(scene->background_hsv, &e->bg_albedo, &e->bg_weights);
		if (bad >= 0)
			return mc_err_set(err, "mc_cl_energy_eval: scene: background colour: %s is not finite",
					  hsv_names[bad]);
		e->bg_weights.s[2] = 1;
	}
	return 0;
}

/* Concatenates the ray indices of the pixels to evaluate, camera by
 * camera; cam_count[c] = camera c's share. */
static int gather_pixels(mc_cl_energy *e, const int *const *pixels, const int *npixels, size_t *count,
			 size_t cam_count[MC_MAX_CAMERAS], mc_err *err)
{
	size_t need = 0;
	for (int c = 0; c < e->ncams; c++) {
		cam_count[c] = 0;
		if (!e->has_image[c])
			continue;
		bool all = !pixels || !pixels[c];
		int n = all ? e->nvalid[c] : (npixels ? npixels[c] : -1);
		if (n < 0)
			return mc_err_set(err, "mc_cl_energy_eval: camera %d: npixels missing or negative", c);
		cam_count[c] = (size_t)n;
		need += (size_t)n;
	}
	if (need > e->pixel_cap && mc_cl_grow_input(e, need, err) != 0)
		return -1;
	size_t k = 0;
	for (int c = 0; c < e->ncams; c++) {
		bool all = !pixels || !pixels[c];
		const int *list = all ? e->valid[c] : pixels[c];
		for (size_t i = 0; i < cam_count[c]; i++) {
			if (list[i] < 0 || list[i] >= e->cam_npix[c])
				return mc_err_set(err, "mc_cl_energy_eval: camera %d: pixels[%zu] = %d out of range 0..%d", c,
						  i, list[i], e->cam_npix[c] - 1);
			e->pixel_host[k++] = (cl_uint)(e->cam_first[c] + list[i]);
		}
	}
	*count = k;
	return 0;
}

/* About max_groups work-groups in all, shared out in proportion to the
 * cameras' pixels; a group never mixes cameras, so that its row holds one
 * camera's gradient (mc_cl_energy_eval_cameras). */
size_t mc_cl_plan_groups(mc_cl_energy *e, const size_t *cam_count, size_t npix)
{
	cl_uint *first = e->pixel_host + npix;
	size_t total = (npix + e->wg - 1) / e->wg, groups = 0, start = 0;
	if (total > e->max_groups)
		total = e->max_groups;
	for (int c = 0; npix > 0 && c < e->ncams; c++) {
		size_t n = cam_count[c];
		if (n == 0)
			continue;
		size_t share = (size_t)((double)total * (double)n / (double)npix + 0.5);
		if (share < 1)
			share = 1;
		for (size_t j = 0; j < share; j++) {
			first[groups] = (cl_uint)(start + n * j / share);
			e->group_cam[groups++] = c;
		}
		start += n;
	}
	if (groups == 0) { /* nothing to evaluate: one empty group */
		first[0] = 0;
		e->group_cam[groups++] = 0;
	}
	first[groups] = (cl_uint)npix;
	return groups;
}

/* One evaluation on the device: upload, run, read back the work-group
 * rows.  Three commands, one wait; with shared memory only the run. */
int mc_cl_launch(mc_cl_energy *e, int ngauss, size_t npix, size_t groups, uint32_t seed, uint32_t thr24,
		 mc_err *err)
{
	size_t bytes = sizeof(cl_float4) * GAUSS_FLOAT4S + sizeof(cl_uint) * (npix + groups + 1);
	cl_int rc = e->shared ? CL_SUCCESS
			      : clEnqueueWriteBuffer(e->queue, e->input, CL_FALSE, 0, bytes, e->input_host, 0, NULL, NULL);
	if (rc != CL_SUCCESS)
		return mc_cl_fail(err, "clEnqueueWriteBuffer(input)", rc);

	cl_int ng = ngauss, np = (cl_int)npix;
	cl_uint sd = seed, thr = thr24;
	size_t row = sizeof(float) * (4 * (size_t)ngauss + 1);
	cl_kernel k = e->kernel;
	rc = clSetKernelArg(k, 5, sizeof(cl_int), &ng);
	rc |= clSetKernelArg(k, 6, sizeof(cl_int), &np);
	rc |= clSetKernelArg(k, 7, sizeof(cl_uint), &sd);
	rc |= clSetKernelArg(k, 8, sizeof(cl_uint), &thr);
	rc |= clSetKernelArg(k, 9, sizeof(cl_float4), &e->bg_albedo);
	rc |= clSetKernelArg(k, 10, sizeof(cl_float4), &e->bg_weights);
	rc |= clSetKernelArg(k, 11, row * e->wg, NULL);
	if (rc != CL_SUCCESS)
		return mc_err_set(err, "OpenCL: clSetKernelArg(color_energy) failed");
	size_t global = groups * e->wg;
	rc = clEnqueueNDRangeKernel(e->queue, k, 1, NULL, &global, &e->wg, 0, NULL, NULL);
	if (rc != CL_SUCCESS)
		return mc_cl_fail(err, "clEnqueueNDRangeKernel(color_energy)", rc);
	if (e->shared)
		rc = clFinish(e->queue);
	else
		rc = clEnqueueReadBuffer(e->queue, e->partial, CL_TRUE, 0, row * groups, e->partial_host, 0, NULL, NULL);
	if (rc != CL_SUCCESS)
		return mc_cl_fail(err, e->shared ? "clFinish" : "clEnqueueReadBuffer(partial)", rc);
	return 0;
}

/* Packs and runs one evaluation; *groups = the rows in partial_host (0
 * when there was nothing to evaluate). */
static int evaluate(mc_cl_energy *e, const mc_scene *scene, const int *const *pixels, const int *npixels,
		    double dropout, uint32_t seed, size_t *groups, mc_err *err)
{
	*groups = 0;
	if (!(dropout >= 0 && dropout <= 1))
		return mc_err_set(err, "mc_cl_energy_eval: dropout = %g, not in [0, 1]", dropout);
	if (pack_scene(e, scene, err) != 0)
		return -1;
	size_t npix = 0, cam_count[MC_MAX_CAMERAS];
	if (gather_pixels(e, pixels, npixels, &npix, cam_count, err) != 0)
		return -1;
	if (npix == 0 || (scene->n == 0 && !scene->background))
		return 0;
	size_t n = mc_cl_plan_groups(e, cam_count, npix);
	if (mc_cl_launch(e, scene->n, npix, n, seed, mc_cl_dropout_threshold(dropout), err) != 0)
		return -1;
	*groups = n;
	return 0;
}

/* Adds the rows of the groups of camera `cam` (-1: every group) in
 * double: the energy (returned), and column k of Gaussian q into
 * out[q][k]. */
static double sum_rows(const mc_cl_energy *e, size_t groups, int ngauss, int cam, double (*out)[4])
{
	size_t stride = 4 * (size_t)ngauss + 1;
	double energy = 0;
	for (size_t g = 0; g < groups; g++) {
		if (cam >= 0 && e->group_cam[g] != cam)
			continue;
		const float *row = e->partial_host + g * stride;
		energy += row[4 * (size_t)ngauss];
		for (int q = 0; q < ngauss; q++)
			for (int k = 0; k < 4; k++)
				out[q][k] += row[4 * q + k];
	}
	return energy;
}

int mc_cl_energy_eval(mc_cl_energy *e, const mc_scene *scene, const int *const *pixels, const int *npixels,
		      double dropout, uint32_t seed, double *energy, mc_vec3 *dmu, double *dsigma, mc_err *err)
{
	*energy = 0;
	size_t groups;
	if (evaluate(e, scene, pixels, npixels, dropout, seed, &groups, err) != 0)
		return -1;
	if (groups == 0)
		return 0;
	double d[MC_MAX_GAUSSIANS][4] = {{0}};
	*energy = sum_rows(e, groups, scene->n, -1, d);
	for (int q = 0; q < scene->n; q++) {
		if (dmu)
			dmu[q] = mc_v3_add(dmu[q], mc_v3(d[q][0], d[q][1], d[q][2]));
		if (dsigma)
			dsigma[q] += d[q][3];
	}
	return 0;
}

int mc_cl_energy_eval_cameras(mc_cl_energy *e, const mc_scene *scene, const int *const *pixels,
			      const int *npixels, double dropout, uint32_t seed, double *energy, mc_vec3 *dmu_cam,
			      mc_err *err)
{
	*energy = 0;
	size_t groups;
	if (evaluate(e, scene, pixels, npixels, dropout, seed, &groups, err) != 0)
		return -1;
	for (int c = 0; groups > 0 && c < e->ncams; c++) {
		double d[MC_MAX_GAUSSIANS][4] = {{0}};
		*energy += sum_rows(e, groups, scene->n, c, d);
		mc_vec3 *g = dmu_cam + (size_t)c * (size_t)scene->n;
		for (int q = 0; q < scene->n; q++)
			g[q] = mc_v3_add(g[q], mc_v3(d[q][0], d[q][1], d[q][2]));
	}
	return 0;
}
