/* The motion tests' helpers: where mocap-graph is, and synthetic BVH clips: a CMU-named skeleton (the
 * older 131_01 naming) walking with swinging legs and arms, straight or
 * turning, written to a file.  No shared data needed. */
#ifndef MOTION_FIXTURE_H
#define MOTION_FIXTURE_H

#include "test_util.h"

#include <math.h>
#include <stdio.h>

/* BUILD/bin/mocap-graph beside this test's BUILD (BUILD/motion/tests/),
 * into out; skips the test when it is not built. */
static inline void find_graph_bin(char *out, size_t cap)
{
	char build[4096];
	if (!mc_test_build_dir(3, build, sizeof(build)))
		TEST_SKIP("cannot tell the build folder from /proc/self/exe");
	snprintf(out, cap, "%s/bin/mocap-graph", build);
	if (access(out, X_OK) != 0)
		TEST_SKIP("%s is not built", out);
}

static const char fixture_hierarchy[] =
	"HIERARCHY\n"
	"ROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
	" JOINT LeftHip\n {\n  OFFSET 10 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"  JOINT LeftKnee\n  {\n   OFFSET 0 -45 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"   JOINT LeftAnkle\n   {\n    OFFSET 0 -42 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"    JOINT LeftToe\n    {\n     OFFSET 0 -5 12\n     CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"     End Site\n     {\n      OFFSET 0 0 4\n     }\n    }\n   }\n  }\n }\n"
	" JOINT RightHip\n {\n  OFFSET -10 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"  JOINT RightKnee\n  {\n   OFFSET 0 -45 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"   JOINT RightAnkle\n   {\n    OFFSET 0 -42 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"    JOINT RightToe\n    {\n     OFFSET 0 -5 12\n     CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"     End Site\n     {\n      OFFSET 0 0 4\n     }\n    }\n   }\n  }\n }\n"
	" JOINT Chest\n {\n  OFFSET 0 25 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"  JOINT Head\n  {\n   OFFSET 0 30 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"   End Site\n   {\n    OFFSET 0 12 0\n   }\n  }\n"
	"  JOINT LeftShoulder\n  {\n   OFFSET 18 22 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"   JOINT LeftElbow\n   {\n    OFFSET 0 -28 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"    JOINT LeftWrist\n    {\n     OFFSET 0 -25 0\n     CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"     End Site\n     {\n      OFFSET 0 -8 0\n     }\n    }\n   }\n  }\n"
	"  JOINT RightShoulder\n  {\n   OFFSET -18 22 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"   JOINT RightElbow\n   {\n    OFFSET 0 -28 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"    JOINT RightWrist\n    {\n     OFFSET 0 -25 0\n     CHANNELS 3 Zrotation Xrotation Yrotation\n"
	"     End Site\n     {\n      OFFSET 0 -8 0\n     }\n    }\n   }\n  }\n }\n}\n";

/* A walk of `seconds` at `fps`: stride period `period` s, forward speed
 * `speed` (file units, cm, per second), turning `turn` degrees per second.
 * Channel order follows the hierarchy: Hips(6), LeftHip..LeftToe (4 x 3),
 * RightHip..RightToe (4 x 3), Chest, Head, LeftShoulder..LeftWrist,
 * RightShoulder..RightWrist (8 x 3): 6 + 16 x 3 = 54 values. */
static inline int fixture_write(const char *path, double seconds, double fps, double period, double speed, double turn)
{
	FILE *f = fopen(path, "w");
	if (!f)
		return -1;
	int n = (int)lround(seconds * fps);
	fputs(fixture_hierarchy, f);
	fprintf(f, "MOTION\nFrames: %d\nFrame Time: %.6f\n", n, 1 / fps);
	double x = 0, z = 0, yaw = 0;
	for (int k = 0; k < n; k++) {
		double t = k / fps, ph = 2 * M_PI * t / period;
		double swing = 25 * sin(ph), knee = 20 * (1 - cos(ph)) / 2;
		double bob = 2 * cos(2 * ph);
		fprintf(f, "%.4f %.4f %.4f 0 0 %.4f", x, 92 + bob, z, yaw);
		/* legs: hip swing, knee bend, ankle, toe */
		fprintf(f, " 0 %.4f 0 0 %.4f 0 0 0 0 0 0 0", -swing, knee);
		fprintf(f, " 0 %.4f 0 0 %.4f 0 0 0 0 0 0 0", swing, 20 * (1 + cos(ph)) / 2);
		/* chest, head */
		fprintf(f, " 0 0 0 0 0 0");
		/* arms swing against the legs */
		fprintf(f, " 0 %.4f 0 0 %.4f 0 0 0 0", swing * 0.8, -10.0);
		fprintf(f, " 0 %.4f 0 0 %.4f 0 0 0 0\n", -swing * 0.8, -10.0);
		double a = yaw * M_PI / 180;
		x += speed / fps * sin(a);
		z += speed / fps * cos(a);
		yaw += turn / fps;
	}
	return fclose(f);
}

#endif
