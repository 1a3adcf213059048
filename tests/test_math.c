/* Tests of core/base/mc_math: rotations, transforms and the small solvers;
 * and core/base/mc_stats' median. */
#include "base/mc_math.h"
#include "base/mc_stats.h"
#include "test_util.h"

static double mat_diff(mc_mat3 a, mc_mat3 b)
{
	double d = 0;
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			d = fmax(d, fabs(a.m[i][j] - b.m[i][j]));
	return d;
}

static void test_rotations(void)
{
	unsigned long long rng = 42;
	for (int it = 0; it < 1000; it++) {
		mc_vec3 w = mc_v3(mc_test_rand(&rng) * 2 - 1, mc_test_rand(&rng) * 2 - 1, mc_test_rand(&rng) * 2 - 1);
		w = mc_v3_scale(mc_v3_normalize(w), mc_test_rand(&rng) * 3.1);
		mc_mat3 R = mc_m3_from_rotvec(w);
		/* orthonormal with determinant +1 */
		CHECK(mat_diff(mc_m3_mul(R, mc_m3_transpose(R)), mc_m3_identity()) < 1e-12);
		mc_vec3 w2 = mc_m3_to_rotvec(R);
		CHECK(mc_v3_norm(mc_v3_sub(w, w2)) < 1e-9);
		mc_quat q = mc_quat_from_rotvec(w);
		CHECK(mat_diff(mc_quat_to_m3(q), R) < 1e-12);
		CHECK(mat_diff(mc_quat_to_m3(mc_quat_from_m3(R)), R) < 1e-12);
		mc_vec3 v = mc_v3(1, -2, 0.5);
		CHECK(mc_v3_norm(mc_v3_sub(mc_quat_rotate(q, v), mc_m3_apply(R, v))) < 1e-12);
		/* composition of quaternions matches matrix product */
		mc_quat q2 = mc_quat_from_rotvec(mc_v3(0.3, -0.2, 0.1));
		CHECK(mat_diff(mc_quat_to_m3(mc_quat_mul(q, q2)), mc_m3_mul(R, mc_quat_to_m3(q2))) < 1e-12);
	}
	/* rotation by 90 degrees about z maps x to y */
	mc_vec3 y = mc_m3_apply(mc_m3_rot_axis(2, M_PI / 2), mc_v3(1, 0, 0));
	CHECK(fabs(y.x) < 1e-12 && fabs(y.y - 1) < 1e-12);
	/* near pi the quaternion path is still exact */
	mc_vec3 wpi = mc_v3(0, M_PI - 1e-9, 0);
	CHECK(mc_v3_norm(mc_v3_sub(mc_m3_to_rotvec(mc_m3_from_rotvec(wpi)), wpi)) < 1e-6);
}

static void test_xforms(void)
{
	mc_xform a = {mc_m3_from_rotvec(mc_v3(0.1, 0.2, 0.3)), mc_v3(1, 2, 3)};
	mc_xform b = {mc_m3_from_rotvec(mc_v3(-0.4, 0.0, 0.2)), mc_v3(-1, 0.5, 0)};
	mc_vec3 p = mc_v3(0.3, -0.7, 2.0);
	mc_vec3 p1 = mc_xform_apply(mc_xform_compose(a, b), p);
	mc_vec3 p2 = mc_xform_apply(a, mc_xform_apply(b, p));
	CHECK(mc_v3_norm(mc_v3_sub(p1, p2)) < 1e-12);
	mc_vec3 back = mc_xform_apply(mc_xform_inverse(a), mc_xform_apply(a, p));
	CHECK(mc_v3_norm(mc_v3_sub(back, p)) < 1e-12);
	double m[4][4];
	mc_xform_to_4x4(a, m);
	mc_xform a2 = mc_xform_from_4x4((const double(*)[4])m);
	CHECK(mat_diff(a.R, a2.R) == 0 && mc_v3_norm(mc_v3_sub(a.t, a2.t)) == 0);
}

static void test_solvers(void)
{
	enum { N = 6 };
	unsigned long long rng = 7;
	double M[N * N], A[N * N], A2[N * N], x[N], b[N], b2[N];
	for (int i = 0; i < N * N; i++)
		M[i] = mc_test_rand(&rng) - 0.5;
	for (int i = 0; i < N; i++) /* A = M M^T + I is SPD */
		for (int j = 0; j < N; j++) {
			double s = i == j;
			for (int k = 0; k < N; k++)
				s += M[i * N + k] * M[j * N + k];
			A[i * N + j] = A2[i * N + j] = s;
		}
	for (int i = 0; i < N; i++)
		x[i] = i - 2.5;
	for (int i = 0; i < N; i++) {
		b[i] = 0;
		for (int j = 0; j < N; j++)
			b[i] += A[i * N + j] * x[j];
		b2[i] = b[i];
	}
	CHECK(mc_la_cholesky_solve(A, b, N));
	CHECK(mc_la_lu_solve(A2, b2, N));
	for (int i = 0; i < N; i++) {
		CHECK_NEAR(b[i], x[i], 1e-9);
		CHECK_NEAR(b2[i], x[i], 1e-9);
	}
	double S[4] = {1, 2, 2, 4}, s[2] = {1, 1};
	CHECK(!mc_la_lu_solve(S, s, 2));
	double NS[4] = {1, 0, 0, -1}, ns[2] = {1, 1};
	CHECK(!mc_la_cholesky_solve(NS, ns, 2));
}

/* Horn's rigid fit recovers a known transform from exact points, and
 * gives the least-squares one (centroids matched) under noise. */
static void test_fit_rigid(void)
{
	mc_vec3 from[6] = {{0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {0, 0, 0.5}, {0.3, -0.4, 0.9}, {-1, 0.2, 0.1}}, to[6];
	mc_xform truth = {mc_m3_from_rotvec(mc_v3(0.4, -2.9, 0.7)), mc_v3(1.5, -0.2, 1.7)};
	for (int i = 0; i < 6; i++)
		to[i] = mc_xform_apply(truth, from[i]);
	mc_xform fit = mc_xform_fit_rigid(from, to, NULL, 6);
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			CHECK(fabs(fit.R.m[i][j] - truth.R.m[i][j]) < 1e-9);
	CHECK(mc_v3_norm(mc_v3_sub(fit.t, truth.t)) < 1e-9);
	/* weights: a point with weight 0 does not count */
	double w[6] = {1, 1, 1, 1, 1, 0};
	to[5] = mc_v3(100, 100, 100);
	fit = mc_xform_fit_rigid(from, to, w, 6);
	CHECK(mc_v3_norm(mc_v3_sub(fit.t, truth.t)) < 1e-9);
}

static void test_median(void)
{
	double odd[5] = {4, -1, 9, 2, 7}, even[4] = {3, 10, 1, 5}, none[1] = {0};
	CHECK(mc_stats_median(odd, 5) == 4);
	CHECK(odd[0] == -1 && odd[4] == 9); /* sorted in place */
	CHECK(mc_stats_median(even, 4) == 4); /* the mean of 3 and 5 */
	CHECK(mc_stats_median(none, 0) == 0);
}

/* The window keeps the last cap samples and counts up to cap. */
static void test_window(void)
{
	double v[3] = {0};
	int n = 0, next = 0;
	mc_stats_window_add(v, 3, &n, &next, 1);
	mc_stats_window_add(v, 3, &n, &next, 2);
	CHECK(n == 2 && next == 2 && v[0] == 1 && v[1] == 2);
	mc_stats_window_add(v, 3, &n, &next, 3);
	mc_stats_window_add(v, 3, &n, &next, 4); /* drops the 1 */
	CHECK(n == 3 && next == 1 && v[0] == 4 && v[1] == 2 && v[2] == 3);
}

int main(void)
{
	test_median();
	test_window();
	test_fit_rigid();
	test_rotations();
	test_xforms();
	test_solvers();
	return mc_test_finish("test_math");
}
