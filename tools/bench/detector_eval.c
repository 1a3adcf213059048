#include "detector_eval.h"

#include "base/mc_stats.h"
#include "base/mc_time.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A detection further than this from the projected ground truth (pixels at
 * the detector's input resolution) counts as false. */
#define FALSE_PX 10.0
/* A keypoint agrees with the other views when their triangulation lands
 * within this many pixels of it, at a 640-pixel image side (issue 36). */
#define AGREE_PX_AT_640 15.0

int bench_detector_open(bench_detector *bd, const char *path, const mc_model *model, const mc_clip *clip, int every,
			int nframes, mc_err *err)
{
	memset(bd, 0, sizeof(*bd));
	bd->det = mc_detector_load(path, err);
	if (!bd->det)
		return -1;
	bd->every = every > 0 ? every : 1;
	if (mc_detector_map_model(bd->det, model, bd->model_map) == 0) {
		mc_err_set(err, "%s: none of its joints is in the body model", path);
		bench_detector_close(bd);
		return -1;
	}
	int nj = mc_detector_njoints(bd->det);
	for (int j = 0; j < nj; j++) {
		const char *name = mc_detector_joint_name(bd->det, j);
		bd->gt_map[j] = mc_clip_joint(clip, name);
		bd->group[j] = bench_joint_group(name); /* -1: not evaluated */
	}
	bd->cap = nframes * clip->rig.ncams * nj;
	bd->views_cap = nframes * clip->rig.ncams;
	bd->view_ms = calloc((size_t)bd->views_cap + 1, sizeof(double));
	for (int g = 0; g < BENCH_GROUPS; g++)
		bd->err[g] = calloc((size_t)bd->cap + 1, sizeof(double));
	for (int g = 0; g < BENCH_GROUPS; g++)
		if (!bd->err[g] || !bd->view_ms) {
			bench_detector_close(bd);
			return mc_err_set(err, "out of memory for the detector's scores");
		}
	return 0;
}

void bench_detector_close(bench_detector *bd)
{
	mc_detector_free(bd->det);
	for (int g = 0; g < BENCH_GROUPS; g++)
		free(bd->err[g]);
	free(bd->view_ms);
	memset(bd, 0, sizeof(*bd));
}

/* Scores one view's detections against the ground truth of frame k. */
static void score_view(bench_detector *bd, const mc_clip *clip, int k, int cam, const mc_detection *det, int ndet,
		       double scale)
{
	const mc_camera *c = &clip->rig.cams[cam];
	int nj = mc_detector_njoints(bd->det);
	const mc_detection *found[MC_DETECTOR_MAX_JOINTS] = {0};
	for (int i = 0; i < ndet; i++)
		found[det[i].joint] = &det[i];
	for (int j = 0; j < nj; j++) {
		int g = bd->group[j];
		if (g < 0 || bd->gt_map[j] < 0)
			continue;
		double u, v;
		bool inside = mc_camera_project_rig(c, mc_clip_gt(clip, k, bd->gt_map[j]), &u, &v) &&
			      u >= -0.5 && v >= -0.5 && u < c->width - 0.5 && v < c->height - 0.5;
		bd->in_image += inside;
		bd->reported += found[j] != NULL;
		if (!found[j]) {
			bd->missed += inside;
			continue;
		}
		if (!inside) {
			bd->false_pos++;
			continue;
		}
		double du = (found[j]->u - u) * scale, dv = (found[j]->v - v) * scale;
		double e = sqrt(du * du + dv * dv);
		bd->false_pos += e > FALSE_PX;
		if (bd->nerr[g] < bd->cap)
			bd->err[g][bd->nerr[g]++] = e;
	}
}

void bench_detector_hints(const mc_tracker *t, const mc_clip *clip, mc_detector_square sq[MC_MAX_CAMERAS])
{
	mc_tracker_init_info info;
	mc_tracker_get_init_info(t, &info);
	const mc_model *m = mc_tracker_model(t);
	mc_fk fk;
	mc_vec3 joints[MC_MAX_JOINTS];
	mc_model_fk(m, mc_tracker_pose(t), &fk);
	for (int j = 0; j < m->njoints; j++)
		joints[j] = fk.rig_from_joint[j].t;
	for (int c = 0; c < clip->rig.ncams; c++)
		if (info.initialising || mc_detector_square_around(&clip->rig.cams[c], joints, m->njoints, &sq[c]) < 0)
			sq[c].size = 0;
}

int bench_detector_run(bench_detector *bd, const mc_clip *clip, int k, const mc_frame_view *views, int nviews,
		       const mc_detector_square *hints, mc_keypoint *kp, int max, mc_err *err)
{
	if (k % bd->every != 0)
		return 0;
	int n = 0, in_w, in_h;
	mc_detector_input_size(bd->det, &in_w, &in_h);
	for (int c = 0; c < nviews; c++) {
		mc_detection det[MC_DETECTOR_MAX_JOINTS];
		uint64_t t0 = mc_now_ns();
		mc_detector_set_person_square(bd->det, hints && hints[c].size > 0 ? &hints[c] : NULL);
		int nd = mc_detector_detect(bd->det, views[c].rgb, views[c].width, views[c].height, views[c].stride, det,
					    MC_DETECTOR_MAX_JOINTS, err);
		if (nd < 0)
			return -1;
		if (bd->nviews < bd->views_cap)
			bd->view_ms[bd->nviews++] = mc_ms_since(t0);
		score_view(bd, clip, k, c, det, nd, (double)in_w / views[c].width);
		n += mc_detections_to_keypoints(det, nd, c, bd->model_map, kp + n, max - n);
	}
	mc_view_agreement_add(&bd->agree, &clip->rig, kp, n, 0.0, AGREE_PX_AT_640);
	return n;
}

/* How far the views agree (clips with four cameras or more): the measure
 * for footage without ground truth, printed for every clip. */
static void report_agreement(const bench_detector *bd, const mc_clip *clip)
{
	if (bd->agree.checked == 0)
		return;
	double pct = 100.0 * (double)bd->agree.agreed / (double)bd->agree.checked;
	printf("  views  %.1f %% of %ld keypoints lie within %.0f px (at 640) of their joint triangulated from three "
	       "other cameras\n",
	       pct, bd->agree.checked, AGREE_PX_AT_640);
	printf("AGREE clip=%s checked=%ld agreed_pct=%.1f\n", clip->name, bd->agree.checked, pct);
}

/* MoveNet with --detector-hint pose: how often the look at the tracked
 * pose sufficed. */
static void report_one_look(const bench_detector *bd)
{
	mc_detector_timing tm;
	mc_detector_get_timing(bd->det, &tm);
	if (tm.one_look > 0)
		printf("  looks  one (at the tracked pose) in %llu of %llu views, else two\n",
		       (unsigned long long)tm.one_look, (unsigned long long)tm.calls);
}

/* A clip without ground truth: the cost and the agreement across views (no
 * DETECT2D line, as nothing was scored). */
static void report_cost_only(bench_detector *bd, const mc_clip *clip)
{
	mc_stats_sort(bd->view_ms, (size_t)bd->nviews);
	printf("detector (%s): 2D error not scored (the clip has no gt.json); cost %.2f ms per view (median of %d "
	       "views, one thread)\n",
	       mc_detector_path(bd->det), mc_stats_percentile(bd->view_ms, (size_t)bd->nviews, 50), bd->nviews);
	report_one_look(bd);
	report_agreement(bd, clip);
}

void bench_detector_report(bench_detector *bd, const mc_clip *clip)
{
	if (!clip->has_gt) {
		report_cost_only(bd, clip);
		return;
	}
	const char *clip_name = clip->name;
	int in_w, in_h;
	mc_detector_input_size(bd->det, &in_w, &in_h);
	printf("detector (%s), 2D error at %dx%d against the projected ground truth:\n", mc_detector_path(bd->det), in_w,
	       in_h);
	double *all = calloc((size_t)bd->cap * BENCH_GROUPS + 1, sizeof(double));
	int nall = 0;
	for (int g = 0; g < BENCH_GROUPS; g++) {
		mc_stats_sort(bd->err[g], (size_t)bd->nerr[g]);
		printf("  %-6s median %5.2f px, p90 %5.2f px (%d detections)\n", bench_group_name(g),
		       mc_stats_percentile(bd->err[g], (size_t)bd->nerr[g], 50),
		       mc_stats_percentile(bd->err[g], (size_t)bd->nerr[g], 90), bd->nerr[g]);
		if (all) {
			memcpy(all + nall, bd->err[g], sizeof(double) * (size_t)bd->nerr[g]);
			nall += bd->nerr[g];
		}
	}
	mc_stats_sort(all, (size_t)nall);
	mc_stats_sort(bd->view_ms, (size_t)bd->nviews);
	double med = all ? mc_stats_percentile(all, (size_t)nall, 50) : 0, p90 = all ? mc_stats_percentile(all, (size_t)nall, 90) : 0;
	double ms = mc_stats_percentile(bd->view_ms, (size_t)bd->nviews, 50);
	printf("  all    median %5.2f px, p90 %5.2f px; missed %d of %d joints inside the image (body-occluded ones "
	       "count too), %d false (outside the image or > %.0f px off) of %d reported\n",
	       med, p90, bd->missed, bd->in_image, bd->false_pos, FALSE_PX, bd->reported);
	printf("  cost   %.2f ms per view (median of %d views, one thread)\n", ms, bd->nviews);
	report_one_look(bd);
	printf("DETECT2D clip=%s median_px=%.2f p90_px=%.2f missed=%d in_image=%d false=%d reported=%d ms_view=%.2f\n",
	       clip_name, med, p90, bd->missed, bd->in_image, bd->false_pos, bd->reported, ms);
	report_agreement(bd, clip);
	free(all);
}
