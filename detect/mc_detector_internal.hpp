// The detector's state, shared by the files of the runtime
// (mc_detector.cpp: loading, the heatmap networks; mc_detector_movenet.cpp:
// the MoveNet networks).  C++ only; C callers see mc_detector.h.
#ifndef MC_DETECTOR_INTERNAL_HPP
#define MC_DETECTOR_INTERNAL_HPP

#include "mc_detector.h"

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include <string>
#include <vector>

// How the network's outputs become keypoints (the sidecar's "decoder").
enum class mc_decoder {
	heatmap, // one `heatmaps` output, per-joint argmax (mc_detector_decode)
	movenet, // MoveNet's four heads (mc_movenet.h), letterboxed, with a second look
};

struct mc_detector {
	std::string path;
	cv::dnn::Net net;
	std::string input_name, output_name;
	mc_decoder decoder = mc_decoder::heatmap;
	bool refine = true; // MoveNet: a second pass on a crop around the person
	bool has_hint = false; // MoveNet: the next view's person square (mc_detector_set_person_square)
	mc_detector_square hint{};
	int in_w = MC_DETECTOR_DEFAULT_INPUT, in_h = MC_DETECTOR_DEFAULT_INPUT;
	int njoints = 0, hm_w = 0, hm_h = 0;
	std::vector<std::string> joints;
	float threshold = MC_DETECTOR_DEFAULT_THRESHOLD;
	float heatmap_sigma = 0; // the sidecar's: DARK decoding when > 0 (mc_detector_decode)
	bool sidecar_joints = false; // the joints come from the sidecar
	std::string sidecar;
	cv::Mat blob;              // 1x3xHinxWin
	cv::Mat resized;           // Hin x Win RGB
	std::vector<float> heatmaps; // J x H x W of the last call
	bool flip = false;        // heatmap models: average with the mirrored view (mc_detector_set_flip)
	std::vector<int> mirror;  // each joint's left/right partner (itself for the middle joints)
	cv::Mat flipped;          // the mirrored view
	mc_detector_timing timing{};
	double total_ms = 0;
};

// The view (Hin x Win RGB24) into d->blob: NCHW float in [0, 1].
void mc_detector_fill_blob(mc_detector *d, const cv::Mat &img);
// A black image as the network's input, for the output checks at load time.
void mc_detector_zero_input(mc_detector *d);

// MoveNet (mc_detector_movenet.cpp): the output check at load time, and one
// view's detection; both return 0 / a count, or -1 with err.
int mc_movenet_check_outputs(mc_detector *d, mc_err *err);
int mc_movenet_detect(mc_detector *d, const cv::Mat &src, mc_detection *out, int max, double *infer_ms,
		      mc_err *err);

#endif
