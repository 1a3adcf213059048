/* The detector inside mocap-bench (--detector MODEL): runs the 2D joint
 * detector on every view of a frame set, hands its keypoints to the
 * tracker, and scores the detections in 2D against the clip's ground truth
 * projected through the rig (for the report only: the tracker never sees
 * the ground truth). */
#ifndef BENCH_DETECTOR_EVAL_H
#define BENCH_DETECTOR_EVAL_H

#include "eval/mc_clip.h"
#include "eval/mc_view_agreement.h"
#include "mc_detector.h"
#include "bench/joint_groups.h"


typedef struct {
	mc_detector *det;
	int model_map[MC_DETECTOR_MAX_JOINTS]; /* detector joint -> model joint, -1 */
	int gt_map[MC_DETECTOR_MAX_JOINTS];    /* detector joint -> gt joint, -1 */
	int group[MC_DETECTOR_MAX_JOINTS];     /* report group, -1: not evaluated */
	int every;                             /* detect on every Nth frame set */
	/* 2D scoring, pixels at the detector's input resolution */
	double *err[BENCH_GROUPS];
	int nerr[BENCH_GROUPS], cap;
	int in_image, missed, false_pos, reported;
	/* agreement across views (4+ cameras; eval/mc_view_agreement.h) */
	mc_view_agreement agree;
	/* cost */
	double *view_ms;
	int nviews, views_cap;
} bench_detector;

/* Loads the model and maps its joints to the model's and the clip's;
 * nframes sizes the score buffers. */
int bench_detector_open(bench_detector *bd, const char *path, const mc_model *model, const mc_clip *clip, int every,
			int nframes, mc_err *err);
void bench_detector_close(bench_detector *bd);

/* Where the tracker's current pose is in each view (sq[c]; size 0: none),
 * for the detector's one look (--detector-hint pose), as mocapd does; all
 * none while the tracker waits for a first pose.  Call it while the tracker
 * is idle. */
void bench_detector_hints(const mc_tracker *t, const mc_clip *clip, mc_detector_square sq[MC_MAX_CAMERAS]);

/* Frame set k: detects (when k is a detection frame; hints[c], when not
 * NULL, says where the person is in view c), scores and writes the
 * tracker's keypoints.  Returns their count, or -1 with err. */
int bench_detector_run(bench_detector *bd, const mc_clip *clip, int k, const mc_frame_view *views, int nviews,
		       const mc_detector_square *hints, mc_keypoint *kp, int max, mc_err *err);

/* The 2D report and its machine-readable DETECT2D line; on a clip without
 * gt.json only the cost. */
void bench_detector_report(bench_detector *bd, const mc_clip *clip);

#endif
