// mc_detector_movenet: running a MoveNet single-pose network (sidecar
// "decoder": "movenet"; docs/DETECT_RUNTIME.md, "MoveNet").
//
// The network sees a square: first the whole view, letterboxed (black
// bars), then, when the first look found the torso, a square around the
// person (MoveNet's own cropping rule, mc_movenet_person_square), where
// the person fills the input and the joints are placed more finely.  The
// keypoints come from the second look when there was one.
#include "mc_detector_internal.hpp"

extern "C" {
#include "mc_movenet.h"
}

#include "base/mc_time.h"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>

namespace {

const char *const head_names[4] = {"heatmaps", "centers", "regress", "offsets"};

// The second look needs the torso with at least this score in the first.
const float refine_min_score = 0.2f;

// A limb split from its twin needs at least this score at its own peak
// (it then reports the pair's score; mc_movenet_separate_pairs).
const float separate_min_score = 0.1f;

// Where the square's input pixels lie in the native image: input pixel
// edge coordinate e maps to native edge coordinate x0 + e / scale.
struct placement {
	double x0, y0, scale_x, scale_y;
};

// The square sq of src into the network's input (black outside the
// image), resized with INTER_AREA; returns where the input lies.
placement fill_square(mc_detector *d, const cv::Mat &src, const mc_movenet_square &sq)
{
	d->resized.create(d->in_h, d->in_w, CV_8UC3);
	d->resized.setTo(cv::Scalar(0, 0, 0));
	double s = d->in_w / (double)sq.size;
	// The part of the square inside the image, in native pixels.
	int x0 = std::max(0, (int)std::floor(sq.x0)), y0 = std::max(0, (int)std::floor(sq.y0));
	int x1 = std::min(src.cols, (int)std::ceil(sq.x0 + sq.size));
	int y1 = std::min(src.rows, (int)std::ceil(sq.y0 + sq.size));
	placement p = {sq.x0, sq.y0, s, d->in_h / (double)sq.size};
	if (x1 <= x0 || y1 <= y0)
		return p;
	// Its place in the input, whole pixels; the scale follows from them.
	int ix0 = std::max(0, (int)std::lround((x0 - sq.x0) * s));
	int iy0 = std::max(0, (int)std::lround((y0 - sq.y0) * p.scale_y));
	int ix1 = std::min(d->in_w, (int)std::lround((x1 - sq.x0) * s));
	int iy1 = std::min(d->in_h, (int)std::lround((y1 - sq.y0) * p.scale_y));
	if (ix1 <= ix0 || iy1 <= iy0)
		return p;
	cv::Mat roi = src(cv::Rect(x0, y0, x1 - x0, y1 - y0));
	cv::Mat dst = d->resized(cv::Rect(ix0, iy0, ix1 - ix0, iy1 - iy0));
	cv::resize(roi, dst, dst.size(), 0, 0, cv::INTER_AREA);
	p.scale_x = (ix1 - ix0) / (double)(x1 - x0);
	p.scale_y = (iy1 - iy0) / (double)(y1 - y0);
	p.x0 = x0 - ix0 / p.scale_x;
	p.y0 = y0 - iy0 / p.scale_y;
	return p;
}

// One look: the network on square sq, decoded to native pixels (xy, score
// per joint).  On a square around the person (separate), a limb decoded
// under both labels is split (mc_movenet_separate_pairs); the letterboxed
// whole view is decoded as MoveNet does, since there a small person's two
// ankles may lie within a cell of each other.  Returns the network's time, ms.
double look(mc_detector *d, const cv::Mat &src, const mc_movenet_square &sq, bool separate, std::vector<float> &xy,
	    std::vector<float> &score)
{
	placement p = fill_square(d, src, sq);
	mc_detector_fill_blob(d, d->resized);
	uint64_t t0 = mc_now_ns();
	d->net.setInput(d->blob, d->input_name);
	std::vector<cv::Mat> outs;
	d->net.forward(outs, std::vector<cv::String>(head_names, head_names + 4));
	double ms = mc_ms_since(t0);
	const size_t plane = (size_t)d->hm_w * (size_t)d->hm_h;
	memcpy(d->heatmaps.data(), outs[0].ptr<float>(), (size_t)d->njoints * plane * sizeof(float));
	mc_movenet_heads heads = {outs[0].ptr<float>(), outs[1].ptr<float>(), outs[2].ptr<float>(),
				  outs[3].ptr<float>(), d->njoints, d->hm_h, d->hm_w};
	std::vector<mc_movenet_point> pts((size_t)d->njoints);
	mc_movenet_decode(&heads, pts.data());
	if (separate)
		mc_movenet_separate_pairs(&heads, separate_min_score, pts.data());
	for (int j = 0; j < d->njoints; j++) {
		// MoveNet's fractions are of the input's edges; native pixel
		// centres sit at edge coordinate + 0.5.
		xy[2 * (size_t)j] = (float)(p.x0 + pts[(size_t)j].x * d->in_w / p.scale_x - 0.5);
		xy[2 * (size_t)j + 1] = (float)(p.y0 + pts[(size_t)j].y * d->in_h / p.scale_y - 0.5);
		score[(size_t)j] = pts[(size_t)j].score;
	}
	return ms;
}

// The two looks: the whole view, letterboxed, then the person found there.
double look_twice(mc_detector *d, const cv::Mat &src, std::vector<float> &xy, std::vector<float> &score)
{
	double ms = look(d, src, mc_movenet_full_square(src.cols, src.rows), false, xy, score);
	mc_movenet_square person;
	if (d->refine && mc_movenet_person_square(xy.data(), score.data(), d->njoints, refine_min_score, &person) == 0)
		ms += look(d, src, person, true, xy, score);
	return ms;
}

} // namespace

int mc_movenet_check_outputs(mc_detector *d, mc_err *err)
{
	const char *p = d->path.c_str();
	if (d->in_w != d->in_h)
		return mc_err_set(err, "%s: a MoveNet network needs a square input, the sidecar says %dx%d", p, d->in_h,
				  d->in_w);
	mc_detector_zero_input(d);
	std::vector<cv::Mat> outs;
	try {
		d->net.forward(outs, std::vector<cv::String>(head_names, head_names + 4));
	} catch (const cv::Exception &e) {
		return mc_err_set(err, "%s: a MoveNet network needs the outputs heatmaps, centers, regress and offsets: %s",
				  p, e.msg.c_str());
	}
	const int J = (int)d->joints.size(), want[4] = {J, 1, 2 * J, 2 * J};
	for (int i = 0; i < 4; i++) {
		const cv::Mat &o = outs[(size_t)i];
		if (o.dims != 4 || o.size[0] != 1 || o.size[1] != want[i] || o.type() != CV_32F ||
		    o.size[2] != outs[0].size[2] || o.size[3] != outs[0].size[3] || o.size[2] < 2 || !o.isContinuous())
			return mc_err_set(err, "%s: output `%s` is not 1x%dxHxW float32 (MoveNet's heads, %d joints)", p,
					  head_names[i], want[i], J);
	}
	d->njoints = J;
	d->hm_h = outs[0].size[2];
	d->hm_w = outs[0].size[3];
	d->heatmaps.assign((size_t)J * (size_t)d->hm_h * (size_t)d->hm_w, 0.0f);
	return 0;
}

int mc_movenet_detect(mc_detector *d, const cv::Mat &src, mc_detection *out, int max, double *infer_ms, mc_err *err)
{
	(void)err;
	std::vector<float> xy(2 * (size_t)d->njoints), score((size_t)d->njoints);
	// With a hint (the tracked pose), one look there, as MoveNet's own
	// tracking does; the two looks when it misses the torso.
	bool one_look = false;
	*infer_ms = 0;
	if (d->has_hint) {
		mc_movenet_square unused;
		*infer_ms = look(d, src, mc_movenet_square{d->hint.x0, d->hint.y0, d->hint.size}, true, xy, score);
		one_look = mc_movenet_person_square(xy.data(), score.data(), d->njoints, refine_min_score, &unused) == 0;
	}
	if (!one_look)
		*infer_ms += look_twice(d, src, xy, score);
	d->timing.one_look += one_look;
	int n = 0;
	for (int j = 0; j < d->njoints && n < max; j++) {
		float c = score[(size_t)j];
		if (!(c >= d->threshold))
			continue;
		out[n++] = mc_detection{j, xy[2 * (size_t)j], xy[2 * (size_t)j + 1], c > 1.0f ? 1.0f : c < 0.0f ? 0.0f : c};
	}
	return n;
}
