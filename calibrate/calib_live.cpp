/* calib_live: views from mocapd's camera rings. */
#include "calib_live.hpp"

extern "C" {
#include "base/mc_time.h"
#include "image/mc_image.h"
#include "ring/mc_ring.h"
}

#include "mocap.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace {

std::atomic<bool> stop_asked{false};

void on_signal(int) { stop_asked = true; }

/* A board held still: the same corners within this many pixels (mean)
 * between looks 0.1 s apart. */
const double still_px = 1.0;
/* A set counts as a new board pose when its corners moved this far (mean)
 * from the last kept set's. */
const double moved_px = 20;
const int grid = 8;

struct live_cam {
	calib_cam cam;           /* views kept so far, for the running RMS */
	mc_ring *ring = nullptr;
	mc_ring_cursor cursor{};
	std::vector<uint8_t> buf, rgb;
	cv::Mat grey;
	calib_corners now, before, earlier, last_kept; /* this look, the one before, the one before that */
	bool fresh = false;      /* a new frame in this look */
	int cells[grid * grid] = {}; /* corners kept in each cell of a grid x grid grid over the image */
	std::string rms = "-";   /* of the views so far, at rms_views views */
	int rms_views = -1;
};

/* The mean distance between the corners two detections share; infinity
 * when they share fewer than half. */
double mean_motion(const calib_corners &a, const calib_corners &b)
{
	double sum = 0;
	int n = 0;
	for (size_t i = 0; i < a.ids.size(); i++)
		for (size_t j = 0; j < b.ids.size(); j++)
			if (a.ids[i] == b.ids[j]) {
				sum += cv::norm(a.px[i] - b.px[j]);
				n++;
			}
	return 2 * n < (int)std::max(a.ids.size(), b.ids.size()) || n == 0 ? INFINITY : sum / n;
}

void unmap_rings(std::vector<live_cam> &cams)
{
	for (live_cam &lc : cams)
		if (lc.ring) {
			mc_ring_close(lc.ring);
			lc.ring = nullptr;
		}
}

/* Maps the rings of the cameras wanted.  Returns 0, 1 when a camera is not
 * offered (yet: the daemon offers a camera's ring once it has opened it),
 * or -1 with err. */
int map_rings(mocap_client *c, std::vector<live_cam> &cams, mc_err *err)
{
	mocap_ring rings[MOCAP_MAX_RINGS];
	int n = mocap_get_rings(c, rings, MOCAP_MAX_RINGS);
	if (n < 0)
		return mc_err_set(err, "cannot get the camera rings from mocapd: %s", mocap_errmsg());
	std::string offered;
	int rc = 0;
	for (int i = 0; i < n; i++) {
		offered += std::string(offered.empty() ? "" : ", ") + rings[i].camera;
		for (live_cam &lc : cams)
			if (rc == 0 && lc.cam.name == rings[i].camera && !lc.ring) {
				lc.ring = mc_ring_map(rings[i].fd, err);
				if (!lc.ring)
					rc = mc_err_prefix(err, "camera %s", rings[i].camera);
				else
					lc.cursor = mc_ring_cursor_now(lc.ring), lc.buf.resize(mc_ring_slot_bytes(lc.ring));
			}
		close(rings[i].fd);
	}
	for (live_cam &lc : cams)
		if (rc == 0 && !lc.ring) {
			mc_err_set(err, "mocapd has no camera '%s' (it has: %s)", lc.cam.name.c_str(),
				   offered.empty() ? "none" : offered.c_str());
			rc = 1;
		}
	if (rc != 0)
		unmap_rings(cams);
	return rc;
}

/* Waits up to 10 s for every camera's ring: a daemon that has just started
 * offers a camera once it has opened it. */
int wait_for_rings(mocap_client *c, std::vector<live_cam> &cams, mc_err *err)
{
	uint64_t give_up = mc_now_ns() + 10 * MC_NS_PER_S;
	int rc;
	while ((rc = map_rings(c, cams, err)) == 1 && mc_now_ns() < give_up && !stop_asked)
		mc_sleep_until_ns(mc_now_ns() + 250 * MC_NS_PER_MS);
	return rc == 0 ? 0 : -1;
}

/* The newest frame of a camera as grey, and the board in it. */
void look(live_cam &lc, const calib_board &board, mc_image_conv *conv)
{
	mc_ring_meta meta;
	mc_err err = {};
	lc.fresh = false;
	if (mc_ring_read_latest(lc.ring, &lc.cursor, lc.buf.data(), lc.buf.size(), &meta, &err) != MC_RING_FRAME)
		return;
	lc.rgb.resize((size_t)meta.width * meta.height * 3);
	mc_image_frame f = {meta.pixfmt, meta.width, meta.height, meta.stride, lc.buf.data(), (size_t)meta.bytesused};
	if (mc_image_to_rgb24(conv, &f, lc.rgb.data(), lc.rgb.size(), &err) < 0) {
		std::fprintf(stderr, "mocap-calibrate: camera %s: %s\n", lc.cam.name.c_str(), err.msg);
		return;
	}
	cv::Mat rgb((int)meta.height, (int)meta.width, CV_8UC3, lc.rgb.data());
	cv::cvtColor(rgb, lc.grey, cv::COLOR_RGB2GRAY);
	lc.cam.width = (int)meta.width, lc.cam.height = (int)meta.height;
	lc.earlier = lc.before;
	lc.before = lc.now;
	lc.now = calib_board_detect(&board, lc.grey);
	lc.fresh = true;
}

/* The board held still over the last three looks (0.2 s): then frames of
 * cameras that are not synchronised, or whose clocks are offset by less
 * than that, show the same board pose. */
bool still(const live_cam &lc, int min_corners)
{
	return lc.fresh && (int)lc.now.ids.size() >= min_corners && mean_motion(lc.now, lc.before) < still_px &&
	       mean_motion(lc.before, lc.earlier) < still_px;
}

/* Corners of this detection in grid cells that hold fewer than two views. */
int novelty(const live_cam &lc)
{
	bool counted[grid * grid] = {};
	int n = 0;
	for (const cv::Point2f &q : lc.now.px) {
		int cell = calib_grid_cell(q, lc.cam.width, lc.cam.height, grid);
		if (lc.cells[cell] < 2 && !counted[cell])
			counted[cell] = true, n++;
	}
	return n;
}

class collector {
public:
	collector(const calib_board &board, const calib_live_options &opt) : board_(board), opt_(opt) {}

	int run(std::vector<live_cam> &cams, mc_err *err);

private:
	const calib_board &board_;
	const calib_live_options &opt_;
	int sets_ = 0, shared_ = 0;
	uint64_t last_kept_ns_ = 0, last_print_ns_ = 0;
	std::string last_line_;

	bool keep_set(std::vector<live_cam> &cams, uint64_t now);
	int save(std::vector<live_cam> &cams, const std::string &name, mc_err *err);
	bool done(const std::vector<live_cam> &cams) const;
	void progress(std::vector<live_cam> &cams, bool final);
};

/* Whether the still cameras' views are worth a new set. */
bool collector::keep_set(std::vector<live_cam> &cams, uint64_t now)
{
	int seeing = 0, adds = 0;
	bool moved = true;
	for (live_cam &lc : cams) {
		if (!still(lc, opt_.solve.min_corners))
			continue;
		seeing++;
		adds += novelty(lc) >= 3;
		if (!lc.last_kept.ids.empty() && mean_motion(lc.now, lc.last_kept) < moved_px)
			moved = false;
	}
	if (seeing == 0 || !moved || now - last_kept_ns_ < 500 * MC_NS_PER_MS)
		return false;
	bool shared_wanted = cams.size() > 1 && seeing > 1 && shared_ < opt_.views;
	return adds > 0 || shared_wanted;
}

int collector::save(std::vector<live_cam> &cams, const std::string &name, mc_err *err)
{
	int seeing = 0;
	for (live_cam &lc : cams) {
		/* Only a still board: a camera whose board moved may show another
		 * pose than the others of this set. */
		if (!still(lc, opt_.solve.min_corners))
			continue;
		std::string dir = opt_.dir + "/" + lc.cam.name;
		mkdir(opt_.dir.c_str(), 0755);
		mkdir(dir.c_str(), 0755);
		std::string path = dir + "/" + name + ".png";
		if (!cv::imwrite(path, lc.grey))
			return mc_err_set(err, "%s: could not be written", path.c_str());
		calib_view v;
		v.name = name;
		v.corners = lc.now;
		v.used = true;
		lc.cam.views.push_back(v);
		lc.last_kept = lc.now;
		for (const cv::Point2f &q : lc.now.px)
			lc.cells[calib_grid_cell(q, lc.cam.width, lc.cam.height, grid)]++;
		seeing++;
	}
	shared_ += seeing > 1;
	return seeing;
}

bool collector::done(const std::vector<live_cam> &cams) const
{
	for (const live_cam &lc : cams)
		if ((int)lc.cam.views.size() < opt_.views || calib_coverage_cells(lc.cam) < 12)
			return false;
	return cams.size() == 1 || shared_ >= opt_.views / 2;
}

/* One line: views, coverage and RMS per camera; the RMS is recomputed
 * every fifth view (a calibration of the views so far). */
void collector::progress(std::vector<live_cam> &cams, bool final)
{
	std::string line;
	for (live_cam &lc : cams) {
		int n = (int)lc.cam.views.size();
		if (n >= opt_.solve.min_views && n != lc.rms_views && (n % 5 == 0 || final)) {
			calib_cam trial = lc.cam;
			mc_err err = {};
			char rms[32] = "-";
			if (calib_intrinsics(&trial, &opt_.solve, &err) == 0)
				std::snprintf(rms, sizeof rms, "%.2f px", trial.rms);
			lc.rms = rms;
			lc.rms_views = n;
		}
		char part[160];
		std::snprintf(part, sizeof part, "%s%s: %d views, coverage %d/16, RMS %s", line.empty() ? "" : " | ",
			      lc.cam.name.c_str(), n, calib_coverage_cells(lc.cam), lc.rms.c_str());
		line += part;
	}
	if (cams.size() > 1)
		line += " | seen together: " + std::to_string(shared_);
	bool tty = isatty(STDOUT_FILENO);
	if (!tty && !final && line == last_line_)
		return;
	last_line_ = line;
	std::printf(tty && !final ? "\r%s\033[K" : "%s\n", line.c_str());
	std::fflush(stdout);
}

int collector::run(std::vector<live_cam> &cams, mc_err *err)
{
	mc_image_conv *conv = mc_image_conv_new(err);
	if (!conv)
		return -1;
	uint64_t start = mc_now_ns();
	int rc = 0;
	while (!stop_asked) {
		uint64_t now = mc_now_ns();
		if (opt_.seconds > 0 && now - start > (uint64_t)(opt_.seconds * 1e9))
			break;
		for (live_cam &lc : cams)
			look(lc, board_, conv);
		bool snapshot = !opt_.snapshot.empty();
		bool all_still = true;
		for (live_cam &lc : cams)
			all_still = all_still && still(lc, opt_.solve.min_corners);
		if (snapshot ? all_still : keep_set(cams, now)) {
			char name[32];
			std::snprintf(name, sizeof name, "set%05d", sets_++);
			if (save(cams, snapshot ? opt_.snapshot : name, err) < 0) {
				rc = -1;
				break;
			}
			last_kept_ns_ = now;
			if (snapshot)
				break;
		}
		if (!snapshot && done(cams))
			break; /* the final progress line follows */
		if (!snapshot && now - last_print_ns_ > MC_NS_PER_S) {
			progress(cams, false);
			last_print_ns_ = now;
		}
		mc_sleep_until_ns(now + 100 * MC_NS_PER_MS);
	}
	if (opt_.snapshot.empty())
		progress(cams, true);
	mc_image_conv_free(conv);
	return rc;
}

} // namespace

int calib_live_collect(const calib_board &board, const std::vector<calib_cam> &cams_in, const calib_live_options &opt,
		       mc_err *err)
{
	mocap_client *c = mocap_connect(opt.socket.empty() ? nullptr : opt.socket.c_str(), "mocap-calibrate");
	if (!c)
		return mc_err_set(err, "%s", mocap_errmsg());
	if (!mocap_is_privileged(c)) {
		mocap_close(c);
		return mc_err_set(err, "the camera rings need mocapd's user or group (run as it, or join its group)");
	}
	std::vector<live_cam> cams(cams_in.size());
	for (size_t i = 0; i < cams.size(); i++)
		cams[i].cam = cams_in[i];
	int rc = wait_for_rings(c, cams, err);
	if (rc == 0) {
		struct sigaction sa = {};
		sa.sa_handler = on_signal;
		sigaction(SIGINT, &sa, nullptr);
		sigaction(SIGTERM, &sa, nullptr);
		collector col(board, opt);
		rc = col.run(cams, err);
		signal(SIGINT, SIG_DFL);
		signal(SIGTERM, SIG_DFL);
	}
	unmap_rings(cams);
	mocap_close(c);
	return rc;
}
