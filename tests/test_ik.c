/* Inverse kinematics: recovers bone scales, root placement and a pose from
 * the joint positions of a known posed model. */
#include "body/mc_ik.h"
#include "test_util.h"

#include <string.h>

static void random_pose(const mc_model *m, double *pose, unsigned long long *rng, double amount)
{
	mc_model_rest_pose(m, pose);
	for (int j = 0; j < m->njoints; j++)
		for (int d = 0; d < m->joints[j].ndof; d++) {
			const mc_joint *jt = &m->joints[j];
			double mid = 0.5 * (jt->lower[d] + jt->upper[d]), half = 0.5 * (jt->upper[d] - jt->lower[d]);
			pose[jt->dof0 + d] = mid + amount * half * (2 * mc_test_rand(rng) - 1);
		}
	mc_model_clamp_pose(m, pose);
}

/* prior_pose: with few targets a strong Tikhonov term decides the dofs
 * they leave free.  Pulling toward a given pose (the tracker's prediction),
 * a fit to targets of that very pose stays on it, from the rest pose, with
 * the root fixed or solved for too (the solved vector then starts with six
 * root dofs); pulling toward 0 it does not. */
static void test_prior_pose(const mc_model *truth)
{
	unsigned long long rng = 7;
	double pose[MC_MAX_DOF];
	random_pose(truth, pose, &rng, 0.5);
	mc_fk fk;
	mc_model_fk(truth, pose, &fk);
	static const char *const names[] = {"left_wrist", "right_wrist", "left_ankle"};
	mc_ik_target tg[3];
	for (int i = 0; i < 3; i++) {
		int j = mc_model_find_joint(truth, names[i]);
		CHECK(j >= 0);
		tg[i] = (mc_ik_target){j, fk.rig_from_joint[j].t, 1.0, {0, 0, 0}};
	}
	for (int variant = 0; variant < 3; variant++) {
		mc_model m = *truth;
		mc_ik_options o;
		mc_ik_options_default(&o);
		o.iterations = 50;
		o.pose_prior = 1e-2;
		o.fit_bone_scale = false;
		o.restarts = false;
		o.fit_root = variant == 1;
		o.prior_pose = variant < 2 ? pose : NULL;
		double est[MC_MAX_DOF], worst = 0;
		mc_model_rest_pose(&m, est);
		mc_err err = {{0}};
		CHECK_MSG(mc_ik_solve(&m, est, tg, 3, &o, &err) >= 0, "%s", err.msg);
		for (int k = 0; k < m.ndof; k++)
			worst = fmax(worst, fabs(est[k] - pose[k]));
		printf("prior toward %s%s: largest dof off the pose %.4f rad\n", variant < 2 ? "the pose" : "0",
		       variant == 1 ? ", root solved for" : "", worst);
		if (variant < 2)
			CHECK_MSG(worst < 1e-3, "variant %d: %g rad", variant, worst);
		else
			CHECK_MSG(worst > 0.1, "toward 0: %g rad", worst);
	}
}

int main(void)
{
	mc_model truth;
	mc_err err = {{0}};
	if (mc_model_load("config/models/default.json", &truth, &err) < 0) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	unsigned long long rng = 3;
	for (int trial = 0; trial < 5; trial++) {
		mc_model m = truth;
		double pose[MC_MAX_DOF], est[MC_MAX_DOF];
		for (int j = 0; j < truth.njoints; j++)
			truth.bone_scale[j] = 0.9 + 0.2 * mc_test_rand(&rng);
		truth.rig_from_root.R = mc_m3_from_rotvec(mc_v3(0.3 * mc_test_rand(&rng), 0.2, -0.1));
		truth.rig_from_root.t = mc_v3(0.1, 0.2 * mc_test_rand(&rng), 0.05);
		random_pose(&truth, pose, &rng, 0.3);
		mc_fk fk, fk2;
		mc_model_fk(&truth, pose, &fk);
		mc_ik_target targets[MC_MAX_JOINTS];
		for (int j = 0; j < truth.njoints; j++)
			targets[j] = (mc_ik_target){j, fk.rig_from_joint[j].t, 1.0, {0, 0, 0}};
		mc_ik_options o;
		mc_ik_options_default(&o);
		o.iterations = 300;
		o.pose_prior = 1e-8;
		mc_model_rest_pose(&m, est);
		double rms = mc_ik_solve(&m, est, targets, truth.njoints, &o, &err);
		CHECK_MSG(rms >= 0 && rms < 0.005, "trial %d: rms %g m (%s)", trial, rms, err.msg);
		mc_model_fk(&m, est, &fk2);
		double worst = 0;
		for (int j = 0; j < truth.njoints; j++)
			worst = fmax(worst, mc_v3_norm(mc_v3_sub(fk.rig_from_joint[j].t, fk2.rig_from_joint[j].t)));
		CHECK_MSG(worst < 0.01, "trial %d: worst joint error %g m", trial, worst);
		for (int j = 1; j < truth.njoints; j++)
			if (mc_v3_norm(truth.joints[j].offset) > 0.02)
				CHECK_NEAR(m.bone_scale[j], truth.bone_scale[j], 1e-6);
	}
	/* Too few targets are refused with a message. */
	mc_model m = truth;
	double est[MC_MAX_DOF];
	mc_ik_target two[2] = {{0, mc_v3(0, 0, 0), 1, {0, 0, 0}}, {1, mc_v3(0, 0.1, 0), 1, {0, 0, 0}}};
	mc_ik_options o;
	mc_ik_options_default(&o);
	mc_model_rest_pose(&m, est);
	CHECK(mc_ik_solve(&m, est, two, 2, &o, &err) < 0 && strstr(err.msg, "at least 3"));
	/* All at one point, or 1e308 m away: no body (issue 20, defect 8). */
	mc_ik_target same[3] = {{1, mc_v3(0, 0, 0), 1, {0, 0, 0}}, {2, mc_v3(0, 0, 0), 1, {0, 0, 0}},
				{3, mc_v3(0, 0, 0), 1, {0, 0, 0}}};
	CHECK(mc_ik_solve(&m, est, same, 3, &o, &err) < 0 && strstr(err.msg, "not a body"));
	same[1].position = mc_v3(1e308, 0, 0);
	CHECK_MSG(mc_ik_solve(&m, est, same, 3, &o, &err) < 0 && strstr(err.msg, "more than 100 m from the rig"), "%s",
		  err.msg);
	test_prior_pose(&truth);
	return mc_test_finish("test_ik");
}
