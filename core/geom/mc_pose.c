#include "geom/mc_pose.h"

#include <stddef.h>

mc_quat mc_quat_nlerp(mc_quat a, mc_quat b, double s)
{
	double d = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
	double sb = d < 0 ? -s : s; /* q and -q are the same rotation: take the nearer */
	mc_quat q = {a.w * (1 - s) + b.w * sb, a.x * (1 - s) + b.x * sb, a.y * (1 - s) + b.y * sb,
		     a.z * (1 - s) + b.z * sb};
	return mc_quat_normalize(q);
}

mc_pose mc_pose_interpolate(const mc_pose *before, const mc_pose *after, uint64_t t)
{
	double span = (double)(after->timestamp_ns - before->timestamp_ns);
	double s = span > 0 ? (double)(t - before->timestamp_ns) / span : 0.0;
	mc_pose out;
	out.timestamp_ns = t;
	out.position = mc_v3_add(mc_v3_scale(before->position, 1 - s), mc_v3_scale(after->position, s));
	out.orientation = mc_quat_nlerp(before->orientation, after->orientation, s);
	return out;
}

bool mc_pose_at(const mc_pose *poses, int n, uint64_t t, uint64_t max_age_ns, mc_pose *out)
{
	const mc_pose *before = NULL, *after = NULL;
	for (int i = 0; i < n; i++) {
		const mc_pose *h = &poses[i];
		if (h->timestamp_ns <= t && (!before || h->timestamp_ns > before->timestamp_ns))
			before = h;
		if (h->timestamp_ns >= t && (!after || h->timestamp_ns < after->timestamp_ns))
			after = h;
	}
	if (before && after && after->timestamp_ns - before->timestamp_ns <= 2 * max_age_ns) {
		*out = mc_pose_interpolate(before, after, t);
		return true;
	}
	const mc_pose *near = NULL;
	if (before && t - before->timestamp_ns <= max_age_ns)
		near = before;
	if (after && after->timestamp_ns - t <= max_age_ns &&
	    (!near || after->timestamp_ns - t < t - near->timestamp_ns))
		near = after;
	if (!near)
		return false;
	*out = *near;
	return true;
}

void mc_pose_apply(const mc_pose *pose, mc_vec3 *position, mc_quat *orientation)
{
	if (position)
		*position = mc_v3_add(mc_quat_rotate(pose->orientation, *position), pose->position);
	if (orientation)
		*orientation = mc_quat_mul(pose->orientation, *orientation);
}
