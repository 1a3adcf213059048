/* board_render: images of a calibration board seen through a known camera,
 * for the calibration tests.  Every pixel is 4x4 rays of the project's own
 * camera model (mc_camera_unproject at the pixel's corners, interpolated
 * inside it), each intersected with the board plane and given the printed
 * board's grey value there (bilinear), or the room's grey where it misses;
 * the 16 are averaged (the pixel's area, so that edges are not aliased),
 * the image is blurred like a lens (Gaussian, sigma 0.6 px) and noise is
 * added (Gaussian, sigma 2 grey levels). */
#ifndef BOARD_RENDER_HPP
#define BOARD_RENDER_HPP

#include "calib_board.hpp"

extern "C" {
#include "geom/mc_camera.h"
}

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>
#include <vector>

struct board_renderer {
	const calib_board *board;
	cv::Mat texture;        /* the printed board with its white margin */
	double px_per_m, margin_m;
	mc_camera cam;
	std::vector<mc_vec3> rays; /* at the pixel corners, (width + 1) x (height + 1); zero: none */

	board_renderer(const calib_board *b, const mc_camera &c) : board(b), px_per_m(4000), margin_m(b->square_m / 2), cam(c)
	{
		texture = calib_board_image(b, px_per_m, margin_m);
		rays.resize((size_t)(cam.width + 1) * (cam.height + 1));
		for (int y = 0; y <= cam.height; y++)
			for (int x = 0; x <= cam.width; x++) {
				mc_vec3 r = mc_v3(0, 0, 0);
				if (!mc_camera_unproject(&cam, x - 0.5, y - 0.5, &r))
					r = mc_v3(0, 0, 0);
				rays[(size_t)y * (cam.width + 1) + x] = r;
			}
	}

	static bool none(mc_vec3 r) { return r.x == 0 && r.y == 0 && r.z == 0; }

	/* One pixel: the mean of 4x4 rays interpolated between its corners. */
	double pixel(int x, int y, mc_vec3 o, const mc_mat3 &board_from_cam) const
	{
		const mc_vec3 *r0 = &rays[(size_t)y * (cam.width + 1) + x], *r1 = r0 + cam.width + 1;
		if (none(r0[0]) || none(r0[1]) || none(r1[0]) || none(r1[1]))
			return 0;
		double sum = 0;
		for (int j = 0; j < 4; j++)
			for (int i = 0; i < 4; i++) {
				double fx = (i + 0.5) / 4, fy = (j + 0.5) / 4;
				mc_vec3 top = mc_v3_axpy(fx, mc_v3_sub(r0[1], r0[0]), r0[0]);
				mc_vec3 bottom = mc_v3_axpy(fx, mc_v3_sub(r1[1], r1[0]), r1[0]);
				mc_vec3 ray = mc_v3_axpy(fy, mc_v3_sub(bottom, top), top);
				sum += sample(o, mc_m3_apply(board_from_cam, ray));
			}
		return sum / 16;
	}

	double sample(mc_vec3 o, mc_vec3 d) const
	{
		const double room = 110;
		if (d.z == 0)
			return room;
		double t = -o.z / d.z;
		if (!(t > 0))
			return room;
		double X = o.x + t * d.x, Y = o.y + t * d.y;
		double tx = (X + margin_m) * px_per_m - 0.5, ty = (Y + margin_m) * px_per_m - 0.5;
		if (tx < 0 || ty < 0 || tx >= texture.cols - 1 || ty >= texture.rows - 1)
			return room;
		int ix = (int)tx, iy = (int)ty;
		double fx = tx - ix, fy = ty - iy;
		const uchar *r0 = texture.ptr<uchar>(iy), *r1 = texture.ptr<uchar>(iy + 1);
		/* The print's black and white are not the sensor's 0 and 255. */
		double g = (1 - fy) * ((1 - fx) * r0[ix] + fx * r0[ix + 1]) + fy * ((1 - fx) * r1[ix] + fx * r1[ix + 1]);
		return 30 + g * (200.0 / 255);
	}

	/* The view of the board at cam_from_board, with noise from rng. */
	cv::Mat render(const mc_xform &cam_from_board, std::mt19937 &rng) const
	{
		mc_xform board_from_cam = mc_xform_inverse(cam_from_board);
		mc_vec3 o = board_from_cam.t;
		cv::Mat img(cam.height, cam.width, CV_32F);
		for (int y = 0; y < cam.height; y++)
			for (int x = 0; x < cam.width; x++)
				img.at<float>(y, x) = (float)pixel(x, y, o, board_from_cam.R);
		cv::GaussianBlur(img, img, cv::Size(0, 0), 0.6);
		std::normal_distribution<float> noise(0, 2);
		for (int y = 0; y < cam.height; y++)
			for (int x = 0; x < cam.width; x++)
				img.at<float>(y, x) += noise(rng);
		cv::Mat out;
		img.convertTo(out, CV_8U);
		return out;
	}
};

/* A board pose whose centre lies along `ray` (camera frame) at `dist`,
 * facing the camera, turned by `tilt_x`, `tilt_y` about its own axes and by
 * `spin` in its plane (radians). */
inline mc_xform board_pose_along(const calib_board &b, mc_vec3 ray, double dist, double tilt_x, double tilt_y, double spin)
{
	mc_vec3 z = mc_v3_normalize(ray); /* board +z points away from the camera */
	mc_vec3 up = std::fabs(z.y) < 0.9 ? mc_v3(0, 1, 0) : mc_v3(1, 0, 0);
	mc_vec3 x = mc_v3_normalize(mc_v3_cross(up, z));
	mc_vec3 y = mc_v3_cross(z, x);
	mc_mat3 facing;
	for (int i = 0; i < 3; i++)
		facing.m[i][0] = mc_v3_get(x, i), facing.m[i][1] = mc_v3_get(y, i), facing.m[i][2] = mc_v3_get(z, i);
	mc_mat3 turn = mc_m3_mul(mc_m3_rot_axis(0, tilt_x), mc_m3_mul(mc_m3_rot_axis(1, tilt_y), mc_m3_rot_axis(2, spin)));
	mc_xform p;
	p.R = mc_m3_mul(facing, turn);
	mc_vec3 centre_board = mc_v3(b.squares_x * b.square_m / 2, b.squares_y * b.square_m / 2, 0);
	p.t = mc_v3_sub(mc_v3_scale(z, dist), mc_m3_apply(p.R, centre_board));
	return p;
}

#endif
