/* mc_detector: the 2D joint detector's runtime (ONNX heatmap network through
 * OpenCV's DNN module; C++ inside, this C11 header outside).
 *
 * One fisheye view in (packed RGB24, any size), keypoints out: for each
 * joint of the model, its pixel in the view's native image and a confidence.
 * docs/DETECT_RUNTIME.md has the model contract and the decoding in full.
 *
 *     mc_err err = {{0}};
 *     mc_detector *d = mc_detector_load("config/models/ego_detector.onnx", &err);
 *     if (!d) { fprintf(stderr, "%s\n", err.msg); return 1; }
 *     mc_detection det[MC_DETECTOR_MAX_JOINTS];
 *     int n = mc_detector_detect(d, rgb, width, height, stride, det, MC_DETECTOR_MAX_JOINTS, &err);
 *     ... det[i].joint names mc_detector_joint_name(d, det[i].joint) ...
 *     mc_detector_free(d);
 *
 * The model (ONNX), fixed by the trainer (tools/train):
 *   input  `image`    float32 1x3xHinxWin (128x128), RGB in [0, 1];
 *   output `heatmaps` float32 1xJxHxW (J joints, H, W read from the model),
 *                     values in [0, 1].
 * A sidecar MODEL.json next to MODEL.onnx (same name, .json) may give
 * {"input": [Hin, Win], "joints": [J names], "threshold": t, "heatmap": [H, W],
 *  "heatmap_sigma": s} (s: the training targets' Gaussian in heat-map cells,
 * which selects the decoding of mc_detector_decode; 0 when absent);
 * without it the joints are the 18 of mc_detector_default_joint_name() and
 * the threshold is 0.3.
 *
 * Threads: a detector is used by one thread at a time (make one per thread).
 * OpenCV's own thread pool is per process: mc_detector_set_threads() sets it
 * for every detector of the process (default 1, set at the first load; the
 * tracker uses the other core).
 *
 * Errors: functions that fail return -1 (or NULL) and fill err with a message
 * that names the model file, e.g.
 *   "build/m.onnx: input `image` is 1x1x96x96, expected 1x3x128x128". */
#ifndef MC_DETECTOR_H
#define MC_DETECTOR_H

#include <stdint.h>

/* The core's headers have no C++ guards of their own. */
#ifdef __cplusplus
extern "C" {
#endif

#include "base/mc_error.h"
#include "body/mc_model.h"
#include "track/mc_tracker.h"

#define MC_DETECTOR_MAX_JOINTS 64
#define MC_DETECTOR_NAME_MAX 32
#define MC_DETECTOR_DEFAULT_THRESHOLD 0.3f
#define MC_DETECTOR_DEFAULT_INPUT 128

typedef struct mc_detector mc_detector;

/* One keypoint of one view. */
typedef struct {
	int joint;        /* the detector's joint index (mc_detector_joint_name) */
	float u, v;       /* native pixels of the view, origin at the top-left pixel's centre */
	float confidence; /* the heatmap's peak value, 0..1 */
} mc_detection;

/* Time spent, milliseconds.  "Per call" is one view: resize, network and
 * decoding. */
typedef struct {
	uint64_t calls;
	double last_ms, mean_ms, max_ms;
	double last_infer_ms; /* the network alone in the last call */
	uint64_t one_look;    /* MoveNet: views that needed only the look at the person square */
} mc_detector_timing;

/* Loads MODEL.onnx (and MODEL.json if there), checks the input shape, runs
 * one forward pass on zeros and checks the output (rank 4, 1xJxHxW with J
 * the joint count, H and W at least 2).  NULL with err naming the file and
 * the mismatch: missing file, not ONNX, wrong input shape, wrong output
 * rank or channel count, a bad sidecar. */
mc_detector *mc_detector_load(const char *onnx_path, mc_err *err);
void mc_detector_free(mc_detector *d);

/* The model's joints: count, names, and the index of a name (-1 if the
 * detector has no such joint). */
int mc_detector_njoints(const mc_detector *d);
const char *mc_detector_joint_name(const mc_detector *d, int joint);
int mc_detector_find_joint(const mc_detector *d, const char *name);
/* The model's input size and heatmap size. */
void mc_detector_input_size(const mc_detector *d, int *width, int *height);
void mc_detector_heatmap_size(const mc_detector *d, int *width, int *height);
const char *mc_detector_path(const mc_detector *d);

/* Keypoints below the threshold are not reported (default: the sidecar's,
 * else 0.3).  0 reports every joint, whatever its confidence (e.g. for an
 * initialisation that weighs them itself). */
float mc_detector_threshold(const mc_detector *d);
void mc_detector_set_threshold(mc_detector *d, float threshold);

/* Heatmap models: whether each view is also run mirrored (left to right),
 * its heat maps mirrored back with each left/right pair's channels
 * exchanged, and averaged with the plain pass's (a flip test: twice the
 * network's cost; docs/DETECT_RUNTIME.md, "Flip test").  Off by default; no
 * effect on MoveNet models. */
void mc_detector_set_flip(mc_detector *d, int on);
/* Whether the flip test is on (never for MoveNet models). */
int mc_detector_flip(const mc_detector *d);

/* MoveNet models (sidecar "decoder": "movenet"): whether a second pass looks
 * at a square around the person the first pass found (the sidecar's
 * "refine", default on).  No effect on heatmap models. */
void mc_detector_set_refine(mc_detector *d, int on);

/* A square of a view (native pixels; it may reach outside the image). */
typedef struct {
	float x0, y0, size;
} mc_detector_square;

/* Where the person is expected in the next view, e.g. around the tracked
 * pose (mc_detector_square_around).  MoveNet models then look there once,
 * instead of at the whole view and then at the person, and fall back to
 * those two looks when that look does not find the torso.  It applies to
 * the next mc_detector_detect call only; NULL clears it.  No effect on
 * heatmap models. */
void mc_detector_set_person_square(mc_detector *d, const mc_detector_square *sq);

/* The square around joints (rig frame, metres) seen from rig camera cam:
 * centred on their bounding box in the image, 1.25 times its larger half
 * side plus 3 % of the image's larger side (the body moves between the
 * pose and the view).  Returns 0, or -1 when fewer than three joints are in
 * front of the camera. */
int mc_detector_square_around(const mc_camera *cam, const mc_vec3 *joints_rig, int n, mc_detector_square *out);

/* OpenCV's thread count for the whole process (>= 1). */
void mc_detector_set_threads(int nthreads);

/* Detects the joints of one view: packed RGB24, width x height, stride bytes
 * per row (0: 3 * width).  Writes at most max detections (in joint order;
 * max >= mc_detector_njoints(d) gets them all) and returns how many, or -1
 * with err. */
int mc_detector_detect(mc_detector *d, const uint8_t *rgb, int width, int height, int stride, mc_detection *out,
		       int max, mc_err *err);

/* The heatmaps of the last mc_detector_detect call (J x H x W floats, row
 * major, valid until the next call), for drawing and debugging. */
const float *mc_detector_heatmaps(const mc_detector *d, int *njoints, int *height, int *width);

void mc_detector_get_timing(const mc_detector *d, mc_detector_timing *t);

/* The decoding on its own (what mc_detector_detect applies to the network's
 * output; tools/train/common.py decode() is the same): for each of J
 * heatmaps (H x W, row major), confidence = the map's maximum; heatmaps
 * whose maximum is below threshold are skipped.  The keypoint (x_c, y_c) in
 * cells: with sigma 0, the argmax cell (the first in raster order on ties)
 * moved to the centroid of its 3x3 window weighted by the values (clipped at
 * the borders; negative values weigh 0); with sigma > 0 (the sidecar's
 * heatmap_sigma, the training targets' Gaussian), the map is smoothed by a
 * Gaussian of sigma cells, and the smoothed map's argmax moves to the
 * vertex of the parabola through its logs at the cell and its two
 * neighbours, in x and in y (DARK).  Then input pixels u_in = (x_c + 0.5) *
 * in_w / W - 0.5, native pixels u = (u_in + 0.5) * native_w / in_w - 0.5
 * (same for v).  Returns the count written (at most max). */
int mc_detector_decode(const float *heatmaps, int njoints, int height, int width, int in_w, int in_h, int native_w,
		       int native_h, float threshold, float sigma, mc_detection *out, int max);

/* Default joint names, in the order of the shipped model's heatmaps:
 * head_top, neck, spine, pelvis, left_shoulder, left_elbow, left_wrist,
 * left_hip, left_knee, left_ankle, left_toe, right_shoulder, right_elbow,
 * right_wrist, right_hip, right_knee, right_ankle, right_toe. */
#define MC_DETECTOR_DEFAULT_NJOINTS 18
const char *mc_detector_default_joint_name(int joint);

/* ---- From detections to the tracker's keypoints. */

/* map[j] for each detector joint j: the index of the joint of the same name
 * in names[0..nnames-1], or -1 (dropped).  map has mc_detector_njoints(d)
 * entries.  Returns how many detector joints found a match. */
int mc_detector_map_names(const mc_detector *d, const char *const *names, int nnames, int *map);
/* The same against a body model's joint names. */
int mc_detector_map_model(const mc_detector *d, const mc_model *model, int *map);

/* Detections of rig camera `cam` to mc_keypoint (cam, model joint index
 * through map, u, v, confidence); unmapped joints are dropped.  Returns the
 * count written (at most max). */
int mc_detections_to_keypoints(const mc_detection *det, int ndet, int cam, const int *map, mc_keypoint *out,
			       int max);

/* Every view of one frame set (views[i] is rig camera i; rgb NULL: missing,
 * skipped), through one detector, to keypoints for mc_tracker_track (or an
 * initialisation from both views of one instant).  Returns the keypoint
 * count (at most max) or -1 with err. */
int mc_detector_detect_views(mc_detector *d, const mc_frame_view *views, int nviews, const int *map,
			     mc_keypoint *out, int max, mc_err *err);

#ifdef __cplusplus
}
#endif

#endif
