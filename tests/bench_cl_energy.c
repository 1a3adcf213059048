/* Benchmark of the OpenCL colour energy (core/energy/mc_cl): evaluations per second
 * of energy + gradient for 1000, 3000 and 10000 sampled pixels over the two
 * 128 x 128 fisheye views of a head-mounted rig looking at a person of 68
 * Gaussians, with and without dropout, against the double reference
 * (mc_energy_color, one thread).  Prints figures; asserts nothing.
 *
 *   bench_cl_energy [platform device [vector_width work_group_size max_groups]]
 *   (defaults: -1 -1 0 0 0, see mc_cl.h) */
#include "cl_scene.h"
#include "base/mc_time.h"
#include "energy/mc_cl.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "test_util.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
	return mc_now_ns() / 1e9;
}

/* CPU time of every thread of the process (PoCL's workers included): the
 * work done, whatever else the machine is running. */
static double cpu_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return mc_timespec_ns(&ts) / 1e9;
}

/* Random valid pixels of each camera (with repeats). */
static void sample_pixels(const mc_raytable *t, int ncams, int total, int **pix, int *npix, unsigned long long *rng)
{
	for (int c = 0; c < ncams; c++) {
		npix[c] = total / ncams;
		pix[c] = malloc(sizeof(int) * (size_t)npix[c]);
		for (int i = 0; i < npix[c];) {
			int p = (int)(mc_test_rand(rng) * t[c].width * t[c].height);
			if (t[c].valid[p])
				pix[c][i++] = p;
		}
	}
}

/* Mean number of Gaussians with c' >= 1e-5 on the sampled rays. */
static double mean_active(const mc_scene *sc, const mc_raytable *t, int ncams, int *const *pix, const int *npix)
{
	long n = 0, rays = 0;
	for (int c = 0; c < ncams; c++)
		for (int i = 0; i < npix[c]; i++, rays++) {
			mc_vec3 dir = t[c].dir[pix[c][i]];
			for (int q = 0; q < sc->n; q++) {
				mc_vec3 d = mc_v3_sub(sc->mu[q], t[c].origin);
				double m = mc_v3_dot(d, dir), r2 = mc_v3_norm2(d) - m * m;
				n += sc->c[q] * exp(-r2 / (2 * sc->sigma[q] * sc->sigma[q])) >= MC_CULL_MAGNITUDE;
			}
		}
	return (double)n / (double)rays;
}

/* Times evaluations of one scene seen by two cameras. */
static int run_scenario(const char *title, int platform, int device, mc_cl_options opts, const mc_raytable *t,
			const mc_scene *sc, unsigned long long *rng)
{
	float *img[2] = {image_random(&t[0], rng), image_random(&t[1], rng)};
	mc_err err = {{0}};
	double t0 = now();
	mc_cl_energy *e = mc_cl_energy_create_opts(platform, device, t, 2, &opts, &err);
	if (!e) {
		printf("SKIP: %s\n", err.msg);
		free(img[0]);
		free(img[1]);
		return 77;
	}
	double t_create = now() - t0;
	for (int c = 0; c < 2; c++)
		if (mc_cl_energy_set_image(e, c, img[c], &err) != 0) {
			fprintf(stderr, "%s\n", err.msg);
			return 1;
		}
	mc_cl_energy_config(e, &opts);
	printf("\n%s\n", title);
	printf("device: %s; vector width %d, work-group size %d, at most %d work-groups, %s\n",
	       mc_cl_energy_device(e), opts.vector_width, opts.work_group_size, opts.max_groups,
	       opts.copy_buffers ? "buffers (upload, kernel, read back)" : "shared memory (one command)");
	printf("scene: %d Gaussians, 2 cameras of %dx%d (%d + %d valid pixels); create %.0f ms\n", sc->n, t[0].width,
	       t[0].height, t[0].nvalid, t[1].nvalid, 1e3 * t_create);

	static const int sizes[] = {1, 1000, 3000, 10000};
	static const double dropouts[] = {0, 0.5};
	for (size_t si = 0; si < sizeof(sizes) / sizeof(sizes[0]); si++) {
		int *pix[2], npix[2];
		sample_pixels(t, 2, sizes[si] < 2 ? 2 : sizes[si], pix, npix, rng);
		double act = mean_active(sc, t, 2, pix, npix);
		for (size_t di = 0; di < sizeof(dropouts) / sizeof(dropouts[0]); di++) {
			mc_vec3 dmu[MC_MAX_GAUSSIANS];
			double dsig[MC_MAX_GAUSSIANS], E = 0;
			int runs = 0;
			double start = now(), cpu_start = cpu_now(), elapsed;
			do {
				if (mc_cl_energy_eval(e, sc, (const int *const *)pix, npix, dropouts[di], (uint32_t)runs, &E,
						      dmu, dsig, &err) != 0) {
					fprintf(stderr, "%s\n", err.msg);
					return 1;
				}
				runs++;
				elapsed = now() - start;
			} while (elapsed < 1.0 || runs < 5);
			double cpu = cpu_now() - cpu_start;
			printf("%6d pixels (%4.1f Gaussians/ray), dropout %.1f: %8.3f ms/eval, %8.1f evals/s, "
			       "%8.3f ms CPU/eval\n",
			       npix[0] + npix[1], act, dropouts[di], 1e3 * elapsed / runs, runs / elapsed, 1e3 * cpu / runs);
		}
		if (sizes[si] == 3000) {
			/* The double reference on one thread, for scale. */
			double start = cpu_now(), Eref = 0;
			mc_vec3 dmu[MC_MAX_GAUSSIANS] = {{0}};
			double dsig[MC_MAX_GAUSSIANS] = {0};
			for (int c = 0; c < 2; c++) {
				mc_view v = {&t[c], img[c]};
				Eref += mc_energy_color(sc, &v, pix[c], npix[c], dmu, dsig);
			}
			printf("%6d pixels, reference mc_energy_color (double, 1 thread): %8.3f ms CPU/eval\n",
			       npix[0] + npix[1], 1e3 * (cpu_now() - start));
		}
		free(pix[0]);
		free(pix[1]);
	}
	mc_cl_energy_destroy(e);
	free(img[0]);
	free(img[1]);
	return 0;
}

/* The project's default model at its rest pose on the project's stereo
 * fisheye rig, 128 x 128 working pixels; 1 if the files are not there. */
static int load_default(mc_raytable t[2], mc_scene *sc)
{
	static mc_rig rig;
	static mc_model model;
	static mc_fk fk;
	double pose[MC_MAX_DOF];
	mc_err err = {{0}};
	if (mc_rig_load("config/rigs/ego_stereo.json", &rig, &err) != 0 ||
	    mc_model_load("config/models/default.json", &model, &err) != 0) {
		printf("\n(default model scenario skipped: %s)\n", err.msg);
		return 1;
	}
	for (int c = 0; c < 2; c++)
		if (mc_raytable_build(&rig.cams[c], 128, 128, &t[c], &err) != 0) {
			printf("\n(default model scenario skipped: %s)\n", err.msg);
			return 1;
		}
	mc_model_rest_pose(&model, pose);
	mc_model_fk(&model, pose, &fk);
	mc_scene_from_model(&model, &fk, sc);
	return 0;
}

int main(int argc, char **argv)
{
	int platform = argc > 2 ? atoi(argv[1]) : -1, device = argc > 2 ? atoi(argv[2]) : -1;
	mc_cl_options opts = {0, 0, 0, false};
	if (argc > 5)
		opts = (mc_cl_options){atoi(argv[3]), atoi(argv[4]), atoi(argv[5]), argc > 6 && !strcmp(argv[6], "copy")};
	else if (getenv("MC_CL_COPY_BUFFERS")) /* side by side: buffers and copies instead of shared memory */
		opts.copy_buffers = true;
	unsigned long long rng = 2024;
	mc_raytable t[2];
	static mc_scene sc;

	tables_ego(t, 128);
	scene_human(&sc, 0.3, &rng);
	int rc = run_scenario("Synthetic person (tests/cl_scene.h): cameras looking straight down the body, 12 cm apart",
			      platform, device, opts, t, &sc, &rng);
	for (int c = 0; c < 2; c++)
		table_free(&t[c]);
	if (rc != 0)
		return rc;

	if (load_default(t, &sc) == 0) {
		rc = run_scenario("Default model (config/models/default.json), rest pose, rig config/rigs/ego_stereo.json",
				  platform, device, opts, t, &sc, &rng);
		for (int c = 0; c < 2; c++)
			mc_raytable_free(&t[c]);
	}
	return rc;
}
