// mc_detector: loading and running the ONNX heatmap network with OpenCV's
// DNN module.  Every C++ exception stops at the functions of this file: the C
// callers get -1 or NULL and a message in mc_err.
//
// The model's declared input shape is read from the ONNX file itself (a few
// lines of protobuf reading below), because OpenCV 4.6 does not expose it
// and would otherwise run a network built for another size without
// complaint.  The output shape is checked by running it once on zeros.
#include "mc_detector_internal.hpp"

#include "base/mc_time.h"

#include <jansson.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <unistd.h>

namespace {

// ---- A minimal protobuf reader: just enough of ONNX's ModelProto to find
// the graph's inputs and their shapes.

struct Dim {
	long long value = -1; // -1: symbolic or unknown
	std::string param;
};

struct ValueInfo {
	std::string name;
	bool has_shape = false;
	std::vector<Dim> dims;
};

struct OnnxInfo {
	bool has_ir_version = false;
	bool has_graph = false;
	std::vector<ValueInfo> inputs, outputs;
	std::vector<std::string> initializers;
};

class Reader {
      public:
	Reader(const uint8_t *p, size_t n) : p_(p), end_(p + n) {}
	bool done() const { return p_ >= end_; }
	bool varint(uint64_t *v)
	{
		*v = 0;
		for (int shift = 0; shift < 64; shift += 7) {
			if (p_ >= end_)
				return false;
			uint8_t b = *p_++;
			*v |= (uint64_t)(b & 0x7f) << shift;
			if (!(b & 0x80))
				return true;
		}
		return false;
	}
	// The next field: its number, wire type, and for length-delimited
	// fields the bytes (else the value in *v).
	bool field(uint32_t *num, int *wire, uint64_t *v, const uint8_t **bytes, size_t *len)
	{
		uint64_t tag;
		if (!varint(&tag))
			return false;
		*num = (uint32_t)(tag >> 3);
		*wire = (int)(tag & 7);
		if (*num == 0)
			return false;
		switch (*wire) {
		case 0:
			return varint(v);
		case 1:
			if (end_ - p_ < 8)
				return false;
			p_ += 8;
			return true;
		case 5:
			if (end_ - p_ < 4)
				return false;
			p_ += 4;
			return true;
		case 2: {
			uint64_t n;
			if (!varint(&n) || n > (uint64_t)(end_ - p_))
				return false;
			*bytes = p_;
			*len = (size_t)n;
			p_ += n;
			return true;
		}
		default: // groups (3, 4) are not used by ONNX
			return false;
		}
	}

      private:
	const uint8_t *p_, *end_;
};

// Calls fn(num, wire, value, bytes, len) for each field; false if malformed.
template <typename F> bool each_field(const uint8_t *p, size_t n, F fn)
{
	Reader r(p, n);
	while (!r.done()) {
		uint32_t num;
		int wire;
		uint64_t v = 0;
		const uint8_t *b = nullptr;
		size_t len = 0;
		if (!r.field(&num, &wire, &v, &b, &len))
			return false;
		if (!fn(num, wire, v, b, len))
			return false;
	}
	return true;
}

bool parse_dim(const uint8_t *p, size_t n, Dim *d)
{
	return each_field(p, n, [&](uint32_t num, int wire, uint64_t v, const uint8_t *b, size_t len) {
		if (num == 1 && wire == 0)
			d->value = (long long)v;
		else if (num == 2 && wire == 2)
			d->param.assign((const char *)b, len);
		return true;
	});
}

bool parse_value_info(const uint8_t *p, size_t n, ValueInfo *vi)
{
	// ValueInfoProto: name = 1, type = 2; TypeProto: tensor_type = 1;
	// TypeProto.Tensor: shape = 2; TensorShapeProto: dim = 1.
	return each_field(p, n, [&](uint32_t num, int wire, uint64_t, const uint8_t *b, size_t len) {
		if (num == 1 && wire == 2)
			vi->name.assign((const char *)b, len);
		else if (num == 2 && wire == 2)
			return each_field(b, len, [&](uint32_t n2, int w2, uint64_t, const uint8_t *b2, size_t l2) {
				if (n2 != 1 || w2 != 2)
					return true;
				return each_field(b2, l2, [&](uint32_t n3, int w3, uint64_t, const uint8_t *b3, size_t l3) {
					if (n3 != 2 || w3 != 2)
						return true;
					vi->has_shape = true;
					return each_field(b3, l3, [&](uint32_t n4, int w4, uint64_t, const uint8_t *b4,
								      size_t l4) {
						if (n4 != 1 || w4 != 2)
							return true;
						Dim d;
						if (!parse_dim(b4, l4, &d))
							return false;
						vi->dims.push_back(d);
						return true;
					});
				});
			});
		return true;
	});
}

bool parse_onnx(const std::vector<uint8_t> &data, OnnxInfo *info)
{
	// ModelProto: ir_version = 1, graph = 7.  GraphProto: initializer = 5,
	// input = 11, output = 12.  TensorProto: name = 8.
	return each_field(data.data(), data.size(), [&](uint32_t num, int wire, uint64_t, const uint8_t *b,
							size_t len) {
		if (num == 1 && wire == 0)
			info->has_ir_version = true;
		else if (num == 7 && wire == 2) {
			info->has_graph = true;
			return each_field(b, len, [&](uint32_t n2, int w2, uint64_t, const uint8_t *b2, size_t l2) {
				if (w2 != 2)
					return true;
				if (n2 == 11 || n2 == 12) {
					ValueInfo vi;
					if (!parse_value_info(b2, l2, &vi))
						return false;
					(n2 == 11 ? info->inputs : info->outputs).push_back(vi);
				} else if (n2 == 5) {
					std::string name;
					if (!each_field(b2, l2, [&](uint32_t n3, int w3, uint64_t, const uint8_t *b3,
								    size_t l3) {
						    if (n3 == 8 && w3 == 2)
							    name.assign((const char *)b3, l3);
						    return true;
					    }))
						return false;
					info->initializers.push_back(name);
				}
				return true;
			});
		}
		return true;
	});
}

std::string shape_text(const std::vector<Dim> &dims)
{
	std::string s;
	for (size_t i = 0; i < dims.size(); i++) {
		if (i)
			s += "x";
		s += dims[i].value >= 0 ? std::to_string(dims[i].value) : (dims[i].param.empty() ? "?" : dims[i].param);
	}
	return s.empty() ? "a scalar" : s;
}

const char *const default_joints[MC_DETECTOR_DEFAULT_NJOINTS] = {
	"head_top",	  "neck",	 "spine",	"pelvis",     "left_shoulder", "left_elbow",
	"left_wrist",	  "left_hip",	 "left_knee",	"left_ankle", "left_toe",      "right_shoulder",
	"right_elbow",	  "right_wrist", "right_hip",	"right_knee", "right_ankle",   "right_toe",
};

bool threads_set = false;
// OpenCV's log level is process-wide: loads that silence it for the import
// take turns.
std::mutex import_lock;

} // namespace

void mc_detector_zero_input(mc_detector *d)
{
	int sz[4] = {1, 3, d->in_h, d->in_w};
	d->blob.create(4, sz, CV_32F);
	d->blob.setTo(cv::Scalar(0));
	d->net.setInput(d->blob, d->input_name);
}

namespace {

// The sidecar MODEL.json: joints, threshold, input and heatmap sizes.
// Returns 0, or -1 with err; *expect_hm_w/h get the declared heatmap size (0
// if none).
int read_sidecar(mc_detector *d, const std::string &json_path, int *expect_hm_w, int *expect_hm_h, mc_err *err)
{
	*expect_hm_w = *expect_hm_h = 0;
	if (access(json_path.c_str(), F_OK) != 0)
		return 0;
	json_error_t jerr;
	json_t *root = json_load_file(json_path.c_str(), 0, &jerr);
	if (!root)
		return mc_err_set(err, "%s:%d: %s", json_path.c_str(), jerr.line, jerr.text);
	int rc = 0;
	if (!json_is_object(root))
		rc = mc_err_set(err, "%s: expected a JSON object", json_path.c_str());
	json_t *joints = rc ? nullptr : json_object_get(root, "joints");
	if (joints) {
		if (!json_is_array(joints) || json_array_size(joints) == 0 ||
		    json_array_size(joints) > MC_DETECTOR_MAX_JOINTS)
			rc = mc_err_set(err, "%s: joints: expected an array of 1..%d joint names", json_path.c_str(),
					MC_DETECTOR_MAX_JOINTS);
		d->joints.clear();
		d->sidecar_joints = true;
		d->sidecar = json_path;
		for (size_t i = 0; !rc && i < json_array_size(joints); i++) {
			const char *s = json_string_value(json_array_get(joints, i));
			if (!s || !*s || strlen(s) >= MC_DETECTOR_NAME_MAX)
				rc = mc_err_set(err, "%s: joints[%zu]: expected a joint name (1..%d characters)",
						json_path.c_str(), i, MC_DETECTOR_NAME_MAX - 1);
			else
				d->joints.push_back(s);
		}
	}
	json_t *thr = rc ? nullptr : json_object_get(root, "threshold");
	if (thr) {
		double t = json_number_value(thr);
		if (!json_is_number(thr) || !(t >= 0 && t <= 1))
			rc = mc_err_set(err, "%s: threshold: expected a number in [0, 1]", json_path.c_str());
		else
			d->threshold = (float)t;
	}
	json_t *sigma = rc ? nullptr : json_object_get(root, "heatmap_sigma");
	if (sigma) {
		double s = json_number_value(sigma);
		if (!json_is_number(sigma) || !(s >= 0 && s <= 8))
			rc = mc_err_set(err, "%s: heatmap_sigma: expected a number of heat-map cells in [0, 8]",
					json_path.c_str());
		else
			d->heatmap_sigma = (float)s;
	}
	json_t *dec = rc ? nullptr : json_object_get(root, "decoder");
	if (dec) {
		const char *v = json_string_value(dec);
		if (v && strcmp(v, "heatmap") == 0)
			d->decoder = mc_decoder::heatmap;
		else if (v && strcmp(v, "movenet") == 0)
			d->decoder = mc_decoder::movenet;
		else
			rc = mc_err_set(err, "%s: decoder: expected \"heatmap\" or \"movenet\"", json_path.c_str());
	}
	json_t *refine = rc ? nullptr : json_object_get(root, "refine");
	if (refine) {
		if (!json_is_boolean(refine))
			rc = mc_err_set(err, "%s: refine: expected true or false", json_path.c_str());
		else
			d->refine = json_is_true(refine);
	}
	const char *pairs[2] = {"input", "heatmap"};
	for (int k = 0; k < 2 && !rc; k++) {
		json_t *a = json_object_get(root, pairs[k]);
		if (!a)
			continue;
		json_int_t h = json_integer_value(json_array_get(a, 0)), w = json_integer_value(json_array_get(a, 1));
		if (!json_is_array(a) || json_array_size(a) != 2 || h < 2 || w < 2 || h > 4096 || w > 4096) {
			rc = mc_err_set(err, "%s: %s: expected [height, width] in pixels", json_path.c_str(), pairs[k]);
		} else if (k == 0) {
			d->in_h = (int)h;
			d->in_w = (int)w;
		} else {
			*expect_hm_h = (int)h;
			*expect_hm_w = (int)w;
		}
	}
	json_decref(root);
	return rc;
}

std::string sidecar_path(const std::string &onnx)
{
	size_t n = onnx.size();
	if (n > 5 && onnx.compare(n - 5, 5, ".onnx") == 0)
		return onnx.substr(0, n - 5) + ".json";
	return onnx + ".json";
}

// Checks the graph's image input against [1, 3, in_h, in_w].
int check_input(mc_detector *d, const OnnxInfo &info, mc_err *err)
{
	const char *p = d->path.c_str();
	const ValueInfo *in = nullptr;
	for (const ValueInfo &vi : info.inputs) {
		bool is_init = false;
		for (const std::string &s : info.initializers)
			is_init = is_init || s == vi.name;
		if (!is_init) {
			if (in)
				return mc_err_set(err, "%s: the model has several inputs (`%s`, `%s`), expected one image",
						  p, in->name.c_str(), vi.name.c_str());
			in = &vi;
		}
	}
	if (!in)
		return mc_err_set(err, "%s: the ONNX graph has no input", p);
	d->input_name = in->name;
	char want[64];
	snprintf(want, sizeof(want), "1x3x%dx%d", d->in_h, d->in_w);
	if (!in->has_shape)
		return 0; // no declared shape: the forward pass below decides
	const long long expect[4] = {1, 3, d->in_h, d->in_w};
	bool ok = in->dims.size() == 4;
	for (size_t i = 0; ok && i < 4; i++)
		ok = in->dims[i].value < 0 || in->dims[i].value == expect[i] || (i == 0 && in->dims[i].value == 0);
	if (!ok)
		return mc_err_set(err, "%s: input `%s` is %s, expected %s (float32 NCHW, RGB in [0, 1])", p,
				  in->name.c_str(), shape_text(in->dims).c_str(), want);
	return 0;
}

// One forward pass on zeros: the output must be 1 x J x H x W.
int check_output(mc_detector *d, int expect_hm_w, int expect_hm_h, mc_err *err)
{
	if (d->decoder == mc_decoder::movenet)
		return mc_movenet_check_outputs(d, err);
	const char *p = d->path.c_str();
	std::vector<std::string> outs = d->net.getUnconnectedOutLayersNames();
	if (outs.empty())
		return mc_err_set(err, "%s: the network has no output", p);
	d->output_name = outs[0];
	if (outs.size() > 1) {
		d->output_name.clear();
		for (const std::string &s : outs)
			if (s == "heatmaps")
				d->output_name = s;
		if (d->output_name.empty())
			return mc_err_set(err, "%s: the network has %zu outputs and none is named `heatmaps`", p,
					  outs.size());
	}
	mc_detector_zero_input(d);
	cv::Mat out = d->net.forward(d->output_name);
	std::string shape;
	for (int i = 0; i < out.dims; i++)
		shape += (i ? "x" : "") + std::to_string(out.size[i]);
	int J = (int)d->joints.size();
	if (out.dims != 4)
		return mc_err_set(err, "%s: output `%s` has rank %d (%s), expected 4 (1x%dxHxW heatmaps)", p,
				  d->output_name.c_str(), out.dims, shape.c_str(), J);
	if (out.size[0] != 1 || out.size[1] != J)
		return mc_err_set(err, "%s: output `%s` is %s: %d heatmap channels, expected 1x%dxHxW (one per joint%s%s)",
				  p, d->output_name.c_str(), shape.c_str(), out.size[1], J,
				  d->sidecar_joints ? " listed in " : " of the 18 default joints",
				  d->sidecar_joints ? d->sidecar.c_str() : "");
	if (out.size[2] < 2 || out.size[3] < 2)
		return mc_err_set(err, "%s: output `%s` is %s: heatmaps smaller than 2x2", p, d->output_name.c_str(),
				  shape.c_str());
	if (out.type() != CV_32F)
		return mc_err_set(err, "%s: output `%s` is not float32", p, d->output_name.c_str());
	if (expect_hm_w && (out.size[2] != expect_hm_h || out.size[3] != expect_hm_w))
		return mc_err_set(err, "%s: output `%s` is %s, but the sidecar says heatmaps of %dx%d", p,
				  d->output_name.c_str(), shape.c_str(), expect_hm_h, expect_hm_w);
	d->njoints = J;
	d->hm_h = out.size[2];
	d->hm_w = out.size[3];
	d->heatmaps.assign((size_t)J * (size_t)d->hm_h * (size_t)d->hm_w, 0.0f);
	return 0;
}

mc_detector *load(const char *onnx_path, mc_err *err)
{
	if (!onnx_path || !*onnx_path) {
		mc_err_set(err, "detector: no model file given");
		return nullptr;
	}
	std::ifstream f(onnx_path, std::ios::binary);
	if (!f) {
		mc_err_set(err, "%s: cannot open the detector model: %s", onnx_path, strerror(errno));
		return nullptr;
	}
	std::vector<uint8_t> data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
	if (f.bad()) {
		mc_err_set(err, "%s: cannot read the detector model", onnx_path);
		return nullptr;
	}
	OnnxInfo info;
	if (data.empty() || !parse_onnx(data, &info) || !info.has_ir_version || !info.has_graph) {
		mc_err_set(err, "%s: not an ONNX model (%s)", onnx_path,
			   data.empty() ? "the file is empty" : "it does not parse as an ONNX ModelProto with a graph");
		return nullptr;
	}
	std::unique_ptr<mc_detector> d(new mc_detector);
	d->path = onnx_path;
	for (const char *j : default_joints)
		d->joints.push_back(j);
	int expect_hm_w, expect_hm_h;
	std::string side = sidecar_path(d->path);
	if (read_sidecar(d.get(), side, &expect_hm_w, &expect_hm_h, err) < 0)
		return nullptr;
	if (check_input(d.get(), info, err) < 0)
		return nullptr;
	std::unique_lock<std::mutex> lock(import_lock);
	if (!threads_set) {
		cv::setNumThreads(1);
		threads_set = true;
	}
	cv::utils::logging::LogLevel old = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
	try {
		d->net = cv::dnn::readNetFromONNX(reinterpret_cast<const char *>(data.data()), data.size());
		d->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
		d->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
	} catch (const cv::Exception &e) {
		cv::utils::logging::setLogLevel(old);
		mc_err_set(err, "%s: OpenCV cannot read this ONNX model: %s", onnx_path, e.msg.c_str());
		return nullptr;
	}
	cv::utils::logging::setLogLevel(old);
	lock.unlock();
	if (d->net.empty()) {
		mc_err_set(err, "%s: OpenCV read an empty network", onnx_path);
		return nullptr;
	}
	try {
		if (check_output(d.get(), expect_hm_w, expect_hm_h, err) < 0)
			return nullptr;
	} catch (const cv::Exception &e) {
		mc_err_set(err, "%s: the network does not run on a 1x3x%dx%d image: %s", onnx_path, d->in_h, d->in_w,
			   e.msg.c_str());
		return nullptr;
	}
	return d.release();
}

} // namespace

void mc_detector_fill_blob(mc_detector *d, const cv::Mat &img)
{
	// HWC uint8 to NCHW float in [0, 1].
	const size_t plane = (size_t)d->in_w * (size_t)d->in_h;
	float *b = d->blob.ptr<float>();
	for (int y = 0; y < d->in_h; y++) {
		const uint8_t *row = img.ptr<uint8_t>(y);
		float *r = b + (size_t)y * (size_t)d->in_w, *g = r + plane, *bl = g + plane;
		for (int x = 0; x < d->in_w; x++) {
			r[x] = row[3 * x] * (1.0f / 255.0f);
			g[x] = row[3 * x + 1] * (1.0f / 255.0f);
			bl[x] = row[3 * x + 2] * (1.0f / 255.0f);
		}
	}
}

namespace {

// One forward pass of the view in d->blob; its heat maps in *o.
int forward_heatmaps(mc_detector *d, cv::Mat *o, double *infer_ms, mc_err *err)
{
	uint64_t t1 = mc_now_ns();
	d->net.setInput(d->blob, d->input_name);
	*o = d->net.forward(d->output_name);
	*infer_ms += mc_ms_since(t1);
	if (o->dims != 4 || o->size[1] != d->njoints || o->size[2] != d->hm_h || o->size[3] != d->hm_w ||
	    o->type() != CV_32F)
		return mc_err_set(err, "%s: the network's output changed shape", d->path.c_str());
	if (!o->isContinuous())
		return mc_err_set(err, "%s: the network's output is not contiguous", d->path.c_str());
	return 0;
}

// The flip test: the mirrored view's heat maps, mirrored back, each channel
// taken from its left/right partner, averaged into d->heatmaps.  A mirrored
// input column x is column W - 1 - x of the heat map exactly, because the
// cells' centres map to input pixels symmetrically.
int add_mirrored_pass(mc_detector *d, const cv::Mat &img, double *infer_ms, mc_err *err)
{
	cv::flip(img, d->flipped, 1);
	mc_detector_fill_blob(d, d->flipped);
	cv::Mat o;
	if (forward_heatmaps(d, &o, infer_ms, err) < 0)
		return -1;
	const float *m = o.ptr<float>();
	const size_t plane = (size_t)d->hm_w * (size_t)d->hm_h;
	for (int j = 0; j < d->njoints; j++) {
		float *h = d->heatmaps.data() + (size_t)j * plane;
		const float *p = m + (size_t)d->mirror[(size_t)j] * plane;
		for (int y = 0; y < d->hm_h; y++) {
			float *row = h + (size_t)y * (size_t)d->hm_w;
			const float *mirrored_row = p + (size_t)y * (size_t)d->hm_w;
			for (int x = 0; x < d->hm_w; x++)
				row[x] = 0.5f * (row[x] + mirrored_row[d->hm_w - 1 - x]);
		}
	}
	return 0;
}

// A heatmap network: the view resized to the input, one forward pass (two
// with the flip test), the per-joint argmax (mc_detector_decode).
int detect_heatmap(mc_detector *d, const cv::Mat &src, mc_detection *out, int max, double *infer_ms, mc_err *err)
{
	const cv::Mat *img = &src;
	if (src.cols != d->in_w || src.rows != d->in_h) {
		cv::resize(src, d->resized, cv::Size(d->in_w, d->in_h), 0, 0, cv::INTER_AREA);
		img = &d->resized;
	}
	mc_detector_fill_blob(d, *img);
	cv::Mat o;
	*infer_ms = 0;
	if (forward_heatmaps(d, &o, infer_ms, err) < 0)
		return -1;
	memcpy(d->heatmaps.data(), o.ptr<float>(), d->heatmaps.size() * sizeof(float));
	if (d->flip && add_mirrored_pass(d, *img, infer_ms, err) < 0)
		return -1;
	return mc_detector_decode(d->heatmaps.data(), d->njoints, d->hm_h, d->hm_w, d->in_w, d->in_h, src.cols,
				  src.rows, d->threshold, d->heatmap_sigma, out, max);
}

int detect(mc_detector *d, const uint8_t *rgb, int width, int height, int stride, mc_detection *out, int max,
	   mc_err *err)
{
	uint64_t t0 = mc_now_ns();
	double infer = 0;
	if (stride == 0)
		stride = 3 * width;
	if (!rgb || width <= 0 || height <= 0 || stride < 3 * width || max < 0 || (max > 0 && !out))
		return mc_err_set(err, "%s: detect: bad image (%dx%d, stride %d) or output", d->path.c_str(), width,
				  height, stride);
	cv::Mat src(height, width, CV_8UC3, const_cast<uint8_t *>(rgb), (size_t)stride);
	int n = d->decoder == mc_decoder::movenet ? mc_movenet_detect(d, src, out, max, &infer, err)
						  : detect_heatmap(d, src, out, max, &infer, err);
	d->has_hint = false; // a hint is for one view
	if (n < 0)
		return -1;
	double ms = mc_ms_since(t0);
	mc_detector_timing &t = d->timing;
	t.calls++;
	t.last_ms = ms;
	t.last_infer_ms = infer;
	d->total_ms += ms;
	t.mean_ms = d->total_ms / (double)t.calls;
	if (ms > t.max_ms)
		t.max_ms = ms;
	return n;
}

} // namespace

extern "C" {

mc_detector *mc_detector_load(const char *onnx_path, mc_err *err)
{
	try {
		return load(onnx_path, err);
	} catch (const std::exception &e) {
		mc_err_set(err, "%s: cannot load the detector: %s", onnx_path ? onnx_path : "(null)", e.what());
	} catch (...) {
		mc_err_set(err, "%s: cannot load the detector (unknown error)", onnx_path ? onnx_path : "(null)");
	}
	return nullptr;
}

void mc_detector_free(mc_detector *d)
{
	try {
		delete d;
	} catch (...) {
	}
}

int mc_detector_detect(mc_detector *d, const uint8_t *rgb, int width, int height, int stride, mc_detection *out,
		       int max, mc_err *err)
{
	if (!d)
		return mc_err_set(err, "detector: not loaded");
	try {
		return detect(d, rgb, width, height, stride, out, max, err);
	} catch (const cv::Exception &e) {
		return mc_err_set(err, "%s: detection failed: %s", d->path.c_str(), e.msg.c_str());
	} catch (const std::exception &e) {
		return mc_err_set(err, "%s: detection failed: %s", d->path.c_str(), e.what());
	} catch (...) {
		return mc_err_set(err, "%s: detection failed (unknown error)", d->path.c_str());
	}
}

int mc_detector_njoints(const mc_detector *d) { return d ? d->njoints : 0; }

const char *mc_detector_joint_name(const mc_detector *d, int joint)
{
	return d && joint >= 0 && joint < d->njoints ? d->joints[(size_t)joint].c_str() : nullptr;
}

int mc_detector_find_joint(const mc_detector *d, const char *name)
{
	for (int j = 0; d && name && j < d->njoints; j++)
		if (d->joints[(size_t)j] == name)
			return j;
	return -1;
}

void mc_detector_input_size(const mc_detector *d, int *width, int *height)
{
	if (width)
		*width = d ? d->in_w : 0;
	if (height)
		*height = d ? d->in_h : 0;
}

void mc_detector_heatmap_size(const mc_detector *d, int *width, int *height)
{
	if (width)
		*width = d ? d->hm_w : 0;
	if (height)
		*height = d ? d->hm_h : 0;
}

const char *mc_detector_path(const mc_detector *d) { return d ? d->path.c_str() : ""; }

float mc_detector_threshold(const mc_detector *d) { return d ? d->threshold : 0.0f; }

void mc_detector_set_threshold(mc_detector *d, float threshold)
{
	if (d && threshold >= 0.0f)
		d->threshold = threshold;
}

void mc_detector_set_person_square(mc_detector *d, const mc_detector_square *sq)
{
	if (!d)
		return;
	d->has_hint = sq && std::isfinite(sq->x0) && std::isfinite(sq->y0) && sq->size >= 8.0f;
	if (d->has_hint)
		d->hint = *sq;
}

int mc_detector_flip(const mc_detector *d)
{
	return d && d->flip;
}

void mc_detector_set_flip(mc_detector *d, int on)
{
	if (!d || d->decoder != mc_decoder::heatmap)
		return;
	d->flip = on != 0;
	d->mirror.resize((size_t)d->njoints);
	for (int j = 0; j < d->njoints; j++) {
		char other[MC_JOINT_NAME_MAX + 8];
		int k = mc_joint_other_side_name(d->joints[(size_t)j].c_str(), other, sizeof(other)) == 1
				? mc_detector_find_joint(d, other)
				: -1;
		d->mirror[(size_t)j] = k >= 0 ? k : j;
	}
}

void mc_detector_set_refine(mc_detector *d, int on)
{
	if (d)
		d->refine = on != 0;
}

void mc_detector_set_threads(int nthreads)
{
	try {
		std::lock_guard<std::mutex> lock(import_lock);
		cv::setNumThreads(nthreads >= 1 ? nthreads : 1);
		threads_set = true;
	} catch (...) {
	}
}

const float *mc_detector_heatmaps(const mc_detector *d, int *njoints, int *height, int *width)
{
	if (njoints)
		*njoints = d ? d->njoints : 0;
	if (height)
		*height = d ? d->hm_h : 0;
	if (width)
		*width = d ? d->hm_w : 0;
	return d && !d->heatmaps.empty() ? d->heatmaps.data() : nullptr;
}

void mc_detector_get_timing(const mc_detector *d, mc_detector_timing *t)
{
	if (t)
		*t = d ? d->timing : mc_detector_timing{};
}

const char *mc_detector_default_joint_name(int joint)
{
	return joint >= 0 && joint < MC_DETECTOR_DEFAULT_NJOINTS ? default_joints[joint] : nullptr;
}

} // extern "C"
