#include "bench/model_floor.h"

#include "bench/score.h"
#include "body/mc_ik.h"

#include <stdio.h>

/* Frame k's evaluated joints as targets (evaluated joint e is the clip's
 * gt_joint[e] and the model's model_joint[e]); returns their count. */
static int frame_targets(const mc_clip *clip, const int *gt_joint, const int *model_joint, int k, mc_ik_target *t,
			 int *eval_of)
{
	int n = 0;
	for (int e = 0; e < BENCH_NEVAL; e++) {
		if (gt_joint[e] < 0 || model_joint[e] < 0)
			continue;
		eval_of[n] = e;
		t[n++] = (mc_ik_target){model_joint[e], mc_clip_gt(clip, k, gt_joint[e]), 1.0, {0, 0, 0}};
	}
	return n;
}

static int fit_frame(mc_model *m, double *pose, const mc_ik_target *t, int n, int k, mc_err *err)
{
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.iterations = 200;
	/* After frame 0 the bones and a fixed root (the head on the rig)
	 * stay; a free root (outside-in) follows the actor. */
	if (k > 0) {
		o.fit_bone_scale = false;
		o.fit_root = m->root_free;
		o.restarts = false;
	}
	return mc_ik_solve(m, pose, t, n, &o, err) < 0 ? -1 : 0;
}

int bench_model_floor(const mc_clip *clip, const char *model_path, mc_err *err)
{
	mc_model m;
	if (mc_model_load(model_path, &m, err) < 0 ||
	    (clip->layout == MC_CLIP_OUTSIDE && mc_model_make_root_free(&m, err) < 0))
		return -1;
	int gt_joint[BENCH_NEVAL], model_joint[BENCH_NEVAL];
	for (int e = 0; e < BENCH_NEVAL; e++) {
		gt_joint[e] = mc_clip_joint(clip, bench_eval_joints[e]);
		model_joint[e] = mc_model_find_joint(&m, bench_eval_joints[e]);
	}
	double pose[MC_MAX_DOF], sum[BENCH_NEVAL] = {0}, total = 0;
	int count[BENCH_NEVAL] = {0}, total_n = 0;
	mc_model_rest_pose(&m, pose);
	for (int k = 0; k < clip->gt.nframes; k++) {
		mc_ik_target t[BENCH_NEVAL];
		int eval_of[BENCH_NEVAL], n = frame_targets(clip, gt_joint, model_joint, k, t, eval_of);
		if (fit_frame(&m, pose, t, n, k, err) < 0) {
			char why[sizeof(err->msg)];
			snprintf(why, sizeof(why), "%s", err->msg);
			return mc_err_set(err, "%s: frame %d: %s", clip->name, k, why);
		}
		mc_fk fk;
		mc_model_fk(&m, pose, &fk);
		for (int i = 0; i < n; i++) {
			double d = mc_v3_norm(mc_v3_sub(fk.rig_from_joint[t[i].joint].t, t[i].position));
			sum[eval_of[i]] += d;
			count[eval_of[i]]++;
			total += d;
			total_n++;
		}
	}
	printf("the body model fitted to each frame's ground truth (inverse kinematics, no images), cm:\n");
	for (int e = 0; e < BENCH_NEVAL; e++)
		if (count[e])
			printf("  %-16s %6.2f\n", bench_eval_joints[e], 100.0 * sum[e] / count[e]);
	printf("FLOOR clip=%s frames=%d mpjpe_cm=%.2f\n", clip->name, clip->gt.nframes,
	       total_n ? 100.0 * total / total_n : 0.0);
	return 0;
}
