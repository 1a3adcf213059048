/* mc_jitter (mocap-bench's JITTER line) on synthetic trajectories whose
 * velocity error and acceleration ratio are known in closed form, and on
 * runs broken by untracked frames. */
#include "eval/mc_jitter.h"
#include "test_util.h"

#define DT 0.1
#define N 20

/* Truth: x = t^2 (a constant 2 m/s^2), t = k DT; joint j is shifted by j
 * metres along z (a shift changes no difference). */
static mc_vec3 truth(int k, int j)
{
	double t = k * DT;
	return mc_v3(t * t, 0, j);
}

/* An estimate that is the truth plus a constant offset: no velocity
 * error, the same acceleration. */
static void test_offset(void)
{
	mc_jitter jt;
	mc_jitter_init(&jt, 2, DT);
	for (int k = 0; k < N; k++) {
		mc_vec3 g[2] = {truth(k, 0), truth(k, 1)}, e[2] = {mc_v3_add(g[0], mc_v3(0.3, -0.2, 0.1)), g[1]};
		mc_jitter_add(&jt, e, g);
	}
	CHECK_NEAR(mc_jitter_vel_err(&jt), 0, 1e-9);
	CHECK_NEAR(mc_jitter_accel_ratio(&jt), 1, 1e-9);
	CHECK(jt.vel_n == 2 * (N - 1) && jt.acc_n == 2 * (N - 2));
}

/* Twice the truth: the velocity error is the truth's finite-difference
 * speed, (2k - 1) DT between frames k - 1 and k, whose mean over k = 1..N-1
 * is (N - 1) DT; the acceleration is twice the truth's. */
static void test_scaled(void)
{
	mc_jitter jt;
	mc_jitter_init(&jt, 1, DT);
	for (int k = 0; k < N; k++) {
		mc_vec3 g = truth(k, 0), e = mc_v3_scale(g, 2);
		mc_jitter_add(&jt, &e, &g);
	}
	CHECK_NEAR(mc_jitter_vel_err(&jt), (N - 1) * DT, 1e-9);
	CHECK_NEAR(mc_jitter_accel_ratio(&jt), 2, 1e-9);
}

/* Shaking: the estimate alternates +-D along y around the truth of one
 * joint, the other joint is exact.  Each step of the shaking joint is off
 * by 2D / DT in velocity; its second difference is (2 DT^2, +-4D) against
 * the truth's (2 DT^2, 0).  Both joints count in the means. */
static void test_shaking(void)
{
	const double D = 0.01;
	mc_jitter jt;
	mc_jitter_init(&jt, 2, DT);
	for (int k = 0; k < N; k++) {
		mc_vec3 g[2] = {truth(k, 0), truth(k, 1)};
		mc_vec3 e[2] = {g[0], mc_v3_add(g[1], mc_v3(0, k % 2 ? D : -D, 0))};
		mc_jitter_add(&jt, e, g);
	}
	CHECK_NEAR(mc_jitter_vel_err(&jt), (0 + 2 * D / DT) / 2, 1e-9);
	double a = 2 * DT * DT, shaken = sqrt(a * a + 16 * D * D);
	CHECK_NEAR(mc_jitter_accel_ratio(&jt), (a + shaken) / (2 * a), 1e-9);
}

/* An untracked frame breaks the run: the estimate jumps by a metre across
 * it, which must not count; differences resume with the frames after it. */
static void test_break(void)
{
	mc_jitter jt;
	mc_jitter_init(&jt, 1, DT);
	for (int k = 0; k < N; k++) {
		if (k == 5) {
			mc_jitter_break(&jt);
			continue;
		}
		mc_vec3 g = truth(k, 0), e = mc_v3_add(g, mc_v3(k < 5 ? 0 : 1, 0, 0));
		mc_jitter_add(&jt, &e, &g);
	}
	CHECK_NEAR(mc_jitter_vel_err(&jt), 0, 1e-9);
	CHECK_NEAR(mc_jitter_accel_ratio(&jt), 1, 1e-9);
	/* runs of 5 (frames 0-4) and N - 6 frames */
	CHECK(jt.vel_n == 4 + (N - 7) && jt.acc_n == 3 + (N - 8));
}

/* Too few frames, or a truth that does not accelerate: no figure. */
static void test_undefined(void)
{
	mc_jitter jt;
	mc_jitter_init(&jt, 1, DT);
	mc_vec3 g = mc_v3(0, 0, 0);
	CHECK(isnan(mc_jitter_vel_err(&jt)) && isnan(mc_jitter_accel_ratio(&jt)));
	mc_jitter_add(&jt, &g, &g);
	mc_jitter_add(&jt, &g, &g);
	CHECK(!isnan(mc_jitter_vel_err(&jt)) && isnan(mc_jitter_accel_ratio(&jt)));
	mc_jitter_add(&jt, &g, &g);
	CHECK(isnan(mc_jitter_accel_ratio(&jt))); /* the truth stands still */
}

int main(void)
{
	test_offset();
	test_scaled();
	test_shaking();
	test_break();
	test_undefined();
	return mc_test_finish("test_jitter");
}
