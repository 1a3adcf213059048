#include "mc_background.h"

#include "mc_energy.h"

#include <math.h>
#include <string.h>

/* Clusters lighter than this share of the pixels are dropped: a few stray
 * pixels must not make a colour "background". */
#define MIN_SHARE 0.02
#define KMEANS_STEPS 4

void mc_background_reset(mc_background *bg)
{
	memset(bg, 0, sizeof(*bg));
}

static uint64_t next_random(uint64_t *s)
{
	uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

static double dist2(const double *a, const float *b)
{
	double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
	return d0 * d0 + d1 * d1 + d2 * d2;
}

static int nearest(const mc_background *bg, const float *c)
{
	int best = 0;
	double bd = INFINITY;
	for (int k = 0; k < bg->n; k++) {
		double d = dist2(bg->rgb[k], c);
		if (d < bd) {
			bd = d;
			best = k;
		}
	}
	return best;
}

/* New centres start at sampled pixels far from the existing ones
 * (farthest-point seeding), so that a colour the cameras just turned to
 * gets a cluster of its own. */
static void seed_clusters(mc_background *bg, const float *rgb, const int *sample, int ns)
{
	while (bg->n < MC_BG_CLUSTERS && ns > 0) {
		int far = 0;
		double fd = -1;
		for (int i = 0; i < ns; i++) {
			const float *c = rgb + 3 * (size_t)sample[i];
			double d = bg->n ? dist2(bg->rgb[nearest(bg, c)], c) : INFINITY;
			if (d > fd) {
				fd = d;
				far = i;
			}
		}
		if (bg->n && fd < 0.01) /* everything is near a centre already */
			break;
		const float *c = rgb + 3 * (size_t)sample[far];
		for (int j = 0; j < 3; j++)
			bg->rgb[bg->n][j] = c[j];
		bg->count[bg->n++] = 0;
	}
}

static void kmeans_step(mc_background *bg, const float *rgb, const int *sample, int ns, const double *old_count,
			double keep)
{
	double sum[MC_BG_CLUSTERS][3], cnt[MC_BG_CLUSTERS];
	for (int k = 0; k < bg->n; k++) {
		cnt[k] = keep * old_count[k];
		for (int j = 0; j < 3; j++)
			sum[k][j] = cnt[k] * bg->rgb[k][j];
	}
	for (int i = 0; i < ns; i++) {
		const float *c = rgb + 3 * (size_t)sample[i];
		int k = nearest(bg, c);
		cnt[k] += 1;
		for (int j = 0; j < 3; j++)
			sum[k][j] += c[j];
	}
	for (int k = 0; k < bg->n; k++) {
		if (cnt[k] > 0)
			for (int j = 0; j < 3; j++)
				bg->rgb[k][j] = sum[k][j] / cnt[k];
		bg->count[k] = cnt[k];
	}
}

static void drop_light_clusters(mc_background *bg)
{
	double total = 0;
	for (int k = 0; k < bg->n; k++)
		total += bg->count[k];
	int n = 0;
	for (int k = 0; k < bg->n; k++)
		if (total > 0 && bg->count[k] >= MIN_SHARE * total) {
			memcpy(bg->rgb[n], bg->rgb[k], sizeof(bg->rgb[k]));
			bg->count[n++] = bg->count[k];
		}
	bg->n = n;
	for (int k = 0; k < bg->n; k++)
		mc_rgb_to_hsv(bg->rgb[k], bg->hsv[k]);
}

void mc_background_update(mc_background *bg, const float *rgb, const int *pixels, int npixels, int max_samples,
			  double keep, uint64_t *rng)
{
	enum { MAX_SAMPLES = 4096 };
	int sample[MAX_SAMPLES];
	int ns = npixels < max_samples ? npixels : max_samples;
	if (ns > MAX_SAMPLES)
		ns = MAX_SAMPLES;
	if (ns <= 0)
		return;
	for (int i = 0; i < ns; i++)
		sample[i] = pixels[ns == npixels ? i : (int)(next_random(rng) % (uint64_t)npixels)];
	double old_count[MC_BG_CLUSTERS];
	seed_clusters(bg, rgb, sample, ns);
	memcpy(old_count, bg->count, sizeof(old_count));
	for (int s = 0; s < KMEANS_STEPS; s++)
		kmeans_step(bg, rgb, sample, ns, old_count, keep);
	drop_light_clusters(bg);
}

double mc_background_match(const mc_background *bg, const double hsv[3])
{
	double best = 0;
	for (int k = 0; k < bg->n; k++) {
		/* squared: only colours close to a cluster count as background;
		 * a body colour that is merely "not unlike" the scene keeps most
		 * of its reward (measured: docs/TRACKER.md) */
		double s = 0.5 * (1.0 - mc_hsv_dissimilarity(bg->hsv[k], hsv));
		s *= s;
		if (s > best)
			best = s;
	}
	return best;
}
