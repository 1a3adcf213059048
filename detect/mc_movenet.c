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

/* The person's cell: the centre map's argmax, weighted toward the middle. */
static size_t person_cell(const mc_movenet_heads *h)
{
	return weighted_argmax(h->centers, h->height, h->width, (float)(h->height / 2), (float)(h->width / 2));
}

/* Joint j's rough place (cells): the person's cell plus its regression. */
static void rough_place(const mc_movenet_heads *h, size_t c, int j, float *ry, float *rx)
{
	const size_t plane = (size_t)h->height * (size_t)h->width;
	*ry = (float)(c / (size_t)h->width) + h->regress[(size_t)(2 * j) * plane + c];
	*rx = (float)(c % (size_t)h->width) + h->regress[(size_t)(2 * j + 1) * plane + c];
}

/* Joint j at cell k: the cell plus its offset, as fractions; the score. */
static mc_movenet_point point_at(const mc_movenet_heads *h, int j, size_t k)
{
	const size_t plane = (size_t)h->height * (size_t)h->width;
	float ky = (float)(k / (size_t)h->width), kx = (float)(k % (size_t)h->width);
	return (mc_movenet_point){.y = (ky + h->offsets[(size_t)(2 * j) * plane + k]) / (float)h->height,
				  .x = (kx + h->offsets[(size_t)(2 * j + 1) * plane + k]) / (float)h->width,
				  .score = h->heatmaps[(size_t)j * plane + k]};
}

void mc_movenet_decode(const mc_movenet_heads *h, mc_movenet_point *out)
{
	const size_t plane = (size_t)h->height * (size_t)h->width;
	size_t c = person_cell(h);
	for (int j = 0; j < h->njoints; j++) {
		float ry, rx;
		rough_place(h, c, j, &ry, &rx);
		size_t k = weighted_argmax(h->heatmaps + (size_t)j * plane, h->height, h->width, ry, rx);
		out[j] = point_at(h, j, k);
	}
}

/* ---- one limb under both labels ----------------------------------------- */

/* COCO's left/right pairs of limb joints: shoulders, elbows, wrists, hips,
 * knees, ankles. */
static const int COCO_PAIRS[][2] = {{5, 6}, {7, 8}, {9, 10}, {11, 12}, {13, 14}, {15, 16}};

static int local_maximum(const float *map, int height, int width, int y, int x)
{
	float v = map[y * width + x];
	for (int dy = -1; dy <= 1; dy++)
		for (int dx = -1; dx <= 1; dx++) {
			int yy = y + dy, xx = x + dx;
			if ((dy || dx) && yy >= 0 && yy < height && xx >= 0 && xx < width && map[yy * width + xx] > v)
				return 0;
		}
	return 1;
}

/* Joint j's best peak (a local maximum of its heat map, weighted as the
 * decoding weighs it, toward its rough place (ry, rx)) farther than
 * MC_MOVENET_PAIR_EXCLUDE cells from the spot (sy, sx) and nearer the rough
 * place than the spot is; -1 when none reaches min_score. */
static long second_peak(const mc_movenet_heads *h, int j, float ry, float rx, float sy, float sx, float min_score)
{
	const float *map = h->heatmaps + (size_t)j * (size_t)h->height * (size_t)h->width;
	const float spot_to_rough = hypotf(sy - ry, sx - rx);
	long best = -1;
	float best_value = -INFINITY;
	for (int y = 0; y < h->height; y++)
		for (int x = 0; x < h->width; x++) {
			float v = map[y * h->width + x], to_rough = hypotf((float)y - ry, (float)x - rx);
			if (v < min_score || to_rough >= spot_to_rough ||
			    hypotf((float)y - sy, (float)x - sx) <= MC_MOVENET_PAIR_EXCLUDE ||
			    !local_maximum(map, h->height, h->width, y, x))
				continue;
			float w = v / (to_rough + MOVENET_DISTANCE_BIAS);
			if (w > best_value) {
				best_value = w;
				best = (long)y * h->width + x;
			}
		}
	return best;
}

void mc_movenet_separate_pairs(const mc_movenet_heads *h, float min_score, mc_movenet_point *out)
{
	size_t c = person_cell(h);
	for (size_t i = 0; i < sizeof(COCO_PAIRS) / sizeof(COCO_PAIRS[0]); i++) {
		int a = COCO_PAIRS[i][0], b = COCO_PAIRS[i][1];
		if (b >= h->njoints)
			continue;
		float sy = out[a].y * (float)h->height, sx = out[a].x * (float)h->width;
		if (hypotf(out[b].y * (float)h->height - sy, out[b].x * (float)h->width - sx) > MC_MOVENET_PAIR_CELLS)
			continue;
		/* The joint whose rough place lies farther from the shared spot
		 * is the one misplaced; when that place is at the spot too, the
		 * network means one place (legs together), and both stay. */
		float ray, rax, rby, rbx;
		rough_place(h, c, a, &ray, &rax);
		rough_place(h, c, b, &rby, &rbx);
		int m = hypotf(ray - sy, rax - sx) > hypotf(rby - sy, rbx - sx) ? a : b;
		float ry = m == a ? ray : rby, rx = m == a ? rax : rbx;
		if (hypotf(ry - sy, rx - sx) <= MC_MOVENET_PAIR_EXCLUDE)
			continue;
		long k = second_peak(h, m, ry, rx, sy, sx, min_score);
		if (k < 0)
			continue;
		/* The pair's score goes with it: the heat map is low there because
		 * the network doubts the side, which the tracker settles. */
		float score = out[m].score;
		out[m] = point_at(h, m, (size_t)k);
		out[m].score = score;
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
