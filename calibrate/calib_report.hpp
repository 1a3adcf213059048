/* calib_report: what a calibration leaves next to the rig file so that a
 * person can judge it: a JSON report (RMS per camera and per view, the
 * views rejected and why, the coverage), a coverage map per camera and an
 * overlay per camera (detected and reprojected corners on a view, beside
 * that view undistorted to a perspective image, where straight board edges
 * must look straight). */
#ifndef CALIB_REPORT_HPP
#define CALIB_REPORT_HPP

#include "calib_solve.hpp"

/* The files written, for the caller to print. */
struct calib_report_files {
	std::string json;
	std::vector<std::string> images;
};

/* Writes PREFIX.report.json, PREFIX.coverage-CAM.png and
 * PREFIX.overlay-CAM.png; images[] are the views as loaded, per camera and
 * view (empty Mats where none). Returns 0 or -1. */
int calib_report_write(const std::string &prefix, const calib_board &board, const std::vector<calib_cam> &cams,
		       const std::vector<std::vector<cv::Mat>> &images, calib_report_files *files, mc_err *err);

#endif
