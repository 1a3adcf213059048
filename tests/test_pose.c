/* Tests of core/geom/mc_pose: interpolation of timed poses (the head poses
 * the server uses for world-frame skeletons), the choice of poses around a
 * time, and moving points and orientations from one frame into another. */
#include "geom/mc_pose.h"
#include "test_util.h"

static mc_pose pose(uint64_t t, double x, double y, double z, mc_quat q)
{
	mc_pose p = {t, mc_v3(x, y, z), q};
	return p;
}

/* The angle between two rotations, radians (q and -q are the same). */
static double quat_angle(mc_quat a, mc_quat b)
{
	double d = fabs(a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z);
	return 2 * acos(d > 1 ? 1 : d);
}

/* The largest component difference, up to sign: exact where the angle
 * through acos is not (acos loses half the digits near 1). */
static double quat_diff(mc_quat a, mc_quat b)
{
	double dm = fmax(fmax(fabs(a.w - b.w), fabs(a.x - b.x)), fmax(fabs(a.y - b.y), fabs(a.z - b.z)));
	double dp = fmax(fmax(fabs(a.w + b.w), fabs(a.x + b.x)), fmax(fabs(a.y + b.y), fabs(a.z + b.z)));
	return fmin(dm, dp);
}

static void test_nlerp(void)
{
	mc_quat a = mc_quat_identity(), b = mc_quat_from_rotvec(mc_v3(0, 0, 0.2));
	CHECK(quat_diff(mc_quat_nlerp(a, b, 0), a) < 1e-12);
	CHECK(quat_diff(mc_quat_nlerp(a, b, 1), b) < 1e-12);
	/* Half way between small rotations: close to slerp's 0.1 rad. */
	mc_quat h = mc_quat_nlerp(a, b, 0.5);
	CHECK_NEAR(quat_angle(h, a), 0.1, 1e-9);
	CHECK_NEAR(h.w * h.w + h.x * h.x + h.y * h.y + h.z * h.z, 1.0, 1e-12);
	/* The shorter arc: -b is the same rotation as b. */
	mc_quat nb = {-b.w, -b.x, -b.y, -b.z};
	CHECK(quat_diff(mc_quat_nlerp(a, nb, 0.5), h) < 1e-12);
}

static void test_interpolate(void)
{
	mc_quat q90 = mc_quat_from_rotvec(mc_v3(0, 0, M_PI / 2));
	mc_pose a = pose(1000, 1, 2, 3, q90), b = pose(2000, 2, 2, 5, q90);
	mc_pose m = mc_pose_interpolate(&a, &b, 1250);
	CHECK(m.timestamp_ns == 1250);
	CHECK_NEAR(m.position.x, 1.25, 1e-12);
	CHECK_NEAR(m.position.y, 2.0, 1e-12);
	CHECK_NEAR(m.position.z, 3.5, 1e-12);
	CHECK(quat_diff(m.orientation, q90) < 1e-12);
	/* Equal timestamps: the first pose, at the time asked. */
	mc_pose same = mc_pose_interpolate(&a, &a, 1000);
	CHECK(same.timestamp_ns == 1000 && same.position.x == 1 && same.position.z == 3);
}

static void test_pose_at(void)
{
	mc_quat id = mc_quat_identity();
	const uint64_t age = 50;
	/* In any order, as a history ring holds them. */
	mc_pose h[4] = {pose(300, 3, 0, 0, id), pose(100, 1, 0, 0, id), pose(200, 2, 0, 0, id),
			pose(500, 5, 0, 0, id)};
	mc_pose out;
	CHECK(!mc_pose_at(h, 0, 100, age, &out));
	/* Bracketed, at most 2 * age apart: interpolated between the nearest two. */
	CHECK(mc_pose_at(h, 4, 150, age, &out) && out.timestamp_ns == 150);
	CHECK_NEAR(out.position.x, 1.5, 1e-12);
	CHECK(mc_pose_at(h, 4, 275, age, &out));
	CHECK_NEAR(out.position.x, 2.75, 1e-12);
	/* Exactly on a sample. */
	CHECK(mc_pose_at(h, 4, 200, age, &out) && out.timestamp_ns == 200);
	CHECK_NEAR(out.position.x, 2.0, 1e-12);
	/* 300..500 is more than 2 * age: the nearer one within age, as it is. */
	CHECK(mc_pose_at(h, 4, 340, age, &out) && out.timestamp_ns == 300 && out.position.x == 3);
	CHECK(mc_pose_at(h, 4, 470, age, &out) && out.timestamp_ns == 500 && out.position.x == 5);
	/* Exactly 2 * age apart still interpolates; wider takes the nearer. */
	mc_pose far[2] = {pose(100, 1, 0, 0, id), pose(300, 3, 0, 0, id)};
	CHECK(mc_pose_at(far, 2, 200, 100, &out) && out.timestamp_ns == 200);
	CHECK_NEAR(out.position.x, 2.0, 1e-12);
	CHECK(mc_pose_at(far, 2, 150, 60, &out) && out.timestamp_ns == 100);
	CHECK(mc_pose_at(far, 2, 260, 60, &out) && out.timestamp_ns == 300);
	/* Too old, too early, and in a wide hole between two. */
	CHECK(!mc_pose_at(h, 4, 600, age, &out));
	CHECK(!mc_pose_at(h, 4, 10, age, &out));
	CHECK(!mc_pose_at(h, 4, 400, age, &out));
	CHECK(mc_pose_at(h, 4, 550, age, &out) && out.timestamp_ns == 500);
}

static void test_apply(void)
{
	/* The server's world-frame case: 90 degrees about z, then (1.1, 2, 3). */
	mc_pose w = pose(0, 1.1, 2, 3, mc_quat_from_rotvec(mc_v3(0, 0, M_PI / 2)));
	mc_vec3 p = mc_v3(2, 0.2, -1);
	mc_quat q = mc_quat_from_rotvec(mc_v3(0, 0.02, 0));
	mc_quat q0 = q;
	mc_pose_apply(&w, &p, &q);
	CHECK_NEAR(p.x, 0.9, 1e-12);
	CHECK_NEAR(p.y, 4.0, 1e-12);
	CHECK_NEAR(p.z, 2.0, 1e-12);
	mc_quat want = mc_quat_mul(w.orientation, q0);
	CHECK(quat_diff(q, want) < 1e-12);
	/* Either part alone. */
	mc_vec3 p2 = mc_v3(0, 0, 0);
	mc_pose_apply(&w, &p2, NULL);
	CHECK(p2.x == 1.1 && p2.y == 2 && p2.z == 3);
	mc_quat q2 = mc_quat_identity();
	mc_pose_apply(&w, NULL, &q2);
	CHECK(quat_diff(q2, w.orientation) < 1e-12);
}

int main(void)
{
	test_nlerp();
	test_interpolate();
	test_pose_at();
	test_apply();
	return mc_test_finish("test_pose");
}
