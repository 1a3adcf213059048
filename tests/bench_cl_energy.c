/* Benchmark of the OpenCL colour energy (core/mc_cl): evaluations per second
 * of energy + gradient for 1000, 3000 and 10000 sampled pixels over the two
 * 128 x 128 fisheye views of a head-mounted rig looking at a person of 68
 * Gaussians, with and without dropout, against the double reference
 * (mc_energy_color, one thread).  Prints figures; asserts nothing.
 *
 *   bench_cl_energy [platform device]     (default: -1 -1, see mc_cl.h) */
#include "cl_scene.h"
#include "mc_cl.h"
#include "test_util.h"

#include <stdlib.h>
#include <time.h>

static double clock_s(clockid_t id)
{
	struct timespec ts;
	clock_gettime(id, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double now(void)
{
	return clock_s(CLOCK_MONOTONIC);
}

/* CPU time of every thread of the process (PoCL's workers included): the
 * work done, whatever else the machine is running. */
static double cpu_now(void)
{
	return clock_s(CLOCK_PROCESS_CPUTIME_ID);
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

int main(int argc, char **argv)
{
	int platform = argc > 2 ? atoi(argv[1]) : -1, device = argc > 2 ? atoi(argv[2]) : -1;
	unsigned long long rng = 2024;
	mc_raytable t[2];
	tables_ego(t, 128);
	float *img[2] = {image_random(&t[0], &rng), image_random(&t[1], &rng)};
	mc_scene sc;
	scene_human(&sc, 0.3, &rng);

	mc_err err = {{0}};
	double t0 = now();
	mc_cl_energy *e = mc_cl_energy_create(platform, device, t, 2, &err);
	if (!e) {
		printf("SKIP: %s\n", err.msg);
		return 77;
	}
	double t_create = now() - t0;
	for (int c = 0; c < 2; c++)
		if (mc_cl_energy_set_image(e, c, img[c], &err) != 0) {
			fprintf(stderr, "%s\n", err.msg);
			return 1;
		}
	printf("device: %s\n", mc_cl_energy_device(e));
	printf("scene: %d Gaussians, 2 cameras of 128x128 (%d + %d valid pixels); create %.0f ms\n", sc.n,
	       t[0].nvalid, t[1].nvalid, 1e3 * t_create);

	static const int sizes[] = {1, 1000, 3000, 10000};
	static const double dropouts[] = {0, 0.5};
	for (size_t si = 0; si < sizeof(sizes) / sizeof(sizes[0]); si++) {
		int *pix[2], npix[2];
		sample_pixels(t, 2, sizes[si] < 2 ? 2 : sizes[si], pix, npix, &rng);
		double act = mean_active(&sc, t, 2, pix, npix);
		for (size_t di = 0; di < sizeof(dropouts) / sizeof(dropouts[0]); di++) {
			mc_vec3 dmu[MC_MAX_GAUSSIANS];
			double dsig[MC_MAX_GAUSSIANS], E = 0;
			int runs = 0;
			double start = now(), cpu_start = cpu_now(), elapsed;
			do {
				if (mc_cl_energy_eval(e, &sc, (const int *const *)pix, npix, dropouts[di], (uint32_t)runs, &E,
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
				Eref += mc_energy_color(&sc, &v, pix[c], npix[c], dmu, dsig);
			}
			printf("%6d pixels, reference mc_energy_color (double, 1 thread): %8.3f ms CPU/eval (E %.6g)\n",
			       npix[0] + npix[1], 1e3 * (cpu_now() - start), Eref);
		}
		free(pix[0]);
		free(pix[1]);
	}
	mc_cl_energy_destroy(e);
	for (int c = 0; c < 2; c++) {
		table_free(&t[c]);
		free(img[c]);
	}
	return 0;
}
