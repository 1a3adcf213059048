/* libFuzzer target: the JSON rig format (core/geom/mc_rig.c, mc_rig_parse).
 * Besides "no crash, no leak, no undefined behaviour": a refused rig gets a
 * message that starts with the file's name; an accepted rig's cameras all
 * pass mc_camera_validate, and the JSON the daemon sends clients for it
 * (mc_rig_to_json) parses back to a rig with the same cameras. */
#include "fuzz_util.h"

#include <stdlib.h>

#define ORIGIN "fuzz_rig.json"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char *text = fuzz_text(data, size);
	mc_rig rig;
	mc_err err = {{0}};
	if (mc_rig_parse(text, ORIGIN, &rig, &err) != 0)
		fuzz_check_refusal("fuzz_rig", ORIGIN, &err);
	else
		fuzz_check_rig("fuzz_rig", &rig);
	free(text);
	return 0;
}
