/* The shipped detector inside the evaluation protocol (mocap-bench
 * --detector; docs/DETECTOR.md):
 *   - on the bundled clip (tests/data/ego_demo, 60 frames) the detector's 2D
 *     error against the projected ground truth stays within a bound, and
 *     the tracker runs with its keypoints;
 *   - on the evaluation clips (../shared/data/ego/walk_131_01 and
 *     jumps_01_01, when present) the tracker with the detector beats the
 *     tracker without it, in MPJPE averaged over the two whole clips.  One
 *     clip alone is too noisy to assert: on walk_131_01 the seed moves the
 *     result by up to 4 cm either way (docs/BENCHMARKS.md).
 * The bundled clip's own 3D comparison is printed, not asserted: over its
 * first 2 s the colour term alone tracks well (9.4 cm) and the detector's
 * errors on the feet cost more than it brings (docs/DETECTOR.md, "Known
 * limits"); what a detector is for, getting lost limbs back, shows over a
 * whole clip.  Skips when the live model (config/models/ego_detector.onnx)
 * is not there. */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Median 2D error bound, pixels at the detector's 128x128 input, on the
 * bundled clip (measured: 3.5 px; docs/DETECTOR.md). */
#define MEDIAN_PX_MAX 6.0

static char tool[4096];

/* Runs mocap-bench on `clip` with `args`; its output goes to out. */
static void run_bench(const char *clip, const char *args, char *out, size_t cap)
{
	char cmd[8192];
	snprintf(cmd, sizeof(cmd), "%s --clip %s --no-thesis --reference-frames 0 --quiet %s 2>&1", tool, clip, args);
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

/* MPJPE (cm) of `clip` without and with the detector. */
static void compare(const char *clip, const char *detector, double *without, double *with, double *median_px)
{
	static char out[1 << 16];
	run_bench(clip, "", out, sizeof(out));
	*without = field(out, "mpjpe_cm");
	run_bench(clip, detector, out, sizeof(out));
	*with = field(out, "mpjpe_cm");
	*median_px = field(out, "median_px");
	CHECK_MSG(isfinite(*without) && isfinite(*with) && isfinite(*median_px), "no RESULT or DETECT2D line:\n%s",
		  out);
}

int main(int argc, char **argv)
{
	(void)argc;
	mc_test_find_tool(argv[0], "mocap-bench", tool, sizeof(tool));
	if (access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
	if (access(MC_TEST_LIVE_EGO_MODEL, R_OK) != 0)
		TEST_SKIP("no shipped detector model (%s)", MC_TEST_LIVE_EGO_MODEL);
	char detector[4200];
	snprintf(detector, sizeof(detector), "--detector %s", MC_TEST_LIVE_EGO_MODEL);

	double without, with, median_px;
	compare("tests/data/ego_demo", detector, &without, &with, &median_px);
	printf("ego_demo, 60 frames: %.2f cm without the detector, %.2f cm with it (not asserted); 2D median %.2f px\n",
	       without, with, median_px);
	CHECK_MSG(median_px <= MEDIAN_PX_MAX, "2D median %.2f px, expected at most %.1f px", median_px, MEDIAN_PX_MAX);

	const char *data = mc_test_data_dir();
	static const char *const clips[] = {"walk_131_01", "jumps_01_01"};
	double sum_without = 0, sum_with = 0;
	int n = 0;
	for (size_t i = 0; i < sizeof(clips) / sizeof(clips[0]); i++) {
		char clip[4200];
		snprintf(clip, sizeof(clip), "%s/ego/%s", data ? data : "", clips[i]);
		if (!data || access(clip, R_OK) != 0) {
			printf("SKIP (part): %s not found, the whole-clip comparison did not run\n", clip);
			n = 0;
			break;
		}
		compare(clip, detector, &without, &with, &median_px);
		printf("%s: %.2f cm without the detector, %.2f cm with it; 2D median %.2f px\n", clips[i], without, with,
		       median_px);
		sum_without += without;
		sum_with += with;
		n++;
	}
	if (n > 0)
		CHECK_MSG(sum_with < sum_without, "the detector did not help: %.2f cm with, %.2f cm without (mean of %d clips)",
			  sum_with / n, sum_without / n, n);
	return mc_test_finish("test_detector_tracking");
}
