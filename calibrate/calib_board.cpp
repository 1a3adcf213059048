/* calib_board: ChArUco board parameters, printing and detection. */
#include "calib_board.hpp"

extern "C" {
#include "base/mc_json.h"
}

#include <opencv2/imgproc.hpp>

#include <jansson.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace {

struct named_dict {
	const char *name;
	cv::aruco::PREDEFINED_DICTIONARY_NAME id;
};

/* The dictionaries offered: 4x4 bits for small prints, 5x5 and 6x6 for
 * boards seen from afar or at an angle (more bits between valid codes). */
const named_dict dictionaries[] = {
	{"4x4_50", cv::aruco::DICT_4X4_50},   {"4x4_100", cv::aruco::DICT_4X4_100},
	{"5x5_50", cv::aruco::DICT_5X5_50},   {"5x5_100", cv::aruco::DICT_5X5_100},
	{"5x5_250", cv::aruco::DICT_5X5_250}, {"6x6_100", cv::aruco::DICT_6X6_100},
	{"6x6_250", cv::aruco::DICT_6X6_250},
};

int dictionary_size(const std::string &name)
{
	return std::atoi(name.c_str() + name.find('_') + 1);
}

} // namespace

int calib_board_init(calib_board *b, mc_err *err)
{
	if (b->squares_x < 3 || b->squares_x > 40 || b->squares_y < 3 || b->squares_y > 40)
		return mc_err_set(err, "squares: each side must be 3..40 squares, got %dx%d", b->squares_x,
				  b->squares_y);
	if (!(b->square_m > 0.002 && b->square_m < 2))
		return mc_err_set(err, "square_mm: must be in (2, 2000) mm, got %g", b->square_m * 1000);
	if (!(b->marker_m > 0 && b->marker_m < b->square_m))
		return mc_err_set(err, "marker_mm: must be above 0 and below square_mm (%g), got %g",
				  b->square_m * 1000, b->marker_m * 1000);
	const named_dict *d = nullptr;
	for (const named_dict &nd : dictionaries)
		if (b->dictionary == nd.name)
			d = &nd;
	if (!d) {
		std::string names;
		for (const named_dict &nd : dictionaries)
			names += std::string(names.empty() ? "" : ", ") + nd.name;
		return mc_err_set(err, "dictionary: unknown '%s' (one of %s)", b->dictionary.c_str(), names.c_str());
	}
	/* A ChArUco board has a marker in every other square. */
	int markers = (b->squares_x * b->squares_y) / 2;
	if (markers > dictionary_size(b->dictionary))
		return mc_err_set(err, "dictionary: %s has %d markers, a %dx%d board needs %d", d->name,
				  dictionary_size(b->dictionary), b->squares_x, b->squares_y, markers);
	b->cv_board = cv::aruco::CharucoBoard::create(b->squares_x, b->squares_y, (float)b->square_m,
						      (float)b->marker_m, cv::aruco::getPredefinedDictionary(d->id));
	return 0;
}

int calib_board_load(const char *path, calib_board *b, mc_err *err)
{
	json_t *root;
	if (mc_json_load_file(path, &root, err) < 0)
		return -1;
	static const char *const keys[] = {"squares", "square_mm", "marker_mm", "dictionary", "note", NULL};
	double squares[2], square_mm, marker_mm;
	char dict[32] = "5x5_100";
	int rc = -1;
	if (mc_json_check_keys(root, path, keys, err) < 0 ||
	    mc_json_numbers(root, "squares", path, squares, 2, true, err) < 0 ||
	    mc_json_positive(root, "square_mm", path, &square_mm, true, err) < 0 ||
	    mc_json_positive(root, "marker_mm", path, &marker_mm, true, err) < 0 ||
	    mc_json_string(root, "dictionary", path, dict, sizeof dict, false, err) < 0)
		goto out;
	if (squares[0] != std::floor(squares[0]) || squares[1] != std::floor(squares[1])) {
		mc_err_set(err, "%s: squares: expected two whole numbers", path);
		goto out;
	}
	b->squares_x = (int)squares[0];
	b->squares_y = (int)squares[1];
	b->square_m = square_mm / 1000;
	b->marker_m = marker_mm / 1000;
	b->dictionary = dict;
	rc = calib_board_init(b, err);
	if (rc < 0)
		mc_err_prefix(err, "%s", path);
out:
	json_decref(root);
	return rc;
}

int calib_board_save(const calib_board *b, const char *path, mc_err *err)
{
	json_t *root = json_pack("{s:[i,i],s:f,s:f,s:s,s:s}", "squares", b->squares_x, b->squares_y, "square_mm",
				 b->square_m * 1000, "marker_mm", b->marker_m * 1000, "dictionary",
				 b->dictionary.c_str(), "note",
				 "ChArUco board for mocap-calibrate --board; print the PDF at 100 % and measure a square");
	int rc = mc_json_save_file(root, path, err);
	json_decref(root);
	return rc;
}

cv::Mat calib_board_image(const calib_board *b, double px_per_m, double margin_m)
{
	int margin = (int)std::lround(margin_m * px_per_m);
	int w = (int)std::lround(b->squares_x * b->square_m * px_per_m);
	int h = (int)std::lround(b->squares_y * b->square_m * px_per_m);
	cv::Mat board;
	b->cv_board->draw(cv::Size(w, h), board, 0, 1);
	cv::Mat page(h + 2 * margin, w + 2 * margin, CV_8UC1, cv::Scalar(255));
	board.copyTo(page(cv::Rect(margin, margin, w, h)));
	return page;
}

/* ---- PDF: one page, black rectangles in PDF points (1/72 inch) ----------- */

namespace {

/* Appends "x y w h re" for every run of black cells in each row of a
 * marker's bit image, so that a marker is a few dozen rectangles. */
void marker_rects(const cv::Mat &bits, double x0, double y0_top, double cell, double page_h, std::string &ops)
{
	char buf[128];
	for (int r = 0; r < bits.rows; r++)
		for (int c = 0; c < bits.cols;) {
			if (bits.at<uchar>(r, c) != 0) {
				c++;
				continue;
			}
			int c1 = c;
			while (c1 < bits.cols && bits.at<uchar>(r, c1) == 0)
				c1++;
			double y = page_h - (y0_top + (r + 1) * cell);
			std::snprintf(buf, sizeof buf, "%.3f %.3f %.3f %.3f re\n", x0 + c * cell, y, (c1 - c) * cell, cell);
			ops += buf;
			c = c1;
		}
}

std::string board_ops(const calib_board *b, double margin_m, double page_h)
{
	const double pt = 72 / 0.0254; /* points per metre */
	double sq = b->square_m * pt, mk = b->marker_m * pt, m = margin_m * pt;
	std::string ops = "0 g\n";
	char buf[128];
	const cv::aruco::Dictionary &dict = *b->cv_board->dictionary;
	int marker = 0;
	for (int y = 0; y < b->squares_y; y++)
		for (int x = 0; x < b->squares_x; x++) {
			double left = m + x * sq, top = m + y * sq;
			/* OpenCV's layout: the top-left square is black; markers sit in
			 * the white squares, numbered row by row. */
			if ((x + y) % 2 == 0) {
				std::snprintf(buf, sizeof buf, "%.3f %.3f %.3f %.3f re\n", left, page_h - top - sq, sq, sq);
				ops += buf;
				continue;
			}
			cv::Mat bits;
			dict.drawMarker(b->cv_board->ids[marker++], dict.markerSize + 2, bits, 1);
			double cell = mk / bits.cols;
			marker_rects(bits, left + (sq - mk) / 2, top + (sq - mk) / 2, cell, page_h, ops);
		}
	return ops + "f\n";
}

} // namespace

int calib_board_write_pdf(const calib_board *b, double margin_m, const char *path, mc_err *err)
{
	const double pt = 72 / 0.0254;
	double page_w = (b->squares_x * b->square_m + 2 * margin_m) * pt;
	double page_h = (b->squares_y * b->square_m + 2 * margin_m) * pt;
	std::string content = board_ops(b, margin_m, page_h);
	std::vector<std::string> objects = {
		"<< /Type /Catalog /Pages 2 0 R >>",
		"<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
		"<< /Type /Page /Parent 2 0 R /MediaBox [0 0 " + std::to_string(page_w) + " " + std::to_string(page_h) +
			"] /Contents 4 0 R /Resources << >> >>",
		"<< /Length " + std::to_string(content.size()) + " >>\nstream\n" + content + "endstream",
	};
	std::string pdf = "%PDF-1.4\n";
	std::vector<size_t> offsets;
	for (size_t i = 0; i < objects.size(); i++) {
		offsets.push_back(pdf.size());
		pdf += std::to_string(i + 1) + " 0 obj\n" + objects[i] + "\nendobj\n";
	}
	size_t xref = pdf.size();
	pdf += "xref\n0 " + std::to_string(objects.size() + 1) + "\n0000000000 65535 f \n";
	char line[32];
	for (size_t off : offsets) {
		std::snprintf(line, sizeof line, "%010zu 00000 n \n", off);
		pdf += line;
	}
	pdf += "trailer\n<< /Size " + std::to_string(objects.size() + 1) + " /Root 1 0 R >>\nstartxref\n" +
	       std::to_string(xref) + "\n%%EOF\n";
	FILE *f = std::fopen(path, "wb");
	if (!f)
		return mc_err_set(err, "%s: %s", path, std::strerror(errno));
	bool ok = std::fwrite(pdf.data(), 1, pdf.size(), f) == pdf.size();
	if (std::fclose(f) != 0 || !ok)
		return mc_err_set(err, "%s: write failed", path);
	return 0;
}

/* OpenCV 4.6's interpolateCornersCharuco returns corners half a pixel
 * right of and below the truth (measured on views rendered through known
 * cameras: +0.50 px in x and y; cv::cornerSubPix alone is unbiased), so
 * each corner is refined again here.  The window must not reach the
 * markers' edges, which would pull the corner: its half-width is the gap
 * between a square's corner and its marker, (square - marker) / 2, taken
 * from the distance to the nearest corner (one square, or more where
 * corners are missing; 90 % of the smallest for perspective), 2 to 8 px. */
static void refine_corners(const calib_board *b, const cv::Mat &grey, std::vector<cv::Point2f> &px)
{
	double gap = (b->square_m - b->marker_m) / 2 / b->square_m;
	for (size_t i = 0; i < px.size(); i++) {
		double nearest = 1e9;
		for (size_t j = 0; j < px.size(); j++)
			if (j != i)
				nearest = std::min(nearest, (double)cv::norm(px[i] - px[j]));
		int half = std::clamp((int)(0.9 * gap * nearest), 2, 8);
		std::vector<cv::Point2f> one = {px[i]};
		cv::cornerSubPix(grey, one, cv::Size(half, half), cv::Size(-1, -1),
				 cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-4));
		px[i] = one[0];
	}
}

calib_corners calib_board_detect(const calib_board *b, const cv::Mat &grey)
{
	calib_corners out;
	std::vector<int> marker_ids;
	std::vector<std::vector<cv::Point2f>> marker_corners, rejected;
	cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
	params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
	cv::aruco::detectMarkers(grey, b->cv_board->dictionary, marker_corners, marker_ids, params, rejected);
	/* Markers rejected by their shape are given another chance against the
	 * board's layout: near a fisheye's rim they are bent. */
	cv::aruco::refineDetectedMarkers(grey, b->cv_board, marker_corners, marker_ids, rejected);
	out.markers = (int)marker_ids.size();
	if (marker_ids.empty())
		return out;
	cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, b->cv_board, out.px, out.ids);
	refine_corners(b, grey, out.px);
	for (int id : out.ids)
		out.obj.push_back(b->cv_board->chessboardCorners[id]);
	return out;
}
