/* The shipped head-mounted detectors (every file in config/models that
 * matches *ego*.onnx: the live ego_detector.onnx and the offline
 * ego_offline_detector.onnx; or $MOCAP_DETECT_MODEL) on real frames of the bundled demo clip
 * (tests/data/ego_demo): the ground-truth joints of gt.json
 * (joints_left_cam) projected through calib.json (equidistant, r = f theta
 * about (cx, cy); the right camera through right_from_left, by mc_clip)
 * against the detections.
 *
 * The checks: on left/00000.jpg (256x256) at least MIN_FOUND of the 18
 * joints are detected and the median pixel error over them is at most
 * BOUND_FRAME0_PX; over frames 0, 15, 30, 45 of both cameras (8 views) the
 * median is at most BOUND_ALL_PX.  Each view's median and 90th percentile
 * and its misses are printed.  The flip test (mc_detector_set_flip) makes
 * the detector mirror-symmetric on left/00000.jpg.  Skips (77) when no
 * model is there. */
#include "base/mc_stats.h"
#include "eval/mc_clip.h"
#include "geom/mc_camera.h"
#include "mc_detector.h"
#include "test_util.h"

#include <glob.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* What the model must achieve, set from what it achieves with a margin
 * (docs/DETECT_RUNTIME.md, "The shipped model on the demo clip"). */
#define BOUND_FRAME0_PX 20.0
#define BOUND_ALL_PX 14.0
#define MIN_FOUND 12

/* The q-th percentile (0..100) of n samples (sorted in place). */
static double percentile(double *v, int n, double q)
{
	mc_stats_sort(v, (size_t)n);
	return mc_stats_percentile(v, (size_t)n, q);
}

/* Detects on view `cam` of frame k; appends the pixel errors of detected
 * joints to err_px, returns the number detected; *missed counts the joints
 * not detected. */
static int measure(mc_detector *d, const mc_clip *clip, const mc_frame_view *view, int k, int cam, double *err_px,
		   int *nerr, int *missed, bool print)
{
	mc_detection det[MC_DETECTOR_MAX_JOINTS];
	mc_err err = {{0}};
	int n = mc_detector_detect(d, view->rgb, view->width, view->height, view->stride, det, MC_DETECTOR_MAX_JOINTS,
				   &err);
	CHECK_MSG(n >= 0, "%s", err.msg);
	if (n < 0)
		return 0;
	bool seen[MC_DETECTOR_MAX_JOINTS] = {false};
	const mc_camera *c = &clip->rig.cams[cam];
	for (int i = 0; i < n; i++) {
		const char *name = mc_detector_joint_name(d, det[i].joint);
		int g = mc_clip_joint(clip, name);
		if (g < 0)
			continue;
		seen[det[i].joint] = true;
		double u, v;
		if (!mc_camera_project_rig(c, mc_clip_gt(clip, k, g), &u, &v))
			continue;
		double e = hypot(det[i].u - u, det[i].v - v);
		err_px[(*nerr)++] = e;
		if (print)
			printf("  %-15s detected (%6.1f, %6.1f) conf %.2f, truth (%6.1f, %6.1f): %5.1f px\n", name,
			       det[i].u, det[i].v, det[i].confidence, u, v, e);
	}
	for (int j = 0; j < mc_detector_njoints(d); j++)
		if (!seen[j] && mc_clip_joint(clip, mc_detector_joint_name(d, j)) >= 0) {
			(*missed)++;
			if (print)
				printf("  %-15s not detected\n", mc_detector_joint_name(d, j));
		}
	return n;
}

/* The joint's left/right partner (itself for the middle joints). */
static int partner(const mc_detector *d, int j)
{
	char other[64];
	if (mc_joint_other_side_name(mc_detector_joint_name(d, j), other, sizeof(other)) != 1)
		return j;
	return mc_detector_find_joint(d, other);
}

/* How many joints break the mirror symmetry: detected on the view and on its
 * mirror image, joint j of the one against its partner of the other (u to
 * width - 1 - u) more than 0.01 px or 1e-4 in confidence apart, or found in
 * one only.  With the flip test the detector is symmetric by construction
 * (its heat maps are an average of both passes), so the count is 0. */
static int mirror_mismatches(mc_detector *d, const mc_frame_view *view)
{
	int w = view->width, h = view->height, bad = 0;
	uint8_t *mirrored = malloc((size_t)w * (size_t)h * 3);
	if (!mirrored)
		return -1;
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++)
			memcpy(mirrored + ((size_t)y * (size_t)w + (size_t)(w - 1 - x)) * 3,
			       view->rgb + (size_t)y * (size_t)view->stride + (size_t)x * 3, 3);
	mc_detection a[MC_DETECTOR_MAX_JOINTS], b[MC_DETECTOR_MAX_JOINTS];
	mc_err err = {{0}};
	int na = mc_detector_detect(d, view->rgb, w, h, view->stride, a, MC_DETECTOR_MAX_JOINTS, &err);
	int nb = mc_detector_detect(d, mirrored, w, h, 0, b, MC_DETECTOR_MAX_JOINTS, &err);
	free(mirrored);
	if (na < 0 || nb < 0)
		return -1;
	bad = na != nb;
	for (int i = 0; i < na; i++) {
		int k = 0, p = partner(d, a[i].joint);
		while (k < nb && b[k].joint != p)
			k++;
		if (k == nb || fabs(b[k].u - (w - 1 - a[i].u)) > 0.01 || fabs(b[k].v - a[i].v) > 0.01 ||
		    fabs(b[k].confidence - a[i].confidence) > 1e-4)
			bad++;
	}
	return bad;
}

/* The flip test (mc_detector_set_flip) on the demo's first left view. */
static void test_flip(mc_detector *d, const mc_frame_view *view)
{
	int plain = mirror_mismatches(d, view);
	mc_detector_set_flip(d, 1);
	int flipped = mirror_mismatches(d, view);
	mc_detector_set_flip(d, 0);
	printf("flip test: %d joints break the mirror symmetry without it, %d with it\n", plain, flipped);
	CHECK_MSG(plain > 0, "the plain network is mirror-symmetric on this view (%d): the check below proves nothing",
		  plain);
	CHECK_MSG(flipped == 0, "%d joints break the mirror symmetry with the flip test", flipped);
}

/* The checks above on one model. */
static void test_model(const char *model, mc_clip *clip)
{
	mc_err err = {{0}};
	mc_detector *d = mc_detector_load(model, &err);
	CHECK_MSG(d, "%s: %s", model, err.msg);
	if (!d)
		return;
	int hw, hh;
	mc_detector_heatmap_size(d, &hw, &hh);
	printf("%s: %d joints, heatmaps %dx%d, threshold %.2f\n", model, mc_detector_njoints(d), hw, hh,
	       mc_detector_threshold(d));
	CHECK(mc_detector_njoints(d) == MC_DETECTOR_DEFAULT_NJOINTS);
	for (int j = 0; j < mc_detector_njoints(d) && j < MC_DETECTOR_DEFAULT_NJOINTS; j++)
		CHECK_MSG(!strcmp(mc_detector_joint_name(d, j), mc_detector_default_joint_name(j)),
			  "joint %d is %s, the contract says %s", j, mc_detector_joint_name(d, j),
			  mc_detector_default_joint_name(j));
	static double errs[4 * 2 * MC_DETECTOR_MAX_JOINTS];
	const int frames[] = {0, 15, 30, 45};
	int nall = 0, missed_all = 0;
	for (size_t f = 0; f < sizeof(frames) / sizeof(frames[0]); f++) {
		mc_frame_view views[MC_MAX_CAMERAS];
		CHECK_MSG(mc_clip_load_frame(clip, frames[f], views, &err) == 0, "%s", err.msg);
		for (int cam = 0; cam < 2; cam++) {
			double e[MC_DETECTOR_MAX_JOINTS];
			int ne = 0, missed = 0;
			bool first = f == 0 && cam == 0;
			if (first)
				printf("frame 0, left camera:\n");
			int found = measure(d, clip, &views[cam], frames[f], cam, e, &ne, &missed, first);
			memcpy(errs + nall, e, sizeof(double) * (size_t)ne);
			nall += ne;
			missed_all += missed;
			double med = percentile(e, ne, 50), p90 = percentile(e, ne, 90);
			printf("frame %2d %-5s: %2d joints detected, %d missed, median %.1f px, p90 %.1f px\n", frames[f],
			       cam ? "right" : "left", found, missed, med, p90);
			if (first) {
				test_flip(d, &views[cam]);
				CHECK_MSG(found >= MIN_FOUND, "%s: only %d joints detected on left/00000.jpg (at least %d expected)",
					  model, found, MIN_FOUND);
				CHECK_MSG(ne > 0 && med <= BOUND_FRAME0_PX,
					  "%s: median error %.1f px on left/00000.jpg (bound %.1f px)", model, med,
					  BOUND_FRAME0_PX);
			}
		}
		mc_clip_free_frame(views);
	}
	double med = percentile(errs, nall, 50), p90 = percentile(errs, nall, 90);
	printf("frames 0, 15, 30, 45, both cameras: %d detections, %d missed, median %.1f px, p90 %.1f px\n", nall,
	       missed_all, med, p90);
	CHECK_MSG(nall > 0 && med <= BOUND_ALL_PX, "%s: median error %.1f px over the 8 views (bound %.1f px)", model,
		  med, BOUND_ALL_PX);
	mc_detector_timing t;
	mc_detector_get_timing(d, &t);
	printf("%.2f ms per 256x256 view (mean of %llu)\n", t.mean_ms, (unsigned long long)t.calls);
	mc_detector_free(d);
}

int main(void)
{
	glob_t g = {0};
	const char *env = getenv("MOCAP_DETECT_MODEL");
	bool from_env = env && *env;
	if (!from_env && (glob("config/models/*ego*.onnx", 0, NULL, &g) != 0 || g.gl_pathc == 0)) {
		globfree(&g);
		TEST_SKIP("no shipped detector model (config/models/*ego*.onnx) yet; set MOCAP_DETECT_MODEL to test another");
	}
	mc_clip *clip = calloc(1, sizeof(*clip));
	mc_err err = {{0}};
	if (!clip || mc_clip_open("tests/data/ego_demo", false, clip, &err) < 0) {
		globfree(&g);
		TEST_SKIP("run from the repository root (tests/data/ego_demo: %s)", err.msg);
	}
	if (from_env)
		test_model(env, clip);
	for (size_t i = 0; !from_env && i < g.gl_pathc; i++)
		test_model(g.gl_pathv[i], clip);
	globfree(&g);
	mc_clip_close(clip);
	free(clip);
	return mc_test_finish("test_detector_shipped");
}
