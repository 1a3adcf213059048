/* libFuzzer target: OCamCalib's calib_results.txt importer
 * (core/geom/mc_rig_import.c, mc_rig_import_ocamcalib), which takes a
 * path: the input is written to a file first (fuzz_load_from_file).  The
 * field of view is the caller's: 100 degrees off axis, as a fisheye's.  A
 * refused file gets a message naming it; an accepted camera, as the only
 * camera of a rig, passes fuzz_check_rig. */
#include "fuzz_util.h"

#include <math.h>
#include <stdio.h>

static int import(const char *path, void *ctx)
{
	(void)ctx;
	mc_rig rig = {.kind = MC_RIG_EGOCENTRIC, .ncams = 1};
	mc_err err = {{0}};
	if (mc_rig_import_ocamcalib(path, 100 * M_PI / 180, &rig.cams[0], &err) != 0) {
		fuzz_check_refusal("fuzz_ocam", path, &err);
		return 0;
	}
	snprintf(rig.name, sizeof(rig.name), "ocam");
	fuzz_check_rig("fuzz_ocam", &rig);
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	return fuzz_load_from_file(data, size, import, NULL);
}
