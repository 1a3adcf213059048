/* libFuzzer target: the JSON body-model format (core/body/mc_model_io.c,
 * mc_model_parse).  A refused model gets a message that starts with the
 * file's name; an accepted one passes mc_model_validate and poses: the
 * forward kinematics of its rest pose are finite. */
#include "fuzz_util.h"

#include "body/mc_model.h"

#include <math.h>
#include <stdlib.h>

#define ORIGIN "fuzz_model.json"

static mc_model model; /* large: static */
static mc_fk fk;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char *text = fuzz_text(data, size);
	mc_err err = {{0}};
	if (mc_model_parse(text, ORIGIN, &model, &err) != 0) {
		fuzz_check_refusal("fuzz_model", ORIGIN, &err);
	} else {
		if (mc_model_validate(&model, &err) != 0)
			fuzz_fail("fuzz_model", "accepted a model that mc_model_validate refuses", &err);
		double pose[MC_MAX_DOF];
		mc_model_rest_pose(&model, pose);
		mc_model_fk(&model, pose, &fk);
		for (int q = 0; q < model.ngauss; q++)
			if (!isfinite(fk.mu[q].x) || !isfinite(fk.mu[q].y) || !isfinite(fk.mu[q].z))
				fuzz_fail("fuzz_model", "a Gaussian of the rest pose is not finite", NULL);
	}
	free(text);
	return 0;
}
