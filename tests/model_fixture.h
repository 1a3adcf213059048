/* The shipped default model and a distance helper, shared by the model
 * tests: test_model.c (kinematics, limits, Gaussians) and test_model_io.c
 * (the JSON format and the default model's proportions). */
#ifndef MC_MODEL_FIXTURE_H
#define MC_MODEL_FIXTURE_H

#include "body/mc_model.h"
#include "test_util.h"

#include <stdbool.h>
#include <stdio.h>

#define DEFAULT_MODEL "config/models/default.json"

static inline double vdist(mc_vec3 a, mc_vec3 b)
{
	return mc_v3_norm(mc_v3_sub(a, b));
}

static inline bool load_default(mc_model *m)
{
	mc_err err;
	if (mc_model_load(DEFAULT_MODEL, m, &err)) {
		fprintf(stderr, "cannot load %s: %s\n", DEFAULT_MODEL, err.msg);
		mc_test_failures++;
		return false;
	}
	return true;
}

#endif
