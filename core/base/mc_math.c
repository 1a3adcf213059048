#include "base/mc_math.h"

#include <string.h>

mc_mat3 mc_m3_identity(void)
{
	mc_mat3 r = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
	return r;
}

mc_mat3 mc_m3_mul(mc_mat3 a, mc_mat3 b)
{
	mc_mat3 r;
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
	return r;
}

mc_vec3 mc_m3_apply(mc_mat3 a, mc_vec3 v)
{
	return mc_v3(a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
		     a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
		     a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z);
}

mc_mat3 mc_m3_transpose(mc_mat3 a)
{
	mc_mat3 r;
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			r.m[i][j] = a.m[j][i];
	return r;
}

mc_mat3 mc_m3_axis_angle(mc_vec3 k, double angle)
{
	double c = cos(angle), s = sin(angle), v = 1.0 - c;
	mc_mat3 r = {{{k.x * k.x * v + c, k.x * k.y * v - k.z * s, k.x * k.z * v + k.y * s},
		      {k.y * k.x * v + k.z * s, k.y * k.y * v + c, k.y * k.z * v - k.x * s},
		      {k.z * k.x * v - k.y * s, k.z * k.y * v + k.x * s, k.z * k.z * v + c}}};
	return r;
}

mc_mat3 mc_m3_from_rotvec(mc_vec3 w)
{
	double th = mc_v3_norm(w);
	if (th < 1e-12) {
		/* First-order expansion: I + [w]x, exact to O(th^2). */
		mc_mat3 r = {{{1, -w.z, w.y}, {w.z, 1, -w.x}, {-w.y, w.x, 1}}};
		return r;
	}
	return mc_m3_axis_angle(mc_v3_scale(w, 1.0 / th), th);
}

mc_vec3 mc_m3_to_rotvec(mc_mat3 R)
{
	return mc_quat_to_rotvec(mc_quat_from_m3(R));
}

mc_mat3 mc_m3_rot_axis(int axis, double angle)
{
	mc_vec3 k = mc_v3(axis == 0, axis == 1, axis == 2);
	return mc_m3_axis_angle(k, angle);
}

mc_mat3 mc_m3_orthonormalize(mc_mat3 R)
{
	return mc_quat_to_m3(mc_quat_from_m3(R));
}

bool mc_m3_isfinite(mc_mat3 a)
{
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			if (!isfinite(a.m[i][j]))
				return false;
	return true;
}

mc_quat mc_quat_identity(void)
{
	mc_quat q = {1, 0, 0, 0};
	return q;
}

mc_quat mc_quat_mul(mc_quat a, mc_quat b)
{
	mc_quat r = {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
		     a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
		     a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
		     a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
	return r;
}

mc_quat mc_quat_normalize(mc_quat q)
{
	double n = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
	if (n <= 0)
		return mc_quat_identity();
	mc_quat r = {q.w / n, q.x / n, q.y / n, q.z / n};
	return r;
}

/* Shepperd's method: pick the largest diagonal term for stability. */
mc_quat mc_quat_from_m3(mc_mat3 R)
{
	const double(*m)[3] = R.m;
	double tr = m[0][0] + m[1][1] + m[2][2];
	mc_quat q;
	if (tr > 0) {
		double s = sqrt(tr + 1.0) * 2;
		q = (mc_quat){0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s};
	} else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
		double s = sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2;
		q = (mc_quat){(m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
	} else if (m[1][1] > m[2][2]) {
		double s = sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2;
		q = (mc_quat){(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s};
	} else {
		double s = sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2;
		q = (mc_quat){(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s};
	}
	q = mc_quat_normalize(q);
	if (q.w < 0)
		q = (mc_quat){-q.w, -q.x, -q.y, -q.z};
	return q;
}

mc_mat3 mc_quat_to_m3(mc_quat q)
{
	double w = q.w, x = q.x, y = q.y, z = q.z;
	mc_mat3 r = {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
		      {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
		      {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
	return r;
}

mc_quat mc_quat_from_rotvec(mc_vec3 w)
{
	double th = mc_v3_norm(w);
	double s = th < 1e-12 ? 0.5 : sin(0.5 * th) / th;
	mc_quat q = {cos(0.5 * th), w.x * s, w.y * s, w.z * s};
	return q;
}

mc_vec3 mc_quat_to_rotvec(mc_quat q)
{
	if (q.w < 0)
		q = (mc_quat){-q.w, -q.x, -q.y, -q.z};
	double sn = sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
	if (sn < 1e-12)
		return mc_v3(2 * q.x, 2 * q.y, 2 * q.z);
	double th = 2.0 * atan2(sn, q.w);
	return mc_v3(q.x * th / sn, q.y * th / sn, q.z * th / sn);
}

mc_vec3 mc_quat_rotate(mc_quat q, mc_vec3 v)
{
	return mc_m3_apply(mc_quat_to_m3(q), v);
}

mc_xform mc_xform_identity(void)
{
	mc_xform x = {mc_m3_identity(), {0, 0, 0}};
	return x;
}

mc_xform mc_xform_compose(mc_xform ab, mc_xform bc)
{
	mc_xform r = {mc_m3_mul(ab.R, bc.R), mc_v3_add(mc_m3_apply(ab.R, bc.t), ab.t)};
	return r;
}

mc_xform mc_xform_inverse(mc_xform ab)
{
	mc_mat3 Rt = mc_m3_transpose(ab.R);
	mc_xform r = {Rt, mc_v3_scale(mc_m3_apply(Rt, ab.t), -1.0)};
	return r;
}

mc_vec3 mc_xform_apply(mc_xform ab, mc_vec3 p)
{
	return mc_v3_add(mc_m3_apply(ab.R, p), ab.t);
}

mc_xform mc_xform_from_4x4(const double m[4][4])
{
	mc_xform x;
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			x.R.m[i][j] = m[i][j];
	x.t = mc_v3(m[0][3], m[1][3], m[2][3]);
	return x;
}

/* Eigenvector of the largest eigenvalue of a symmetric 4x4 matrix, by
 * cyclic Jacobi rotations (exact to rounding in a few sweeps). */
static void sym4_top_eigenvector(double A[4][4], double v[4])
{
	double V[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
	for (int sweep = 0; sweep < 50; sweep++) {
		double off = 0;
		for (int p = 0; p < 4; p++)
			for (int q = p + 1; q < 4; q++)
				off += A[p][q] * A[p][q];
		if (off < 1e-30)
			break;
		for (int p = 0; p < 4; p++)
			for (int q = p + 1; q < 4; q++) {
				if (fabs(A[p][q]) < 1e-300)
					continue;
				double theta = (A[q][q] - A[p][p]) / (2 * A[p][q]);
				double t = (theta >= 0 ? 1 : -1) / (fabs(theta) + sqrt(theta * theta + 1));
				double c = 1 / sqrt(t * t + 1), s = t * c;
				for (int k = 0; k < 4; k++) { /* A = A J */
					double akp = A[k][p], akq = A[k][q];
					A[k][p] = c * akp - s * akq;
					A[k][q] = s * akp + c * akq;
				}
				for (int k = 0; k < 4; k++) { /* A = J^T A */
					double apk = A[p][k], aqk = A[q][k];
					A[p][k] = c * apk - s * aqk;
					A[q][k] = s * apk + c * aqk;
				}
				for (int k = 0; k < 4; k++) {
					double vkp = V[k][p], vkq = V[k][q];
					V[k][p] = c * vkp - s * vkq;
					V[k][q] = s * vkp + c * vkq;
				}
			}
	}
	int best = 0;
	for (int k = 1; k < 4; k++)
		if (A[k][k] > A[best][best])
			best = k;
	for (int k = 0; k < 4; k++)
		v[k] = V[k][best];
}

mc_xform mc_xform_fit_rigid(const mc_vec3 *from, const mc_vec3 *to, const double *w, int n)
{
	mc_vec3 ca = mc_v3(0, 0, 0), cb = mc_v3(0, 0, 0);
	double wsum = 0;
	for (int i = 0; i < n; i++) {
		double wi = w ? w[i] : 1;
		ca = mc_v3_axpy(wi, from[i], ca);
		cb = mc_v3_axpy(wi, to[i], cb);
		wsum += wi;
	}
	mc_xform x = mc_xform_identity();
	if (!(wsum > 0))
		return x;
	ca = mc_v3_scale(ca, 1 / wsum);
	cb = mc_v3_scale(cb, 1 / wsum);
	double S[3][3] = {{0}};
	for (int i = 0; i < n; i++) {
		double wi = w ? w[i] : 1;
		mc_vec3 a = mc_v3_sub(from[i], ca), b = mc_v3_sub(to[i], cb);
		for (int r = 0; r < 3; r++)
			for (int c = 0; c < 3; c++)
				S[r][c] += wi * mc_v3_get(a, r) * mc_v3_get(b, c);
	}
	/* Horn (1987): the rotation's quaternion is the top eigenvector of N. */
	double N[4][4] = {
		{S[0][0] + S[1][1] + S[2][2], S[1][2] - S[2][1], S[2][0] - S[0][2], S[0][1] - S[1][0]},
		{S[1][2] - S[2][1], S[0][0] - S[1][1] - S[2][2], S[0][1] + S[1][0], S[2][0] + S[0][2]},
		{S[2][0] - S[0][2], S[0][1] + S[1][0], -S[0][0] + S[1][1] - S[2][2], S[1][2] + S[2][1]},
		{S[0][1] - S[1][0], S[2][0] + S[0][2], S[1][2] + S[2][1], -S[0][0] - S[1][1] + S[2][2]},
	};
	double q[4];
	sym4_top_eigenvector(N, q);
	x.R = mc_quat_to_m3(mc_quat_normalize((mc_quat){q[0], q[1], q[2], q[3]}));
	x.t = mc_v3_sub(cb, mc_m3_apply(x.R, ca));
	return x;
}

void mc_xform_to_4x4(mc_xform x, double m[4][4])
{
	memset(m, 0, sizeof(double) * 16);
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			m[i][j] = x.R.m[i][j];
	m[0][3] = x.t.x;
	m[1][3] = x.t.y;
	m[2][3] = x.t.z;
	m[3][3] = 1;
}

bool mc_la_cholesky_solve(double *A, double *b, int n)
{
	for (int j = 0; j < n; j++) {
		double d = A[j * n + j];
		for (int k = 0; k < j; k++)
			d -= A[j * n + k] * A[j * n + k];
		if (!(d > 0))
			return false;
		d = sqrt(d);
		A[j * n + j] = d;
		for (int i = j + 1; i < n; i++) {
			double s = A[i * n + j];
			for (int k = 0; k < j; k++)
				s -= A[i * n + k] * A[j * n + k];
			A[i * n + j] = s / d;
		}
	}
	for (int i = 0; i < n; i++) { /* L y = b */
		double s = b[i];
		for (int k = 0; k < i; k++)
			s -= A[i * n + k] * b[k];
		b[i] = s / A[i * n + i];
	}
	for (int i = n - 1; i >= 0; i--) { /* L^T x = y */
		double s = b[i];
		for (int k = i + 1; k < n; k++)
			s -= A[k * n + i] * b[k];
		b[i] = s / A[i * n + i];
	}
	return true;
}

bool mc_la_lu_solve(double *A, double *b, int n)
{
	double scale = 0;
	for (int i = 0; i < n * n; i++)
		scale = fmax(scale, fabs(A[i]));
	if (!(scale > 0))
		return false;
	for (int c = 0; c < n; c++) {
		int p = c;
		for (int r = c + 1; r < n; r++)
			if (fabs(A[r * n + c]) > fabs(A[p * n + c]))
				p = r;
		if (fabs(A[p * n + c]) < 1e-14 * scale)
			return false;
		if (p != c) {
			for (int k = 0; k < n; k++) {
				double t = A[c * n + k];
				A[c * n + k] = A[p * n + k];
				A[p * n + k] = t;
			}
			double t = b[c];
			b[c] = b[p];
			b[p] = t;
		}
		for (int r = c + 1; r < n; r++) {
			double f = A[r * n + c] / A[c * n + c];
			for (int k = c; k < n; k++)
				A[r * n + k] -= f * A[c * n + k];
			b[r] -= f * b[c];
		}
	}
	for (int i = n - 1; i >= 0; i--) {
		double s = b[i];
		for (int k = i + 1; k < n; k++)
			s -= A[i * n + k] * b[k];
		b[i] = s / A[i * n + i];
	}
	return true;
}

bool mc_rays_nearest_point(const mc_vec3 *origin, const mc_vec3 *dir, const double *weight, int n, mc_vec3 *x)
{
	double A[9] = {0}, b[3] = {0};
	for (int i = 0; i < n; i++) {
		double d[3] = {dir[i].x, dir[i].y, dir[i].z}, o[3] = {origin[i].x, origin[i].y, origin[i].z};
		double w = weight ? weight[i] : 1.0;
		for (int p = 0; p < 3; p++)
			for (int q = 0; q < 3; q++) {
				double P = w * ((p == q) - d[p] * d[q]);
				A[3 * p + q] += P;
				b[p] += P * o[q];
			}
	}
	if (!mc_la_lu_solve(A, b, 3))
		return false;
	*x = mc_v3(b[0], b[1], b[2]);
	return mc_v3_isfinite(*x);
}
