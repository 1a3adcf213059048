/* test_calibrate: mocap-calibrate against cameras whose truth is known.
 *
 * Board views are rendered through the project's own camera models
 * (board_render.hpp: each pixel's rays meet the board plane, blur, noise),
 * written as image folders, calibrated by the installed program, and the
 * rig file it writes is compared with the truth: focal length within 0.5 %,
 * centre within 1 px, the whole lens (truth's ray for every pixel,
 * projected through the calibration) within 0.5 px over the image, RMS
 * below 0.3 px, a stereo baseline within 2 mm; for a pinhole camera, a
 * head-mounted fisheye stereo pair, a lens of OCamCalib's model calibrated
 * as a fisheye, and three outside-in cameras with a board on the floor.
 * Then the printed board (the PDF's rectangles, drawn here) must be found
 * whole, and bad input must get messages that say what to do. */
#include "board_render.hpp"
#include "calib_board.hpp"

extern "C" {
#include "geom/mc_rig.h"
#include "test_util.h"
}

#include <opencv2/imgcodecs.hpp>

#include <jansson.h>

#include <fstream>
#include <sstream>
#include <string>

namespace {

std::string tool, tmp;
const double deg = M_PI / 180;

std::string run(const std::string &args, int *status)
{
	static char out[1 << 16];
	std::string cmd = tool + " " + args + " 2>&1";
	*status = mc_test_run(cmd.c_str(), out, sizeof out);
	return out;
}

std::string make_dir(const std::string &name)
{
	std::string d = tmp + "/" + name;
	mkdir(d.c_str(), 0755);
	return d;
}

std::string save_board(const calib_board &b, const std::string &name)
{
	std::string path = tmp + "/" + name + ".json";
	mc_err err = {};
	if (calib_board_save(&b, path.c_str(), &err) < 0)
		std::fprintf(stderr, "%s\n", err.msg);
	return path;
}

calib_board board(int sx, int sy, double square_mm, double marker_mm)
{
	calib_board b;
	b.squares_x = sx, b.squares_y = sy, b.square_m = square_mm / 1000, b.marker_m = marker_mm / 1000;
	mc_err err = {};
	if (calib_board_init(&b, &err) < 0)
		std::fprintf(stderr, "%s\n", err.msg);
	return b;
}

void write_view(const std::string &dir, int i, const cv::Mat &img)
{
	char name[64];
	std::snprintf(name, sizeof name, "/view%03d.png", i);
	cv::imwrite(dir + name, img);
}

/* The worst distance, over a grid of pixels of the truth's valid image,
 * between a pixel and where its true ray lands through the estimate. */
double lens_error(const mc_camera &truth, const mc_camera &est, double max_theta)
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

bool load_rig(const std::string &path, mc_rig *rig)
{
	mc_err err = {};
	if (mc_rig_load(path.c_str(), rig, &err) < 0) {
		std::fprintf(stderr, "%s\n", err.msg);
		return false;
	}
	return true;
}

/* The report's RMS of camera i. */
double report_rms(const std::string &rig_path, int i)
{
	std::string path = rig_path.substr(0, rig_path.size() - 5) + ".report.json";
	json_error_t e;
	json_t *root = json_load_file(path.c_str(), 0, &e);
	double rms = root ? json_real_value(json_object_get(json_array_get(json_object_get(root, "cameras"), i), "rms_px")) : -1;
	json_decref(root);
	return root ? rms : -1;
}

void check_intrinsics(const char *what, const mc_camera &truth, const mc_camera &est, double lens_theta)
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

mc_camera pinhole_truth()
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
std::vector<mc_xform> spread_poses(const calib_board &b, const mc_camera &cam, int n, double reach, double d0, double d1,
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

void test_pinhole()
{
	calib_board b = board(9, 7, 40, 30);
	std::string bpath = save_board(b, "board_pin"), dir = make_dir("pin");
	mc_camera truth = pinhole_truth();
	board_renderer r(&b, truth);
	std::mt19937 rng(1);
	std::vector<mc_xform> poses = spread_poses(b, truth, 36, 0.9, 0.4, 0.65, 45 * deg, 2);
	for (size_t i = 0; i < poses.size(); i++)
		write_view(dir, (int)i, r.render(poses[i], rng));
	int st;
	std::string out = run("--board " + bpath + " --camera cam,pinhole=" + dir + " --out " + tmp + "/pin.json", &st);
	std::printf("%s", out.c_str());
	CHECK_MSG(st == 0, "exit %d", st);
	mc_rig rig;
	if (st != 0 || !load_rig(tmp + "/pin.json", &rig))
		return;
	check_intrinsics("pinhole", truth, rig.cams[0], 40 * deg);
	double rms = report_rms(tmp + "/pin.json", 0);
	CHECK_MSG(rms >= 0 && rms < 0.3, "pinhole RMS %.3f px", rms);
	for (const char *f : {"/pin.report.json", "/pin.coverage-cam.png", "/pin.overlay-cam.png"})
		CHECK_MSG(access((tmp + f).c_str(), R_OK) == 0, "%s missing", f);
}

mc_camera fisheye_truth(const char *name, double cx, double cy)
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

/* A head-mounted pair: two fisheyes 12 cm apart, the right one turned out
 * by 8 degrees; boards in front of the rig, seen by both. */
void test_stereo_fisheye()
{
	calib_board b = board(6, 4, 60, 45);
	std::string bpath = save_board(b, "board_fish"), left_dir = make_dir("left"), right_dir = make_dir("right");
	mc_camera left = fisheye_truth("left", 318.2, 322.9), right = fisheye_truth("right", 321.7, 317.6);
	right.fx = 206, right.fy = 205;
	right.rig_from_cam.R = mc_m3_rot_axis(1, 8 * deg);
	right.rig_from_cam.t = mc_v3(0.12, 0.004, -0.003);
	board_renderer rl(&b, left), rr(&b, right);
	std::mt19937 rng(3);
	/* Poses relative to the left camera, spread out to 70 degrees. */
	std::vector<mc_xform> poses = spread_poses(b, left, 24, 0.72, 0.28, 0.45, 30 * deg, 4);
	mc_xform right_from_rig = mc_xform_inverse(right.rig_from_cam);
	for (size_t i = 0; i < poses.size(); i++) {
		write_view(left_dir, (int)i, rl.render(poses[i], rng));
		write_view(right_dir, (int)i, rr.render(mc_xform_compose(right_from_rig, poses[i]), rng));
	}
	int st;
	std::string out = run("--board " + bpath + " --camera left,equidistant,180=" + left_dir +
				      " --camera right,equidistant,180=" + right_dir + " --out " + tmp + "/stereo.json",
			      &st);
	std::printf("%s", out.c_str());
	CHECK_MSG(st == 0, "exit %d", st);
	mc_rig rig;
	if (st != 0 || !load_rig(tmp + "/stereo.json", &rig))
		return;
	CHECK(rig.kind == MC_RIG_EGOCENTRIC);
	check_intrinsics("fisheye left", left, rig.cams[0], 85 * deg);
	check_intrinsics("fisheye right", right, rig.cams[1], 85 * deg);
	double base = mc_v3_norm(mc_v3_sub(rig.cams[1].rig_from_cam.t, right.rig_from_cam.t));
	CHECK_MSG(base < 0.002, "right camera off by %.4f m", base);
	mc_mat3 dR = mc_m3_mul(mc_m3_transpose(right.rig_from_cam.R), rig.cams[1].rig_from_cam.R);
	double angle = mc_v3_norm(mc_m3_to_rotvec(dR));
	CHECK_MSG(angle < 0.1 * deg, "right camera turned %.4f deg off", angle / deg);
	std::printf("stereo: right camera %.2f mm, %.4f deg from the truth\n", base * 1000, angle / deg);
	for (int i = 0; i < 2; i++) {
		double rms = report_rms(tmp + "/stereo.json", i);
		CHECK_MSG(rms >= 0 && rms < 0.3, "fisheye %d RMS %.3f px", i, rms);
	}
}

/* An OCamCalib-model lens (a polynomial in rho, off-centre), calibrated as
 * an equidistant fisheye with four coefficients. */
void test_ocam_lens()
{
	calib_board b = board(6, 4, 60, 45);
	std::string dir = make_dir("ocam");
	mc_camera truth{};
	std::snprintf(truth.name, sizeof truth.name, "ocam");
	truth.model = MC_CAM_OCAM;
	truth.width = truth.height = 640;
	/* The evaluation rig's lens (calib.json's ocam_poly) at 640 px, off centre:
	 * w(rho) = a0 + a2 rho^2 + a3 rho^3 + a4 rho^4. */
	double s = 640.0 / 256;
	const double pol[] = {81.52990483414433, 0, -0.004317285269898635, 6.361321148859789e-06, -8.948906882522099e-08};
	for (int i = 0; i < 5; i++)
		truth.ocam_pol[i] = pol[i] * std::pow(s, 1 - i);
	truth.ocam_pol_len = 5;
	truth.ocam_xc = 324.6, truth.ocam_yc = 315.2, truth.ocam_c = 1;
	truth.max_theta = 90 * deg;
	truth.rig_from_cam = mc_xform_identity();
	mc_err err = {};
	CHECK_MSG(mc_camera_validate(&truth, &err) == 0, "%s", err.msg);
	board_renderer r(&b, truth);
	std::mt19937 rng(5);
	std::vector<mc_xform> poses = spread_poses(b, truth, 28, 0.8, 0.28, 0.45, 30 * deg, 6);
	for (size_t i = 0; i < poses.size(); i++)
		write_view(dir, (int)i, r.render(poses[i], rng));
	int st;
	std::string out = run("--board " + save_board(b, "board_ocam") + " --camera ocam,equidistant,180=" + dir +
				      " --out " + tmp + "/ocam.json",
			      &st);
	std::printf("%s", out.c_str());
	CHECK_MSG(st == 0, "exit %d", st);
	mc_rig rig;
	if (st != 0 || !load_rig(tmp + "/ocam.json", &rig))
		return;
	const mc_camera &est = rig.cams[0];
	CHECK_MSG(std::hypot(est.cx - truth.ocam_xc, est.cy - truth.ocam_yc) < 1, "ocam centre %.3f %.3f", est.cx, est.cy);
	double lens = lens_error(truth, est, 85 * deg);
	CHECK_MSG(lens < 0.5, "ocam lens off by up to %.3f px", lens);
	double rms = report_rms(tmp + "/ocam.json", 0);
	CHECK_MSG(rms >= 0 && rms < 0.3, "ocam RMS %.3f px", rms);
	std::printf("ocam lens as equidistant: centre off %.3f px, lens off up to %.3f px, RMS %.3f px\n",
		    std::hypot(est.cx - truth.ocam_xc, est.cy - truth.ocam_yc), lens, rms);
}

} // namespace

int main(int argc, char **argv)
{
	(void)argc;
	char build[4096];
	if (!mc_test_build_dir(3, build, sizeof build))
		TEST_SKIP("cannot find the build folder from /proc/self/exe");
	tool = std::string(build) + "/bin/mocap-calibrate";
	if (access(tool.c_str(), X_OK) != 0)
		TEST_SKIP("%s is not built", tool.c_str());
	char dir[] = "/tmp/test_calibrate.XXXXXX";
	if (!mkdtemp(dir))
		TEST_SKIP("mkdtemp failed");
	tmp = dir;
	(void)argv;
	test_pinhole();
	test_stereo_fisheye();
	test_ocam_lens();
	if (mc_test_failures == 0)
		mc_test_run(("rm -rf " + tmp).c_str(), build, sizeof build);
	else
		std::fprintf(stderr, "test_calibrate: files kept in %s\n", tmp.c_str());
	return mc_test_finish("test_calibrate");
}
