/* Scenes, ray tables and images for the OpenCL energy test and benchmark
 * (tests/test_cl_energy.c, tests/bench_cl_energy.c).  Ray tables are built
 * here by hand (pinhole, and an ideal 180-degree equidistant fisheye), so
 * that these programs depend only on mc_math and the backend. */
#ifndef MC_CL_SCENE_H
#define MC_CL_SCENE_H

#include "energy/mc_energy.h"
#include "base/mc_math.h"
#include "geom/mc_rig.h"
#include "test_util.h"

#include <stdlib.h>
#include <string.h>

static inline double scene_uniform(unsigned long long *rng, double lo, double hi)
{
	return lo + (hi - lo) * mc_test_rand(rng);
}

static inline void table_alloc(mc_raytable *t, int w, int h, mc_vec3 origin)
{
	memset(t, 0, sizeof(*t));
	t->width = w;
	t->height = h;
	t->scale_x = t->scale_y = 1;
	t->origin = origin;
	t->dir = calloc((size_t)w * h, sizeof(mc_vec3));
	t->valid = calloc((size_t)w * h, 1);
	if (!t->dir || !t->valid) {
		fprintf(stderr, "out of memory\n");
		exit(1);
	}
}

static inline void table_free(mc_raytable *t)
{
	free(t->dir);
	free(t->valid);
	memset(t, 0, sizeof(*t));
}

/* Pinhole camera at `origin` looking along +z, focal length f pixels. */
static inline void table_pinhole(mc_raytable *t, int w, int h, double f, mc_vec3 origin)
{
	table_alloc(t, w, h, origin);
	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++) {
			int k = j * w + i;
			t->dir[k] = mc_v3_normalize(mc_v3((i + 0.5 - 0.5 * w) / f, (j + 0.5 - 0.5 * h) / f, 1));
			t->valid[k] = 1;
			t->nvalid++;
		}
}

/* 180-degree equidistant fisheye, w x w pixels, image circle touching the
 * borders; pixels outside the circle are invalid.  rig_from_cam rotates the
 * camera's rays into the rig frame. */
static inline void table_fisheye(mc_raytable *t, int w, mc_mat3 rig_from_cam, mc_vec3 origin)
{
	table_alloc(t, w, w, origin);
	for (int j = 0; j < w; j++)
		for (int i = 0; i < w; i++) {
			int k = j * w + i;
			double u = i + 0.5 - 0.5 * w, v = j + 0.5 - 0.5 * w, r = sqrt(u * u + v * v);
			double theta = r / (0.5 * w) * (M_PI / 2);
			if (theta >= M_PI / 2)
				continue;
			mc_vec3 d = r > 0 ? mc_v3(sin(theta) * u / r, sin(theta) * v / r, cos(theta)) : mc_v3(0, 0, 1);
			t->dir[k] = mc_m3_apply(rig_from_cam, d);
			t->valid[k] = 1;
			t->nvalid++;
		}
}

static inline void scene_random_hsv(unsigned long long *rng, double hsv[3])
{
	hsv[0] = mc_test_rand(rng);
	hsv[1] = mc_test_rand(rng);
	hsv[2] = mc_test_rand(rng);
}

/* n Gaussians scattered in front of a camera at the origin looking along +z. */
static inline void scene_random(mc_scene *s, int n, unsigned long long *rng)
{
	memset(s, 0, sizeof(*s));
	s->n = n;
	for (int q = 0; q < n; q++) {
		s->mu[q] = mc_v3(scene_uniform(rng, -0.6, 0.6), scene_uniform(rng, -0.45, 0.45),
				 scene_uniform(rng, 0.8, 3.0));
		s->sigma[q] = scene_uniform(rng, 0.03, 0.2);
		s->c[q] = scene_uniform(rng, 0.5, 1.5) / s->sigma[q];
		scene_random_hsv(rng, s->hsv[q]);
	}
}

/* A Gaussian standing for a sphere of radius r (roughly thesis 4.3 at
 * m = 0.1: the optical depth through the centre is ln 10). */
static inline void scene_add(mc_scene *s, mc_vec3 p, double r, const double hsv[3])
{
	int q = s->n++;
	s->mu[q] = p;
	s->sigma[q] = 0.75 * r;
	s->c[q] = log(10.0) / (sqrt(2 * M_PI) * s->sigma[q]);
	memcpy(s->hsv[q], hsv, sizeof(s->hsv[q]));
}

/* n Gaussians evenly along the segment a -> b, radius ra -> rb. */
static inline void scene_limb(mc_scene *s, mc_vec3 a, mc_vec3 b, int n, double ra, double rb, const double hsv[3])
{
	for (int i = 0; i < n; i++) {
		double t = n > 1 ? (double)i / (n - 1) : 0.5;
		scene_add(s, mc_v3_add(a, mc_v3_scale(mc_v3_sub(b, a), t)), ra + (rb - ra) * t, hsv);
	}
}

/* Rest direction d rotated by a random rotation of up to `amount` rad. */
static inline mc_vec3 scene_bend(mc_vec3 d, double amount, unsigned long long *rng)
{
	mc_vec3 w = mc_v3(scene_uniform(rng, -1, 1), scene_uniform(rng, -1, 1), scene_uniform(rng, -1, 1));
	return mc_m3_apply(mc_m3_from_rotvec(mc_v3_scale(w, amount / sqrt(3.0))), d);
}

/* A person of 68 Gaussians seen from a head-mounted rig: the rig frame is
 * the left camera's, the camera looks down the body (+z = down, x = the
 * person's left-right, -y = forward).  The limbs take random directions
 * around the rest pose, up to `amount` rad (0: rest pose). */
static inline void scene_human(mc_scene *s, double amount, unsigned long long *rng)
{
	static const double shirt[3] = {0.02, 0.7, 0.6}, skin[3] = {0.07, 0.4, 0.8}, jeans[3] = {0.6, 0.5, 0.35},
			    shoes[3] = {0.0, 0.1, 0.15}, hair[3] = {0.08, 0.3, 0.2};
	memset(s, 0, sizeof(*s));
	mc_vec3 neck = mc_v3(0.06, 0.22, 0.12);
	mc_vec3 down = scene_bend(mc_v3(0, 0, 1), 0.3 * amount, rng);
	mc_vec3 side = mc_v3_normalize(mc_v3_cross(mc_v3(0, 1, 0), down)); /* the person's left-right */
	mc_vec3 front = mc_v3_cross(down, side);
	mc_vec3 pelvis = mc_v3_add(neck, mc_v3_scale(down, 0.55));
	/* head (behind the cameras), neck, torso in three columns */
	scene_add(s, mc_v3(0.06, 0.2, -0.08), 0.09, hair);
	scene_add(s, mc_v3(0.06, 0.18, 0.0), 0.08, skin);
	scene_add(s, mc_v3_add(neck, mc_v3_scale(down, -0.03)), 0.05, skin);
	for (int col = -1; col <= 1; col++) {
		mc_vec3 off = mc_v3_scale(side, 0.08 * col);
		scene_limb(s, mc_v3_add(mc_v3_add(neck, off), mc_v3_scale(down, 0.1)),
			   mc_v3_add(mc_v3_add(pelvis, off), mc_v3_scale(down, -0.05)), 5, 0.1, 0.09, shirt);
	}
	for (int lr = -1; lr <= 1; lr += 2) {
		mc_vec3 shoulder = mc_v3_add(mc_v3_add(neck, mc_v3_scale(side, 0.18 * lr)), mc_v3_scale(down, 0.05));
		scene_add(s, shoulder, 0.06, shirt);
		mc_vec3 d1 = scene_bend(down, amount, rng), elbow = mc_v3_add(shoulder, mc_v3_scale(d1, 0.3));
		mc_vec3 d2 = scene_bend(d1, amount, rng), wrist = mc_v3_add(elbow, mc_v3_scale(d2, 0.27));
		mc_vec3 d3 = scene_bend(d2, 0.5 * amount, rng), hand = mc_v3_add(wrist, mc_v3_scale(d3, 0.1));
		scene_limb(s, shoulder, elbow, 4, 0.05, 0.045, skin);
		scene_limb(s, elbow, wrist, 4, 0.045, 0.035, skin);
		scene_limb(s, wrist, hand, 2, 0.035, 0.035, skin);

		mc_vec3 hip = mc_v3_add(pelvis, mc_v3_scale(side, 0.1 * lr));
		scene_add(s, hip, 0.08, jeans);
		mc_vec3 l1 = scene_bend(down, 0.6 * amount, rng), knee = mc_v3_add(hip, mc_v3_scale(l1, 0.45));
		mc_vec3 l2 = scene_bend(l1, 0.6 * amount, rng), ankle = mc_v3_add(knee, mc_v3_scale(l2, 0.43));
		mc_vec3 toe = mc_v3_add(ankle, mc_v3_scale(scene_bend(front, 0.3 * amount, rng), 0.18));
		scene_limb(s, hip, knee, 5, 0.075, 0.06, jeans);
		scene_limb(s, knee, ankle, 5, 0.055, 0.045, jeans);
		scene_limb(s, ankle, toe, 3, 0.045, 0.04, shoes);
	}
}

/* The stereo head-mounted rig: two 180-degree fisheyes looking down the
 * body, 12 cm apart, w x w working pixels each. */
static inline void tables_ego(mc_raytable t[2], int w)
{
	table_fisheye(&t[0], w, mc_m3_identity(), mc_v3(0, 0, 0));
	table_fisheye(&t[1], w, mc_m3_identity(), mc_v3(0.12, 0, 0));
}

/* Uniform random HSV image, 3 floats per pixel. */
static inline float *image_random(const mc_raytable *t, unsigned long long *rng)
{
	size_t n = (size_t)t->width * t->height;
	float *img = malloc(3 * n * sizeof(float));
	if (!img) {
		fprintf(stderr, "out of memory\n");
		exit(1);
	}
	for (size_t i = 0; i < 3 * n; i++)
		img[i] = (float)mc_test_rand(rng);
	return img;
}

#endif
