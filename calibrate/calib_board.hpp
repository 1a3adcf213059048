/* calib_board: the ChArUco calibration board: its parameters (board.json),
 * its printable image (PNG) and vector page (PDF), and finding its corners
 * in a view.
 *
 * A ChArUco board is a chessboard whose white squares hold ArUco markers:
 * every inner corner has an id, so a view that sees only part of the board
 * (the usual case near a fisheye's rim) still gives known board points.
 * Board coordinates: metres, x along the columns, y along the rows (down
 * the printed page), z = 0 on the board, origin at the outer corner of the
 * top-left square; OpenCV's own convention for CharucoBoard. */
#ifndef CALIB_BOARD_HPP
#define CALIB_BOARD_HPP

extern "C" {
#include "base/mc_error.h"
}

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

struct calib_board {
	int squares_x = 8, squares_y = 6; /* squares along x (columns) and y (rows) */
	double square_m = 0.04;           /* side of a chessboard square */
	double marker_m = 0.03;           /* side of a marker inside a white square */
	std::string dictionary = "5x5_100";
	cv::Ptr<cv::aruco::CharucoBoard> cv_board;
};

/* One view's board corners: ids index calib_board's inner corners. */
struct calib_corners {
	std::vector<int> ids;
	std::vector<cv::Point2f> px;  /* OpenCV pixel coordinates (pixel centre at integer) */
	std::vector<cv::Point3f> obj; /* the same corners on the board, metres */
	int markers = 0;              /* markers decoded */
};

/* Builds the OpenCV board from the parameters; checks them (message names the
 * field). Returns 0 or -1. */
int calib_board_init(calib_board *b, mc_err *err);

/* board.json: {"squares": [x, y], "square_mm": s, "marker_mm": m, "dictionary": "5x5_100"}.
 * Errors name the file and field. */
int calib_board_load(const char *path, calib_board *b, mc_err *err);
int calib_board_save(const calib_board *b, const char *path, mc_err *err);

/* The board as an 8-bit image at px_per_m, with a white margin of margin_m
 * around it (no margin: the board fills the image exactly). */
cv::Mat calib_board_image(const calib_board *b, double px_per_m, double margin_m);

/* A one-page PDF whose page is the board plus margin_m at true size (print
 * at 100 %, no scaling); squares and marker cells are vector rectangles. */
int calib_board_write_pdf(const calib_board *b, double margin_m, const char *path, mc_err *err);

/* Finds the board in an 8-bit grey image: markers, then the chessboard
 * corners between them, refined to subpixel. Returns the corners found
 * (possibly none). */
calib_corners calib_board_detect(const calib_board *b, const cv::Mat &grey);

#endif
