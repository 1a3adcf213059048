/* A point's offset from a camera's ray (geom/mc_ray.h): the line's beyond
 * MC_RAY_NEAR_M, the angle times MC_RAY_NEAR_M nearer, continuous, its
 * Jacobian and gradient right, and a point at the camera's centre far
 * from every ray, as a wrist beside a head-mounted camera must be. */
#include "test_util.h"

#include "geom/mc_ray.h"

static const mc_vec3 dir_raw = {0.2, -0.3, 0.93};

static mc_vec3 unit_dir(void)
{
	return mc_v3_normalize(dir_raw);
}

/* A point at depth t along dir, `off` metres off it sideways. */
static mc_vec3 at(double t, double off)
{
	mc_vec3 d = unit_dir(), side = mc_v3_normalize(mc_v3_cross(d, mc_v3(1, 0, 0)));
	return mc_v3_axpy(off, side, mc_v3_scale(d, t));
}

static void test_far_is_the_line(void)
{
	mc_vec3 d = unit_dir(), v = at(2.0, 0.07);
	mc_vec3 r = mc_ray_offset(v, d, MC_RAY_NEAR_M), line = mc_v3_reject(v, d);
	CHECK_NEAR(mc_v3_norm(mc_v3_sub(r, line)), 0, 1e-12);
	CHECK_NEAR(mc_v3_norm(r), 0.07, 1e-12);
}

static void test_near_is_the_angle(void)
{
	mc_vec3 d = unit_dir();
	/* 2 cm off at 0.15 m is the angle of 4 cm off at 0.3 m */
	CHECK_NEAR(mc_v3_norm(mc_ray_offset(at(0.15, 0.02), d, MC_RAY_NEAR_M)), 0.02 * MC_RAY_NEAR_M / 0.15, 1e-12);
	/* continuous where the stretches meet */
	for (int s = 0; s < 2; s++) {
		double t = s ? MC_RAY_NEAR_M : MC_RAY_MIN_DEPTH_M;
		mc_vec3 a = mc_ray_offset(at(t - 1e-9, 0.03), d, MC_RAY_NEAR_M);
		mc_vec3 b = mc_ray_offset(at(t + 1e-9, 0.03), d, MC_RAY_NEAR_M);
		CHECK_NEAR(mc_v3_norm(mc_v3_sub(a, b)), 0, 1e-6);
	}
}

/* The camera's centre, and a point just behind it, lie on every ray's line;
 * measured from the ray they must be far from a ray 40 degrees off the
 * axis, while a point on that ray at 0.2 m is on it. */
static void test_camera_centre(void)
{
	mc_vec3 d = mc_v3_normalize(mc_v3(0.64, 0, 0.77));
	double centre = mc_v3_norm(mc_ray_offset(mc_v3(0, 0, 0), d, MC_RAY_NEAR_M));
	double behind = mc_v3_norm(mc_ray_offset(mc_v3(-0.05, 0.01, -0.04), d, MC_RAY_NEAR_M));
	printf("offset from the ray: camera centre %.2f m, a point behind it %.2f m (the line: %.3f m)\n", centre,
	       behind, mc_v3_norm(mc_v3_reject(mc_v3(-0.05, 0.01, -0.04), d)));
	CHECK(centre >= MC_RAY_NEAR_M * 0.99);
	CHECK(behind >= MC_RAY_NEAR_M);
	CHECK_NEAR(mc_v3_norm(mc_ray_offset(mc_v3_scale(d, 0.2), d, MC_RAY_NEAR_M)), 0, 1e-12);
	/* near 0: the line's offset everywhere, the centre on every ray */
	CHECK_NEAR(mc_v3_norm(mc_ray_offset(mc_v3(0, 0, 0), d, 0)), 0, 1e-12);
}

/* mc_ray_offset_move and mc_ray_offset_pull against central differences,
 * in each stretch. */
static void test_derivatives(void)
{
	mc_vec3 d = unit_dir(), dv = mc_v3(0.3, -0.7, 0.2), g = mc_v3(-0.4, 0.1, 0.9);
	const double depth[] = {1.2, MC_RAY_NEAR_M / 2, 0.02, -0.2}, h = 1e-6;
	for (int i = 0; i < 4; i++) {
		mc_vec3 v = at(depth[i], 0.04);
		mc_vec3 num = mc_v3_scale(mc_v3_sub(mc_ray_offset(mc_v3_axpy(h, dv, v), d, MC_RAY_NEAR_M),
						    mc_ray_offset(mc_v3_axpy(-h, dv, v), d, MC_RAY_NEAR_M)),
					  0.5 / h);
		CHECK_NEAR(mc_v3_norm(mc_v3_sub(num, mc_ray_offset_move(v, d, MC_RAY_NEAR_M, dv))), 0, 1e-6);
		/* g . (J e_k) = (J^T g)_k for each axis */
		mc_vec3 pull = mc_ray_offset_pull(v, d, MC_RAY_NEAR_M, g);
		const mc_vec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
		for (int k = 0; k < 3; k++)
			CHECK_NEAR(mc_v3_dot(g, mc_ray_offset_move(v, d, MC_RAY_NEAR_M, axes[k])), mc_v3_get(pull, k), 1e-12);
	}
}

int main(void)
{
	test_far_is_the_line();
	test_near_is_the_angle();
	test_camera_centre();
	test_derivatives();
	return mc_test_finish("test_ray");
}
