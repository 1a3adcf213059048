#include "geom/mc_ray.h"

/* Three stretches along the ray, by the depth t = v . dir:
 *   t >= near:           r = P v                       (P = I - dir dir^T)
 *   MIN <= t < near:     r = (near / t) P v            (the angle, times near)
 *   t < MIN:             r = (near / MIN) (v - MIN dir)
 * continuous at both joins; near <= MIN leaves only the first. */
mc_vec3 mc_ray_offset(mc_vec3 v, mc_vec3 dir, double near)
{
	double t = mc_v3_dot(v, dir);
	if (t >= near || near <= MC_RAY_MIN_DEPTH_M)
		return mc_v3_reject(v, dir);
	if (t >= MC_RAY_MIN_DEPTH_M)
		return mc_v3_scale(mc_v3_reject(v, dir), near / t);
	return mc_v3_scale(mc_v3_axpy(-MC_RAY_MIN_DEPTH_M, dir, v), near / MC_RAY_MIN_DEPTH_M);
}

/* In the middle stretch dr = (near / t) (P dv - P v (dir . dv) / t). */
mc_vec3 mc_ray_offset_move(mc_vec3 v, mc_vec3 dir, double near, mc_vec3 dv)
{
	double t = mc_v3_dot(v, dir);
	if (t >= near || near <= MC_RAY_MIN_DEPTH_M)
		return mc_v3_reject(dv, dir);
	if (t >= MC_RAY_MIN_DEPTH_M) {
		mc_vec3 d = mc_v3_axpy(-mc_v3_dot(dir, dv) / t, mc_v3_reject(v, dir), mc_v3_reject(dv, dir));
		return mc_v3_scale(d, near / t);
	}
	return mc_v3_scale(dv, near / MC_RAY_MIN_DEPTH_M);
}

/* In the middle stretch J^T g = (near / t) (P g - dir (P v . g) / t). */
mc_vec3 mc_ray_offset_pull(mc_vec3 v, mc_vec3 dir, double near, mc_vec3 g)
{
	double t = mc_v3_dot(v, dir);
	if (t >= near || near <= MC_RAY_MIN_DEPTH_M)
		return mc_v3_reject(g, dir);
	if (t >= MC_RAY_MIN_DEPTH_M) {
		mc_vec3 d = mc_v3_axpy(-mc_v3_dot(mc_v3_reject(v, dir), g) / t, dir, mc_v3_reject(g, dir));
		return mc_v3_scale(d, near / t);
	}
	return mc_v3_scale(g, near / MC_RAY_MIN_DEPTH_M);
}
