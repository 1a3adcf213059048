/* mc_math: small fixed-size vector, rotation and rigid-transform algebra.
 *
 * Everything is double precision and passed by value: these types are a few
 * doubles wide and the compiler keeps them in registers.  Conventions:
 *   - mc_xform maps p -> R p + t ("a_from_b" names say which frames it joins);
 *   - quaternions are (w, x, y, z), unit length, Hamilton product;
 *   - axis-angle vectors have the rotation angle as their length.
 */
#ifndef MC_MATH_H
#define MC_MATH_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct { double x, y, z; } mc_vec3;
typedef struct { double m[3][3]; } mc_mat3;          /* row-major */
typedef struct { double w, x, y, z; } mc_quat;
typedef struct { mc_mat3 R; mc_vec3 t; } mc_xform;  /* p -> R p + t */

static inline mc_vec3 mc_v3(double x, double y, double z) { mc_vec3 v = {x, y, z}; return v; }
static inline mc_vec3 mc_v3_add(mc_vec3 a, mc_vec3 b) { return mc_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline mc_vec3 mc_v3_sub(mc_vec3 a, mc_vec3 b) { return mc_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline mc_vec3 mc_v3_scale(mc_vec3 a, double s) { return mc_v3(a.x * s, a.y * s, a.z * s); }
static inline mc_vec3 mc_v3_axpy(double s, mc_vec3 a, mc_vec3 b) { return mc_v3(s * a.x + b.x, s * a.y + b.y, s * a.z + b.z); }
static inline double mc_v3_dot(mc_vec3 a, mc_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline mc_vec3 mc_v3_cross(mc_vec3 a, mc_vec3 b)
{
	return mc_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
/* v without its component along the unit vector dir: the offset of a point
 * v (relative to a line's origin) from the line. */
static inline mc_vec3 mc_v3_reject(mc_vec3 v, mc_vec3 dir) { return mc_v3_axpy(-mc_v3_dot(v, dir), dir, v); }
static inline double mc_v3_norm2(mc_vec3 a) { return mc_v3_dot(a, a); }
static inline double mc_v3_norm(mc_vec3 a) { return sqrt(mc_v3_dot(a, a)); }
static inline mc_vec3 mc_v3_normalize(mc_vec3 a)
{
	double n = mc_v3_norm(a);
	return n > 0 ? mc_v3_scale(a, 1.0 / n) : a;
}
static inline bool mc_v3_isfinite(mc_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
static inline double mc_v3_get(mc_vec3 a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }

mc_mat3 mc_m3_identity(void);
mc_mat3 mc_m3_mul(mc_mat3 a, mc_mat3 b);
mc_vec3 mc_m3_apply(mc_mat3 a, mc_vec3 v);
mc_mat3 mc_m3_transpose(mc_mat3 a);
/* Rotation by angle about a unit axis (Rodrigues). */
mc_mat3 mc_m3_axis_angle(mc_vec3 unit_axis, double angle);
/* Rotation from an axis-angle vector (angle = length). Exact near zero. */
mc_mat3 mc_m3_from_rotvec(mc_vec3 rotvec);
/* Inverse of mc_m3_from_rotvec, angle in [0, pi]. */
mc_vec3 mc_m3_to_rotvec(mc_mat3 R);
/* Elementary rotations about x (0), y (1) or z (2). */
mc_mat3 mc_m3_rot_axis(int axis, double angle);
/* Nearest rotation to a near-orthonormal matrix (re-orthonormalise). */
mc_mat3 mc_m3_orthonormalize(mc_mat3 R);
bool mc_m3_isfinite(mc_mat3 a);

mc_quat mc_quat_identity(void);
mc_quat mc_quat_mul(mc_quat a, mc_quat b);
mc_quat mc_quat_normalize(mc_quat q);
mc_quat mc_quat_from_m3(mc_mat3 R);   /* w >= 0 */
mc_mat3 mc_quat_to_m3(mc_quat q);
mc_quat mc_quat_from_rotvec(mc_vec3 rotvec);
mc_vec3 mc_quat_to_rotvec(mc_quat q);
mc_vec3 mc_quat_rotate(mc_quat q, mc_vec3 v);

mc_xform mc_xform_identity(void);
mc_xform mc_xform_compose(mc_xform a_from_b, mc_xform b_from_c); /* a_from_c */
mc_xform mc_xform_inverse(mc_xform a_from_b);                    /* b_from_a */
mc_vec3 mc_xform_apply(mc_xform a_from_b, mc_vec3 p_b);
/* From a 4x4 row-major homogeneous matrix; the rotation block is kept as is. */
mc_xform mc_xform_from_4x4(const double m[4][4]);
/* The rigid transform T minimising sum_i w[i] |T(from[i]) - to[i]|^2
 * (Horn's closed form with unit quaternions), n >= 3 points not all on one
 * line; w may be NULL for equal weights. */
mc_xform mc_xform_fit_rigid(const mc_vec3 *from, const mc_vec3 *to, const double *w, int n);
void mc_xform_to_4x4(mc_xform x, double m[4][4]);

/* Small dense linear algebra, row-major n x n, n <= MC_LA_MAX. */
#define MC_LA_MAX 128
/* Solves A x = b for symmetric positive definite A by Cholesky; A and b are
 * overwritten (A by its factor, b by x). Returns false if A is not SPD. */
bool mc_la_cholesky_solve(double *A, double *b, int n);
/* Solves A x = b by LU with partial pivoting; overwrites A and b. Returns
 * false for a (numerically) singular A. */
bool mc_la_lu_solve(double *A, double *b, int n);
/* The point nearest to n rays (origin[i], unit dir[i]) in least squares,
 * sum_i w_i |(I - d_i d_i^T)(x - o_i)|^2 (weight NULL: all 1).  False
 * when the rays are (near) parallel. */
bool mc_rays_nearest_point(const mc_vec3 *origin, const mc_vec3 *dir, const double *weight, int n, mc_vec3 *x);

/* splitmix64: a small, fast random generator (state *s, any seed); good
 * enough for sampling pixels and simulating noise, not for cryptography. */
static inline uint64_t mc_rng_next(uint64_t *s)
{
	uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double mc_rng_uniform(uint64_t *s)
{
	return (mc_rng_next(s) >> 11) * 0x1.0p-53;
}

#endif
