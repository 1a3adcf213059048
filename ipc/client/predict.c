/* Prediction: a pose extrapolated to a requested time from the motion
 * between two poses, constant velocity on positions and constant angular
 * velocity on orientations (mocap.h, mocap_predict). */
#include "client/internal.h"

#include <math.h>

/* Hamilton product of (w, x, y, z) quaternions. */
static void quat_mul(const double a[4], const double b[4], double o[4])
{
	double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
	double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
	double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
	double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
	o[0] = w, o[1] = x, o[2] = y, o[3] = z;
}

static void quat_normalize(double q[4])
{
	double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	if (!(n > 0)) {
		q[0] = 1, q[1] = q[2] = q[3] = 0;
		return;
	}
	for (int i = 0; i < 4; i++)
		q[i] /= n;
}

/* The rotation d with newer = d * older (in the space both are given in),
 * raised to the power s: the same angular velocity over s times the time. */
static void delta_power(const double older[4], const double newer[4], double s, double out[4])
{
	double inv[4] = {older[0], -older[1], -older[2], -older[3]}, d[4];
	quat_mul(newer, inv, d);
	if (d[0] < 0) /* the shorter way round */
		for (int i = 0; i < 4; i++)
			d[i] = -d[i];
	double v = sqrt(d[1] * d[1] + d[2] * d[2] + d[3] * d[3]);
	double half = atan2(v, d[0]) * s;
	double k = v > 1e-12 ? sin(half) / v : s; /* small angles: sin(s a)/sin(a) -> s */
	out[0] = cos(half);
	out[1] = d[1] * k, out[2] = d[2] * k, out[3] = d[3] * k;
}

static bool usable_pair(const mocap_skeleton_frame *older, const mocap_skeleton_frame *newer)
{
	return older && older != newer && older->skeleton_id == newer->skeleton_id &&
	       older->njoints == newer->njoints && older->space == newer->space &&
	       older->capture_ns < newer->capture_ns &&
	       newer->capture_ns - older->capture_ns <= MOCAP_PREDICT_MAX_GAP_NS;
}

int mocap_predict(const mocap_skeleton_frame *older, const mocap_skeleton_frame *newer, uint64_t t_ns,
		  mocap_skeleton_frame *out)
{
	if (!newer || !out || newer->njoints < 0 || newer->njoints > MOCAP_MAX_JOINTS)
		return mcl_set_err(MOCAP_E_ARG, "mocap_predict: need a newer frame and an output");
	if (out != newer)
		memcpy(out, newer, FRAME_BYTES(newer->njoints));
	if (!usable_pair(older, newer))
		return 2;
	int clamped = 0;
	int64_t ahead = (int64_t)(t_ns - newer->capture_ns);
	if (ahead > (int64_t)MOCAP_PREDICT_MAX_NS || ahead < -(int64_t)MOCAP_PREDICT_MAX_NS) {
		ahead = ahead > 0 ? (int64_t)MOCAP_PREDICT_MAX_NS : -(int64_t)MOCAP_PREDICT_MAX_NS;
		clamped = 1;
	}
	double s = (double)ahead / (double)(newer->capture_ns - older->capture_ns);
	for (int j = 0; j < newer->njoints; j++) {
		const mocap_joint *a = &older->joints[j], *b = &newer->joints[j];
		mocap_joint *o = &out->joints[j];
		for (int i = 0; i < 3; i++)
			o->position[i] = b->position[i] + (b->position[i] - a->position[i]) * s;
		double d[4], q[4];
		delta_power(a->orientation, b->orientation, s, d);
		quat_mul(d, b->orientation, q);
		quat_normalize(q);
		memcpy(o->orientation, q, sizeof(q));
	}
	out->capture_ns = newer->capture_ns + (uint64_t)ahead;
	return clamped;
}
