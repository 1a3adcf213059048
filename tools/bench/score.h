/* mocap-bench's scoring against the clip's ground truth: MPJPE over the
 * evaluated joints (docs/CONVENTIONS.md) and by joint group, the error by
 * reported confidence, the pose held still for reference, the jitter
 * (mc_jitter), and the reports printed from them. */
#ifndef BENCH_SCORE_H
#define BENCH_SCORE_H

#include "eval/mc_clip.h"
#include "eval/mc_jitter.h"
#include "eval/mc_simdet.h"
#include "track/mc_tracker.h"

#define BENCH_NEVAL 15
extern const char *const bench_eval_joints[BENCH_NEVAL];
/* The joints the simulated detector gives (--simulated-detector): those
 * of the shipped detector of the clip's rig, so that the tracker gets what
 * it gets from that detector.  Head-mounted: the runtime's 18
 * (mc_detector_default_joint_name: head_top, spine and pelvis besides the
 * evaluated ones); outside-in: MoveNet's, whose 17 COCO joints name 12 of
 * ours (config/models/outside_detector.json: no neck, no toes).  Until
 * stop 61 both rigs got the 15 evaluated joints.  Returns their number. */
#define BENCH_MAX_SIM_JOINTS 18
int bench_sim_joints(const mc_clip *clip, const char *names[BENCH_MAX_SIM_JOINTS]);
/* The limbs' ends, for how long a limb stays lost (the LIMBS line). */
#define BENCH_NLIMBS 4
#define BENCH_LIMB_LOST_M 0.20
extern const char *const bench_limb_ends[BENCH_NLIMBS];

typedef struct {
	int frames;
	double *ms;
	long iterations; /* gradient iterations run, over all frame sets */
	double err_sum[BENCH_NEVAL];
	int err_n;
	double still_sum[BENCH_NEVAL]; /* holding the initial pose for every frame */
	int states[MC_TRACK_INITIALISING + 1];
	int first_tracked; /* first frame set out of the initialising state, -1: none */
	double conf_sum[BENCH_NEVAL];
	/* joint estimates binned by their reported confidence (quarters of
	 * [0, 1]): how many, and their summed error */
	int conf_n[4];
	double conf_err[4];
	mc_jitter jitter; /* over the tracked frame sets, initialised by bench_score_begin */
	mc_simdet_stats sim; /* what the simulated detector did */
	/* per limb end (bench_limb_ends): frame sets in a row, now and at
	 * most, with the joint more than BENCH_LIMB_LOST_M off */
	int limb_run[BENCH_NLIMBS], limb_longest[BENCH_NLIMBS];
	/* the same counting only frame sets where the truth's joint projects
	 * into some camera's image; those where it does not neither count
	 * nor end a run (issue 35: "a limb in view is never lost for more
	 * than 0.5 s") */
	int view_run[BENCH_NLIMBS], view_longest[BENCH_NLIMBS];
	double frame_dt; /* seconds between scored frame sets */
} bench_stats;

/* Before the first frame set: the jitter's joints and the time between
 * tracked frame sets (frame_step of the clip's frames). */
void bench_score_begin(const mc_clip *clip, int frame_step, bench_stats *st);
/* Scores frame set k's estimate sk (and the still pose) against the truth. */
void bench_score_frame(const mc_clip *clip, int k, const mc_skeleton *sk, const mc_skeleton *still, bench_stats *st);
/* MPJPE in metres over the frame sets scored so far. */
double bench_mpjpe(const bench_stats *st);

void bench_print_accuracy(const mc_clip *clip, const bench_stats *st);
/* JITTER clip=NAME vel_err_ms=X accel_ratio=Y (nan when undefined). */
void bench_print_jitter(const mc_clip *clip, const bench_stats *st);
/* How long each limb stayed lost: the longest run of frame sets with its
 * end more than 20 cm from the truth, in seconds, and the worst of them:
 *   LIMBS clip=NAME left_wrist=S right_wrist=S left_ankle=S right_ankle=S worst_s=S */
void bench_print_limbs(const mc_clip *clip, const bench_stats *st);
/* What the simulated detector did, as shares:
 *   SIMDET clip=NAME keypoints=N far_pct=F collapsed_pct=C swapped_pct=S occluded_pct=O
 *     occluded_wrong_pct=W outlier_pct=X
 * far: keypoints more than 10 px (128-wide scale) off; collapsed, swapped:
 * of the (view, pair) cases with both keypoints; occluded: of the
 * keypoints of paired joints checked; occluded_wrong: of those occluded
 * ones; outlier: of the keypoints. */
void bench_print_simdet(const mc_clip *clip, const mc_simdet_stats *s);
/* --init detect: when tracking started and, with a ground truth, the
 * bone lengths against it (the BONES line). */
void bench_print_init_report(const mc_tracker *t, const mc_clip *clip, const bench_stats *st);

typedef struct {
	double median, p95, p99, mean;
} bench_timing;
bench_timing bench_timing_of(const double *ms, int n);

#endif
