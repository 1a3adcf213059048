/* Tests of the learned pose prior (core/body/mc_pose_prior): a small
 * mixture written here (energy 0 at the likelier mean, growing away from
 * it, the gradient matching finite differences, the mixture's two modes),
 * errors that name the field, and the shipped config/models/pose_prior.json,
 * which must find a standing pose likelier than a contorted one and mirrored
 * poses about as likely as each other. */
#include "body/mc_model.h"
#include "body/mc_pose_prior.h"
#include "test_util.h"

#include <string.h>

#define MODEL "config/models/default.json"
#define SHIPPED "config/models/pose_prior.json"

/* Two components over the left knee (1 dof) and the left elbow's flexion:
 * a narrow one at (-0.3, 0.5), a wide one at (-1.5, 1.5). */
static const char *two_modes = "{\"dofs\": [\"left_knee.x\", \"left_elbow.x\"], \"components\": ["
			       "{\"weight\": 0.7, \"mean\": [-0.3, 0.5], \"precision_chol\": [[4], [0.5, 3]]},"
			       "{\"weight\": 0.3, \"mean\": [-1.5, 1.5], \"precision_chol\": [[1], [0, 1]]}]}";

static int dof_index(const mc_model *m, const char *name)
{
	for (int k = 0; k < m->ndof; k++) {
		char buf[64];
		mc_model_dof_name(m, k, buf, sizeof(buf));
		if (strcmp(buf, name) == 0)
			return k;
	}
	return -1;
}

static void test_energy_and_gradient(const mc_model *m)
{
	mc_err err = {{0}};
	mc_pose_prior *p = mc_pose_prior_parse(two_modes, "two.json", m, &err);
	CHECK_MSG(p != NULL, "%s", err.msg);
	if (!p)
		return;
	CHECK(mc_pose_prior_ndofs(p) == 2 && mc_pose_prior_ncomponents(p) == 2);
	int knee = dof_index(m, "left_knee.x"), elbow = dof_index(m, "left_elbow.x");
	double pose[MC_MAX_DOF] = {0};
	pose[knee] = -0.3;
	pose[elbow] = 0.5;
	double at_mode = mc_pose_prior_energy(p, pose, 1.0, NULL);
	/* about 0 at the likelier mode (the other component adds a little) */
	CHECK(at_mode > -0.1 && at_mode < 0.1);
	pose[elbow] = 1.0;
	double off = mc_pose_prior_energy(p, pose, 1.0, NULL);
	CHECK(off > at_mode + 0.5);
	CHECK_NEAR(mc_pose_prior_energy(p, pose, 2.5, NULL), 2.5 * off, 1e-12);
	/* the gradient against central differences, at a point between modes */
	pose[knee] = -0.9;
	pose[elbow] = 1.1;
	double grad[MC_MAX_DOF] = {0};
	mc_pose_prior_energy(p, pose, 2.0, grad);
	for (int k = 0; k < m->ndof; k++) {
		double h = 1e-6, save = pose[k];
		pose[k] = save + h;
		double ep = mc_pose_prior_energy(p, pose, 2.0, NULL);
		pose[k] = save - h;
		double em = mc_pose_prior_energy(p, pose, 2.0, NULL);
		pose[k] = save;
		CHECK_NEAR(grad[k], (ep - em) / (2 * h), 1e-5);
	}
	CHECK(grad[knee] != 0 && grad[elbow] != 0);
	/* far from both modes the pull weakens (the robust form): the energy
	 * still grows along a line, by less at each equal step */
	double e_line[4];
	for (int i = 0; i < 4; i++) {
		pose[knee] = -0.3;
		pose[elbow] = 0.5 - 1.0 * i;
		e_line[i] = mc_pose_prior_energy(p, pose, 1.0, NULL);
	}
	CHECK(e_line[1] > e_line[0] && e_line[2] > e_line[1] && e_line[3] > e_line[2]);
	CHECK(e_line[3] - e_line[2] < e_line[2] - e_line[1]);
	CHECK(e_line[3] < MC_PRIOR_ROBUST_NATS * log(1.0 + 0.5 * 9.0 * 9.0 / MC_PRIOR_ROBUST_NATS) + 1.0);
	/* the second mode is a local minimum of its own */
	pose[knee] = -1.5;
	pose[elbow] = 1.5;
	double second = mc_pose_prior_energy(p, pose, 1.0, NULL);
	pose[elbow] = 1.3;
	CHECK(mc_pose_prior_energy(p, pose, 1.0, NULL) > second);
	mc_pose_prior_free(p);
}

static void expect_error(const mc_model *m, const char *json, const char *needle)
{
	mc_err err = {{0}};
	mc_pose_prior *p = mc_pose_prior_parse(json, "bad.json", m, &err);
	CHECK_MSG(p == NULL, "accepted: %s", json);
	CHECK_MSG(strstr(err.msg, needle) != NULL, "'%s' lacks '%s'", err.msg, needle);
	mc_pose_prior_free(p);
}

static void test_errors(const mc_model *m)
{
	expect_error(m, "{\"dofs\": [\"left_knee.q\"], \"components\": []}", "dofs[0]: the model has no dof 'left_knee.q'");
	expect_error(m, "{\"dofs\": [], \"components\": []}", "bad.json: dofs");
	expect_error(m, "{\"dofs\": [\"left_knee.x\"]}", "bad.json: components");
	expect_error(m,
		     "{\"dofs\": [\"left_knee.x\"], \"components\": [{\"weight\": 1, \"mean\": [0], "
		     "\"precision_chol\": [[0]]}]}",
		     "components[0].precision_chol[0][0]: the diagonal must be > 0");
	expect_error(m,
		     "{\"dofs\": [\"left_knee.x\"], \"components\": [{\"weight\": 1, \"mean\": [0, 1], "
		     "\"precision_chol\": [[1]]}]}",
		     "components[0].mean");
	expect_error(m,
		     "{\"dofs\": [\"left_knee.x\"], \"components\": [{\"weight\": 0, \"mean\": [0], "
		     "\"precision_chol\": [[1]]}]}",
		     "components[0].weight");
}

/* The shipped prior: a person standing with arms down is likelier than the
 * same person with a knee bent 130 degrees, the trunk bent back 30 and the
 * arm twisted to its limit; a pose and its mirror image score alike. */
static void test_shipped(mc_model *m)
{
	mc_err err = {{0}};
	mc_pose_prior *p = mc_pose_prior_load(SHIPPED, m, &err);
	CHECK_MSG(p != NULL, "%s", err.msg);
	if (!p)
		return;
	double stand[MC_MAX_DOF] = {0}, odd[MC_MAX_DOF] = {0};
	mc_model_rest_pose(m, stand);
	memcpy(odd, stand, sizeof(odd));
	odd[dof_index(m, "left_knee.x")] = -2.27;
	odd[dof_index(m, "spine.x")] = -0.52;
	odd[dof_index(m, "left_shoulder.y")] = 1.5;
	double e_stand = mc_pose_prior_energy(p, stand, 1.0, NULL);
	double e_odd = mc_pose_prior_energy(p, odd, 1.0, NULL);
	printf("shipped prior: %d components over %d dofs; standing %.1f, contorted %.1f\n",
	       mc_pose_prior_ncomponents(p), mc_pose_prior_ndofs(p), e_stand, e_odd);
	CHECK(e_odd > e_stand + 4);
	/* a step with the left leg, and its mirror with the right */
	double step[MC_MAX_DOF], mirror[MC_MAX_DOF];
	memcpy(step, stand, sizeof(step));
	memcpy(mirror, stand, sizeof(mirror));
	step[dof_index(m, "left_hip.x")] = 0.5;
	step[dof_index(m, "left_knee.x")] = -0.6;
	mirror[dof_index(m, "right_hip.x")] = 0.5;
	mirror[dof_index(m, "right_knee.x")] = -0.6;
	double e_step = mc_pose_prior_energy(p, step, 1.0, NULL), e_mirror = mc_pose_prior_energy(p, mirror, 1.0, NULL);
	printf("step %.2f, mirrored step %.2f\n", e_step, e_mirror);
	CHECK(fabs(e_step - e_mirror) < 0.15 * (fabs(e_step) + 1));
	/* a free root (outside-in) maps the same dofs, shifted by six */
	mc_model free_root = *m;
	CHECK(mc_model_make_root_free(&free_root, &err) == 0);
	mc_pose_prior *pf = mc_pose_prior_load(SHIPPED, &free_root, &err);
	CHECK_MSG(pf != NULL, "%s", err.msg);
	if (pf) {
		double shifted[MC_MAX_DOF] = {0};
		memcpy(shifted + MC_ROOT_FREE_DOFS, odd, sizeof(double) * (size_t)m->ndof);
		CHECK_NEAR(mc_pose_prior_energy(pf, shifted, 1.0, NULL), e_odd, 1e-9);
		mc_pose_prior_free(pf);
	}
	mc_pose_prior_free(p);
}

int main(void)
{
	mc_err err = {{0}};
	mc_model m;
	if (mc_model_load(MODEL, &m, &err) < 0) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	test_energy_and_gradient(&m);
	test_errors(&m);
	test_shipped(&m);
	return mc_test_finish("test_pose_prior");
}
