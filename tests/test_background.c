/* Background colour clusters (core/mc_background): learnt from pixels that
 * cannot show the body, they say how much a colour looks like the scene,
 * and follow it when the cameras turn to a new one. */
#include "mc_background.h"
#include "mc_energy.h"
#include "test_util.h"

#include <string.h>

#define N 2000

static void fill(float *rgb, int *idx, int n, const double a[3], const double b[3], unsigned long long *rng)
{
	for (int i = 0; i < n; i++) {
		const double *c = i % 3 ? a : b; /* two thirds a, one third b */
		for (int k = 0; k < 3; k++)
			rgb[3 * i + k] = (float)(c[k] + 0.03 * (mc_test_rand(rng) - 0.5));
		idx[i] = i;
	}
}

static double match_rgb(const mc_background *bg, const double rgb[3])
{
	double hsv[3];
	mc_rgb_to_hsv(rgb, hsv);
	return mc_background_match(bg, hsv);
}

int main(void)
{
	static float rgb[3 * N];
	static int idx[N];
	unsigned long long rng = 5;
	uint64_t seed = 9;
	const double floor[3] = {0.62, 0.60, 0.57}, grass[3] = {0.30, 0.45, 0.20};
	const double red_shirt[3] = {0.55, 0.15, 0.12}, blue[3] = {0.15, 0.20, 0.60};
	mc_background bg;
	mc_background_reset(&bg);
	CHECK(match_rgb(&bg, floor) == 0); /* nothing learnt: nothing matches */

	fill(rgb, idx, N, floor, grass, &rng);
	mc_background_update(&bg, rgb, idx, N, 1500, 0.0, &seed);
	CHECK(bg.n >= 2 && bg.n <= MC_BG_CLUSTERS);
	printf("clusters %d; match floor %.2f grass %.2f shirt %.2f blue %.2f\n", bg.n, match_rgb(&bg, floor),
	       match_rgb(&bg, grass), match_rgb(&bg, red_shirt), match_rgb(&bg, blue));
	CHECK(match_rgb(&bg, floor) > 0.9);
	CHECK(match_rgb(&bg, grass) > 0.9);
	CHECK(match_rgb(&bg, red_shirt) < 0.3);
	CHECK(match_rgb(&bg, blue) < 0.3);

	/* The cameras turn to a blue wall: it becomes background within a few
	 * updates, while the floor is still remembered. */
	double before = match_rgb(&bg, blue);
	fill(rgb, idx, N, blue, blue, &rng);
	for (int i = 0; i < 3; i++)
		mc_background_update(&bg, rgb, idx, N, 1500, 0.7, &seed);
	CHECK(match_rgb(&bg, blue) > 0.9 && match_rgb(&bg, blue) > before);
	CHECK(match_rgb(&bg, floor) > 0.5);
	CHECK(match_rgb(&bg, red_shirt) < 0.3);

	/* A few stray pixels do not make a colour background. */
	mc_background_reset(&bg);
	fill(rgb, idx, N, floor, floor, &rng);
	for (int i = 0; i < 10; i++)
		for (int k = 0; k < 3; k++)
			rgb[3 * i + k] = (float)red_shirt[k];
	mc_background_update(&bg, rgb, idx, N, N, 0.0, &seed);
	CHECK(match_rgb(&bg, red_shirt) < 0.3);
	CHECK(match_rgb(&bg, floor) > 0.9);

	/* The contrast: background-like pixels never reward, others keep d. */
	CHECK_NEAR(mc_background_contrast(-1.0, 0.0), -1.0, 1e-12);
	CHECK_NEAR(mc_background_contrast(-1.0, 1.0), 0.0, 1e-12);
	CHECK_NEAR(mc_background_contrast(1.0, 1.0), 1.0, 1e-12);
	CHECK_NEAR(mc_background_contrast(0.2, 0.5), 0.2 + 0.5 * 0.5 * 0.8, 1e-12);
	return mc_test_finish("test_background");
}
