/* mc_background: what the scene behind the actor looks like, as a few
 * colour clusters, so that the colour energy can tell "this pixel looks
 * like the shirt" from "this pixel looks like the shirt, and like the floor".
 *
 * The clusters are learnt from pixels that cannot show the body (outside
 * every Gaussian's projected reach at the predicted pose), and follow the
 * scene as the head-mounted cameras move.  mc_background_match() gives, for
 * an image colour, how much it looks like the background, in [0, 1]; the
 * energy turns that into a weaker reward for covering the pixel (see
 * docs/TRACKER.md, "Background contrast"). */
#ifndef MC_BACKGROUND_H
#define MC_BACKGROUND_H

#include <stdbool.h>
#include <stdint.h>

#define MC_BG_CLUSTERS 8

typedef struct {
	int n;                               /* clusters in use */
	double rgb[MC_BG_CLUSTERS][3];       /* centres, [0, 1] */
	double hsv[MC_BG_CLUSTERS][3];       /* the same in HSV */
	double count[MC_BG_CLUSTERS];        /* pixels behind each centre */
} mc_background;

void mc_background_reset(mc_background *bg);

/* Updates the clusters from background pixels: `pixels` index a packed
 * float RGB image.  At most `max_samples` of them are drawn at random; a few
 * k-means steps start from the current centres.  `keep` in [0, 1) is how
 * much of the old clusters' weight survives (0 = learn afresh). */
void mc_background_update(mc_background *bg, const float *rgb, const int *pixels, int npixels, int max_samples,
			  double keep, uint64_t *rng);

/* How much an image colour (HSV in [0, 1]) looks like the background:
 * 0 (like none of the clusters) .. 1 (exactly one of them): the square of
 * (1 - d) / 2 for the nearest cluster, d the HSV dissimilarity the energy
 * uses. 0 when there are no clusters. */
double mc_background_match(const mc_background *bg, const double hsv[3]);

#endif
