/* libFuzzer target: the evaluation data's calib.json importer
 * (core/geom/mc_rig_import.c, mc_rig_import_ego_calib), which takes a
 * path: the input is written to a file first (fuzz_load_from_file).  Both
 * lens models are read from every input (equidistant, and the fitted OCam
 * polynomial).  A refused file gets a message naming it; an accepted rig
 * passes fuzz_check_rig. */
#include "fuzz_util.h"

static int import(const char *path, void *ctx)
{
	bool use_ocam = *(bool *)ctx;
	mc_rig rig;
	mc_err err = {{0}};
	if (mc_rig_import_ego_calib(path, use_ocam, &rig, &err) != 0)
		fuzz_check_refusal("fuzz_calib", path, &err);
	else
		fuzz_check_rig("fuzz_calib", &rig);
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	for (int i = 0; i < 2; i++) {
		bool use_ocam = i == 1;
		fuzz_load_from_file(data, size, import, &use_ocam);
	}
	return 0;
}
