#include "geom/mc_ray.h"

/* Three stretches along the ray, by the depth t = v . dir:
 *   RAY_FAR     t >= near:        r = P v                   (P = I - dir dir^T)
 *   RAY_NEAR    MIN <= t < near:  r = (near / t) P v        (the angle, times near)
 *   RAY_CLOSE   t < MIN:          r = (near / MIN) (v - MIN dir)
 * continuous at both joins; near <= MIN leaves only RAY_FAR.  The offset and
 * its two derivatives take the stretch and its scale from stretch_of, so
 * that they agree. */
typedef enum { RAY_FAR, RAY_NEAR, RAY_CLOSE } stretch;

/* v's stretch, its depth *t and the offset's scale *s there. */
static stretch stretch_of(mc_vec3 v, mc_vec3 dir, double near, double *t, double *s)
{
	*t = mc_v3_dot(v, dir);
	*s = 1;
	if (*t >= near || near <= MC_RAY_MIN_DEPTH_M)
		return RAY_FAR;
	if (*t >= MC_RAY_MIN_DEPTH_M) {
		*s = near / *t;
		return RAY_NEAR;
	}
	*s = near / MC_RAY_MIN_DEPTH_M;
	return RAY_CLOSE;
}

mc_vec3 mc_ray_offset(mc_vec3 v, mc_vec3 dir, double near)
{
	double t, s;
	bool close = stretch_of(v, dir, near, &t, &s) == RAY_CLOSE;
	return mc_v3_scale(close ? mc_v3_axpy(-MC_RAY_MIN_DEPTH_M, dir, v) : mc_v3_reject(v, dir), s);
}

/* The offset's Jacobian J at v times x, or with `transpose` J^T x: s P x,
 * in RAY_NEAR less s P v (dir . x) / t (J) or s dir (P v . x) / t (J^T);
 * in RAY_CLOSE s x. */
static mc_vec3 jacobian_apply(mc_vec3 v, mc_vec3 dir, double near, mc_vec3 x, bool transpose)
{
	double t, s;
	stretch st = stretch_of(v, dir, near, &t, &s);
	if (st == RAY_CLOSE)
		return mc_v3_scale(x, s);
	mc_vec3 d = mc_v3_reject(x, dir);
	if (st == RAY_NEAR) {
		mc_vec3 pv = mc_v3_reject(v, dir);
		d = transpose ? mc_v3_axpy(-mc_v3_dot(pv, x) / t, dir, d) : mc_v3_axpy(-mc_v3_dot(dir, x) / t, pv, d);
	}
	return mc_v3_scale(d, s);
}

mc_vec3 mc_ray_offset_move(mc_vec3 v, mc_vec3 dir, double near, mc_vec3 dv)
{
	return jacobian_apply(v, dir, near, dv, false);
}

mc_vec3 mc_ray_offset_pull(mc_vec3 v, mc_vec3 dir, double near, mc_vec3 g)
{
	return jacobian_apply(v, dir, near, g, true);
}
