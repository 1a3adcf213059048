/* calib_fixture: the calibration tests' known cameras, board views and
 * checks against the truth. */
#ifndef CALIB_FIXTURE_HPP
#define CALIB_FIXTURE_HPP

#include "board_render.hpp"

extern "C" {
#include "test_util.h"
}

#include <algorithm>
#include <cstdio>
#include <random>
#include <vector>

static const double deg = M_PI / 180;

inline calib_board board(int sx, int sy, double square_mm, double marker_mm, const char *dictionary = "5x5_100")
{
	calib_board b;
	b.dictionary = dictionary;
	b.squares_x = sx, b.squares_y = sy, b.square_m = square_mm / 1000, b.marker_m = marker_mm / 1000;
	mc_err err = {};
	if (calib_board_init(&b, &err) < 0)
		std::fprintf(stderr, "%s\n", err.msg);
	return b;
}

/* The worst distance, over a grid of pixels of the truth's valid image,
 * between a pixel and where its true ray lands through the estimate. */
inline double lens_error(const mc_camera &truth, const mc_camera &est, double max_theta)
{
	double worst = 0;
	for (int y = 0; y < truth.height; y += 8)
		for (int x = 0; x < truth.width; x += 8) {
			mc_vec3 ray;
			double u, v;
			if (!mc_camera_unproject(&truth, x, y, &ray) || std::acos(ray.z) > max_theta)
				continue;
			if (!mc_camera_project_unbounded(&est, ray, &u, &v))
				return INFINITY;
			worst = std::max(worst, std::hypot(u - x, v - y));
		}
	return worst;
}

inline void check_intrinsics(const char *what, const mc_camera &truth, const mc_camera &est, double lens_theta)
{
	CHECK_MSG(std::fabs(est.fx / truth.fx - 1) < 0.005 && std::fabs(est.fy / truth.fy - 1) < 0.005,
		  "%s: focal %.3f %.3f, truth %.3f %.3f", what, est.fx, est.fy, truth.fx, truth.fy);
	CHECK_MSG(std::hypot(est.cx - truth.cx, est.cy - truth.cy) < 1, "%s: centre %.3f %.3f, truth %.3f %.3f", what,
		  est.cx, est.cy, truth.cx, truth.cy);
	double lens = lens_error(truth, est, lens_theta);
	CHECK_MSG(lens < 0.5, "%s: lens off by up to %.3f px", what, lens);
	std::printf("%s: f %.3f/%.3f (truth %.3f/%.3f), centre off %.3f px, lens off up to %.3f px\n", what, est.fx, est.fy,
		    truth.fx, truth.fy, std::hypot(est.cx - truth.cx, est.cy - truth.cy), lens);
}

inline mc_camera pinhole_truth()
{
	mc_camera c{};
	std::snprintf(c.name, sizeof c.name, "cam");
	c.model = MC_CAM_PINHOLE;
	c.width = 640, c.height = 480;
	c.fx = 520, c.fy = 516, c.cx = 323.4, c.cy = 236.8;
	c.k[0] = -0.27, c.k[1] = 0.08;
	c.max_theta = 50 * deg;
	c.rig_from_cam = mc_xform_identity();
	return c;
}

/* Views spread over the image, as a person would hold the board: its
 * centre at n pixels on a sunflower spiral over the image (out to
 * `reach` of the half-diagonal, so into the corners), at distances in
 * [d0, d1], tilted up to `tilt` about both board axes. */
inline std::vector<mc_xform> spread_poses(const calib_board &b, const mc_camera &cam, int n, double reach, double d0, double d1,
				   double tilt, unsigned seed)
{
	std::mt19937 rng(seed);
	std::uniform_real_distribution<double> uni(0, 1);
	std::vector<mc_xform> poses;
	double half_w = cam.width / 2.0, half_h = cam.height / 2.0;
	for (int i = 0; poses.size() < (size_t)n && i < 4 * n; i++) {
		double r = std::sqrt((i % n + 0.5) / n) * reach * std::sqrt(2.0), phi = i * 2.39996;
		double u = std::clamp(half_w + r * half_w * std::cos(phi), 0.0, cam.width - 1.0);
		double v = std::clamp(half_h + r * half_h * std::sin(phi), 0.0, cam.height - 1.0);
		mc_vec3 ray;
		if (!mc_camera_unproject(&cam, u, v, &ray) || ray.z < 0.1)
			continue;
		poses.push_back(board_pose_along(b, ray, d0 + (d1 - d0) * uni(rng), (2 * uni(rng) - 1) * tilt,
						 (2 * uni(rng) - 1) * tilt, (uni(rng) - 0.5) * 60 * deg));
	}
	return poses;
}

inline mc_camera fisheye_truth(const char *name, double cx, double cy)
{
	mc_camera c{};
	std::snprintf(c.name, sizeof c.name, "%s", name);
	c.model = MC_CAM_EQUIDISTANT;
	c.width = c.height = 640;
	c.fx = 203, c.fy = 204.5, c.cx = cx, c.cy = cy;
	c.k[0] = 0.03, c.k[1] = -0.012, c.k[2] = 0.002;
	c.max_theta = 90 * deg;
	c.rig_from_cam = mc_xform_identity();
	return c;
}

#endif
