/* The thesis' ch. 4 configuration inside mocap-bench (its speed report):
 * see bench/thesis.h. */
#include "bench/thesis.h"

#include "base/mc_time.h"
#include "energy/mc_cl.h"
#include "energy/mc_energy.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* ---- the thesis' ch. 4 configuration -------------------------------------
 * About 10,000 pixels near the body, 72 Gaussians, no sampling: full
 * gradient iterations (kinematics, energy and gradient, chain rule) per
 * second.  The thesis reports 8.1 on a 4-core 3.6 GHz CPU. */

typedef struct {
	mc_raytable rt;
	int *pixels;
	int npixels;
	float *hsv;
} thesis_view;

static bool near_model(const mc_scene *sc, mc_vec3 o, mc_vec3 n)
{
	for (int q = 0; q < sc->n; q++) {
		mc_vec3 d = mc_v3_sub(sc->mu[q], o);
		double along = mc_v3_dot(d, n);
		if (along > 0 && mc_v3_norm2(d) - along * along < pow(3 * sc->sigma[q], 2))
			return true;
	}
	return false;
}

static int thesis_view_build(const mc_camera *cam, const mc_scene *sc, const mc_frame_view *img, thesis_view *tv,
			     mc_err *err)
{
	for (int res = 128; res <= 512; res += 32) {
		if (mc_raytable_build(cam, res, res, &tv->rt, err) < 0)
			return -1;
		tv->pixels = malloc(sizeof(int) * res * res);
		tv->npixels = 0;
		for (int p = 0; p < res * res && tv->pixels && tv->npixels < 10000; p++)
			if (tv->rt.valid[p] && near_model(sc, tv->rt.origin, tv->rt.dir[p]))
				tv->pixels[tv->npixels++] = p;
		if (tv->npixels >= 10000 || res == 512)
			break;
		free(tv->pixels);
		mc_raytable_free(&tv->rt);
	}
	int W = tv->rt.width, H = tv->rt.height;
	tv->hsv = malloc(sizeof(float) * 3 * W * H);
	if (!tv->pixels || !tv->hsv)
		return mc_err_set(err, "out of memory");
	for (int j = 0; j < H; j++)
		for (int i = 0; i < W; i++) { /* nearest-neighbour sample of the image */
			const uint8_t *px = img->rgb + (size_t)(j * img->height / H) * img->stride + 3 * (i * img->width / W);
			double rgb[3] = {px[0] / 255.0, px[1] / 255.0, px[2] / 255.0}, hsv[3];
			mc_rgb_to_hsv(rgb, hsv);
			for (int k = 0; k < 3; k++)
				tv->hsv[3 * (j * W + i) + k] = (float)hsv[k];
		}
	return 0;
}

/* One gradient iteration of the thesis configuration (kinematics, energy
 * and gradient, chain rule). */
static int thesis_iteration(const mc_model *m, const double *pose, thesis_view *tv, mc_cl_energy *cl, mc_err *err)
{
	mc_view view = {&tv->rt, tv->hsv};
	mc_fk fk;
	mc_scene sc;
	mc_vec3 dmu[MC_MAX_GAUSSIANS] = {{0}};
	double dsigma[MC_MAX_GAUSSIANS] = {0}, grad[MC_MAX_DOF] = {0}, E;
	mc_model_fk(m, pose, &fk);
	mc_scene_from_model(m, &fk, &sc);
	if (cl) {
		const int *pix[1] = {tv->pixels};
		if (mc_cl_energy_eval(cl, &sc, pix, &tv->npixels, 0.0, 1, &E, dmu, dsigma, err) < 0)
			return -1;
	} else {
		E = mc_energy_color(&sc, &view, tv->pixels, tv->npixels, dmu, dsigma);
	}
	mc_model_backprop(m, pose, &fk, dmu, grad);
	(void)E;
	return 0;
}

/* Iterations per second, after one untimed iteration: the first launch of
 * a kernel on PoCL compiles it for the work-group size (tens of ms), a
 * cost paid once per tracker, not per iteration. */
static double thesis_iterations_per_s(const mc_model *m, const double *pose, thesis_view *tv, mc_cl_energy *cl,
				      int iterations, mc_err *err)
{
	if (thesis_iteration(m, pose, tv, cl, err) < 0)
		return -1;
	uint64_t t0 = mc_now_ns();
	for (int it = 0; it < iterations; it++)
		if (thesis_iteration(m, pose, tv, cl, err) < 0)
			return -1;
	return iterations / (mc_ms_since(t0) / 1e3);
}

int bench_thesis_run(const mc_model *model, const double *pose, const mc_clip *clip, int cl_platform,
		     int cl_device, mc_err *err)
{
	mc_model m = *model;
	if (m.ngauss > 72)
		m.ngauss = 72;
	mc_fk fk;
	mc_scene sc;
	mc_model_fk(&m, pose, &fk);
	mc_scene_from_model(&m, &fk, &sc);
	mc_frame_view views[MC_MAX_CAMERAS];
	thesis_view tv = {0};
	if (mc_clip_load_frame(clip, 0, views, err) < 0)
		return -1;
	int rc = thesis_view_build(&clip->rig.cams[0], &sc, &views[0], &tv, err);
	mc_clip_free_frame(views);
	mc_cl_energy *cl = rc == 0 ? mc_cl_energy_create(cl_platform, cl_device, &tv.rt, 1, err) : NULL;
	if (cl)
		rc = mc_cl_energy_set_image(cl, 0, tv.hsv, err);
	double cl_rate = (cl && rc == 0) ? thesis_iterations_per_s(&m, pose, &tv, cl, 50, err) : -1;
	double ref_rate = rc == 0 ? thesis_iterations_per_s(&m, pose, &tv, NULL, 2, err) : -1;
	if (rc == 0)
		printf("thesis ch. 4 configuration: %d pixels (%dx%d), %d Gaussians, %d pose parameters, no sampling:\n"
		       "  opencl    %.2f gradient iterations/s\n  reference %.2f gradient iterations/s\n"
		       "  (thesis: 8.1 on a 4-core 3.6 GHz CPU, 72 Gaussians, 44 parameters)\n",
		       tv.npixels, tv.rt.width, tv.rt.height, m.ngauss, m.ndof, cl_rate, ref_rate);
	if (cl)
		mc_cl_energy_destroy(cl);
	mc_raytable_free(&tv.rt);
	free(tv.pixels);
	free(tv.hsv);
	return cl_rate < 0 || ref_rate < 0 ? -1 : 0;
}

