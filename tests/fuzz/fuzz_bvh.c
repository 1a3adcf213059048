/* libFuzzer target: the BVH parser (core/body/mc_bvh.c, mc_bvh_parse, what
 * mc_bvh_load runs on the file it read), on the input's bytes as they are:
 * not NUL-terminated, so that a read past the end is caught.  A refused
 * file gets a message that starts with its name and leaves nothing
 * allocated; an accepted one is used as the sim driver uses it (the CMU
 * joint map, the rest height, forward kinematics of its first and last
 * frames), then freed. */
#include "fuzz_util.h"

#include "body/mc_bvh.h"

#include <stdlib.h>

#define ORIGIN "fuzz.bvh"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	mc_bvh bvh;
	mc_err err = {{0}};
	if (mc_bvh_parse((const char *)data, size, ORIGIN, &bvh, &err) != 0) {
		fuzz_check_refusal("fuzz_bvh", ORIGIN, &err);
		if (bvh.joints || bvh.values)
			fuzz_fail("fuzz_bvh", "a refused file left its arrays set", &err);
		return 0;
	}
	if (bvh.njoints < 1 || bvh.njoints > MC_BVH_MAX_JOINTS)
		fuzz_fail("fuzz_bvh", "accepted a file with no joint or too many", NULL);
	int index[MC_BVH_CMU_JOINTS];
	if (mc_bvh_map_cmu(&bvh, index, &err) == 0) {
		mc_vec3 joints[MC_BVH_CMU_JOINTS];
		mc_bvh_joints_in_head(&bvh, index, 0, 0.01, joints);
	}
	(void)mc_bvh_rest_height(&bvh);
	mc_xform *world = malloc((size_t)bvh.njoints * sizeof(*world));
	if (!world)
		abort();
	mc_bvh_fk(&bvh, 0, world);
	mc_bvh_fk(&bvh, bvh.nframes - 1, world);
	free(world);
	mc_bvh_free(&bvh);
	return 0;
}
