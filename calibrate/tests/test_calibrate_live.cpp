/* test_calibrate_live: mocap-calibrate --live against a running mocapd.
 *
 * A head-mounted fisheye pair of known lenses and baseline sees a board
 * moved through 24 poses, each held for 10 frames (1/3 s); the frames are written
 * as numbered PNG files and played by mocapd's files driver (capture only:
 * [tracker] enabled = false, the rig is what is being calibrated).
 * mocap-calibrate maps the daemon's camera rings over the socket, keeps
 * views as the board stands still, and writes the rig, which must match the
 * truth as the folder calibration does (focal length 0.5 %, centre 1 px,
 * lens 0.5 px, baseline 2 mm).  Then --snapshot, and the errors: an unknown
 * camera, no daemon, a folder given with --live. */
#include "calib_fixture.hpp"

extern "C" {
#include "daemon/harness.h"
#include "geom/mc_rig.h"
}

#include <opencv2/imgcodecs.hpp>

#include <string>

namespace {

std::string tool, tmp;

std::string run(const std::string &args, int *status)
{
	static char out[1 << 16];
	*status = mc_test_run((tool + " " + args + " 2>&1").c_str(), out, sizeof out);
	return out;
}

/* Renders the clip: DIR/left/NNNNN.png and DIR/right/NNNNN.png. */
void render_clip(const calib_board &b, const mc_camera &left, const mc_camera &right)
{
	mkdir((tmp + "/left").c_str(), 0755);
	mkdir((tmp + "/right").c_str(), 0755);
	board_renderer rl(&b, left), rr(&b, right);
	std::mt19937 rng(21);
	std::vector<mc_xform> poses = spread_poses(b, left, 24, 0.72, 0.28, 0.45, 30 * deg, 22);
	mc_xform right_from_rig = mc_xform_inverse(right.rig_from_cam);
	int frame = 0;
	for (const mc_xform &p : poses) {
		cv::Mat l = rl.render(p, rng), r = rr.render(mc_xform_compose(right_from_rig, p), rng);
		for (int k = 0; k < 10; k++, frame++) {
			char name[32];
			std::snprintf(name, sizeof name, "/%05d.png", frame);
			cv::imwrite(tmp + "/left" + name, l);
			cv::imwrite(tmp + "/right" + name, r);
		}
	}
}

void test_live(mcd_run *d)
{
	mc_camera left = fisheye_truth("left", 318.2, 322.9), right = fisheye_truth("right", 321.7, 317.6);
	right.rig_from_cam.R = mc_m3_rot_axis(1, 8 * deg);
	right.rig_from_cam.t = mc_v3(0.12, 0.004, -0.003);
	int st;
	std::string out = run("--live --socket " + std::string(d->sock) + " --board " + tmp +
				      "/board.json --camera left,equidistant,180 --camera right,equidistant,180 --views 14 "
				      "--seconds 60 --out " + tmp + "/live.json",
			      &st);
	std::printf("%s", out.c_str());
	CHECK_MSG(st == 0, "--live: exit %d", st);
	CHECK(out.find("seen together") != std::string::npos && out.find("coverage") != std::string::npos);
	mc_rig rig;
	mc_err err = {};
	if (st != 0 || mc_rig_load((tmp + "/live.json").c_str(), &rig, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return;
	}
	check_intrinsics("live left", left, rig.cams[0], 85 * deg);
	check_intrinsics("live right", right, rig.cams[1], 85 * deg);
	double base = mc_v3_norm(mc_v3_sub(rig.cams[1].rig_from_cam.t, right.rig_from_cam.t));
	CHECK_MSG(base < 0.002, "live: right camera off by %.4f m", base);
	CHECK(access((tmp + "/live.views/left").c_str(), F_OK) == 0 && access((tmp + "/live.report.json").c_str(), F_OK) == 0);

	out = run("--live --socket " + std::string(d->sock) + " --board " + tmp +
			  "/board.json --camera left,equidistant --camera right,equidistant --snapshot floor --seconds 20 --out " +
			  tmp + "/snap.json",
		  &st);
	CHECK_MSG(st == 0 && access((tmp + "/snap.views/left/floor.png").c_str(), F_OK) == 0 &&
			  access((tmp + "/snap.views/right/floor.png").c_str(), F_OK) == 0,
		  "--snapshot: exit %d: %s", st, out.c_str());

	out = run("--live --socket " + std::string(d->sock) + " --board " + tmp +
			  "/board.json --camera middle,pinhole --seconds 5 --out " + tmp + "/x.json",
		  &st);
	CHECK_MSG(st == 1 && out.find("no camera 'middle' (it has: left, right)") != std::string::npos, "exit %d: %s", st,
		  out.c_str());
}

} // namespace

int main()
{
	if (!mcd_find_build_up(3))
		TEST_SKIP("mocapd is not built");
	tool = std::string(mcd_build_dir) + "/bin/mocap-calibrate";
	if (access(tool.c_str(), X_OK) != 0)
		TEST_SKIP("%s is not built", tool.c_str());
	char dir[] = "/tmp/test_calibrate_live.XXXXXX";
	if (!mkdtemp(dir))
		TEST_SKIP("mkdtemp failed");
	tmp = dir;
	calib_board b = board(6, 4, 60, 45);
	mc_err err = {};
	CHECK(calib_board_save(&b, (tmp + "/board.json").c_str(), &err) == 0);
	mc_camera left = fisheye_truth("left", 318.2, 322.9), right = fisheye_truth("right", 321.7, 317.6);
	right.rig_from_cam.R = mc_m3_rot_axis(1, 8 * deg);
	right.rig_from_cam.t = mc_v3(0.12, 0.004, -0.003);
	render_clip(b, left, right);

	int st;
	std::string out = run("--live --socket " + tmp + "/none.sock --board " + tmp +
				      "/board.json --camera left,pinhole --out " + tmp + "/x.json",
			      &st);
	CHECK_MSG(st == 1 && out.find("not running") != std::string::npos, "no daemon: exit %d: %s", st, out.c_str());
	out = run("--live --board " + tmp + "/board.json --camera left,pinhole=" + tmp + " --out " + tmp + "/x.json", &st);
	CHECK_MSG(st == 2 && out.find("without a folder") != std::string::npos, "exit %d: %s", st, out.c_str());

	mcd_run d;
	CHECK(mcd_run_init(&d));
	std::string build = mcd_build_dir;
	std::string conf = "[daemon]\nplugin_dir = " + build + "/drivers\n" +
			   "[camera left]\ndriver = files\nloop = true\nrate = 30\npath = " + tmp + "/left\n" +
			   "[camera right]\ndriver = files\nloop = true\nrate = 30\npath = " + tmp + "/right\n" +
			   "[tracker]\nenabled = false\n[socket]\npath = @SOCK@\n";
	mcd_run_config(&d, conf.c_str());
	if (mcd_run_start_ready(&d, nullptr)) {
		test_live(&d);
		mcd_run_cleanup(&d);
	}
	if (mc_test_failures == 0)
		mc_test_run(("rm -rf " + tmp).c_str(), &conf[0], conf.size());
	else
		std::fprintf(stderr, "test_calibrate_live: files kept in %s\n", tmp.c_str());
	return mc_test_finish("test_calibrate_live");
}
