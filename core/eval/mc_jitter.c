#include "eval/mc_jitter.h"

#include <math.h>
#include <string.h>

void mc_jitter_init(mc_jitter *j, int njoints, double dt)
{
	memset(j, 0, sizeof(*j));
	j->njoints = njoints < MC_JITTER_MAX_JOINTS ? njoints : MC_JITTER_MAX_JOINTS;
	j->dt = dt;
}

void mc_jitter_break(mc_jitter *j)
{
	j->run = 0;
}

/* Second difference x - 2 prev + prev2, as a length. */
static double second_diff(mc_vec3 x, mc_vec3 prev, mc_vec3 prev2)
{
	return mc_v3_norm(mc_v3_add(mc_v3_sub(x, mc_v3_scale(prev, 2)), prev2));
}

void mc_jitter_add(mc_jitter *j, const mc_vec3 *est, const mc_vec3 *gt)
{
	for (int i = 0; i < j->njoints; i++) {
		if (j->run >= 1) {
			mc_vec3 de = mc_v3_sub(est[i], j->est[0][i]), dg = mc_v3_sub(gt[i], j->gt[0][i]);
			j->vel_err_sum += mc_v3_norm(mc_v3_sub(de, dg)) / j->dt;
			j->vel_n++;
		}
		if (j->run >= 2) {
			j->acc_est_sum += second_diff(est[i], j->est[0][i], j->est[1][i]);
			j->acc_gt_sum += second_diff(gt[i], j->gt[0][i], j->gt[1][i]);
			j->acc_n++;
		}
	}
	memcpy(j->est[1], j->est[0], sizeof(j->est[0]));
	memcpy(j->gt[1], j->gt[0], sizeof(j->gt[0]));
	memcpy(j->est[0], est, sizeof(mc_vec3) * j->njoints);
	memcpy(j->gt[0], gt, sizeof(mc_vec3) * j->njoints);
	if (j->run < 2)
		j->run++;
}

double mc_jitter_vel_err(const mc_jitter *j)
{
	return j->vel_n ? j->vel_err_sum / j->vel_n : NAN;
}

double mc_jitter_accel_ratio(const mc_jitter *j)
{
	return j->acc_n && j->acc_gt_sum > 0 ? j->acc_est_sum / j->acc_gt_sum : NAN;
}
