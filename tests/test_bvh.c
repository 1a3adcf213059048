/* Tests of core/body/mc_bvh: the two CMU files in shared/data/mocap, forward
 * kinematics, and malformed snippets (errors name the origin and line). */
#include "body/mc_bvh.h"
#include "test_util.h"

#include <jansson.h>
#include <string.h>

static const char *small_bvh =
	"HIERARCHY\n"
	"ROOT Hips\n"
	"{\n"
	"\tOFFSET 0 0 0\n"
	"\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
	"\tJOINT Spine\n"
	"\t{\n"
	"\t\tOFFSET 0 10 0\n"
	"\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n"
	"\t\tEnd Site\n"
	"\t\t{\n"
	"\t\t\tOFFSET 0 5 0\n"
	"\t\t}\n"
	"\t}\n"
	"\tJOINT Leg\n"
	"\t{\n"
	"\t\tOFFSET 2 -1 0\n"
	"\t\tCHANNELS 1 Xrotation\n"
	"\t}\n"
	"}\n"
	"MOTION\n"
	"Frames: 2\n"
	"Frame Time: 0.04\n"
	"1 2 3 0 0 0 0 0 0 0\n"
	"\n"
	"0 0 0 90 0 0 0 90 0 45\n";

static void test_small(void)
{
	mc_bvh b;
	mc_err err;
	CHECK_MSG(mc_bvh_parse(small_bvh, strlen(small_bvh), "small", &b, &err) == 0, "%s", err.msg);
	CHECK(b.njoints == 4 && mc_bvh_count_joints(&b) == 3);
	CHECK(b.nchannels == 10 && b.nframes == 2);
	CHECK_NEAR(b.frame_time, 0.04, 1e-12);
	int spine = mc_bvh_find(&b, "Spine"), end = mc_bvh_find(&b, "Spine_End"), leg = mc_bvh_find(&b, "Leg");
	CHECK(spine == 1 && end == 2 && leg == 3 && mc_bvh_find(&b, "Nope") == -1);
	CHECK(b.joints[end].end_site && b.joints[end].parent == spine && b.joints[end].nchannels == 0);
	CHECK(b.joints[spine].channel0 == 6 && b.joints[leg].channel0 == 9);
	CHECK(b.joints[spine].channels[0] == MC_BVH_ZROT && b.joints[spine].channels[1] == MC_BVH_XROT);
	CHECK_NEAR(b.joints[leg].offset.x, 2, 0);
	CHECK(mc_bvh_frame(&b, 1)[9] == 45 && mc_bvh_frame(&b, 7) == mc_bvh_frame(&b, 1));

	mc_xform x[4];
	/* Frame 0: translated by (1, 2, 3), no rotation. */
	mc_bvh_fk(&b, 0, x);
	CHECK_NEAR(x[end].t.x, 1, 1e-12);
	CHECK_NEAR(x[end].t.y, 2 + 15, 1e-12);
	CHECK_NEAR(x[end].t.z, 3, 1e-12);
	/* Frame 1: root turned 90 degrees about z: the spine (up, +y) points
	 * along -x; the spine's own 90 degrees about x (Z X Y order) then tips
	 * its end along the root's rotated z. */
	mc_bvh_fk(&b, 1, x);
	CHECK_NEAR(x[spine].t.x, -10, 1e-9);
	CHECK_NEAR(x[spine].t.y, 0, 1e-9);
	CHECK_NEAR(x[end].t.x, -10, 1e-9);
	CHECK_NEAR(x[end].t.z, 5, 1e-9);
	/* The leg at (2, -1, 0) turned about z: (1, 2, 0). */
	CHECK_NEAR(x[leg].t.x, 1, 1e-9);
	CHECK_NEAR(x[leg].t.y, 2, 1e-9);
	mc_bvh_free(&b);
}

/* The hierarchies differ in joint names but not in size. */
static void test_cmu_file(const char *dir, const char *file, int frames, const char *some_joint)
{
	char path[512];
	snprintf(path, sizeof(path), "%s/mocap/%s", dir, file);
	mc_bvh b;
	mc_err err;
	CHECK_MSG(mc_bvh_load(path, &b, &err) == 0, "%s", err.msg);
	if (!b.joints)
		return;
	CHECK_MSG(mc_bvh_count_joints(&b) == 31, "%s: %d joints", file, mc_bvh_count_joints(&b));
	CHECK(b.njoints == 31 + 7); /* 7 End Sites */
	CHECK(b.nchannels == 6 + 30 * 3);
	CHECK_MSG(b.nframes == frames, "%s: %d frames", file, b.nframes);
	CHECK_NEAR(b.frame_time, 1.0 / 120, 1e-6);
	CHECK(strcmp(b.joints[0].name, "Hips") == 0 && b.joints[0].parent == -1);
	CHECK(mc_bvh_find(&b, "Head") > 0 && mc_bvh_find(&b, some_joint) > 0);
	for (int i = 1; i < b.njoints; i++)
		CHECK(b.joints[i].parent >= 0 && b.joints[i].parent < i);
	/* Bones keep their lengths in every frame, and the head stays above
	 * the hips (+y is up in these files). */
	mc_xform *x = malloc(sizeof(mc_xform) * (size_t)b.njoints);
	int head = mc_bvh_find(&b, "Head");
	int bad_len = 0, upside_down = 0;
	for (int f = 0; f < b.nframes; f += 37) {
		mc_bvh_fk(&b, f, x);
		for (int i = 1; i < b.njoints; i++) {
			double len = mc_v3_norm(mc_v3_sub(x[i].t, x[b.joints[i].parent].t));
			bad_len += fabs(len - mc_v3_norm(b.joints[i].offset)) > 1e-9;
		}
		upside_down += x[head].t.y < x[0].t.y;
	}
	CHECK(bad_len == 0 && upside_down == 0);
	free(x);
	mc_bvh_free(&b);
}

/* Each snippet must fail with a message holding `needle` and the line. */
static void expect_error(const char *text, const char *needle)
{
	mc_bvh b;
	mc_err err = {{0}};
	int rc = mc_bvh_parse(text, strlen(text), "snip.bvh", &b, &err);
	CHECK_MSG(rc == -1, "accepted: %s", text);
	CHECK_MSG(strstr(err.msg, needle) != NULL, "'%s' lacks '%s'", err.msg, needle);
	CHECK_MSG(strncmp(err.msg, "snip.bvh", 8) == 0, "'%s' does not name the origin", err.msg);
	CHECK(b.joints == NULL && b.values == NULL);
}

#define HEAD "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n}\n"

static void test_malformed(void)
{
	/* Whole-file loaders refuse what is not a regular file (issue 20,
	 * defect 1: a directory made ftell say LLONG_MAX and malloc 2^63). */
	mc_bvh dir_bvh;
	mc_err derr;
	CHECK(mc_bvh_load("tests/data", &dir_bvh, &derr) < 0);
	CHECK_MSG(strstr(derr.msg, "tests/data: not a regular file (a directory)"), "%s", derr.msg);
	CHECK(mc_bvh_load("/dev/zero", &dir_bvh, &derr) < 0);
	CHECK_MSG(strstr(derr.msg, "not a regular file (a character device)"), "%s", derr.msg);
	expect_error("", "end of file");
	expect_error("HIERARCH\n", ":1: expected HIERARCHY");
	expect_error("HIERARCHY\nJOINT A\n", ":2: expected ROOT");
	expect_error("HIERARCHY\nROOT A\nOFFSET 0 0 0\n", ":3: expected '{'");
	expect_error("HIERARCHY\nROOT A\n{\nOFFSET 0 x 0\n}\n", ":4: OFFSET: 'x' is not a number");
	expect_error("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 2 Xposition Wrotation\n}\n",
		     ":5: CHANNELS: 'Wrotation' is not a channel name");
	expect_error("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 7\n}\n", "count 7");
	expect_error("HIERARCHY\nROOT A\n{\nCHANNELS 1 Xposition\n}\nMOTION\n", ":5: joint 'A' has no OFFSET");
	expect_error("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nEnd Site\n{\nOFFSET 1 1 1\nCHANNELS 1 Xrotation\n}\n}\n",
		     ":8: unexpected 'CHANNELS' in End Site of 'A'");
	expect_error("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nEnd Sight\n", "expected 'End Site'");
	expect_error("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nJOINT B\n{\nOFFSET 1 1 1\n", "end of file");
	expect_error("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nBOGUS\n}\n", ":5: unexpected 'BOGUS' in joint 'A'");
	expect_error("HIERARCHY\nMOTION\nFrames: 0\nFrame Time: 0.1\n", "no ROOT");
	expect_error(HEAD "MOTION\nFrame: 1\n", ":8: expected 'Frames:'");
	expect_error(HEAD "MOTION\nFrames: -1\n", "not a frame count");
	expect_error(HEAD "MOTION\nFrames: 1\nFrame Time: 0\n1 2 3\n", "not a frame period");
	expect_error(HEAD "MOTION\nFrames: 1\nFrameTime: 0.1\n1 2 3\n", "expected 'Frame Time:'");
	expect_error(HEAD "MOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3\n4 5\n", ":11: frame 1 has 2 values, the hierarchy has 3");
	expect_error(HEAD "MOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3\n4 5 6 7\n", ":11: frame 1 has 4 values");
	expect_error(HEAD "MOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3\n4 five 6\n", ":11: frame 1: value 2: 'five'");
	expect_error(HEAD "MOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3\n4 5 6\n7 8 9\n", ":12: more frame lines");
	expect_error(HEAD "MOTION\nFrames: 3\nFrame Time: 0.1\n1 2 3\n4 5 6\n", "'Frames: 3' but the file has 2");
	expect_error(HEAD "MOTION\nFrames: 99999999\nFrame Time: 0.1\n1 2 3\n", "do not fit");
	expect_error(HEAD "MOTION\nFrames: 1\nFrame Time: 0.1\n1 2 inf\n", "'inf' is not a number");
	/* Deep nesting is refused, not a stack overflow. */
	size_t cap = 200000, n = 0;
	char *deep = malloc(cap);
	n += (size_t)snprintf(deep + n, cap - n, "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n");
	for (int i = 0; i < 300; i++)
		n += (size_t)snprintf(deep + n, cap - n, "JOINT J%d\n{\nOFFSET 0 1 0\n", i);
	expect_error(deep, "nested deeper");
	free(deep);
	/* CRLF line ends are fine. */
	const char *crlf = "HIERARCHY\r\nROOT A\r\n{\r\nOFFSET 0 0 0\r\nCHANNELS 1 Xrotation\r\n}\r\nMOTION\r\n"
			   "Frames: 1\r\nFrame Time: 0.5\r\n7\r\n";
	mc_bvh b;
	mc_err err;
	CHECK_MSG(mc_bvh_parse(crlf, strlen(crlf), "crlf", &b, &err) == 0, "%s", err.msg);
	CHECK(b.nframes == 1 && b.values && b.values[0] == 7);
	mc_bvh_free(&b);
	CHECK(mc_bvh_load("/nonexistent/x.bvh", &b, &err) == -1 && strstr(err.msg, "/nonexistent/x.bvh"));
	/* Not a CMU skeleton. */
	CHECK(mc_bvh_parse(small_bvh, strlen(small_bvh), "small", &b, &err) == 0);
	int idx[MC_BVH_CMU_JOINTS];
	CHECK(mc_bvh_map_cmu(&b, idx, &err) == -1 && strstr(err.msg, "Head_End"));
	CHECK_NEAR(mc_bvh_rest_height(&b), 16, 1e-12); /* leg end -1 .. spine end 15 */
	mc_bvh_free(&b);
	CHECK(mc_bvh_cmu_joint_name(MC_BVH_CMU_JOINTS) == NULL && strcmp(mc_bvh_cmu_joint_name(4), "left_shoulder") == 0);
}

/* The mapped CMU joints, scaled to the actor and put in the head frame,
 * are the evaluation data's ground truth up to one rigid transform: every
 * distance between two joints agrees. */
static void test_cmu_map(const char *dir, const char *bvh_file, const char *clip, double start_s)
{
	char path[512];
	snprintf(path, sizeof(path), "%s/mocap/%s", dir, bvh_file);
	mc_bvh b;
	mc_err err;
	CHECK_MSG(mc_bvh_load(path, &b, &err) == 0, "%s", err.msg);
	int idx[MC_BVH_CMU_JOINTS];
	CHECK_MSG(mc_bvh_map_cmu(&b, idx, &err) == 0, "%s", err.msg);
	snprintf(path, sizeof(path), "%s/ego/%s/gt.json", dir, clip);
	json_error_t je;
	json_t *gt = json_load_file(path, 0, &je);
	CHECK_MSG(gt != NULL, "%s: %s", path, je.text);
	if (!gt || !b.joints) {
		mc_bvh_free(&b);
		return;
	}
	double height = json_number_value(json_object_get(gt, "height_m"));
	double fps = json_number_value(json_object_get(gt, "fps"));
	double mpu = height / mc_bvh_rest_height(&b);
	json_t *frames = json_object_get(gt, "frames");
	double worst = 0;
	for (size_t k = 0; k < json_array_size(frames); k += 17) {
		int f = (int)lround((start_s + (double)k / fps) / b.frame_time);
		mc_vec3 mine[MC_BVH_CMU_JOINTS], theirs[MC_BVH_CMU_JOINTS];
		mc_bvh_joints_in_head(&b, idx, f, mpu, mine);
		json_t *joints = json_object_get(json_array_get(frames, k), "joints_left_cam");
		for (int i = 0; i < MC_BVH_CMU_JOINTS; i++) {
			json_t *a = json_object_get(joints, mc_bvh_cmu_joint_name(i));
			theirs[i] = mc_v3(json_number_value(json_array_get(a, 0)), json_number_value(json_array_get(a, 1)),
					  json_number_value(json_array_get(a, 2)));
		}
		for (int i = 0; i < MC_BVH_CMU_JOINTS; i++)
			for (int j = i + 1; j < MC_BVH_CMU_JOINTS; j++) {
				double d = fabs(mc_v3_norm(mc_v3_sub(mine[i], mine[j])) -
						mc_v3_norm(mc_v3_sub(theirs[i], theirs[j])));
				worst = fmax(worst, d);
			}
		/* The head frame: the neck is its origin, head_top straight up. */
		CHECK(mc_v3_norm(mine[1]) < 1e-9);
		CHECK(mine[0].y < -0.09 && fabs(mine[0].x) < 0.03);
		/* The left shoulder is on the actor's left: -x in model axes. */
		CHECK(mine[4].x < mine[11].x);
	}
	CHECK_MSG(worst < 0.003, "%s: joint distances differ from gt.json by up to %.4f m", clip, worst);
	printf("%s: joint distances agree with gt.json to %.4f m\n", clip, worst);
	json_decref(gt);
	mc_bvh_free(&b);
}

int main(void)
{
	test_small();
	test_malformed();
	const char *dir = mc_test_data_dir();
	if (dir) {
		test_cmu_file(dir, "131_01.bvh", 994, "LeftElbow");
		test_cmu_file(dir, "01_01.bvh", 2752, "LeftForeArm");
		/* Clip start times from shared/data/README.md. */
		test_cmu_map(dir, "131_01.bvh", "walk_131_01", 0.0);
		test_cmu_map(dir, "01_01.bvh", "jumps_01_01", 2.0);
	} else {
		printf("the CMU files were not checked\n");
	}
	return mc_test_finish("test_bvh");
}
