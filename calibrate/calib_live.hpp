/* calib_live: collecting calibration views live from mocapd's cameras.
 *
 * A privileged client of the daemon maps the named cameras' frame rings
 * (read-only memfds from the socket), finds the board in the newest frame
 * of each camera several times a second, and keeps a frame set when the
 * board is held still (so that it is sharp and the cameras agree on its
 * pose) and the set adds something: board corners where a camera has few
 * yet (a 8x8 grid over its image), or, with several cameras, another
 * board pose that two or more cameras see at once.  It prints its progress
 * (views kept, coverage of each camera's image, the current RMS) and stops
 * when every camera has enough views and coverage, when the time is up or
 * on Ctrl-C.  Kept views are written as PNG files, DIR/CAMERA/setNNNNN.png,
 * so that the calibration runs from folders as usual and can be repeated. */
#ifndef CALIB_LIVE_HPP
#define CALIB_LIVE_HPP

#include "calib_solve.hpp"

struct calib_live_options {
	std::string socket;      /* empty: the default socket */
	std::string dir;         /* where the views go: DIR/CAMERA/ */
	int views = 20;          /* views per camera (and shared sets with several cameras) to aim for */
	double seconds = 0;      /* give up collecting after this long; 0: until done or Ctrl-C */
	std::string snapshot;    /* not empty: save one still frame set under this name and stop */
	calib_options solve;     /* for the running RMS */
};

/* Collects views of the cameras named in cams (their model too, for the
 * running RMS). Returns 0 when it stopped (done, time, Ctrl-C), -1 with err
 * when the daemon cannot be used. */
int calib_live_collect(const calib_board &board, const std::vector<calib_cam> &cams, const calib_live_options &opt,
		       mc_err *err);

#endif
