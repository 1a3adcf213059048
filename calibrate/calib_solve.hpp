/* calib_solve: camera intrinsics and rig extrinsics from board views.
 *
 * Per camera, OpenCV gives the first estimate (cv::calibrateCamera for the
 * pinhole model with radial-tangential distortion, cv::fisheye::calibrate
 * for the equidistant Kannala-Brandt model).  Then one bundle adjustment
 * refines everything through the project's own camera models
 * (mc_camera_project_unbounded), so that what is saved is exactly what
 * mocapd projects with, including fisheye rays beyond 90 degrees, which
 * cv::fisheye cannot represent: every camera's intrinsics, every camera's
 * pose in the rig (the first camera's frame, or the floor board's), and one
 * board pose per view set (the images of one instant, matched across
 * cameras by file name).  Views whose error stands out are rejected with
 * their reason, and the adjustment runs again without them. */
#ifndef CALIB_SOLVE_HPP
#define CALIB_SOLVE_HPP

#include "calib_board.hpp"

extern "C" {
#include "geom/mc_camera.h"
}

#include <string>
#include <vector>

/* One image of one camera. */
struct calib_view {
	std::string name; /* the image's name without folder and extension: the view set */
	calib_corners corners;
	bool used = false;
	std::string why;  /* why it is not used */
	double rms = 0;   /* reprojection error, pixels, after the final adjustment */
	double max_err = 0;
	int dropped = 0;  /* corners dropped as outliers */
	mc_xform cam_from_board{}; /* the board's pose, after the adjustment */
};

struct calib_cam {
	std::string name;
	mc_camera_model model = MC_CAM_PINHOLE;
	int width = 0, height = 0;
	double fov_deg = 0;  /* the lens's field of view when known; 0: from the image corners */
	bool pinhole_k3 = false;         /* estimate k3 too */
	bool pinhole_tangential = false; /* estimate p1 p2 (they trade off with the centre) */
	std::vector<calib_view> views;
	mc_camera cam{};     /* the result */
	double rms = 0;
	int used_views = 0;
};

struct calib_options {
	int min_corners = 8;       /* fewer corners in a view: not used */
	int min_views = 4;         /* fewer usable views per camera: an error */
	double reject_px = 1.0;    /* a view's RMS above max(reject_px, 3 x median) is rejected */
	double corner_sigmas = 4;  /* a corner off by more than this many times the camera's RMS
				      (and 0.5 px) is dropped */
	std::string floor_view;    /* a view set with the board on the floor: the world frame (z up) */
	bool verbose = false;
};

/* Marks each view used or not (with why) from its corners, checks that the
 * used views cover the image, and estimates the intrinsics (OpenCV, then the
 * adjustment over this camera's views). Errors say what to do. */
int calib_intrinsics(calib_cam *c, const calib_options *opt, mc_err *err);

/* With two or more cameras: finds each camera's pose from the view sets
 * that cameras share, then adjusts all cameras and views jointly. With one
 * camera it leaves the camera at the rig origin (or places it over the
 * floor board). Fills each cam's rig_from_cam; the rig frame is the first
 * camera's frame, or with opt->floor_view the board's floor frame (z up,
 * origin at the board's first corner). */
int calib_extrinsics(std::vector<calib_cam> &cams, const calib_options *opt, mc_err *err);

/* Reprojection of the board corners of a view through the calibrated camera
 * (pixels; false where the corner does not project). */
bool calib_reproject(const calib_cam &c, const calib_view &v, std::vector<cv::Point2f> &px);

/* The cell of an n x n grid over a width x height image that pixel q
 * falls in, row by row (0 .. n*n - 1; pixels outside go to the nearest). */
int calib_grid_cell(cv::Point2f q, int width, int height, int n);

/* The cells of a 4x4 grid over the image that hold used corners (0..16). */
int calib_coverage_cells(const calib_cam &c);

#endif
