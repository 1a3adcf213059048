/* calib_report: report JSON, coverage maps and overlays. */
#include "calib_report.hpp"

extern "C" {
#include "base/mc_json.h"
}

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <jansson.h>

#include <algorithm>
#include <cmath>

namespace {

json_t *view_json(const calib_view &v)
{
	json_t *j = json_pack("{s:s,s:b,s:i,s:i}", "name", v.name.c_str(), "used", v.used, "markers",
			      v.corners.markers, "corners", (int)v.corners.ids.size());
	if (v.used) {
		json_object_set_new(j, "rms_px", json_real(v.rms));
		json_object_set_new(j, "max_px", json_real(v.max_err));
		json_object_set_new(j, "dropped_corners", json_integer(v.dropped));
	} else {
		json_object_set_new(j, "why", json_string(v.why.c_str()));
	}
	return j;
}

json_t *camera_json(const calib_cam &c)
{
	const mc_camera &k = c.cam;
	json_t *views = json_array();
	for (const calib_view &v : c.views)
		json_array_append_new(views, view_json(v));
	json_t *dist = json_array();
	for (int i = 0; i < (c.model == MC_CAM_PINHOLE ? 5 : 4); i++)
		json_array_append_new(dist, json_real(k.k[i]));
	return json_pack("{s:s,s:s,s:[i,i],s:f,s:i,s:i,s:i,s:{s:f,s:f,s:f,s:f,s:o,s:f},s:[f,f,f],s:o}", "name",
			 c.name.c_str(), "model", mc_camera_model_name(c.model), "size", c.width, c.height, "rms_px",
			 c.rms, "views_used", c.used_views, "views", (int)c.views.size(), "coverage_cells_of_16",
			 calib_coverage_cells(c), "intrinsics", "fx", k.fx, "fy", k.fy, "cx", k.cx, "cy", k.cy, "k",
			 dist, "max_theta_deg", k.max_theta * 180 / M_PI, "position_m", k.rig_from_cam.t.x,
			 k.rig_from_cam.t.y, k.rig_from_cam.t.z, "per_view", views);
}

/* Distances between camera centres: a stereo rig's baseline at a glance. */
json_t *baselines_json(const std::vector<calib_cam> &cams)
{
	json_t *b = json_array();
	for (size_t i = 0; i < cams.size(); i++)
		for (size_t j = i + 1; j < cams.size(); j++)
			json_array_append_new(
				b, json_pack("{s:s,s:s,s:f}", "from", cams[i].name.c_str(), "to", cams[j].name.c_str(),
					     "distance_m",
					     mc_v3_norm(mc_v3_sub(cams[i].cam.rig_from_cam.t, cams[j].cam.rig_from_cam.t))));
	return b;
}

/* Images at most 960 pixels wide, so that reports stay small. */
double display_scale(int width) { return width > 960 ? 960.0 / width : 1.0; }

cv::Mat coverage_map(const calib_cam &c)
{
	double s = display_scale(c.width);
	cv::Mat img(cvRound(c.height * s), cvRound(c.width * s), CV_8UC3, cv::Scalar(32, 32, 32));
	for (int i = 1; i < 4; i++) {
		cv::line(img, cv::Point(img.cols * i / 4, 0), cv::Point(img.cols * i / 4, img.rows), cv::Scalar(80, 80, 80));
		cv::line(img, cv::Point(0, img.rows * i / 4), cv::Point(img.cols, img.rows * i / 4), cv::Scalar(80, 80, 80));
	}
	int n = 0;
	for (const calib_view &v : c.views) {
		if (!v.used)
			continue;
		/* One hue per view, so that each view's patch can be told apart. */
		cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar((n++ * 37) % 180, 200, 255)), bgr;
		cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
		cv::Vec3b col = bgr.at<cv::Vec3b>(0, 0);
		for (const cv::Point2f &q : v.corners.px)
			cv::circle(img, cv::Point2f(q.x * (float)s, q.y * (float)s), 2, cv::Scalar(col[0], col[1], col[2]),
				   cv::FILLED);
	}
	char text[96];
	std::snprintf(text, sizeof text, "%s: %d views, %d/16 cells, RMS %.2f px", c.name.c_str(), c.used_views,
		      calib_coverage_cells(c), c.rms);
	cv::putText(img, text, cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1);
	return img;
}

/* The view with the most corners, drawn with detected (green circles) and
 * reprojected (red crosses) corners, beside the same view remapped to a
 * perspective camera of up to 100 degrees through the calibration. */
cv::Mat overlay(const calib_cam &c, const std::vector<cv::Mat> &images)
{
	const calib_view *best = nullptr;
	const cv::Mat *img = nullptr;
	for (size_t i = 0; i < c.views.size(); i++)
		if (c.views[i].used && !images[i].empty() &&
		    (!best || c.views[i].corners.ids.size() > best->corners.ids.size()))
			best = &c.views[i], img = &images[i];
	if (!best)
		return cv::Mat();
	cv::Mat left;
	cv::cvtColor(*img, left, cv::COLOR_GRAY2BGR);
	std::vector<cv::Point2f> re;
	calib_reproject(c, *best, re);
	for (size_t i = 0; i < re.size(); i++) {
		cv::circle(left, best->corners.px[i], 4, cv::Scalar(0, 255, 0), 1);
		cv::drawMarker(left, re[i], cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 6, 1);
	}
	/* The perspective view: same size, half-field min(max_theta, 50 deg). */
	double half = std::min(c.cam.max_theta, 50 * M_PI / 180);
	double f = 0.5 * std::min(c.width, c.height) / std::tan(half);
	cv::Mat mapx(c.height, c.width, CV_32F), mapy(c.height, c.width, CV_32F);
	for (int y = 0; y < c.height; y++)
		for (int x = 0; x < c.width; x++) {
			double u = -1, v = -1;
			mc_vec3 ray = mc_v3((x - (c.width - 1) / 2.0) / f, (y - (c.height - 1) / 2.0) / f, 1);
			if (!mc_camera_project(&c.cam, ray, &u, &v))
				u = v = -1;
			mapx.at<float>(y, x) = (float)u, mapy.at<float>(y, x) = (float)v;
		}
	cv::Mat right;
	cv::remap(left, right, mapx, mapy, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0, 0, 0));
	cv::Mat both;
	cv::hconcat(left, right, both);
	double s = display_scale(both.cols / 2);
	if (s < 1)
		cv::resize(both, both, cv::Size(), s, s, cv::INTER_AREA);
	return both;
}

int write_png(const std::string &path, const cv::Mat &img, calib_report_files *files, mc_err *err)
{
	try {
		if (!cv::imwrite(path, img))
			return mc_err_set(err, "%s: could not be written", path.c_str());
	} catch (const cv::Exception &e) {
		return mc_err_set(err, "%s: %s", path.c_str(), e.what());
	}
	files->images.push_back(path);
	return 0;
}

} // namespace

int calib_report_write(const std::string &prefix, const calib_board &board, const std::vector<calib_cam> &cams,
		       const std::vector<std::vector<cv::Mat>> &images, calib_report_files *files, mc_err *err)
{
	json_t *jcams = json_array();
	for (const calib_cam &c : cams)
		json_array_append_new(jcams, camera_json(c));
	json_t *root = json_pack("{s:{s:[i,i],s:f,s:f,s:s},s:o,s:o}", "board", "squares", board.squares_x,
				 board.squares_y, "square_mm", board.square_m * 1000, "marker_mm", board.marker_m * 1000,
				 "dictionary", board.dictionary.c_str(), "cameras", jcams, "camera_distances",
				 baselines_json(cams));
	files->json = prefix + ".report.json";
	int rc = mc_json_save_file(root, files->json.c_str(), err);
	json_decref(root);
	for (size_t i = 0; rc == 0 && i < cams.size(); i++) {
		rc = write_png(prefix + ".coverage-" + cams[i].name + ".png", coverage_map(cams[i]), files, err);
		cv::Mat ov = rc == 0 ? overlay(cams[i], images[i]) : cv::Mat();
		if (rc == 0 && !ov.empty())
			rc = write_png(prefix + ".overlay-" + cams[i].name + ".png", ov, files, err);
	}
	return rc;
}
