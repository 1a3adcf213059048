/* The shipped detector inside the evaluation protocol, on the bundled clip
 * (tests/data/ego_demo, 60 frames): mocap-bench with --detector must track
 * better than without it, and the detector's 2D error against the
 * projected ground truth stays within a bound.  Skips when no model ships
 * yet (config/models/ *ego*.onnx, docs/DETECTOR.md). */
#include "test_util.h"

#include <glob.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Median 2D error bound, pixels at the detector's 128x128 input (docs/DETECTOR.md
 * gives the measured figure; this leaves a margin for other machines). */
#define MEDIAN_PX_MAX 6.0

static char tool[4096];

/* Runs mocap-bench on the clip with `args`; its output goes to out. */
static void run_bench(const char *args, char *out, size_t cap)
{
	char cmd[8192];
	snprintf(cmd, sizeof(cmd), "%s --clip tests/data/ego_demo --no-thesis --reference-frames 0 --quiet %s 2>&1", tool,
		 args);
	int rc = mc_test_run(cmd, out, cap);
	CHECK_MSG(rc == 0, "%s -> exit %d:\n%s", cmd, rc, out);
}

/* X of the first " KEY=X" field of the output; NAN when absent. */
static double field(const char *out, const char *key)
{
	char needle[64];
	snprintf(needle, sizeof(needle), " %s=", key);
	const char *p = strstr(out, needle);
	return p ? atof(p + strlen(needle)) : NAN;
}

int main(int argc, char **argv)
{
	(void)argc;
	mc_test_find_tool(argv[0], "mocap-bench", tool, sizeof(tool));
	if (access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
	glob_t g;
	if (glob("config/models/*ego*.onnx", 0, NULL, &g) != 0 || g.gl_pathc != 1) {
		globfree(&g);
		TEST_SKIP("no shipped detector model (exactly one config/models/*ego*.onnx expected)");
	}
	char model[4200];
	snprintf(model, sizeof(model), "--detector %s", g.gl_pathv[0]);
	globfree(&g);

	static char out[1 << 16];
	run_bench("", out, sizeof(out));
	double without = field(out, "mpjpe_cm");
	run_bench(model, out, sizeof(out));
	double with = field(out, "mpjpe_cm"), median_px = field(out, "median_px");
	printf("ego_demo, 60 frames: %.2f cm without the detector, %.2f cm with it; 2D median %.2f px\n", without, with,
	       median_px);
	CHECK_MSG(isfinite(without) && isfinite(with), "no RESULT line:\n%s", out);
	CHECK_MSG(with < without, "the detector did not help: %.2f cm with, %.2f cm without", with, without);
	CHECK_MSG(median_px <= MEDIAN_PX_MAX, "2D median %.2f px, expected at most %.1f px", median_px, MEDIAN_PX_MAX);
	return mc_test_finish("test_detector_tracking");
}
