/* mc_movenet: MoveNet's single-pose decoding and the second pass's crop
 * (see mc_movenet.h). */
#include "mc_movenet.h"

#include <math.h>
#include <stddef.h>

/* MoveNet's distance bias: a cell's weight is 1 / (distance + 1.8). */
#define MOVENET_DISTANCE_BIAS 1.8f

/* COCO's joint order, which MoveNet's heads follow. */
enum { COCO_LEFT_SHOULDER = 5, COCO_RIGHT_SHOULDER = 6, COCO_LEFT_HIP = 11, COCO_RIGHT_HIP = 12 };

/* Argmax over an H x W map weighted by 1 / (distance to (cy, cx) + bias);
 * the first cell in raster order on ties, as TensorFlow's ArgMax. */
static size_t weighted_argmax(const float *map, int height, int width, float cy, float cx)
{
	size_t best = 0;
	float best_value = -INFINITY;
	for (int y = 0; y < height; y++)
		for (int x = 0; x < width; x++) {
			float d = sqrtf((y - cy) * (y - cy) + (x - cx) * (x - cx));
			size_t i = (size_t)y * (size_t)width + (size_t)x;
			float v = map[i] / (d + MOVENET_DISTANCE_BIAS);
			if (v > best_value) {
				best_value = v;
				best = i;
			}
		}
	return best;
}

void mc_movenet_decode(const mc_movenet_heads *h, mc_movenet_point *out)
{
	const size_t plane = (size_t)h->height * (size_t)h->width;
	size_t c = weighted_argmax(h->centers, h->height, h->width, (float)(h->height / 2), (float)(h->width / 2));
	float cy = (float)(c / (size_t)h->width), cx = (float)(c % (size_t)h->width);
	for (int j = 0; j < h->njoints; j++) {
		float ry = cy + h->regress[(size_t)(2 * j) * plane + c];
		float rx = cx + h->regress[(size_t)(2 * j + 1) * plane + c];
		const float *heat = h->heatmaps + (size_t)j * plane;
		size_t k = weighted_argmax(heat, h->height, h->width, ry, rx);
		float ky = (float)(k / (size_t)h->width), kx = (float)(k % (size_t)h->width);
		out[j].y = (ky + h->offsets[(size_t)(2 * j) * plane + k]) / (float)h->height;
		out[j].x = (kx + h->offsets[(size_t)(2 * j + 1) * plane + k]) / (float)h->width;
		out[j].score = heat[k];
	}
}

mc_movenet_square mc_movenet_full_square(int width, int height)
{
	float size = (float)(width > height ? width : height);
	return (mc_movenet_square){.x0 = 0.5f * ((float)width - size), .y0 = 0.5f * ((float)height - size),
				   .size = size};
}

static int seen(const float *score, int j, float min_score) { return score[j] >= min_score; }

int mc_movenet_person_square(const float *xy, const float *score, int njoints, float min_score,
			     mc_movenet_square *out)
{
	if (njoints <= COCO_RIGHT_HIP)
		return -1;
	if (!(seen(score, COCO_LEFT_HIP, min_score) || seen(score, COCO_RIGHT_HIP, min_score)) ||
	    !(seen(score, COCO_LEFT_SHOULDER, min_score) || seen(score, COCO_RIGHT_SHOULDER, min_score)))
		return -1;
	/* The centre: the mid-hip point, or the hip that is seen. */
	float cx = 0, cy = 0, n = 0;
	for (int j = COCO_LEFT_HIP; j <= COCO_RIGHT_HIP; j++)
		if (seen(score, j, min_score)) {
			cx += xy[2 * j];
			cy += xy[2 * j + 1];
			n += 1;
		}
	cx /= n;
	cy /= n;
	float torso = 0, body = 0;
	for (int j = 0; j < njoints; j++) {
		if (!seen(score, j, min_score))
			continue;
		float dx = fabsf(xy[2 * j] - cx), dy = fabsf(xy[2 * j + 1] - cy);
		float d = dx > dy ? dx : dy;
		int is_torso = j == COCO_LEFT_SHOULDER || j == COCO_RIGHT_SHOULDER || j == COCO_LEFT_HIP ||
			       j == COCO_RIGHT_HIP;
		if (is_torso && d > torso)
			torso = d;
		if (d > body)
			body = d;
	}
	float half = fmaxf(1.9f * torso, 1.2f * body);
	if (!(half >= 8.0f))
		return -1;
	*out = (mc_movenet_square){.x0 = cx - half, .y0 = cy - half, .size = 2.0f * half};
	return 0;
}
