/* Fitting the body model to another skeleton's joints (body/mc_fit_joints):
 * a skeleton that places its spine and pelvis as the model does is fitted by
 * every joint; one that puts its pelvis at hip height and its spine low on
 * the back (as some motion-capture skeletons do) is fitted by its limb
 * joints and neck, which it then meets, where a fit to every joint misses
 * the hips by centimetres. */
#include "body/mc_fit_joints.h"
#include "body/mc_ik.h"
#include "test_util.h"

#include <string.h>

/* An actor with a long back and other limb lengths than the model's, a
 * little bent, its joints in the rig frame. */
static void make_actor(const mc_model *model, mc_model *actor, mc_fk *fk)
{
	*actor = *model;
	unsigned long long rng = 11;
	for (int j = 0; j < actor->njoints; j++)
		actor->bone_scale[j] = 0.9 + 0.25 * mc_test_rand(&rng);
	static const char *const torso[] = {"spine", "pelvis", "left_hip", "right_hip"};
	for (int i = 0; i < 4; i++)
		actor->bone_scale[mc_model_find_joint(actor, torso[i])] = 1.15;
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(actor, pose);
	for (int k = 0; k < actor->ndof; k++)
		pose[k] += 0.3 * (mc_test_rand(&rng) - 0.5);
	mc_model_clamp_pose(actor, pose);
	mc_model_fk(actor, pose, fk);
}

/* The model fitted to the named joints; returns the largest miss of the
 * limb joints and neck (metres), and the spine's miss in *spine_miss. */
static double fit_and_measure(const mc_model *model, const mc_model *actor, const mc_vec3 *given, double *spine_miss)
{
	const char *names[MC_MAX_JOINTS];
	for (int j = 0; j < actor->njoints; j++)
		names[j] = actor->joints[j].name;
	mc_model m = *model;
	double pose[MC_MAX_DOF];
	mc_err err = {{0}};
	double rms = mc_fit_joints(&m, pose, names, given, actor->njoints, &err);
	CHECK_MSG(rms >= 0, "fit: %s", err.msg);
	mc_fk fk;
	mc_model_fk(&m, pose, &fk);
	double worst = 0;
	for (int j = 0; j < actor->njoints; j++) {
		double d = mc_v3_norm(mc_v3_sub(fk.rig_from_joint[j].t, given[j]));
		if (mc_fit_joints_is_landmark(names[j]))
			worst = fmax(worst, d);
		else if (!strcmp(names[j], "spine"))
			*spine_miss = d;
	}
	return worst;
}

/* The same joints fitted the plain way (every joint weighing 1): the
 * hips' miss, to show that the second skeleton is one it gets wrong. */
static double plain_fit_hip_miss(const mc_model *model, const mc_vec3 *given)
{
	mc_model m = *model;
	mc_ik_target t[MC_MAX_JOINTS];
	for (int j = 0; j < m.njoints; j++)
		t[j] = (mc_ik_target){j, given[j], 1.0, {0, 0, 0}};
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.iterations = 200;
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(&m, pose);
	mc_err err = {{0}};
	CHECK(mc_ik_solve(&m, pose, t, m.njoints, &o, &err) >= 0);
	mc_fk fk;
	mc_model_fk(&m, pose, &fk);
	int hip = mc_model_find_joint(&m, "left_hip");
	return mc_v3_norm(mc_v3_sub(fk.rig_from_joint[hip].t, given[hip]));
}

/* |left - right| of a pair of joints in fk, metres. */
static double pair_width(const mc_model *m, const mc_fk *fk, const char *left, const char *right)
{
	return mc_v3_norm(mc_v3_sub(fk->rig_from_joint[mc_model_find_joint(m, left)].t,
				    fk->rig_from_joint[mc_model_find_joint(m, right)].t));
}

/* An actor whose hips and shoulders sit narrower and lower on their bones
 * than the model's (another skeleton's convention: the held-out clips'
 * shoulders 2-7 cm and every clip's hips 2-6 cm narrower than the model's
 * once scaled by the bones' lengths).  The fitted model's pairs take the
 * given widths; the limbs and neck are still met.  Before the widths were
 * fitted: hips 20.9 cm apart, shoulders 37.8, the limbs and neck missed by
 * up to 4.1 cm; now to 0.1 cm, the limbs and neck within 2.2. */
static void test_pair_widths(const mc_model *model)
{
	mc_model actor = *model;
	static const char *const pairs[][2] = {{"left_hip", "right_hip"}, {"left_shoulder", "right_shoulder"}};
	static const double narrower[] = {0.8, 0.75};
	for (int p = 0; p < 2; p++)
		for (int k = 0; k < 2; k++) {
			mc_vec3 *o = &actor.joints[mc_model_find_joint(&actor, pairs[p][k])].offset;
			o->x *= narrower[p];
			o->y *= 1.25;
		}
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(&actor, pose);
	pose[actor.joints[mc_model_find_joint(&actor, "left_elbow")].dof0] = 0.3; /* a bent arm */
	mc_fk fk;
	mc_model_fk(&actor, pose, &fk);
	mc_vec3 given[MC_MAX_JOINTS];
	for (int j = 0; j < actor.njoints; j++)
		given[j] = fk.rig_from_joint[j].t;
	double spine, worst = fit_and_measure(model, &actor, given, &spine);

	const char *names[MC_MAX_JOINTS];
	for (int j = 0; j < actor.njoints; j++)
		names[j] = actor.joints[j].name;
	mc_model m = *model;
	mc_err err = {{0}};
	CHECK(mc_fit_joints(&m, pose, names, given, actor.njoints, &err) >= 0);
	mc_fk fitted;
	mc_model_fk(&m, pose, &fitted);
	for (int p = 0; p < 2; p++) {
		double want = pair_width(&actor, &fk, pairs[p][0], pairs[p][1]),
		       got = pair_width(&m, &fitted, pairs[p][0], pairs[p][1]);
		printf("%s and %s: %.1f cm apart, fitted %.1f\n", pairs[p][0], pairs[p][1], 100 * want, 100 * got);
		CHECK_MSG(fabs(got - want) < 0.005, "%s: %.1f cm apart, %.1f given", pairs[p][0], 100 * got, 100 * want);
	}
	printf("narrower pairs: limbs and neck within %.2f cm\n", 100 * worst);
	CHECK_MSG(worst < 0.03, "limbs and neck missed by up to %g m", worst);
}

int main(void)
{
	mc_model model, actor;
	mc_err err = {{0}};
	if (mc_model_load("config/models/default.json", &model, &err) < 0) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	mc_fk fk;
	make_actor(&model, &actor, &fk);
	mc_vec3 given[MC_MAX_JOINTS];
	for (int j = 0; j < actor.njoints; j++)
		given[j] = fk.rig_from_joint[j].t;

	/* The model's kind of skeleton: every joint met, the spine too. */
	double spine = -1, worst = fit_and_measure(&model, &actor, given, &spine);
	printf("model's kind: limbs and neck within %.2f cm, spine %.2f cm\n", 100 * worst, 100 * spine);
	CHECK_MSG(worst < 0.01 && spine >= 0 && spine < 0.01, "worst %g m, spine %g m", worst, spine);

	/* The pelvis moved to the hips' midpoint, the spine 15 cm down the
	 * back: the limbs and neck are still met, the spine is not followed. */
	int pelvis = mc_model_find_joint(&actor, "pelvis"), sp = mc_model_find_joint(&actor, "spine");
	int lh = mc_model_find_joint(&actor, "left_hip"), rh = mc_model_find_joint(&actor, "right_hip");
	mc_vec3 hips = mc_v3_scale(mc_v3_add(given[lh], given[rh]), 0.5);
	mc_vec3 down = mc_v3_normalize(mc_v3_sub(hips, given[sp]));
	given[pelvis] = hips;
	given[sp] = mc_v3_add(given[sp], mc_v3_scale(down, 0.15));
	double plain = plain_fit_hip_miss(&model, given);
	worst = fit_and_measure(&model, &actor, given, &spine);
	printf("pelvis at the hips: limbs and neck within %.2f cm (fitted by every joint: a hip %.2f cm off), spine "
	       "%.2f cm from the given\n",
	       100 * worst, 100 * plain, 100 * spine);
	CHECK_MSG(plain > 0.03, "the plain fit meets the hips to %g m: the case tests nothing", plain);
	CHECK_MSG(worst < 0.015, "limbs and neck missed by up to %g m", worst);
	CHECK_MSG(spine > MC_FIT_JOINTS_AGREE_M, "spine followed to %g m", spine);

	test_pair_widths(&model);

	/* A target the solve refuses (a joint 2 km away): an error, and the
	 * model as it was (the pairs' widths and bone scales were once set
	 * before the solve looked at the targets). */
	mc_model kept = model;
	given[lh].x = 2000;
	const char *all[MC_MAX_JOINTS];
	for (int j = 0; j < actor.njoints; j++)
		all[j] = actor.joints[j].name;
	double refused_pose[MC_MAX_DOF];
	CHECK(mc_fit_joints(&kept, refused_pose, all, given, actor.njoints, &err) < 0 && strstr(err.msg, "left_hip"));
	CHECK_MSG(!memcmp(&kept, &model, sizeof(model)), "a refused fit changed the model");

	/* Too few landmarks: the fit by every joint still answers. */
	const char *few[] = {"neck", "spine", "pelvis", "head_top"};
	mc_vec3 at[4] = {given[mc_model_find_joint(&actor, "neck")], given[sp], given[pelvis],
			 given[mc_model_find_joint(&actor, "head_top")]};
	mc_model m = model;
	double pose[MC_MAX_DOF];
	CHECK_MSG(mc_fit_joints(&m, pose, few, at, 4, &err) >= 0, "%s", err.msg);
	/* None known: the IK's own message. */
	const char *unknown[] = {"tail", "wing", "antenna"};
	CHECK(mc_fit_joints(&m, pose, unknown, at, 3, &err) < 0 && strstr(err.msg, "at least 3"));
	return mc_test_finish("test_fit_joints");
}
