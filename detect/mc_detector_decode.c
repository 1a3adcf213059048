/* mc_detector: heatmap decoding and the mapping of detections to the
 * tracker's keypoints (plain C, no OpenCV: see mc_detector.h). */
#include "mc_detector.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The widest heat map blur_plane() takes (its row buffer is on the stack);
 * wider ones are decoded by the centroid. */
#define BLUR_MAX_W 4096

/* Separable Gaussian blur of one plane into out: radius ceil(3 sigma), at
 * most 8 cells, edges repeated (tools/train/common.py blur() is the same).
 * The inner loops run over contiguous floats without branches, so that
 * they vectorise: 0.03 ms for 18 planes of 32x32 here. */
static void blur_plane(const float *restrict in, float *restrict tmp, float *restrict out, int w, int h,
		       double sigma)
{
	enum { MAX_R = 8 };
	float k[2 * MAX_R + 1], row[BLUR_MAX_W + 2 * MAX_R];
	double e[2 * MAX_R + 1], ks = 0;
	int r = (int)ceil(3 * sigma);
	r = r > MAX_R ? MAX_R : r;
	for (int i = -r; i <= r; i++)
		ks += e[i + r] = exp(-0.5 * i * i / (sigma * sigma));
	for (int i = 0; i <= 2 * r; i++)
		k[i] = (float)(e[i] / ks);
	for (int y = 0; y < h; y++) {
		const float *restrict src = in + (size_t)y * (size_t)w;
		for (int i = 0; i < r; i++)
			row[i] = src[0], row[r + w + i] = src[w - 1];
		memcpy(row + r, src, (size_t)w * sizeof(float));
		float *restrict dst = tmp + (size_t)y * (size_t)w;
		for (int x = 0; x < w; x++)
			dst[x] = 0;
		for (int i = 0; i <= 2 * r; i++)
			for (int x = 0; x < w; x++)
				dst[x] += k[i] * row[x + i];
	}
	for (int y = 0; y < h; y++) {
		float *restrict dst = out + (size_t)y * (size_t)w;
		for (int x = 0; x < w; x++)
			dst[x] = 0;
		for (int i = -r; i <= r; i++) {
			int yy = y + i < 0 ? 0 : y + i >= h ? h - 1 : y + i;
			const float *restrict src = tmp + (size_t)yy * (size_t)w;
			for (int x = 0; x < w; x++)
				dst[x] += k[i + r] * src[x];
		}
	}
}

static size_t argmax_plane(const float *h, size_t plane)
{
	size_t best = 0;
	for (size_t i = 1; i < plane; i++)
		if (h[i] > h[best])
			best = i;
	return best;
}

/* The vertex of the parabola through the logs of three samples, as an
 * offset from the middle one (0 when they do not curve down). */
static double log_parabola_offset(float a, float b, float c)
{
	double la = log(fmax(a, 1e-10)), lb = log(fmax(b, 1e-10)), lc = log(fmax(c, 1e-10));
	double d2 = la - 2 * lb + lc;
	if (!(d2 < 0))
		return 0;
	double o = -0.5 * (lc - la) / d2;
	return o > 1 ? 1 : o < -1 ? -1 : o;
}

static void centroid3x3(const float *h, int width, int height, int bx, int by, double *xc, double *yc)
{
	double sw = 0, sx = 0, sy = 0;
	for (int y = by - 1; y <= by + 1; y++)
		for (int x = bx - 1; x <= bx + 1; x++) {
			if (x < 0 || y < 0 || x >= width || y >= height)
				continue;
			double w = h[(size_t)y * (size_t)width + (size_t)x];
			if (!(w > 0))
				continue;
			sw += w;
			sx += w * x;
			sy += w * y;
		}
	*xc = sw > 0 ? sx / sw : bx, *yc = sw > 0 ? sy / sw : by;
}

/* One heatmap's keypoint in heat-map cells, given its raw argmax best: that
 * cell moved to the 3x3 centroid (sigma 0), or DARK's: the map smoothed by
 * the training target's Gaussian, its argmax, the log-parabola vertex in x
 * and in y.  The
 * smoothing makes the argmax pick the peak with the most mass over a lone
 * spike, and the log of a Gaussian is a parabola, so the vertex has none of
 * the centroid's pull toward the cell's middle (up to 0.23 cell at 0.5
 * cell off with the centroid, a step of 1.9 input pixels when the argmax
 * moves on). */
static void locate(const float *h, size_t best, int width, int height, float sigma, float *scratch, double *xc,
		   double *yc)
{
	size_t plane = (size_t)width * (size_t)height;
	int bx = (int)(best % (size_t)width), by = (int)(best / (size_t)width);
	if (!(sigma > 0) || !scratch || width > BLUR_MAX_W) {
		centroid3x3(h, width, height, bx, by, xc, yc);
		return;
	}
	const float *s = scratch + plane;
	blur_plane(h, scratch, scratch + plane, width, height, sigma);
	best = argmax_plane(s, plane);
	bx = (int)(best % (size_t)width), by = (int)(best / (size_t)width);
	size_t at = best, w = (size_t)width;
	*xc = bx + (bx > 0 && bx < width - 1 ? log_parabola_offset(s[at - 1], s[at], s[at + 1]) : 0);
	*yc = by + (by > 0 && by < height - 1 ? log_parabola_offset(s[at - w], s[at], s[at + w]) : 0);
}

int mc_detector_decode(const float *heatmaps, int njoints, int height, int width, int in_w, int in_h, int native_w,
		       int native_h, float threshold, float sigma, mc_detection *out, int max)
{
	if (!heatmaps || njoints <= 0 || height <= 0 || width <= 0 || in_w <= 0 || in_h <= 0 || !out)
		return 0;
	int n = 0;
	const size_t plane = (size_t)width * (size_t)height;
	/* Without scratch (out of memory) the centroid still decodes. */
	float *scratch = sigma > 0 ? malloc(2 * plane * sizeof(float)) : NULL;
	for (int j = 0; j < njoints && n < max; j++) {
		const float *h = heatmaps + (size_t)j * plane;
		size_t best = argmax_plane(h, plane);
		float conf = h[best];
		/* NaN never passes; confidences outside [0, 1] (a model that
		 * breaks the contract) are clamped. */
		if (!(conf >= threshold))
			continue;
		double xc, yc;
		locate(h, best, width, height, sigma, scratch, &xc, &yc);
		double u_in = (xc + 0.5) * in_w / width - 0.5, v_in = (yc + 0.5) * in_h / height - 0.5;
		double u = (u_in + 0.5) * native_w / in_w - 0.5, v = (v_in + 0.5) * native_h / in_h - 0.5;
		out[n++] = (mc_detection){.joint = j,
					  .u = (float)u,
					  .v = (float)v,
					  .confidence = conf > 1.0f ? 1.0f : conf < 0.0f ? 0.0f : conf};
	}
	free(scratch);
	return n;
}

int mc_detector_map_names(const mc_detector *d, const char *const *names, int nnames, int *map)
{
	int found = 0;
	for (int j = 0; j < mc_detector_njoints(d); j++) {
		map[j] = -1;
		const char *name = mc_detector_joint_name(d, j);
		for (int k = 0; names && k < nnames; k++)
			if (names[k] && !strcmp(names[k], name)) {
				map[j] = k;
				found++;
				break;
			}
	}
	return found;
}

int mc_detector_map_model(const mc_detector *d, const mc_model *model, int *map)
{
	const char *names[MC_MAX_JOINTS];
	int n = model ? model->njoints : 0;
	for (int k = 0; k < n; k++)
		names[k] = model->joints[k].name;
	return mc_detector_map_names(d, names, n, map);
}

int mc_detections_to_keypoints(const mc_detection *det, int ndet, int cam, const int *map, mc_keypoint *out,
			       int max)
{
	int n = 0;
	for (int i = 0; i < ndet && n < max; i++) {
		int joint = det[i].joint >= 0 ? map[det[i].joint] : -1;
		if (joint < 0)
			continue;
		out[n++] = (mc_keypoint){.cam = cam,
					 .joint = joint,
					 .u = det[i].u,
					 .v = det[i].v,
					 .conf = det[i].confidence};
	}
	return n;
}

int mc_detector_detect_views(mc_detector *d, const mc_frame_view *views, int nviews, const int *map,
			     mc_keypoint *out, int max, mc_err *err)
{
	mc_detection det[MC_DETECTOR_MAX_JOINTS];
	int n = 0;
	for (int c = 0; c < nviews; c++) {
		if (!views[c].rgb)
			continue;
		int nd = mc_detector_detect(d, views[c].rgb, views[c].width, views[c].height, views[c].stride, det,
					    MC_DETECTOR_MAX_JOINTS, err);
		if (nd < 0)
			return mc_err_prefix(err, "camera %d", c);
		n += mc_detections_to_keypoints(det, nd, c, map, out + n, max - n);
	}
	return n;
}

int mc_detector_square_around(const mc_camera *cam, const mc_vec3 *joints_rig, int n, mc_detector_square *out)
{
	mc_xform cam_from_rig = mc_xform_inverse(cam->rig_from_cam);
	double lo_u = INFINITY, lo_v = INFINITY, hi_u = -INFINITY, hi_v = -INFINITY;
	int seen = 0;
	for (int i = 0; i < n; i++) {
		double u, v;
		if (!mc_camera_project_unbounded(cam, mc_xform_apply(cam_from_rig, joints_rig[i]), &u, &v) ||
		    !isfinite(u) || !isfinite(v))
			continue;
		lo_u = fmin(lo_u, u), hi_u = fmax(hi_u, u);
		lo_v = fmin(lo_v, v), hi_v = fmax(hi_v, v);
		seen++;
	}
	if (seen < 3)
		return -1;
	double side = cam->width > cam->height ? cam->width : cam->height;
	double half = 1.25 * 0.5 * fmax(hi_u - lo_u, hi_v - lo_v) + 0.03 * side;
	double cu = 0.5 * (lo_u + hi_u), cv = 0.5 * (lo_v + hi_v);
	*out = (mc_detector_square){(float)(cu - half), (float)(cv - half), (float)(2 * half)};
	return 0;
}
