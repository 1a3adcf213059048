/* MoveNet in the detector runtime (detect/mc_movenet.c,
 * detect/mc_detector_movenet.cpp):
 *   - the decoding on made-up heads: the person nearest the image centre
 *     and each joint near its regressed place win over stronger peaks of a
 *     bystander, and the offsets are added;
 *   - the second look's square (MoveNet's cropping rule), and none without
 *     the torso;
 *   - the shipped Lightning model (config/models/outside_detector.onnx) on
 *     real frames (tests/data/real_p2s: Pose2Sim's demo) with the second
 *     look off, against TensorFlow.js's own keypoints for the same frames
 *     (detect/tests/data/outside_detector_reference.json, made by
 *     tools/convert/movenet_reference.py);
 *   - with the second look on, every body joint found in every view;
 *   - a sidecar with an unknown decoder is refused, naming the field. */
#include "image/mc_image.h"
#include "mc_detector.h"
#include "mc_movenet.h"
#include "test_util.h"

#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MODEL "config/models/outside_detector.onnx"
#define REFERENCE "detect/tests/data/outside_detector_reference.json"
#define FRAMES "tests/data/real_p2s"
#define J 17
#define G 16 /* made-up heads: 16 x 16 cells */

static float heat[J * G * G], center[G * G], regress[2 * J * G * G], offsets[2 * J * G * G];

static void put(float *plane, int y, int x, float v) { plane[y * G + x] = v; }

static void test_decode(void)
{
	memset(heat, 0, sizeof(heat));
	memset(center, 0, sizeof(center));
	memset(regress, 0, sizeof(regress));
	memset(offsets, 0, sizeof(offsets));
	/* The person near the centre (8, 8) at cell (7, 9), a stronger
	 * bystander at the corner (1, 1). */
	put(center, 7, 9, 0.5f);
	put(center, 1, 1, 0.9f);
	for (int j = 0; j < J; j++) {
		/* Joint j's regression from the person's cell to (3 + j % 10, 5). */
		int ty = 3 + j % 10, tx = 5;
		put(regress + (2 * j) * G * G, 7, 9, (float)(ty - 7));
		put(regress + (2 * j + 1) * G * G, 7, 9, (float)(tx - 9));
		/* A weaker peak there, a stronger one on the far side. */
		put(heat + j * G * G, ty, tx, 0.6f);
		put(heat + j * G * G, 14, 14, 0.95f);
		put(offsets + (2 * j) * G * G, ty, tx, 0.25f);
		put(offsets + (2 * j + 1) * G * G, ty, tx, -0.5f);
	}
	mc_movenet_heads h = {heat, center, regress, offsets, J, G, G};
	mc_movenet_point p[J];
	mc_movenet_decode(&h, p);
	for (int j = 0; j < J; j++) {
		CHECK_NEAR(p[j].y, (3 + j % 10 + 0.25) / G, 1e-6);
		CHECK_NEAR(p[j].x, (5 - 0.5) / G, 1e-6);
		CHECK_NEAR(p[j].score, 0.6, 1e-6);
	}
}

/* Both knees decoded at one cell (the right knee's peak, where the left's
 * heat map is strongest too): the left knee, whose regressed place is 3
 * cells away, moves to its own second peak and keeps the pair's score;
 * with that peak too weak, or the left's regressed place at the spot too
 * (legs together), or a pair apart already, nothing moves. */
static void test_separate_pairs(void)
{
	enum { LEFT_KNEE = 13, RIGHT_KNEE = 14 };
	memset(heat, 0, sizeof(heat));
	memset(center, 0, sizeof(center));
	memset(regress, 0, sizeof(regress));
	memset(offsets, 0, sizeof(offsets));
	put(center, 8, 8, 0.9f);
	/* Rough places: the right knee at (12, 9), the left at (12, 5). */
	put(regress + (2 * RIGHT_KNEE) * G * G, 8, 8, 4.0f);
	put(regress + (2 * RIGHT_KNEE + 1) * G * G, 8, 8, 1.0f);
	put(regress + (2 * LEFT_KNEE) * G * G, 8, 8, 4.0f);
	put(regress + (2 * LEFT_KNEE + 1) * G * G, 8, 8, -3.0f);
	put(heat + RIGHT_KNEE * G * G, 12, 8, 0.9f);
	put(heat + LEFT_KNEE * G * G, 12, 8, 0.8f);  /* the right knee's place */
	put(heat + LEFT_KNEE * G * G, 12, 7, 0.5f);  /* the same peak's flank */
	put(heat + LEFT_KNEE * G * G, 12, 3, 0.3f);  /* the left knee, weaker */
	put(heat + LEFT_KNEE * G * G, 2, 14, 0.35f); /* a stray peak far away */
	mc_movenet_heads h = {heat, center, regress, offsets, J, G, G};
	mc_movenet_point p[J];
	mc_movenet_decode(&h, p);
	CHECK_NEAR(p[LEFT_KNEE].x, p[RIGHT_KNEE].x, 1e-6); /* collapsed */
	mc_movenet_separate_pairs(&h, 0.1f, p);
	CHECK_NEAR(p[RIGHT_KNEE].y * G, 12, 1e-5);
	CHECK_NEAR(p[RIGHT_KNEE].x * G, 8, 1e-5);
	CHECK_NEAR(p[RIGHT_KNEE].score, 0.9, 1e-6);
	CHECK_NEAR(p[LEFT_KNEE].y * G, 12, 1e-5);
	CHECK_NEAR(p[LEFT_KNEE].x * G, 3, 1e-5);
	CHECK_NEAR(p[LEFT_KNEE].score, 0.8, 1e-6);
	/* The second peak below the minimum score: both stay. */
	mc_movenet_decode(&h, p);
	mc_movenet_separate_pairs(&h, 0.4f, p);
	CHECK_NEAR(p[LEFT_KNEE].x * G, 8, 1e-5);
	CHECK_NEAR(p[RIGHT_KNEE].x * G, 8, 1e-5);
	/* The left knee's regressed place at the spot too: both stay. */
	put(regress + (2 * LEFT_KNEE + 1) * G * G, 8, 8, -1.0f);
	mc_movenet_decode(&h, p);
	mc_movenet_separate_pairs(&h, 0.1f, p);
	CHECK_NEAR(p[LEFT_KNEE].x * G, 8, 1e-5);
	CHECK_NEAR(p[RIGHT_KNEE].x * G, 8, 1e-5);
	/* Apart already (3 cells): the decoding stands. */
	put(regress + (2 * LEFT_KNEE + 1) * G * G, 8, 8, -3.0f);
	put(heat + LEFT_KNEE * G * G, 12, 5, 0.95f);
	mc_movenet_decode(&h, p);
	mc_movenet_separate_pairs(&h, 0.1f, p);
	CHECK_NEAR(p[LEFT_KNEE].x * G, 5, 1e-5);
	CHECK_NEAR(p[RIGHT_KNEE].x * G, 8, 1e-5);
}

static void test_square(void)
{
	float xy[2 * J], score[J];
	for (int j = 0; j < J; j++) {
		xy[2 * j] = 100;
		xy[2 * j + 1] = 100;
		score[j] = 0.9f;
	}
	/* Shoulders 40 px above the hips at (100, 100), an ankle 90 px below. */
	xy[2 * 5 + 1] = xy[2 * 6 + 1] = 60;
	xy[2 * 15 + 1] = 190;
	mc_movenet_square sq;
	CHECK(mc_movenet_person_square(xy, score, J, 0.2f, &sq) == 0);
	/* max(1.9 * 40, 1.2 * 90) = 108 each way. */
	CHECK_NEAR(sq.size, 216, 1e-3);
	CHECK_NEAR(sq.x0, 100 - 108, 1e-3);
	CHECK_NEAR(sq.y0, 100 - 108, 1e-3);
	score[11] = score[12] = 0.1f; /* no hip seen: no second look */
	CHECK(mc_movenet_person_square(xy, score, J, 0.2f, &sq) < 0);
	mc_movenet_square full = mc_movenet_full_square(360, 640);
	CHECK_NEAR(full.x0, -140, 1e-6);
	CHECK_NEAR(full.y0, 0, 1e-6);
	CHECK_NEAR(full.size, 640, 1e-6);
}

/* Detects on FRAMES/name; returns the count (joints indexed by det.joint). */
static int detect_file(mc_detector *d, const char *name, mc_detection *det)
{
	char path[512];
	snprintf(path, sizeof(path), "%s/%s", FRAMES, name);
	mc_err err = {{0}};
	mc_image_conv *conv = mc_image_conv_new(&err);
	uint8_t *rgb = NULL;
	int w = 0, h = 0, n = -1;
	if (conv && mc_image_load(conv, path, &rgb, &w, &h, &err) == 0)
		n = mc_detector_detect(d, rgb, w, h, 0, det, MC_DETECTOR_MAX_JOINTS, &err);
	CHECK_MSG(n >= 0, "%s: %s", path, err.msg);
	free(rgb);
	mc_image_conv_free(conv);
	return n;
}

static void test_reference(mc_detector *d)
{
	json_error_t jerr;
	json_t *root = json_load_file(REFERENCE, 0, &jerr);
	CHECK_MSG(root, "%s:%d: %s", REFERENCE, jerr.line, jerr.text);
	json_t *views = json_object_get(root, "keypoints");
	CHECK(json_array_size(views) == 8);
	mc_detector_set_refine(d, 0);
	mc_detector_set_threshold(d, 0);
	double worst_px = 0, worst_score = 0;
	for (size_t i = 0; i < json_array_size(views); i++) {
		json_t *v = json_array_get(views, i);
		mc_detection det[MC_DETECTOR_MAX_JOINTS];
		int n = detect_file(d, json_string_value(json_object_get(v, "image")), det);
		CHECK(n == J);
		for (int k = 0; k < n; k++) {
			json_t *ref = json_array_get(json_object_get(v, "joints"), (size_t)det[k].joint);
			double du = det[k].u - json_number_value(json_array_get(ref, 0));
			double dv = det[k].v - json_number_value(json_array_get(ref, 1));
			double ds = det[k].confidence - json_number_value(json_array_get(ref, 2));
			worst_px = fmax(worst_px, sqrt(du * du + dv * dv));
			worst_score = fmax(worst_score, fabs(ds));
		}
	}
	printf("against TensorFlow.js (first look only): worst %.3f px, score %.4f\n", worst_px, worst_score);
	/* JPEG decoders differ by a grey level here and there; a decoding
	 * mistake moves a joint by a cell (13 native px) or half of one. */
	CHECK(worst_px < 1.0);
	CHECK(worst_score < 0.01);
	json_decref(root);
}

static void test_real_views(mc_detector *d)
{
	static const char *const body[] = {"left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
					   "left_wrist",    "right_wrist",    "left_hip",   "right_hip",
					   "left_knee",     "right_knee",     "left_ankle", "right_ankle"};
	mc_detector_set_refine(d, 1);
	mc_detector_set_threshold(d, 0.3f);
	for (int cam = 0; cam < 4; cam++)
		for (int f = 0; f <= 50; f += 50) {
			char name[64];
			snprintf(name, sizeof(name), "cam%d/%05d.jpg", cam, f);
			mc_detection det[MC_DETECTOR_MAX_JOINTS];
			int n = detect_file(d, name, det), found = 0;
			for (size_t b = 0; b < sizeof(body) / sizeof(body[0]); b++)
				for (int k = 0; k < n; k++)
					found += det[k].joint == mc_detector_find_joint(d, body[b]);
			printf("%s: %d of the 12 body joints found\n", name, found);
			CHECK_MSG(found >= 10, "%s: %d of the 12 body joints found", name, found);
		}
}


/* The hint (mc_detector_set_person_square): a square around the person
 * found without one needs one look and puts the joints where the two looks
 * did; a square on an empty corner misses the torso, so the two looks run
 * and give exactly the unhinted keypoints; a hint is for one view only. */
static void test_hint(mc_detector *d)
{
	mc_detector_set_refine(d, 1);
	mc_detector_set_threshold(d, 0);
	const char *name = "cam1/00050.jpg";
	mc_detection ref[MC_DETECTOR_MAX_JOINTS], det[MC_DETECTOR_MAX_JOINTS];
	int n = detect_file(d, name, ref);
	CHECK(n == J);
	float lo_u = 1e9f, lo_v = 1e9f, hi_u = -1e9f, hi_v = -1e9f;
	for (int k = 0; k < n; k++) {
		lo_u = fminf(lo_u, ref[k].u), hi_u = fmaxf(hi_u, ref[k].u);
		lo_v = fminf(lo_v, ref[k].v), hi_v = fmaxf(hi_v, ref[k].v);
	}
	float half = 0.6f * fmaxf(hi_u - lo_u, hi_v - lo_v);
	mc_detector_square around = {0.5f * (lo_u + hi_u) - half, 0.5f * (lo_v + hi_v) - half, 2 * half};
	mc_detector_timing before, after;
	mc_detector_get_timing(d, &before);
	mc_detector_set_person_square(d, &around);
	CHECK(detect_file(d, name, det) == J);
	mc_detector_get_timing(d, &after);
	CHECK(after.one_look == before.one_look + 1);
	/* a crop a little different from the second look's: the same joints,
	 * a few pixels apart (a joint on the wrong limb would be 50 or more) */
	double d_px[J], worst = 0;
	int nd = 0;
	for (int k = 0; k < J; k++)
		if (ref[k].confidence > 0.5f && det[k].confidence > 0.5f) {
			d_px[nd] = hypot(det[k].u - ref[k].u, det[k].v - ref[k].v);
			worst = fmax(worst, d_px[nd++]);
		}
	int below = 0;
	for (int i = 0; i < nd; i++)
		below += d_px[i] < 12.0;
	printf("hint around the person: one look; %d of %d confident joints within 12 px of the two looks, worst "
	       "%.1f px\n",
	       below, nd, worst);
	CHECK(nd >= 10);
	CHECK(below * 4 >= nd * 3);
	CHECK(worst < 40.0);
	/* an empty corner (the ceiling): the two looks, the same keypoints */
	mc_detector_square corner = {0, 0, 60};
	mc_detector_set_person_square(d, &corner);
	CHECK(detect_file(d, name, det) == J);
	mc_detector_get_timing(d, &before);
	CHECK(before.one_look == after.one_look);
	for (int k = 0; k < J; k++)
		CHECK(det[k].u == ref[k].u && det[k].v == ref[k].v && det[k].confidence == ref[k].confidence);
	/* the hint was used up: the next view looks twice */
	mc_detector_set_person_square(d, &around);
	CHECK(detect_file(d, name, det) == J);
	CHECK(detect_file(d, name, det) == J);
	mc_detector_get_timing(d, &after);
	CHECK(after.one_look == before.one_look + 1);
}

/* mc_detector_square_around: joints 2 m in front of a pinhole camera. */
static void test_square_around(void)
{
	mc_camera cam;
	memset(&cam, 0, sizeof(cam));
	cam.model = MC_CAM_PINHOLE;
	cam.width = 640, cam.height = 480;
	cam.fx = cam.fy = 500, cam.cx = 319.5, cam.cy = 239.5;
	cam.max_theta = 1.2;
	cam.rig_from_cam = mc_xform_identity();
	mc_vec3 joints[3] = {mc_v3(-0.2, -0.4, 2), mc_v3(0.2, 0.4, 2), mc_v3(0, 0, 2)};
	mc_detector_square sq;
	CHECK(mc_detector_square_around(&cam, joints, 3, &sq) == 0);
	/* the box is 100 x 200 px around the centre: half 1.25 * 100 + 3 % of 640 */
	CHECK_NEAR(sq.size, 2 * (125 + 19.2), 1e-3);
	CHECK_NEAR(sq.x0 + sq.size / 2, 319.5, 1e-3);
	CHECK_NEAR(sq.y0 + sq.size / 2, 239.5, 1e-3);
	mc_vec3 behind[3] = {mc_v3(0, 0, -1), mc_v3(0.1, 0, -1), mc_v3(0, 0.1, 2)};
	CHECK(mc_detector_square_around(&cam, behind, 3, &sq) < 0);
}

static void test_bad_sidecar(void)
{
	char dir[] = "/tmp/mc_movenet_XXXXXX", onnx[600], json[600], target[600];
	CHECK(mkdtemp(dir) != NULL);
	snprintf(onnx, sizeof(onnx), "%s/m.onnx", dir);
	snprintf(json, sizeof(json), "%s/m.json", dir);
	CHECK(realpath(MODEL, target) != NULL);
	CHECK(symlink(target, onnx) == 0);
	FILE *f = fopen(json, "w");
	fputs("{\"decoder\": \"centernet\", \"input\": [192, 192]}\n", f);
	fclose(f);
	mc_err err = {{0}};
	CHECK(mc_detector_load(onnx, &err) == NULL);
	CHECK_MSG(strstr(err.msg, "m.json: decoder") != NULL, "message: %s", err.msg);
	unlink(onnx);
	unlink(json);
	rmdir(dir);
}

int main(void)
{
	test_decode();
	test_separate_pairs();
	test_square();
	test_square_around();
	if (access(MODEL, R_OK) != 0)
		TEST_SKIP("%s is not there (run from the repository root)", MODEL);
	mc_err err = {{0}};
	mc_detector *d = mc_detector_load(MODEL, &err);
	CHECK_MSG(d, "%s", err.msg);
	if (d) {
		int w, h;
		mc_detector_input_size(d, &w, &h);
		CHECK(w == 192 && h == 192 && mc_detector_njoints(d) == J);
		mc_detector_heatmap_size(d, &w, &h);
		CHECK(w == 48 && h == 48);
		test_reference(d);
		test_real_views(d);
		test_hint(d);
		mc_detector_free(d);
	}
	test_bad_sidecar();
	return mc_test_finish("test_detector_movenet");
}
