/* libFuzzer target: the outside-in cameras.json importer
 * (core/geom/mc_rig_import.c, mc_rig_import_cameras_json), which takes a
 * path: the input is written to a file first (fuzz_load_from_file).  A
 * refused file gets a message naming it; an accepted rig passes
 * fuzz_check_rig. */
#include "fuzz_util.h"

static int import(const char *path, void *ctx)
{
	(void)ctx;
	mc_rig rig;
	mc_err err = {{0}};
	if (mc_rig_import_cameras_json(path, &rig, &err) != 0)
		fuzz_check_refusal("fuzz_cameras", path, &err);
	else
		fuzz_check_rig("fuzz_cameras", &rig);
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	return fuzz_load_from_file(data, size, import, NULL);
}
