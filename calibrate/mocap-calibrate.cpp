/* mocap-calibrate: camera intrinsics and rig extrinsics from images of a
 * ChArUco board, written as a mocapd rig file with a report beside it
 * (docs/CALIBRATION.md).
 *
 *   mocap-calibrate board --out PREFIX [--squares XxY] [--square-mm S] [--marker-mm M]
 *                   [--dictionary D] [--margin-mm M] [--dpi N]
 *   mocap-calibrate --board BOARD.json --camera NAME,MODEL[,FOV_DEG]=DIR ... --out RIG.json
 *                   [--name RIG] [--kind egocentric|outside-in] [--floor IMAGE] [--k3] [--tangential] [--verbose]
 *
 * Exit codes: 0 done, 1 the calibration failed (the message says what to
 * do), 2 bad command line or input files. */
#include "calib_board.hpp"
#include "calib_live.hpp"
#include "calib_report.hpp"
#include "calib_solve.hpp"

extern "C" {
#include "base/mc_parse.h"
#include "geom/mc_rig.h"
#include "mc_install_paths.h" /* generated: MC_VERSION */
}

#include <opencv2/imgcodecs.hpp>

#include <dirent.h>
#include <getopt.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <cstring>

namespace {

const char *const prog = "mocap-calibrate";

void usage(FILE *out)
{
	std::fprintf(out,
		     "usage: %s board --out PREFIX [--squares XxY] [--square-mm S] [--marker-mm M]\n"
		     "                 [--dictionary D] [--margin-mm M] [--dpi N]\n"
		     "       %s --board BOARD.json --camera NAME,MODEL[,FOV_DEG]=DIR [--camera ...] --out RIG.json\n"
		     "                 [--name RIG] [--kind egocentric|outside-in] [--floor IMAGE] [--k3] [--tangential] [--verbose]\n"
		     "       %s --live [--socket PATH] [--views N] [--seconds S] [--snapshot NAME]\n"
		     "                 --board BOARD.json --camera NAME,MODEL[,FOV_DEG] ... --out RIG.json [...]\n"
		     "MODEL is pinhole or equidistant (fisheye). Images of one instant carry the same file\n"
		     "name in every camera's folder; --live collects them from mocapd's cameras into\n"
		     "RIG.views/CAMERA/. -h/--help, -V/--version. Exit status: 0 done, 1 the calibration\n"
		     "failed, 2 bad command line or input. See mocap-calibrate(1) and docs/CALIBRATION.md.\n",
		     prog, prog, prog);
}

/* -h and -V, as every mocapd program takes them (exit 0). */
[[noreturn]] void help_or_version(int o)
{
	if (o == 'h')
		usage(stdout);
	else
		std::printf("%s %s\n", prog, MC_VERSION);
	std::exit(0);
}

#define HELP_VERSION_OPTS {"help", no_argument, nullptr, 'h'}, {"version", no_argument, nullptr, 'W'}

[[noreturn]] void bad_usage(const char *fmt, const char *arg)
{
	std::fprintf(stderr, "%s: ", prog);
	std::fprintf(stderr, fmt, arg);
	std::fprintf(stderr, "\n");
	usage(stderr);
	std::exit(2);
}

/* ---- board ---------------------------------------------------------------- */

int cmd_board(int argc, char **argv)
{
	calib_board b;
	std::string out;
	double margin_mm = 10, dpi = 300;
	static const option opts[] = {{"out", required_argument, nullptr, 'o'},
				      {"squares", required_argument, nullptr, 's'},
				      {"square-mm", required_argument, nullptr, 'q'},
				      {"marker-mm", required_argument, nullptr, 'm'},
				      {"dictionary", required_argument, nullptr, 'd'},
				      {"margin-mm", required_argument, nullptr, 'g'},
				      {"dpi", required_argument, nullptr, 'p'},
				      HELP_VERSION_OPTS,
				      {nullptr, 0, nullptr, 0}};
	double v;
	for (int o; (o = getopt_long(argc, argv, "hV", opts, nullptr)) != -1;) {
		switch (o) {
		case 'o': out = optarg; break;
		case 's':
			if (std::sscanf(optarg, "%dx%d", &b.squares_x, &b.squares_y) != 2)
				bad_usage("--squares: expected COLUMNSxROWS, e.g. 8x6, got '%s'", optarg);
			break;
		case 'q':
			if (!mc_parse_double(optarg, &v))
				bad_usage("--square-mm: not a number: '%s'", optarg);
			b.square_m = v / 1000;
			break;
		case 'm':
			if (!mc_parse_double(optarg, &v))
				bad_usage("--marker-mm: not a number: '%s'", optarg);
			b.marker_m = v / 1000;
			break;
		case 'd': b.dictionary = optarg; break;
		case 'g':
			if (!mc_parse_double(optarg, &margin_mm) || margin_mm < 0)
				bad_usage("--margin-mm: expected a number of millimetres >= 0, got '%s'", optarg);
			break;
		case 'p':
			if (!mc_parse_double(optarg, &dpi) || dpi < 30 || dpi > 2400)
				bad_usage("--dpi: expected 30..2400, got '%s'", optarg);
			break;
		case 'h':
		case 'V':
		case 'W': help_or_version(o == 'h' ? 'h' : 'V');
		default: usage(stderr); return 2;
		}
	}
	if (out.empty())
		bad_usage("board: --out PREFIX is required%s", "");
	mc_err err = {};
	if (calib_board_init(&b, &err) < 0)
		mc_fail_exit(prog, 2, "%s", err.msg);
	cv::Mat img = calib_board_image(&b, dpi / 0.0254, margin_mm / 1000);
	if (!cv::imwrite(out + ".png", img))
		mc_fail_exit(prog, 1, "%s.png: could not be written", out.c_str());
	if (calib_board_write_pdf(&b, margin_mm / 1000, (out + ".pdf").c_str(), &err) < 0 ||
	    calib_board_save(&b, (out + ".json").c_str(), &err) < 0)
		mc_fail_exit(prog, 1, "%s", err.msg);
	std::printf("wrote %s.pdf (print at 100 %%: %.0f x %.0f mm), %s.png (%d x %d at %.0f dpi), %s.json "
		    "(for --board)\n",
		    out.c_str(), (b.squares_x * b.square_m + 2 * margin_mm / 1000) * 1000,
		    (b.squares_y * b.square_m + 2 * margin_mm / 1000) * 1000, out.c_str(), img.cols, img.rows, dpi,
		    out.c_str());
	return 0;
}

/* ---- calibration ---------------------------------------------------------- */

struct camera_arg {
	calib_cam cam;
	std::string dir;
};

/* NAME,MODEL[,FOV_DEG]=DIR; without =DIR for --live (checked later). */
camera_arg parse_camera(const char *arg)
{
	camera_arg c;
	const char *eq = std::strchr(arg, '=');
	if (eq == arg || (eq && !eq[1]))
		bad_usage("--camera: expected NAME,MODEL[,FOV_DEG]=DIR, got '%s'", arg);
	c.dir = eq ? eq + 1 : "";
	std::string spec(arg, eq ? eq : arg + std::strlen(arg));
	std::vector<std::string> parts;
	for (size_t start = 0;;) {
		size_t comma = spec.find(',', start);
		parts.push_back(spec.substr(start, comma - start));
		if (comma == std::string::npos)
			break;
		start = comma + 1;
	}
	if (parts.size() < 2 || parts.size() > 3)
		bad_usage("--camera: expected NAME,MODEL[,FOV_DEG]=DIR, got '%s'", arg);
	c.cam.name = parts[0];
	mc_err err = {};
	if (mc_rig_check_camera_name(c.cam.name.c_str(), "--camera", &err) < 0)
		mc_fail_exit(prog, 2, "%s", err.msg);
	if (mc_camera_model_parse(parts[1].c_str(), &c.cam.model) < 0 || c.cam.model == MC_CAM_OCAM)
		bad_usage("--camera: MODEL must be pinhole or equidistant, got '%s'", parts[1].c_str());
	if (parts.size() == 3 && (!mc_parse_double(parts[2].c_str(), &c.cam.fov_deg) || c.cam.fov_deg <= 0 ||
				  c.cam.fov_deg >= 360))
		bad_usage("--camera: FOV_DEG must be a field of view in degrees (0, 360), got '%s'", parts[2].c_str());
	return c;
}

bool is_image_name(const std::string &n)
{
	static const char *const exts[] = {".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff"};
	std::string lower = n;
	std::transform(lower.begin(), lower.end(), lower.begin(), ::tolower);
	for (const char *e : exts)
		if (lower.size() > std::strlen(e) && lower.compare(lower.size() - std::strlen(e), std::string::npos, e) == 0)
			return true;
	return false;
}

std::vector<std::string> list_images(const std::string &dir)
{
	DIR *d = opendir(dir.c_str());
	if (!d)
		mc_fail_exit(prog, 2, "%s: %s", dir.c_str(), std::strerror(errno));
	std::vector<std::string> names;
	while (dirent *e = readdir(d))
		if (e->d_name[0] != '.' && is_image_name(e->d_name))
			names.push_back(e->d_name);
	closedir(d);
	std::sort(names.begin(), names.end());
	if (names.empty())
		mc_fail_exit(prog, 2, "%s: no images (.png, .jpg, .bmp, .pgm, .ppm, .tif) in this folder", dir.c_str());
	return names;
}

/* Loads a camera's images and finds the board in each. All images of one
 * camera must have one size; unreadable files are views with a reason. */
void load_views(camera_arg &c, const calib_board &board, std::vector<cv::Mat> &images, bool verbose)
{
	std::string first;
	for (const std::string &n : list_images(c.dir)) {
		std::string path = c.dir + "/" + n;
		calib_view v;
		v.name = n.substr(0, n.rfind('.'));
		cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
		if (img.empty()) {
			v.why = "not an image that could be read";
		} else if (first.empty()) {
			first = path;
			c.cam.width = img.cols, c.cam.height = img.rows;
		} else if (img.cols != c.cam.width || img.rows != c.cam.height) {
			mc_fail_exit(prog, 2,
				     "%s is %dx%d but %s is %dx%d: one camera's images must all have its size "
				     "(resize none; use one folder per camera and resolution)",
				     path.c_str(), img.cols, img.rows, first.c_str(), c.cam.width, c.cam.height);
		}
		if (!img.empty())
			v.corners = calib_board_detect(&board, img);
		if (verbose)
			std::fprintf(stderr, "%s: %d markers, %zu corners\n", path.c_str(), v.corners.markers,
				     v.corners.ids.size());
		c.cam.views.push_back(v);
		images.push_back(img);
	}
	if (first.empty())
		mc_fail_exit(prog, 2, "%s: none of the images could be read", c.dir.c_str());
}

void print_camera(const calib_cam &c)
{
	std::printf("%s: %s %dx%d, %d of %zu views used, RMS %.3f px, coverage %d/16\n", c.name.c_str(),
		    mc_camera_model_name(c.model), c.width, c.height, c.used_views, c.views.size(), c.rms,
		    calib_coverage_cells(c));
	std::printf("  fx %.3f fy %.3f cx %.3f cy %.3f k [%.6g %.6g %.6g %.6g %.6g] field %.1f deg\n", c.cam.fx,
		    c.cam.fy, c.cam.cx, c.cam.cy, c.cam.k[0], c.cam.k[1], c.cam.k[2], c.cam.k[3], c.cam.k[4],
		    2 * c.cam.max_theta * 180 / M_PI);
	for (const calib_view &v : c.views)
		if (!v.used)
			std::printf("  view %s not used: %s\n", v.name.c_str(), v.why.c_str());
}

struct calibrate_args {
	std::string board, out, name = "calibrated", floor;
	mc_rig_kind kind = MC_RIG_EGOCENTRIC;
	bool kind_given = false, k3 = false, tangential = false, verbose = false;
	std::vector<camera_arg> cams;
	bool live = false;
	calib_live_options live_opt;
};

calibrate_args parse_calibrate(int argc, char **argv)
{
	calibrate_args a;
	static const option opts[] = {{"board", required_argument, nullptr, 'b'},
				      {"camera", required_argument, nullptr, 'c'},
				      {"out", required_argument, nullptr, 'o'},
				      {"name", required_argument, nullptr, 'n'},
				      {"kind", required_argument, nullptr, 'k'},
				      {"floor", required_argument, nullptr, 'f'},
				      {"k3", no_argument, nullptr, '3'},
				      {"tangential", no_argument, nullptr, 't'},
				      {"verbose", no_argument, nullptr, 'v'},
				      {"live", no_argument, nullptr, 'L'},
				      {"socket", required_argument, nullptr, 'S'},
				      {"views", required_argument, nullptr, 'V'},
				      {"seconds", required_argument, nullptr, 'T'},
				      {"snapshot", required_argument, nullptr, 'P'},
				      HELP_VERSION_OPTS,
				      {nullptr, 0, nullptr, 0}};
	double v;
	/* 'V' is --views here: -V for the version is the short option, which
	 * getopt reports as 'V' too, so --views is told apart by its index. */
	int index = -1;
	for (int o; (o = getopt_long(argc, argv, "hV", opts, &index)) != -1; index = -1) {
		if (o == 'V' && index < 0)
			help_or_version('V');
		switch (o) {
		case 'L': a.live = true; break;
		case 'S': a.live_opt.socket = optarg; break;
		case 'V':
			if (!mc_parse_double(optarg, &v) || v < 4 || v > 500 || v != std::floor(v))
				bad_usage("--views: expected a whole number 4..500, got '%s'", optarg);
			a.live_opt.views = (int)v;
			break;
		case 'T':
			if (!mc_parse_double(optarg, &a.live_opt.seconds) || a.live_opt.seconds <= 0)
				bad_usage("--seconds: expected a positive number, got '%s'", optarg);
			break;
		case 'P': a.live_opt.snapshot = optarg; break;
		case 'b': a.board = optarg; break;
		case 'c': a.cams.push_back(parse_camera(optarg)); break;
		case 'o': a.out = optarg; break;
		case 'n': a.name = optarg; break;
		case 'k':
			if (std::strcmp(optarg, "egocentric") && std::strcmp(optarg, "outside-in"))
				bad_usage("--kind: egocentric or outside-in, got '%s'", optarg);
			a.kind = std::strcmp(optarg, "egocentric") ? MC_RIG_OUTSIDE_IN : MC_RIG_EGOCENTRIC;
			a.kind_given = true;
			break;
		case 'f': a.floor = optarg; break;
		case '3': a.k3 = true; break;
		case 't': a.tangential = true; break;
		case 'v': a.verbose = true; break;
		case 'h':
		case 'W': help_or_version(o == 'h' ? 'h' : 'V');
		default: usage(stderr); std::exit(2);
		}
	}
	if (optind < argc)
		bad_usage("unexpected argument '%s'", argv[optind]);
	if (a.board.empty() || a.out.empty() || a.cams.empty())
		bad_usage("--board, --camera and --out are required%s", "");
	if ((int)a.cams.size() > MC_MAX_CAMERAS)
		bad_usage("at most 8 cameras in one rig%s", "");
	if (a.out.size() < 6 || a.out.compare(a.out.size() - 5, 5, ".json") != 0)
		bad_usage("--out: the rig file's name must end in .json, got '%s'", a.out.c_str());
	/* A board on the floor defines a world frame: an outside-in rig. */
	if (!a.kind_given && !a.floor.empty())
		a.kind = MC_RIG_OUTSIDE_IN;
	/* Live: the views go to RIG.views/CAMERA/ and are calibrated from there. */
	a.live_opt.dir = a.out.substr(0, a.out.size() - 5) + ".views";
	for (camera_arg &c : a.cams) {
		if (a.live && !c.dir.empty())
			bad_usage("--camera: with --live, give NAME,MODEL[,FOV_DEG] without a folder, got '=%s'", c.dir.c_str());
		if (!a.live && c.dir.empty())
			bad_usage("--camera %s: expected NAME,MODEL[,FOV_DEG]=DIR (or --live)", c.cam.name.c_str());
		if (a.live)
			c.dir = a.live_opt.dir + "/" + c.cam.name;
	}
	if (!a.live && (!a.live_opt.socket.empty() || !a.live_opt.snapshot.empty() || a.live_opt.seconds > 0))
		bad_usage("--socket, --seconds and --snapshot go with --live%s", "");
	return a;
}

/* Collects views from mocapd; returns 1 after a snapshot (nothing more
 * to do), 0 when the views are there to calibrate. */
int collect_live(calibrate_args &a, const calib_board &board)
{
	std::vector<calib_cam> cams;
	for (camera_arg &c : a.cams) {
		c.cam.pinhole_k3 = a.k3;
		c.cam.pinhole_tangential = a.tangential;
		cams.push_back(c.cam);
	}
	mc_err err = {};
	if (calib_live_collect(board, cams, a.live_opt, &err) < 0)
		mc_fail_exit(prog, 1, "%s", err.msg);
	if (!a.live_opt.snapshot.empty()) {
		std::printf("saved %s.png of every camera that saw the board, in %s/\n", a.live_opt.snapshot.c_str(),
			    a.live_opt.dir.c_str());
		return 1;
	}
	for (camera_arg &c : a.cams)
		if (access(c.dir.c_str(), F_OK) != 0)
			mc_fail_exit(prog, 1,
				     "camera %s: no view was kept (the board was never seen held still): hold the "
				     "whole board still in front of it for a moment, in good light",
				     c.cam.name.c_str());
	return 0;
}

int cmd_calibrate(int argc, char **argv)
{
	calibrate_args a = parse_calibrate(argc, argv);
	mc_err err = {};
	calib_board board;
	if (calib_board_load(a.board.c_str(), &board, &err) < 0)
		mc_fail_exit(prog, 2, "%s", err.msg);
	calib_options opt;
	opt.floor_view = a.floor;
	opt.verbose = a.verbose;
	if (a.live && collect_live(a, board) != 0)
		return 0; /* a snapshot: nothing to calibrate yet */
	std::vector<calib_cam> cams;
	std::vector<std::vector<cv::Mat>> images(a.cams.size());
	for (size_t i = 0; i < a.cams.size(); i++) {
		for (size_t j = 0; j < i; j++)
			if (a.cams[j].cam.name == a.cams[i].cam.name)
				bad_usage("--camera: the name '%s' is given twice", a.cams[i].cam.name.c_str());
		a.cams[i].cam.pinhole_k3 = a.k3;
		a.cams[i].cam.pinhole_tangential = a.tangential;
		load_views(a.cams[i], board, images[i], a.verbose);
		cams.push_back(a.cams[i].cam);
	}
	for (calib_cam &c : cams)
		if (calib_intrinsics(&c, &opt, &err) < 0)
			mc_fail_exit(prog, 1, "%s", err.msg);
	if (calib_extrinsics(cams, &opt, &err) < 0)
		mc_fail_exit(prog, 1, "%s", err.msg);
	mc_rig rig = {};
	std::snprintf(rig.name, sizeof rig.name, "%s", a.name.c_str());
	rig.kind = a.kind;
	rig.ncams = (int)cams.size();
	for (size_t i = 0; i < cams.size(); i++)
		rig.cams[i] = cams[i].cam;
	if (mc_rig_save(&rig, a.out.c_str(), &err) < 0)
		mc_fail_exit(prog, 1, "%s", err.msg);
	calib_report_files files;
	if (calib_report_write(a.out.substr(0, a.out.size() - 5), board, cams, images, &files, &err) < 0)
		mc_fail_exit(prog, 1, "%s", err.msg);
	for (const calib_cam &c : cams)
		print_camera(c);
	for (size_t i = 0; i < cams.size(); i++)
		for (size_t j = i + 1; j < cams.size(); j++)
			std::printf("%s - %s: %.4f m apart\n", cams[i].name.c_str(), cams[j].name.c_str(),
				    mc_v3_norm(mc_v3_sub(cams[i].cam.rig_from_cam.t, cams[j].cam.rig_from_cam.t)));
	std::printf("wrote %s, %s", a.out.c_str(), files.json.c_str());
	for (const std::string &f : files.images)
		std::printf(", %s", f.c_str());
	std::printf("\n");
	return 0;
}

} // namespace

int main(int argc, char **argv)
{
	if (argc > 1 && std::strcmp(argv[1], "board") == 0)
		return cmd_board(argc - 1, argv + 1);
	return cmd_calibrate(argc, argv);
}
