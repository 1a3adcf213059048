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
#include "calib_fixture.hpp"

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

void write_view(const std::string &dir, int i, const cv::Mat &img)
{
	char name[64];
	std::snprintf(name, sizeof name, "/view%03d.png", i);
	cv::imwrite(dir + name, img);
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

/* Renders the board at `poses` through cam into the folder NAME. */
std::string views_dir(const std::string &name, const calib_board &b, const mc_camera &cam,
		      const std::vector<mc_xform> &poses)
{
	std::string dir = make_dir(name);
	board_renderer r(&b, cam);
	std::mt19937 rng(11);
	for (size_t i = 0; i < poses.size(); i++)
		write_view(dir, (int)i, r.render(poses[i], rng));
	return dir;
}

/* Renders the board at `poses` through truth, calibrates that folder as
 * camera NAME of model `model` ("pinhole", "equidistant,180") and loads
 * the rig NAME.json. */
bool calibrate_views(const calib_board &b, const mc_camera &truth, const std::vector<mc_xform> &poses,
		     const std::string &name, const std::string &model, mc_rig *rig)
{
	std::string dir = views_dir(name, b, truth, poses);
	int st;
	std::string out = run("--board " + save_board(b, "board_" + name) + " --camera " + name + "," + model + "=" + dir +
				      " --out " + tmp + "/" + name + ".json",
			      &st);
	std::printf("%s", out.c_str());
	CHECK_MSG(st == 0, "%s: exit %d", name.c_str(), st);
	return st == 0 && load_rig(tmp + "/" + name + ".json", rig);
}

void test_pinhole()
{
	calib_board b = board(9, 7, 40, 30);
	mc_camera truth = pinhole_truth();
	mc_rig rig;
	if (!calibrate_views(b, truth, spread_poses(b, truth, 36, 0.9, 0.4, 0.65, 45 * deg, 2), "pin", "pinhole", &rig))
		return;
	check_intrinsics("pinhole", truth, rig.cams[0], 40 * deg);
	double rms = report_rms(tmp + "/pin.json", 0);
	CHECK_MSG(rms >= 0 && rms < 0.3, "pinhole RMS %.3f px", rms);
	for (const char *f : {"/pin.report.json", "/pin.coverage-pin.png", "/pin.overlay-pin.png"})
		CHECK_MSG(access((tmp + f).c_str(), R_OK) == 0, "%s missing", f);
}

/* A head-mounted pair: two fisheyes 12 cm apart, the right one turned out
 * by 8 degrees; boards in front of the rig, seen by both, two of the sets
 * mixed up. */
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
		/* Views 3 and 4 of the right camera swapped: two sets whose images
		 * were not taken at one instant, to be found and left out. */
		size_t j = i == 3 ? 4 : (i == 4 ? 3 : i);
		write_view(right_dir, (int)i, rr.render(mc_xform_compose(right_from_rig, poses[j]), rng));
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
	CHECK_MSG(out.find("view view003 not used: with camera left's view") != std::string::npos &&
			  out.find("view view004 not used: with camera left's view") != std::string::npos,
		  "the swapped views were not found");
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
	mc_rig rig;
	if (!calibrate_views(b, truth, spread_poses(b, truth, 28, 0.8, 0.28, 0.45, 30 * deg, 6), "ocam", "equidistant,180",
			     &rig))
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

/* Three cameras over a room, 2 m up, looking at its middle; each sees
 * the board close up for its lens, all see it in the middle of the room,
 * and it lies on the floor once: the rig's world frame. */
mc_camera room_camera(int i)
{
	mc_camera c = pinhole_truth();
	std::snprintf(c.name, sizeof c.name, "cam%d", i);
	c.width = 800, c.height = 600;
	c.fx = 583 + 6 * i, c.fy = 581 + 4 * i, c.cx = 402.5 - 3 * i, c.cy = 297.25 + 2 * i;
	c.k[0] = -0.12 + 0.03 * i, c.k[1] = 0.05;
	double a = (i - 1) * 45 * deg;
	mc_vec3 pos = mc_v3(2.0 * std::cos(a), 2.0 * std::sin(a), 2.0), target = mc_v3(0.2, 0, 0.7);
	mc_vec3 z = mc_v3_normalize(mc_v3_sub(target, pos));
	mc_vec3 x = mc_v3_normalize(mc_v3_cross(z, mc_v3(0, 0, 1))), y = mc_v3_cross(z, x);
	for (int r = 0; r < 3; r++)
		c.rig_from_cam.R.m[r][0] = mc_v3_get(x, r), c.rig_from_cam.R.m[r][1] = mc_v3_get(y, r),
		c.rig_from_cam.R.m[r][2] = mc_v3_get(z, r);
	c.rig_from_cam.t = pos;
	return c;
}

void test_outside_in()
{
	calib_board b = board(8, 6, 110, 80, "4x4_50");
	std::string bpath = save_board(b, "board_room");
	std::vector<mc_camera> truth;
	std::vector<std::string> dirs;
	std::mt19937 rng(7);
	/* The board in the middle of the room, as the middle camera sees it. */
	mc_camera mid = room_camera(1);
	std::vector<mc_xform> shared = spread_poses(b, mid, 8, 0.3, 2.0, 2.6, 25 * deg, 8);
	/* On the floor, face up, its first corner away from the world's origin. */
	mc_xform world_from_floor = mc_xform_identity();
	world_from_floor.R.m[1][1] = world_from_floor.R.m[2][2] = -1;
	world_from_floor.t = mc_v3(-0.3, 0.3, 0);
	std::string args = "--board " + bpath + " --floor floor --out " + tmp + "/room.json";
	for (int i = 0; i < 3; i++) {
		truth.push_back(room_camera(i));
		dirs.push_back(make_dir("room" + std::to_string(i)));
		board_renderer r(&b, truth[i]);
		mc_xform cam_from_world = mc_xform_inverse(truth[i].rig_from_cam);
		std::vector<mc_xform> near = spread_poses(b, truth[i], 16, 0.9, 1.1, 1.6, 35 * deg, 10 + i);
		for (size_t k = 0; k < near.size(); k++)
			write_view(dirs[i], 100 * (i + 1) + (int)k, r.render(near[k], rng));
		for (size_t k = 0; k < shared.size(); k++)
			write_view(dirs[i], (int)k,
				   r.render(mc_xform_compose(cam_from_world, mc_xform_compose(mid.rig_from_cam, shared[k])), rng));
		cv::imwrite(dirs[i] + "/floor.png", r.render(mc_xform_compose(cam_from_world, world_from_floor), rng));
		args += " --camera cam" + std::to_string(i) + ",pinhole=" + dirs[i];
	}
	int st;
	std::string out = run(args, &st);
	std::printf("%s", out.c_str());
	CHECK_MSG(st == 0, "exit %d", st);
	mc_rig rig;
	if (st != 0 || !load_rig(tmp + "/room.json", &rig))
		return;
	CHECK(rig.kind == MC_RIG_OUTSIDE_IN && rig.ncams == 3);
	for (int i = 0; i < 3 && i < rig.ncams; i++) {
		char what[32];
		std::snprintf(what, sizeof what, "room cam%d", i);
		check_intrinsics(what, truth[i], rig.cams[i], 40 * deg);
		/* The floor frame is the board's, flipped to z up: floor_from_board. */
		mc_xform floor_from_board = mc_xform_identity();
		floor_from_board.R.m[1][1] = floor_from_board.R.m[2][2] = -1;
		mc_xform expect = mc_xform_compose(floor_from_board, mc_xform_compose(mc_xform_inverse(world_from_floor),
											    truth[i].rig_from_cam));
		double off = mc_v3_norm(mc_v3_sub(rig.cams[i].rig_from_cam.t, expect.t));
		double turn = mc_v3_norm(mc_m3_to_rotvec(mc_m3_mul(mc_m3_transpose(expect.R), rig.cams[i].rig_from_cam.R)));
		CHECK_MSG(off < 0.005 && turn < 0.1 * deg, "%s: %.2f mm, %.3f deg off in the floor frame", what,
			  off * 1000, turn / deg);
		std::printf("%s: %.2f mm, %.4f deg from the truth in the floor frame\n", what, off * 1000, turn / deg);
	}
}

/* The PDF's rectangles, filled here at 2 px per point, and the PNG: each
 * must show the whole board. */
void test_board_print()
{
	calib_board b = board(7, 5, 40, 30);
	std::string prefix = tmp + "/print";
	int st;
	std::string out = run("board --out " + prefix + " --squares 7x5 --square-mm 40 --marker-mm 30", &st);
	CHECK_MSG(st == 0, "board: exit %d: %s", st, out.c_str());
	std::ifstream pdf(prefix + ".pdf");
	std::string line;
	double page_w = 0, page_h = 0;
	std::vector<cv::Rect2d> rects;
	while (std::getline(pdf, line)) {
		size_t mb = line.find("/MediaBox [0 0 ");
		if (mb != std::string::npos)
			std::sscanf(line.c_str() + mb + 15, "%lf %lf", &page_w, &page_h);
		double x, y, w, h;
		char op[4];
		if (std::sscanf(line.c_str(), "%lf %lf %lf %lf %3s", &x, &y, &w, &h, op) == 5 && std::string(op) == "re")
			rects.push_back(cv::Rect2d(x, y, w, h));
	}
	CHECK_NEAR(page_w, (0.28 + 0.02) / 0.0254 * 72, 0.01); /* 7 x 40 mm and 10 mm margins, in points */
	cv::Mat page((int)(2 * page_h), (int)(2 * page_w), CV_8U, cv::Scalar(255));
	for (const cv::Rect2d &r : rects)
		cv::rectangle(page, cv::Point2d(2 * r.x, 2 * (page_h - r.y - r.height)),
			      cv::Point2d(2 * (r.x + r.width), 2 * (page_h - r.y)), cv::Scalar(0), cv::FILLED, cv::LINE_AA, 0);
	calib_corners from_pdf = calib_board_detect(&b, page);
	CHECK_MSG(from_pdf.ids.size() == 24, "PDF: %zu of 24 corners found", from_pdf.ids.size());
	calib_corners from_png = calib_board_detect(&b, cv::imread(prefix + ".png", cv::IMREAD_GRAYSCALE));
	CHECK_MSG(from_png.ids.size() == 24, "PNG: %zu of 24 corners found", from_png.ids.size());
	/* The square size: 40 mm is 113.4 points, corner to corner. */
	if (from_pdf.ids.size() == 24) {
		int a = -1, c = -1;
		for (size_t i = 0; i < 24; i++)
			a = from_pdf.ids[i] == 0 ? (int)i : a, c = from_pdf.ids[i] == 1 ? (int)i : c;
		CHECK_NEAR(cv::norm(from_pdf.px[a] - from_pdf.px[c]) / 2, 0.04 / 0.0254 * 72, 0.5);
	}
	CHECK(run("board --out " + prefix + " --squares 40x40", &st).find("dictionary") != std::string::npos && st == 2);
	CHECK(run("board --out " + prefix + " --square-mm 30 --marker-mm 30", &st).find("marker_mm") != std::string::npos &&
	      st == 2);
}

void expect_failure(const std::string &args, int code, const char *needle)
{
	int st;
	std::string out = run(args, &st);
	CHECK_MSG(st == code && out.find(needle) != std::string::npos, "'%s': exit %d, expected %d and '%s' in: %s",
		  args.c_str(), st, code, needle, out.c_str());
}

void test_bad_input()
{
	calib_board b = board(7, 5, 40, 30);
	std::string bpath = save_board(b, "board_bad"), out = " --out " + tmp + "/bad.json";
	mc_camera cam = pinhole_truth();
	cam.width = 320, cam.height = 240, cam.fx = 260, cam.fy = 258, cam.cx = 160, cam.cy = 120;
	std::mt19937 rng(12);
	/* No board: the room alone. */
	std::vector<mc_xform> away(5, board_pose_along(b, mc_v3(0, 0, -1), 1, 0, 0, 0));
	expect_failure("--board " + bpath + " --camera c,pinhole=" + views_dir("blank", b, cam, away) + out, 1,
		       "found in 0 of 5 images");
	/* Too few views. */
	std::vector<mc_xform> two = spread_poses(b, cam, 2, 0.3, 0.5, 0.6, 20 * deg, 13);
	expect_failure("--board " + bpath + " --camera c,pinhole=" + views_dir("two", b, cam, two) + out, 1,
		       "at least 4 needed");
	/* Every view in the top-left corner (a 640x480 camera). */
	mc_camera wide = pinhole_truth();
	std::vector<mc_xform> corner;
	for (int i = 0; i < 6; i++) {
		mc_vec3 ray;
		mc_camera_unproject(&wide, 100 + 4 * i, 80 + 3 * i, &ray);
		corner.push_back(board_pose_along(b, ray, 0.9 + 0.03 * i, 0.1 * i, -0.05 * i, 0));
	}
	expect_failure("--board " + bpath + " --camera c,pinhole=" + views_dir("corner", b, wide, corner) + out, 1,
		       "of 16 parts of the image");
	/* Mixed sizes. */
	std::string mixed = views_dir("mixed", b, cam, two);
	cv::imwrite(mixed + "/small.png", cv::Mat(100, 100, CV_8U, cv::Scalar(128)));
	expect_failure("--board " + bpath + " --camera c,pinhole=" + mixed + out, 2, "must all have its size");
	/* Command line and files. */
	expect_failure("--board " + tmp + "/none.json --camera c,pinhole=" + mixed + out, 2, "none.json");
	std::ofstream(tmp + "/badboard.json") << "{\"squares\": [7, 5], \"square_mm\": 40}";
	expect_failure("--board " + tmp + "/badboard.json --camera c,pinhole=" + mixed + out, 2, "marker_mm");
	expect_failure("--board " + bpath + " --camera c,fisheye=" + mixed + out, 2, "pinhole or equidistant");
	expect_failure("--board " + bpath + " --camera c=" + mixed + out, 2, "NAME,MODEL");
	expect_failure("--board " + bpath + " --camera c,pinhole=" + tmp + "/nowhere" + out, 2, "nowhere");
	expect_failure("--board " + bpath + " --camera c,pinhole=" + mixed + " --out " + tmp + "/rig.txt", 2, ".json");
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
	test_outside_in();
	test_board_print();
	test_bad_input();
	if (mc_test_failures == 0)
		mc_test_run(("rm -rf " + tmp).c_str(), build, sizeof build);
	else
		std::fprintf(stderr, "test_calibrate: files kept in %s\n", tmp.c_str());
	return mc_test_finish("test_calibrate");
}
