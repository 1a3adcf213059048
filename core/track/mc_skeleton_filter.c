#include "track/mc_skeleton_filter.h"

#include <math.h>

void mc_skeleton_filter_init(mc_skeleton_filter *f, const mc_one_euro_params *params, double max_gap_s)
{
	f->params = *params;
	f->max_gap_s = max_gap_s;
	mc_skeleton_filter_reset(f);
}

void mc_skeleton_filter_reset(mc_skeleton_filter *f)
{
	f->started = false;
	f->last_ns = 0;
	f->njoints = 0;
	for (int j = 0; j < MC_MAX_JOINTS; j++) {
		mc_one_euro3_reset(&f->position[j]);
		f->orientation[j] = mc_quat_identity();
	}
}

/* Whether sk continues the filtered stream; *dt_s: the time since the last. */
static bool continues(const mc_skeleton_filter *f, const mc_skeleton *sk, double *dt_s)
{
	if (!f->started || sk->njoints != f->njoints || sk->timestamp_ns <= f->last_ns)
		return false;
	*dt_s = (double)(sk->timestamp_ns - f->last_ns) / 1e9;
	return *dt_s <= f->max_gap_s;
}

/* Normalised lerp from a to b by alpha, the shorter way round. */
static mc_quat blend(mc_quat a, mc_quat b, double alpha)
{
	if (a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z < 0)
		b = (mc_quat){-b.w, -b.x, -b.y, -b.z};
	mc_quat q = {a.w + alpha * (b.w - a.w), a.x + alpha * (b.x - a.x), a.y + alpha * (b.y - a.y),
		     a.z + alpha * (b.z - a.z)};
	return mc_quat_normalize(q);
}

/* Starts the stream at sk, which passes through unchanged. */
static void start(mc_skeleton_filter *f, const mc_skeleton *sk)
{
	mc_skeleton_filter_reset(f);
	f->started = true;
	f->last_ns = sk->timestamp_ns;
	f->njoints = sk->njoints;
	for (int j = 0; j < sk->njoints; j++) {
		mc_one_euro3_step(&f->position[j], &f->params, sk->joints[j].position, 0);
		f->orientation[j] = sk->joints[j].orientation;
	}
}

/* A rotation's factor: the largest of its joint's and its children's. */
static void rotation_alphas(const mc_skeleton *sk, const double *pos_alpha, double *rot_alpha)
{
	for (int j = 0; j < sk->njoints; j++)
		rot_alpha[j] = pos_alpha[j];
	for (int c = 0; c < sk->njoints; c++) {
		int p = sk->joints[c].parent;
		if (p >= 0 && p < sk->njoints)
			rot_alpha[p] = fmax(rot_alpha[p], pos_alpha[c]);
	}
}

bool mc_skeleton_filter_apply(mc_skeleton_filter *f, mc_skeleton *sk)
{
	double dt_s = 0;
	bool searching = sk->state == MC_TRACK_LOST || sk->state == MC_TRACK_INITIALISING;
	if (searching || sk->njoints <= 0 || sk->njoints > MC_MAX_JOINTS || !continues(f, sk, &dt_s)) {
		if (searching || sk->njoints <= 0 || sk->njoints > MC_MAX_JOINTS)
			mc_skeleton_filter_reset(f);
		else
			start(f, sk);
		return false;
	}
	double pos_alpha[MC_MAX_JOINTS], rot_alpha[MC_MAX_JOINTS];
	for (int j = 0; j < sk->njoints; j++) {
		pos_alpha[j] = mc_one_euro3_step(&f->position[j], &f->params, sk->joints[j].position, dt_s);
		sk->joints[j].position = f->position[j].value;
	}
	rotation_alphas(sk, pos_alpha, rot_alpha);
	for (int j = 0; j < sk->njoints; j++) {
		f->orientation[j] = blend(f->orientation[j], sk->joints[j].orientation, rot_alpha[j]);
		sk->joints[j].orientation = f->orientation[j];
	}
	f->last_ns = sk->timestamp_ns;
	return true;
}

mc_vec3 mc_skeleton_filter_velocity(const mc_skeleton_filter *f, int j)
{
	if (j < 0 || j >= MC_MAX_JOINTS)
		return mc_v3(0, 0, 0);
	return f->position[j].velocity;
}
