/* The detector runtime without the shipped model: the heatmap decoding on
 * hand-made heatmaps (the exact formula of docs/DETECT_RUNTIME.md), bad
 * models and sidecars (each error names the file and the mismatch), a
 * detector whose answer is known (detect/tests/data/fixed_wrist.onnx) on a
 * real frame at two sizes and with a padded stride, the threshold, the
 * timing, and the mapping to the tracker's keypoints.  Run from the
 * repository root. */
#include "body/mc_model.h"
#include "image/mc_image.h"
#include "mc_detector.h"
#include "test_util.h"

#include <stdlib.h>
#include <math.h>
#include <string.h>
#include <unistd.h>

#define DATA "detect/tests/data/"

/* ---- decoding */

static void test_decode(void)
{
	enum { J = 4, H = 32, W = 32 };
	static float hm[J * H * W];
	memset(hm, 0, sizeof(hm));
	/* joint 0: peak 0.8 at (10, 20), 0.4 to its right: x_c = 10.333.. */
	hm[0 * H * W + 20 * W + 10] = 0.8f;
	hm[0 * H * W + 20 * W + 11] = 0.4f;
	/* joint 1: in the corner (0, 0), the window clipped; below it 0.6 */
	hm[1 * H * W + 0] = 0.9f;
	hm[1 * H * W + 1 * W + 0] = 0.6f;
	/* joint 2: below the threshold */
	hm[2 * H * W + 5 * W + 5] = 0.29f;
	/* joint 3: a tie (the first in raster order wins) and a negative
	 * neighbour that weighs nothing */
	hm[3 * H * W + 7 * W + 3] = 0.5f;
	hm[3 * H * W + 9 * W + 30] = 0.5f;
	hm[3 * H * W + 7 * W + 4] = -0.7f;
	mc_detection d[J];
	int n = mc_detector_decode(hm, J, H, W, 128, 128, 256, 256, 0.3f, 0, d, J);
	CHECK(n == 3);
	if (n != 3)
		return;
	/* u_in = (x_c + 0.5) * 128 / 32 - 0.5; u = (u_in + 0.5) * 256 / 128 - 0.5 */
	double xc = (10 * 0.8 + 11 * 0.4) / 1.2;
	double u_in = (xc + 0.5) * 4 - 0.5, v_in = (20 + 0.5) * 4 - 0.5;
	CHECK(d[0].joint == 0);
	CHECK_NEAR(d[0].u, (u_in + 0.5) * 2 - 0.5, 1e-4);
	CHECK_NEAR(d[0].v, (v_in + 0.5) * 2 - 0.5, 1e-4);
	CHECK_NEAR(d[0].confidence, 0.8, 1e-6);
	double yc = 0.6 / 1.5;
	CHECK(d[1].joint == 1);
	CHECK_NEAR(d[1].u, ((0 + 0.5) * 4 - 0.5 + 0.5) * 2 - 0.5, 1e-4);
	CHECK_NEAR(d[1].v, ((yc + 0.5) * 4 - 0.5 + 0.5) * 2 - 0.5, 1e-4);
	CHECK(d[2].joint == 3);
	CHECK_NEAR(d[2].u, ((3 + 0.5) * 4) * 2 - 0.5, 1e-4);
	CHECK_NEAR(d[2].v, ((7 + 0.5) * 4) * 2 - 0.5, 1e-4);
	/* Another native size and heatmap size: 64x64 heatmaps, 640x480 view. */
	static float hm2[64 * 64];
	memset(hm2, 0, sizeof(hm2));
	hm2[31 * 64 + 17] = 1.0f;
	n = mc_detector_decode(hm2, 1, 64, 64, 128, 128, 640, 480, 0.3f, 0, d, 1);
	CHECK(n == 1);
	CHECK_NEAR(d[0].u, (17 + 0.5) * 640 / 64.0 - 0.5, 1e-3);
	CHECK_NEAR(d[0].v, (31 + 0.5) * 480 / 64.0 - 0.5, 1e-3);
	/* max limits the output; threshold 0 reports everything. */
	CHECK(mc_detector_decode(hm, J, H, W, 128, 128, 256, 256, 0.3f, 0, d, 1) == 1);
	CHECK(mc_detector_decode(hm, J, H, W, 128, 128, 256, 256, 0.0f, 0, d, J) == J);
}

/* A Gaussian of sigma_cells cells at (x0, y0) with peak height peak, added
 * to one H x W plane. */
static void add_gaussian(float *plane, int w, int h, double x0, double y0, double sigma_cells, double peak)
{
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++)
			plane[y * w + x] += (float)(peak * exp(-((x - x0) * (x - x0) + (y - y0) * (y - y0)) /
							   (2 * sigma_cells * sigma_cells)));
}

/* DARK decoding (sigma > 0): a Gaussian target's centre comes back to a
 * hundredth of a cell where the 3x3 centroid is pulled toward the cell's
 * middle; a broad peak wins over a taller lone spike; the confidence stays
 * the map's maximum. */
static void test_decode_dark(void)
{
	enum { H = 32, W = 32 };
	static float hm[2 * H * W];
	memset(hm, 0, sizeof(hm));
	add_gaussian(hm, W, H, 10.4, 20.3, 1.0, 0.9);
	mc_detection d[2];
	/* Input 128 = native 128: u = (x_c + 0.5) * 4 - 0.5. */
	CHECK(mc_detector_decode(hm, 1, H, W, 128, 128, 128, 128, 0.3f, 1.0f, d, 1) == 1);
	CHECK_NEAR((d[0].u + 0.5) / 4 - 0.5, 10.4, 0.01);
	CHECK_NEAR((d[0].v + 0.5) / 4 - 0.5, 20.3, 0.01);
	CHECK_NEAR(d[0].confidence, hm[20 * W + 10], 1e-6);
	CHECK(mc_detector_decode(hm, 1, H, W, 128, 128, 128, 128, 0.3f, 0, d, 1) == 1);
	CHECK_MSG(fabs((d[0].u + 0.5) / 4 - 0.5 - 10.4) > 0.1, "the centroid at %.3f", (d[0].u + 0.5) / 4 - 0.5);
	/* A spike of 0.95 at (5, 5) against a Gaussian of 0.8 at (24, 12). */
	float *two = hm + H * W;
	add_gaussian(two, W, H, 24, 12, 1.0, 0.8);
	two[5 * W + 5] = 0.95f;
	CHECK(mc_detector_decode(two, 1, H, W, 128, 128, 128, 128, 0.3f, 1.0f, d, 1) == 1);
	CHECK_NEAR((d[0].u + 0.5) / 4 - 0.5, 24, 0.01);
	CHECK_NEAR((d[0].v + 0.5) / 4 - 0.5, 12, 0.01);
	CHECK_NEAR(d[0].confidence, 0.95, 1e-6);
	CHECK(mc_detector_decode(two, 1, H, W, 128, 128, 128, 128, 0.3f, 0, d, 1) == 1);
	CHECK_NEAR(d[0].u, 5 * 4 + 1.5, 1e-4);
	/* Below the threshold, nothing, whatever the decoding. */
	CHECK(mc_detector_decode(two, 1, H, W, 128, 128, 128, 128, 0.96f, 1.0f, d, 1) == 0);
}

/* ---- bad models */

/* Loading path fails with a message that names the file `named` and says
 * a and b. */
static void expect_error_naming(const char *path, const char *named, const char *a, const char *b)
{
	mc_err err = {{0}};
	mc_detector *d = mc_detector_load(path, &err);
	CHECK_MSG(!d, "%s loaded", path);
	mc_detector_free(d);
	printf("%s -> %s\n", path, err.msg);
	CHECK_MSG(strstr(err.msg, named), "the error does not name %s: %s", named, err.msg);
	CHECK_MSG(strstr(err.msg, a), "the error does not say \"%s\": %s", a, err.msg);
	CHECK_MSG(!b || strstr(err.msg, b), "the error does not say \"%s\": %s", b ? b : "", err.msg);
}

static void expect_load_error(const char *path, const char *a, const char *b)
{
	expect_error_naming(path, path, a, b);
}

static bool write_file(const char *path, const void *data, size_t n)
{
	FILE *f = fopen(path, "wb");
	bool ok = f && fwrite(data, 1, n, f) == n;
	if (f)
		ok = fclose(f) == 0 && ok;
	return ok;
}

static bool copy_file(const char *from, const char *to)
{
	uint8_t *data = NULL;
	size_t n = 0;
	mc_err err = {{0}};
	if (mc_image_read_file(from, &data, &n, &err) < 0)
		return false;
	bool ok = write_file(to, data, n);
	free(data);
	return ok;
}

static void test_bad_models(void)
{
	expect_load_error(DATA "no_such_model.onnx", "cannot open", "No such file");
	expect_load_error(DATA "not_onnx.onnx", "not an ONNX model", NULL);
	expect_load_error(DATA "bad_input.onnx", "input `image` is 1x1x96x96", "expected 1x3x128x128");
	expect_load_error(DATA "bad_channels.onnx", "17 heatmap channels", "expected 1x18xHxW");
	expect_load_error(DATA "bad_rank.onnx", "has rank 2 (1x18432)", "expected 4");
	/* An empty file. */
	char dir[] = "/tmp/mc-detector-test-XXXXXX";
	CHECK(mkdtemp(dir));
	char onnx[128], json[128];
	snprintf(onnx, sizeof(onnx), "%s/empty.onnx", dir);
	CHECK(write_file(onnx, "", 0));
	expect_load_error(onnx, "not an ONNX model", "empty");
	unlink(onnx);
	/* Sidecars: a good model with a sidecar that disagrees, or is broken. */
	snprintf(onnx, sizeof(onnx), "%s/m.onnx", dir);
	snprintf(json, sizeof(json), "%s/m.json", dir);
	CHECK(copy_file(DATA "fixed_wrist.onnx", onnx));
	const char *j17 = "{\"input\": [128, 128], \"joints\": [\"a\",\"b\",\"c\",\"d\",\"e\",\"f\",\"g\",\"h\",\"i\","
			  "\"j\",\"k\",\"l\",\"m\",\"n\",\"o\",\"p\",\"q\"], \"threshold\": 0.3}";
	CHECK(write_file(json, j17, strlen(j17)));
	expect_load_error(onnx, "18 heatmap channels", "expected 1x17xHxW");
	const char *hm64 = "{\"heatmap\": [64, 64]}";
	CHECK(write_file(json, hm64, strlen(hm64)));
	expect_load_error(onnx, "1x18x32x32", "sidecar says heatmaps of 64x64");
	const char *in96 = "{\"input\": [96, 96]}";
	CHECK(write_file(json, in96, strlen(in96)));
	expect_load_error(onnx, "input `image` is 1x3x128x128", "expected 1x3x96x96");
	const char *broken = "{\"joints\": [";
	CHECK(write_file(json, broken, strlen(broken)));
	expect_error_naming(onnx, json, ":1:", NULL);
	const char *thr = "{\"threshold\": 2}";
	CHECK(write_file(json, thr, strlen(thr)));
	expect_error_naming(onnx, json, "threshold: expected a number in [0, 1]", NULL);
	const char *sigma = "{\"heatmap_sigma\": \"wide\"}";
	CHECK(write_file(json, sigma, strlen(sigma)));
	expect_error_naming(onnx, json, "heatmap_sigma: expected a number of heat-map cells in [0, 8]", NULL);
	/* A good sidecar: its joints and threshold are used. */
	const char *good = "{\"input\": [128, 128], \"heatmap\": [32, 32], \"threshold\": 0.5, \"joints\": [\"head_top\","
			   "\"neck\",\"spine\",\"pelvis\",\"left_shoulder\",\"left_elbow\",\"left_wrist\",\"left_hip\","
			   "\"left_knee\",\"left_ankle\",\"left_toe\",\"right_shoulder\",\"right_elbow\",\"wrist_r\","
			   "\"right_hip\",\"right_knee\",\"right_ankle\",\"right_toe\"]}";
	CHECK(write_file(json, good, strlen(good)));
	mc_err err = {{0}};
	mc_detector *d = mc_detector_load(onnx, &err);
	CHECK_MSG(d, "%s", err.msg);
	if (d) {
		CHECK_NEAR(mc_detector_threshold(d), 0.5, 1e-6);
		CHECK(mc_detector_find_joint(d, "wrist_r") == 13);
		CHECK(mc_detector_find_joint(d, "right_wrist") == -1);
		mc_detector_free(d);
	}
	unlink(json);
	unlink(onnx);
	rmdir(dir);
}

/* ---- a detector with a known answer on a real frame */

static void test_fixed_model(void)
{
	mc_err err = {{0}};
	mc_detector *d = mc_detector_load(DATA "fixed_wrist.onnx", &err);
	CHECK_MSG(d, "%s", err.msg);
	if (!d)
		return;
	int w, h;
	mc_detector_input_size(d, &w, &h);
	CHECK(w == 128 && h == 128);
	mc_detector_heatmap_size(d, &w, &h);
	CHECK(w == 32 && h == 32);
	CHECK(mc_detector_njoints(d) == 18);
	CHECK(!strcmp(mc_detector_joint_name(d, 13), "right_wrist"));
	CHECK(!strcmp(mc_detector_joint_name(d, 0), "head_top"));
	CHECK(mc_detector_joint_name(d, 18) == NULL);
	CHECK_NEAR(mc_detector_threshold(d), 0.3, 1e-6);

	uint8_t *rgb = NULL;
	int fw = 0, fh = 0;
	mc_image_conv *conv = mc_image_conv_new(&err);
	CHECK(conv && mc_image_load(conv, "tests/data/ego_demo/left/00000.jpg", &rgb, &fw, &fh, &err) == 0);
	mc_image_conv_free(conv);
	CHECK(fw == 256 && fh == 256);
	if (!rgb) {
		mc_detector_free(d);
		return;
	}
	/* The model's right wrist peaks at cell (17, 9) with equal neighbours:
	 * native pixel 8 * x + 3.5 for a 256 view, 4 * x + 1.5 for a 128 one. */
	mc_detection det[MC_DETECTOR_MAX_JOINTS];
	int n = mc_detector_detect(d, rgb, fw, fh, 0, det, MC_DETECTOR_MAX_JOINTS, &err);
	CHECK_MSG(n == 1, "%d detections (%s)", n, err.msg);
	if (n == 1) {
		CHECK(det[0].joint == 13);
		CHECK_NEAR(det[0].u, 139.5, 1e-3);
		CHECK_NEAR(det[0].v, 75.5, 1e-3);
		CHECK_NEAR(det[0].confidence, 0.9, 1e-5);
	}
	/* A padded stride, and a view at the network's own size. */
	int stride = 3 * fw + 16;
	uint8_t *padded = calloc((size_t)stride * (size_t)fh, 1);
	uint8_t *small = malloc(128 * 128 * 3);
	CHECK(padded && small);
	if (padded && small) {
		for (int y = 0; y < fh; y++)
			memcpy(padded + (size_t)y * (size_t)stride, rgb + (size_t)y * (size_t)fw * 3, (size_t)fw * 3);
		n = mc_detector_detect(d, padded, fw, fh, stride, det, MC_DETECTOR_MAX_JOINTS, &err);
		CHECK(n == 1 && det[0].joint == 13);
		CHECK(mc_image_resize_rgb24(rgb, fw, fh, small, 128, 128, &err) == 0);
		n = mc_detector_detect(d, small, 128, 128, 0, det, MC_DETECTOR_MAX_JOINTS, &err);
		CHECK(n == 1);
		if (n == 1) {
			CHECK_NEAR(det[0].u, 69.5, 1e-3);
			CHECK_NEAR(det[0].v, 37.5, 1e-3);
		}
	}
	free(padded);
	free(small);
	/* Bad calls fail with a message naming the model. */
	CHECK(mc_detector_detect(d, NULL, fw, fh, 0, det, 18, &err) == -1 && strstr(err.msg, "fixed_wrist.onnx"));
	CHECK(mc_detector_detect(d, rgb, fw, fh, 10, det, 18, &err) == -1);
	/* The heatmaps of the last call. */
	int hj, hh, hw;
	const float *hm = mc_detector_heatmaps(d, &hj, &hh, &hw);
	CHECK(hm && hj == 18 && hh == 32 && hw == 32);
	if (hm)
		CHECK_NEAR(hm[13 * 32 * 32 + 9 * 32 + 17], 0.9, 1e-5);
	/* Threshold 0: every joint. */
	mc_detector_set_threshold(d, 0.0f);
	CHECK(mc_detector_detect(d, rgb, fw, fh, 0, det, MC_DETECTOR_MAX_JOINTS, &err) == 18);
	mc_detector_set_threshold(d, 0.3f);
	/* Timing. */
	mc_detector_timing t;
	mc_detector_get_timing(d, &t);
	printf("fixed model: %llu calls, %.3f ms mean, %.3f max, last network %.3f ms\n", (unsigned long long)t.calls,
	       t.mean_ms, t.max_ms, t.last_infer_ms);
	CHECK(t.calls == 4);
	CHECK(t.mean_ms > 0 && t.max_ms >= t.mean_ms && t.last_ms > 0 && t.last_infer_ms > 0 &&
	      t.last_infer_ms <= t.last_ms);

	/* To the tracker's keypoints: names of the default body model. */
	mc_model *model = calloc(1, sizeof(*model));
	CHECK(model && mc_model_load("config/models/default.json", model, &err) == 0);
	int map[MC_DETECTOR_MAX_JOINTS];
	int wrist = model ? mc_model_find_joint(model, "right_wrist") : -1;
	CHECK(wrist >= 0);
	int found = model ? mc_detector_map_model(d, model, map) : 0;
	printf("default body model: %d of the detector's 18 joints\n", found);
	CHECK(found >= 16);
	CHECK(map[13] == wrist);
	n = mc_detector_detect(d, rgb, fw, fh, 0, det, MC_DETECTOR_MAX_JOINTS, &err);
	mc_keypoint kp[4];
	CHECK(mc_detections_to_keypoints(det, n, 1, map, kp, 4) == 1);
	CHECK(kp[0].cam == 1 && kp[0].joint == wrist);
	CHECK_NEAR(kp[0].u, 139.5, 1e-3);
	CHECK_NEAR(kp[0].conf, 0.9, 1e-5);
	/* Joints the names do not have are dropped. */
	const char *names[] = {"pelvis", "neck"};
	CHECK(mc_detector_map_names(d, names, 2, map) == 2 && map[13] == -1 && map[3] == 0 && map[1] == 1);
	CHECK(mc_detections_to_keypoints(det, n, 0, map, kp, 4) == 0);
	/* Both views of one instant; a missing view is skipped. */
	mc_detector_map_model(d, model, map);
	mc_frame_view views[3] = {{fw, fh, 0, rgb, 1}, {0, 0, 0, NULL, 1}, {fw, fh, 0, rgb, 1}};
	CHECK(mc_detector_detect_views(d, views, 3, map, kp, 4, &err) == 2);
	CHECK(kp[0].cam == 0 && kp[1].cam == 2);
	free(model);
	free(rgb);
	mc_detector_free(d);
}

int main(void)
{
	if (access(DATA "fixed_wrist.onnx", R_OK) != 0 || access("tests/data/ego_demo/left/00000.jpg", R_OK) != 0)
		TEST_SKIP("run from the repository root (" DATA " or tests/data/ego_demo not found)");
	test_decode();
	test_decode_dark();
	test_bad_models();
	test_fixed_model();
	return mc_test_finish("test_detector");
}
