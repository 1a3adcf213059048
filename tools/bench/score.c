#include "bench/score.h"

#include "base/mc_stats.h"
#include "bench/joint_groups.h"
#include "mc_detector.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *const bench_eval_joints[BENCH_NEVAL] = {
	"neck",      "left_shoulder", "left_elbow",     "left_wrist",  "left_hip",    "left_knee",
	"left_ankle", "left_toe",     "right_shoulder", "right_elbow", "right_wrist", "right_hip",
	"right_knee", "right_ankle",  "right_toe",
};

_Static_assert(MC_DETECTOR_DEFAULT_NJOINTS <= BENCH_MAX_SIM_JOINTS, "the runtime's joints fit the simulated ones");

int bench_sim_joints(const mc_clip *clip, const char *names[BENCH_MAX_SIM_JOINTS])
{
	static const char *const movenet[] = {
		"left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
		"left_hip",      "right_hip",      "left_knee",  "right_knee",  "left_ankle", "right_ankle",
	};
	int n = 0;
	if (clip->layout == MC_CLIP_OUTSIDE)
		for (; n < (int)(sizeof(movenet) / sizeof(movenet[0])); n++)
			names[n] = movenet[n];
	else
		for (; n < BENCH_MAX_SIM_JOINTS && mc_detector_default_joint_name(n); n++)
			names[n] = mc_detector_default_joint_name(n);
	return n;
}

const char *const bench_limb_ends[BENCH_NLIMBS] = {"left_wrist", "right_wrist", "left_ankle", "right_ankle"};

static int skeleton_joint(const mc_skeleton *sk, const char *name)
{
	for (int j = 0; j < sk->njoints; j++)
		if (!strcmp(sk->joints[j].name, name))
			return j;
	return -1;
}

/* Evaluated joint e of sk.  A joint the model lacks is placed at the
 * camera, so that it cannot improve any score. */
static mc_vec3 estimate_of(const mc_skeleton *sk, int e)
{
	int m = skeleton_joint(sk, bench_eval_joints[e]);
	return m >= 0 ? sk->joints[m].position : mc_v3(0, 0, 0);
}

static void score(const mc_clip *clip, int k, const mc_skeleton *sk, double err_sum[BENCH_NEVAL])
{
	for (int e = 0; e < BENCH_NEVAL; e++) {
		int g = mc_clip_joint(clip, bench_eval_joints[e]);
		if (g >= 0)
			err_sum[e] += mc_v3_norm(mc_v3_sub(estimate_of(sk, e), mc_clip_gt(clip, k, g)));
	}
}

/* Whether the reported per-joint confidence says something: the error of
 * the joint estimates per confidence quarter. */
static void score_confidence(const mc_clip *clip, int k, const mc_skeleton *sk, bench_stats *st)
{
	for (int e = 0; e < BENCH_NEVAL; e++) {
		int g = mc_clip_joint(clip, bench_eval_joints[e]), j = skeleton_joint(sk, bench_eval_joints[e]);
		if (g < 0 || j < 0)
			continue;
		double c = sk->joints[j].confidence;
		int bin = c >= 1 ? 3 : (c > 0 ? (int)(4 * c) : 0);
		st->conf_sum[e] += c;
		st->conf_n[bin]++;
		st->conf_err[bin] += mc_v3_norm(mc_v3_sub(sk->joints[j].position, mc_clip_gt(clip, k, g)));
	}
}

void bench_score_begin(const mc_clip *clip, int frame_step, bench_stats *st)
{
	int n = 0;
	for (int e = 0; e < BENCH_NEVAL; e++)
		n += mc_clip_joint(clip, bench_eval_joints[e]) >= 0;
	mc_jitter_init(&st->jitter, n, frame_step / clip->gt.fps);
	st->frame_dt = frame_step / clip->gt.fps;
}

/* One more frame set of a run: lost lengthens it, found ends it. */
static void count_run(bool lost, int *run, int *longest)
{
	*run = lost ? *run + 1 : 0;
	if (*run > *longest)
		*longest = *run;
}

/* Runs of frame sets with a limb's end more than BENCH_LIMB_LOST_M off:
 * every frame set, and those where the end is in view. */
static void score_limbs(const mc_clip *clip, int k, const mc_skeleton *sk, bench_stats *st)
{
	for (int l = 0; l < BENCH_NLIMBS; l++) {
		int g = mc_clip_joint(clip, bench_limb_ends[l]), j = skeleton_joint(sk, bench_limb_ends[l]);
		if (g < 0)
			continue;
		mc_vec3 truth = mc_clip_gt(clip, k, g);
		bool lost = j < 0 || mc_v3_norm(mc_v3_sub(sk->joints[j].position, truth)) > BENCH_LIMB_LOST_M;
		count_run(lost, &st->limb_run[l], &st->limb_longest[l]);
		if (mc_rig_sees(&clip->rig, truth))
			count_run(lost, &st->view_run[l], &st->view_longest[l]);
	}
}

/* The jitter over the joints MPJPE scores; a frame set still waiting for a
 * first pose was not tracked, so it breaks the differences. */
static void score_jitter(const mc_clip *clip, int k, const mc_skeleton *sk, bench_stats *st)
{
	if (sk->state == MC_TRACK_INITIALISING) {
		mc_jitter_break(&st->jitter);
		return;
	}
	mc_vec3 est[BENCH_NEVAL], gt[BENCH_NEVAL];
	int n = 0;
	for (int e = 0; e < BENCH_NEVAL; e++) {
		int g = mc_clip_joint(clip, bench_eval_joints[e]);
		if (g < 0)
			continue;
		est[n] = estimate_of(sk, e);
		gt[n++] = mc_clip_gt(clip, k, g);
	}
	mc_jitter_add(&st->jitter, est, gt);
}

void bench_score_frame(const mc_clip *clip, int k, const mc_skeleton *sk, const mc_skeleton *still, bench_stats *st)
{
	score(clip, k, sk, st->err_sum);
	score_confidence(clip, k, sk, st);
	score(clip, k, still, st->still_sum);
	score_jitter(clip, k, sk, st);
	score_limbs(clip, k, sk, st);
	st->err_n++;
}

double bench_mpjpe(const bench_stats *st)
{
	double sum = 0;
	for (int e = 0; e < BENCH_NEVAL; e++)
		sum += st->err_sum[e];
	return st->err_n ? sum / (st->err_n * BENCH_NEVAL) : 0;
}

static void print_states(const bench_stats *st)
{
	printf("(states: %d ok, %d uncertain, %d lost, %d initialising)\n", st->states[MC_TRACK_OK],
	       st->states[MC_TRACK_UNCERTAIN], st->states[MC_TRACK_LOST], st->states[MC_TRACK_INITIALISING]);
}

/* Without a ground truth only the states are reported. */
static void print_unscored(const mc_clip *clip, const bench_stats *st)
{
	printf("accuracy: not scored (%s has no gt.json)\n  %d frames ", clip->name, st->frames);
	print_states(st);
}

void bench_print_accuracy(const mc_clip *clip, const bench_stats *st)
{
	if (!clip->has_gt) {
		print_unscored(clip, st);
		return;
	}
	printf("accuracy (MPJPE, cm, %s, no alignment, %d camera%s):\n",
	       clip->layout == MC_CLIP_OUTSIDE ? "world frame" : "left camera frame", clip->rig.ncams,
	       clip->rig.ncams == 1 ? "" : "s");
	for (int g = 0; g < BENCH_GROUPS; g++) {
		double sum = 0;
		int n = 0;
		for (int e = 0; e < BENCH_NEVAL; e++)
			if (bench_joint_group(bench_eval_joints[e]) == g) {
				sum += st->err_sum[e];
				n++;
			}
		printf("  %-6s %6.2f\n", bench_group_name(g), n ? 100.0 * sum / (n * st->err_n) : 0);
	}
	for (int e = 0; e < BENCH_NEVAL; e++)
		printf("  %-15s %6.2f   (mean confidence %.2f)\n", bench_eval_joints[e],
		       100.0 * st->err_sum[e] / st->err_n, st->conf_sum[e] / st->err_n);
	double still = 0;
	for (int e = 0; e < BENCH_NEVAL; e++)
		still += st->still_sum[e];
	printf("  holding the initial pose instead (no tracking): %.2f\n",
	       st->err_n ? 100.0 * still / (st->err_n * BENCH_NEVAL) : 0.0);
	printf("  overall %6.2f over %d frames ", 100.0 * bench_mpjpe(st), st->err_n);
	print_states(st);
	printf("  error by reported joint confidence:");
	for (int b = 0; b < 4; b++)
		printf("  %.2f-%.2f: %.2f cm (%d)", b / 4.0, (b + 1) / 4.0,
		       st->conf_n[b] ? 100.0 * st->conf_err[b] / st->conf_n[b] : 0.0, st->conf_n[b]);
	printf("\n");
}

void bench_print_jitter(const mc_clip *clip, const bench_stats *st)
{
	printf("JITTER clip=%s vel_err_ms=%.3f accel_ratio=%.3f\n", clip->name, mc_jitter_vel_err(&st->jitter),
	       mc_jitter_accel_ratio(&st->jitter));
}

void bench_print_limbs(const mc_clip *clip, const bench_stats *st)
{
	int worst = 0, worst_in_view = 0;
	printf("LIMBS clip=%s", clip->name);
	for (int l = 0; l < BENCH_NLIMBS; l++) {
		printf(" %s=%.2f", bench_limb_ends[l], st->limb_longest[l] * st->frame_dt);
		if (st->limb_longest[l] > worst)
			worst = st->limb_longest[l];
		if (st->view_longest[l] > worst_in_view)
			worst_in_view = st->view_longest[l];
	}
	printf(" worst_s=%.2f worst_in_view_s=%.2f\n", worst * st->frame_dt, worst_in_view * st->frame_dt);
}

/* The bone length of model joint j (to its parent) in the ground truth:
 * the median over the clip, or -1 when the clip lacks either end. */
static double gt_bone_length(const mc_clip *clip, const mc_model *m, int j)
{
	int p = m->joints[j].parent;
	int a = mc_clip_joint(clip, m->joints[j].name), b = p >= 0 ? mc_clip_joint(clip, m->joints[p].name) : -1;
	if (a < 0 || b < 0 || clip->gt.nframes <= 0)
		return -1;
	double *len = malloc(sizeof(double) * clip->gt.nframes);
	if (!len)
		return -1;
	for (int k = 0; k < clip->gt.nframes; k++)
		len[k] = mc_v3_norm(mc_v3_sub(mc_clip_gt(clip, k, a), mc_clip_gt(clip, k, b)));
	mc_stats_sort(len, clip->gt.nframes);
	double v = mc_stats_percentile(len, clip->gt.nframes, 50);
	free(len);
	return v;
}

/* The BONES line: the bone lengths the tracker measured against the ground
 * truth's. */
static void print_bones(const mc_tracker *t, const mc_clip *clip, const bench_stats *st)
{
	const mc_model *m = mc_tracker_model(t);
	double sum = 0, worst = 0;
	int n = 0;
	printf("  bone lengths (cm, estimate / ground truth):");
	for (int j = 0; j < m->njoints; j++) {
		double gt = gt_bone_length(clip, m, j), rest = mc_v3_norm(m->joints[j].offset);
		if (gt < 0.05 || rest < 1e-3)
			continue;
		double est = m->bone_scale[j] * rest, e = fabs(est - gt) / gt;
		printf(" %s %.1f/%.1f", m->joints[j].name, 100 * est, 100 * gt);
		sum += e;
		worst = fmax(worst, e);
		n++;
	}
	printf("\nBONES clip=%s bones=%d mean_err_pct=%.1f max_err_pct=%.1f first_frame=%d\n", clip->name, n,
	       n ? 100 * sum / n : 0, 100 * worst, st->first_tracked);
}

void bench_print_init_report(const mc_tracker *t, const mc_clip *clip, const bench_stats *st)
{
	mc_tracker_init_info in;
	mc_tracker_get_init_info(t, &in);
	printf("init from detections: first pose at frame set %d (%.2f s), size %s (bone scale %.3f) from %d frame "
	       "sets, %d re-fits, turned around %d times\n",
	       st->first_tracked, st->first_tracked >= 0 ? st->first_tracked / clip->gt.fps : -1.0,
	       in.shape_measured ? "measured" : "NOT measured", in.scale, in.shape_frames, in.refits, in.turns);
	if (clip->has_gt)
		print_bones(t, clip, st);
}

static double pct(long a, long b)
{
	return b ? 100.0 * a / b : 0;
}

void bench_print_simdet(const mc_clip *clip, const mc_simdet_stats *s)
{
	printf("SIMDET clip=%s keypoints=%ld far_pct=%.1f collapsed_pct=%.1f swapped_pct=%.1f occluded_pct=%.1f "
	       "occluded_wrong_pct=%.1f outlier_pct=%.1f\n",
	       clip->name, s->keypoints, pct(s->far, s->keypoints), pct(s->collapsed, s->pairs),
	       pct(s->swapped, s->pairs), pct(s->occluded, s->keypoints), pct(s->occluded_wrong, s->occluded),
	       pct(s->outliers, s->keypoints));
}

bench_timing bench_timing_of(const double *ms, int n)
{
	double *sorted = malloc(sizeof(double) * (n ? n : 1));
	bench_timing t = {0, 0, 0, 0};
	if (!sorted || n == 0) {
		free(sorted);
		return t;
	}
	memcpy(sorted, ms, sizeof(double) * n);
	mc_stats_sort(sorted, (size_t)n);
	for (int i = 0; i < n; i++)
		t.mean += sorted[i] / n;
	t.median = mc_stats_percentile(sorted, (size_t)n, 50);
	t.p95 = mc_stats_percentile(sorted, (size_t)n, 95);
	t.p99 = mc_stats_percentile(sorted, (size_t)n, 99);
	free(sorted);
	return t;
}
