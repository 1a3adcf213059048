/* mocap-bench: tracks an evaluation clip from its images and scores it
 * against gt.json (a clip without one, real footage, is tracked from the
 * detections and not scored).  Both layouts of ../shared/data are read (mc_clip):
 * head-mounted stereo fisheye (ego/<clip>) and outside-in static cameras
 * (outside/<clip>, tracked with a free root; --cameras picks a subset).
 *
 * Evaluation protocol (docs/CONVENTIONS.md): only the images, the calibration and the
 * ground truth of frame 0 (to initialise pose and bone lengths) are used;
 * MPJPE in cm over the evaluated joints, in the rig frame (the left camera
 * frame, or the world frame outside-in), with no alignment.  The last
 * lines are machine-readable:
 *   RESULT clip=NAME frames=N mpjpe_cm=X fps=Y ms_p99=Z device=DEV cameras=C iterations=I
 *   JITTER clip=NAME vel_err_ms=V accel_ratio=A
 *   LIMBS clip=NAME left_wrist=S right_wrist=S left_ankle=S right_ankle=S worst_s=S
 * (I: gradient iterations per frame set, averaged over the clip; V, A:
 * bench/score.h and core/eval/mc_jitter.h) */
#include "base/mc_parse.h"
#include "base/mc_stats.h"
#include "base/mc_thread.h"
#include "base/mc_time.h"
#include "energy/mc_energy.h"
#include "energy/mc_cl.h"
#include "eval/mc_clip.h"
#include "image/mc_draw.h"
#include "track/mc_tracker.h"
#include "bench/detector_eval.h"
#include "bench/keypoints_out.h"
#include "bench/model_floor.h"
#include "bench/options.h"
#include "bench/score.h"
#include "bench/thesis.h"
#include "mc_install_paths.h" /* generated: MC_INSTALL_DATA_DIR */

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define BENCH_MAX_KEYPOINTS (MC_MAX_CAMERAS * MC_DETECTOR_MAX_JOINTS)
#define BENCH_DETECTOR_NICE 10 /* mocapd's [detector] nice default */



/* ---- tracking ---------------------------------------------------------- */

static mc_tracker *start_tracker(const options *o, const mc_clip *clip, const mc_tracker_settings *s, mc_err *err)
{
	mc_model model;
	if (mc_model_load(o->model_path, &model, err) < 0)
		return NULL;
	mc_tracker *t = mc_tracker_create(&clip->rig, &model, s, err);
	if (t && o->prior_path && mc_tracker_load_pose_prior(t, o->prior_path, err) < 0) {
		mc_tracker_destroy(t);
		return NULL;
	}
	if (t && o->init_detect) {
		if (mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, err) < 0) {
			mc_tracker_destroy(t);
			return NULL;
		}
		return t;
	}
	if (t && mc_clip_init_tracker(clip, t, err) < 0) {
		mc_tracker_destroy(t);
		return NULL;
	}
	return t;
}

static void write_estimate(FILE *out, int k, const mc_skeleton *sk)
{
	fprintf(out, "{\"index\": %d, \"state\": \"%s\", \"joints\": {", k, mc_track_state_name(sk->state));
	for (int j = 0; j < sk->njoints; j++)
		fprintf(out, "%s\"%s\": [%.5f, %.5f, %.5f]", j ? ", " : "", sk->joints[j].name, sk->joints[j].position.x,
			sk->joints[j].position.y, sk->joints[j].position.z);
	fprintf(out, "}, \"confidence\": {");
	for (int j = 0; j < sk->njoints; j++)
		fprintf(out, "%s\"%s\": %.3f", j ? ", " : "", sk->joints[j].name, sk->joints[j].confidence);
	fprintf(out, "}}\n");
}

/* Left camera image with the estimate (by side colour) and the ground truth
 * (green) drawn over it, as DIR/overlay_%05d.png. */
static void write_overlay(const options *o, const mc_clip *clip, int k, const mc_frame_view *view,
			  const mc_skeleton *sk)
{
	const int zoom = 3; /* small fisheye images: enlarge for reading */
	mc_canvas im = {malloc((size_t)view->width * view->height * 3 * zoom * zoom), view->width * zoom,
			view->height * zoom};
	if (!im.rgb)
		return;
	for (int y = 0; y < im.height; y++)
		for (int x = 0; x < im.width; x++)
			memcpy(im.rgb + ((size_t)y * im.width + x) * 3,
			       view->rgb + (size_t)(y / zoom) * view->stride + 3 * (x / zoom), 3);
	mc_vec3 pos[MC_MAX_JOINTS], gt[MC_MAX_JOINTS];
	int parent[MC_MAX_JOINTS];
	bool have[MC_MAX_JOINTS];
	const char *names[MC_MAX_JOINTS];
	for (int j = 0; j < sk->njoints; j++) {
		int g = mc_clip_joint(clip, sk->joints[j].name);
		pos[j] = sk->joints[j].position;
		parent[j] = sk->joints[j].parent;
		names[j] = sk->joints[j].name;
		have[j] = g >= 0;
		gt[j] = g >= 0 ? mc_clip_gt(clip, k, g) : pos[j];
	}
	double thick = mc_draw_thickness(&im);
	mc_draw_skeleton(&im, &clip->rig.cams[0], sk->njoints, gt, parent, have, NULL, MC_DRAW_GT, 0.6 * thick);
	mc_draw_skeleton(&im, &clip->rig.cams[0], sk->njoints, pos, parent, NULL, names, NULL, thick);
	char path[4096];
	mc_err err;
	snprintf(path, sizeof(path), "%s/overlay_%05d.png", o->overlay_dir, k);
	if (mc_draw_write_png(path, &im, &err) < 0)
		fprintf(stderr, "mocap-bench: %s\n", err.msg);
	free(im.rgb);
}

/* The skeleton of the tracker's current pose (before tracking: the
 * initial pose), for the "no tracking" reference figure. */
static void current_skeleton(const mc_tracker *t, mc_skeleton *sk)
{
	const mc_model *m = mc_tracker_model(t);
	mc_fk fk;
	mc_model_fk(m, mc_tracker_pose(t), &fk);
	memset(sk, 0, sizeof(*sk));
	sk->njoints = m->njoints;
	for (int j = 0; j < m->njoints; j++) {
		snprintf(sk->joints[j].name, sizeof(sk->joints[j].name), "%s", m->joints[j].name);
		sk->joints[j].position = fk.rig_from_joint[j].t;
	}
}

/* The keypoints of frame set k: the detector's (timed with the frame, as
 * part of the cost of tracking it), the simulated detector's, the file's,
 * or none. */
static int frame_keypoints(const options *o, bench_detector *bd, mc_tracker *t, const mc_clip *clip, int k,
			   const mc_frame_view *views, uint64_t *rng, mc_simdet_stats *sim_stats, mc_keypoint *kp, int cap,
			   mc_err *err)
{
	if (bd) {
		mc_detector_square hints[MC_MAX_CAMERAS];
		if (o->detector_hint)
			bench_detector_hints(t, clip, hints);
		return bench_detector_run(bd, clip, k, views, clip->rig.ncams, o->detector_hint ? hints : NULL, kp, cap,
					  err);
	}
	if (o->simulated_detector_px >= 0) {
		const char *joints[BENCH_MAX_SIM_JOINTS];
		int njoints = bench_sim_joints(clip, joints);
		return mc_simdet_keypoints(clip, mc_tracker_model(t), joints, njoints, k, &o->sim, rng, kp, cap,
					   sim_stats);
	}
	if (o->keypoints_in_path)
		return bench_keypoints_frame(&o->keypoints_in, k, kp, cap);
	return 0;
}

/* A tracked frame set: scored against the ground truth (and the pose held
 * still), written, counted, and shown every 30 frame sets. */
static void record_frame(const options *o, const mc_clip *clip, int k, int nframes, const mc_skeleton *sk,
			 const mc_skeleton *still, FILE *out, bench_stats *st)
{
	st->states[sk->state]++;
	st->iterations += sk->iterations;
	if (st->first_tracked < 0 && sk->state != MC_TRACK_INITIALISING)
		st->first_tracked = k;
	if (clip->has_gt)
		bench_score_frame(clip, k, sk, still, st);
	if (out)
		write_estimate(out, k, sk);
	if (!o->quiet && (k % 30 == 0 || k + o->frame_step >= nframes))
		printf("  frame %4d  %-9s  %6.1f ms  running mpjpe %.2f cm\n", k, mc_track_state_name(sk->state),
		       st->ms[st->frames], clip->has_gt ? 100.0 * bench_mpjpe(st) : NAN);
	st->frames++;
}

static int track_frame(const options *o, mc_tracker *t, const mc_clip *clip, const mc_frame_view *views,
		       const mc_keypoint *kp, int nkp, mc_skeleton *sk, mc_err *err)
{
	mc_tracker_init_info info = {0};
	if (o->keypoints_at_iteration > 0)
		mc_tracker_get_init_info(t, &info);
	/* While waiting for a first pose the tracker does not iterate, and
	 * mocapd gives it the newest detections up to 0.3 s old instead. */
	if (o->keypoints_at_iteration <= 0 || info.initialising)
		return mc_tracker_track(t, views, clip->rig.ncams, kp, nkp, sk, err);
	/* --keypoints-at-iteration N: the frame set's keypoints join the
	 * tracking at gradient iteration N, as in mocapd when the detector
	 * finishes while the tracker already works on its frame set. */
	mc_keypoints_at late = {kp, nkp, o->keypoints_at_iteration};
	mc_tracker_set_keypoint_poll(t, mc_keypoints_at_poll, &late);
	int rc = mc_tracker_track(t, views, clip->rig.ncams, NULL, 0, sk, err);
	mc_tracker_set_keypoint_poll(t, NULL, NULL);
	return rc;
}

/* One frame set after another: keypoints (when any), then tracking, both
 * on the clock. */
static int track_serial(const options *o, mc_tracker *t, bench_detector *bd, const mc_clip *clip, int nframes,
			FILE *out, bench_stats *st, mc_err *err)
{
	mc_skeleton still;
	current_skeleton(t, &still);
	uint64_t rng = o->s.seed + 1;
	for (int k = 0; k < nframes; k += o->frame_step) {
		mc_frame_view views[MC_MAX_CAMERAS];
		mc_skeleton sk;
		mc_keypoint kp[BENCH_MAX_KEYPOINTS];
		if (mc_clip_load_frame(clip, k, views, err) < 0)
			return -1;
		uint64_t t0 = mc_now_ns();
		int nkp = frame_keypoints(o, bd, t, clip, k, views, &rng, &st->sim, kp, BENCH_MAX_KEYPOINTS, err);
		int rc = nkp < 0 ? -1 : track_frame(o, t, clip, views, kp, nkp, &sk, err);
		st->ms[st->frames] = mc_ms_since(t0);
		if (rc == 0 && o->keypoints_file)
			bench_keypoints_write(o->keypoints_file, k, &clip->rig, mc_tracker_model(t), kp, nkp);
		if (rc == 0 && o->overlay_dir && k % o->overlay_every == 0)
			write_overlay(o, clip, k, &views[0], &sk);
		mc_clip_free_frame(views);
		if (rc < 0)
			return -1;
		record_frame(o, clip, k, nframes, &sk, &still, out, st);
	}
	return 0;
}

/* A frame set whose detection runs on a thread of its own. */
typedef struct {
	bench_detector *bd;
	const mc_clip *clip;
	int k;
	mc_frame_view views[MC_MAX_CAMERAS];
	mc_detector_square hints[MC_MAX_CAMERAS]; /* --detector-hint pose */
	bool use_hints;
	bool loaded, running;
	pthread_t thread;
	mc_keypoint kp[BENCH_MAX_KEYPOINTS];
	int nkp; /* -1: failed, with err */
	mc_err err;
} detect_slot;

static void *detect_slot_run(void *arg)
{
	detect_slot *d = arg;
	mc_thread_lower_priority(BENCH_DETECTOR_NICE); /* as mocapd's detector threads ([detector] nice) */
	d->nkp = bench_detector_run(d->bd, d->clip, d->k, d->views, d->clip->rig.ncams, d->use_hints ? d->hints : NULL,
				    d->kp, BENCH_MAX_KEYPOINTS, &d->err);
	return NULL;
}

/* Loads frame set k and starts its detection (with t's pose as the hint
 * when use_hints: the tracker is idle here). */
static int detect_slot_start(detect_slot *d, int k, const mc_tracker *t, mc_err *err)
{
	d->k = k;
	if (d->use_hints)
		bench_detector_hints(t, d->clip, d->hints);
	if (mc_clip_load_frame(d->clip, k, d->views, err) < 0)
		return -1;
	d->loaded = true;
	int rc = pthread_create(&d->thread, NULL, detect_slot_run, d);
	if (rc != 0)
		return mc_err_set(err, "mocap-bench: detector thread: %s", strerror(rc));
	d->running = true;
	return 0;
}

/* Waits for the detection; -1 (with err) if it failed. */
static int detect_slot_join(detect_slot *d, mc_err *err)
{
	if (d->running)
		pthread_join(d->thread, NULL);
	d->running = false;
	if (d->nkp < 0) {
		*err = d->err;
		return -1;
	}
	return 0;
}

static void detect_slot_unload(detect_slot *d)
{
	if (d->running)
		pthread_join(d->thread, NULL);
	d->running = false;
	if (d->loaded)
		mc_clip_free_frame(d->views);
	d->loaded = false;
}

/* As mocapd runs the detector (its own threads, on the newest frame set,
 * while the tracking thread tracks the one before): frame set k + 1 is
 * detected while k is tracked.  The clock runs while the tracker works and
 * while it waits for the detection it needs; frame loading (off the clock,
 * as in track_serial) happens while nothing else runs, so it gives the
 * detector no head start.  Same keypoints as track_serial, so the same
 * estimates; only the time differs. */
static int track_pipelined(const options *o, mc_tracker *t, bench_detector *bd, const mc_clip *clip, int nframes,
			   FILE *out, bench_stats *st, mc_err *err)
{
	mc_skeleton still;
	current_skeleton(t, &still);
	detect_slot slot[2] = {{.bd = bd, .clip = clip}, {.bd = bd, .clip = clip}};
	const int step = o->frame_step;
	for (int s = 0; s < 2; s++)
		slot[s].use_hints = o->detector_hint;
	int rc = nframes > 0 ? detect_slot_start(&slot[0], 0, t, err) : 0;
	for (int i = 0, k = 0; rc == 0 && k < nframes; i++, k += step) {
		detect_slot *cur = &slot[i % 2];
		uint64_t t0 = mc_now_ns();
		rc = detect_slot_join(cur, err);
		double waited = mc_ms_since(t0);
		if (rc == 0 && k + step < nframes)
			rc = detect_slot_start(&slot[(i + 1) % 2], k + step, t, err);
		mc_skeleton sk;
		t0 = mc_now_ns();
		if (rc == 0)
			rc = track_frame(o, t, clip, cur->views, cur->kp, cur->nkp, &sk, err);
		st->ms[st->frames] = waited + mc_ms_since(t0);
		if (rc == 0 && o->keypoints_file)
			bench_keypoints_write(o->keypoints_file, k, &clip->rig, mc_tracker_model(t), cur->kp, cur->nkp);
		if (rc == 0 && o->overlay_dir && k % o->overlay_every == 0)
			write_overlay(o, clip, k, &cur->views[0], &sk);
		if (rc == 0)
			record_frame(o, clip, k, nframes, &sk, &still, out, st);
		detect_slot_unload(cur);
	}
	detect_slot_unload(&slot[0]);
	detect_slot_unload(&slot[1]);
	return rc;
}

static int track_clip(const options *o, mc_tracker *t, bench_detector *bd, const mc_clip *clip, int nframes,
		      FILE *out, bench_stats *st, mc_err *err)
{
	st->ms = calloc(nframes, sizeof(double));
	if (!st->ms)
		return mc_err_set(err, "out of memory");
	st->first_tracked = -1;
	if (clip->has_gt)
		bench_score_begin(clip, o->frame_step, st);
	if (bd && !o->detector_serial)
		return track_pipelined(o, t, bd, clip, nframes, out, st, err);
	return track_serial(o, t, bd, clip, nframes, out, st, err);
}

/* ---- report ------------------------------------------------------------ */

static void print_settings(const mc_tracker_settings *s, const char *device)
{
	printf("device: %s\n", device);
	printf("settings: backend=%s width=%d height=%d iterations=%d pixel_fraction=%g dropout=%g step=%g "
	       "momentum=%g lambda_detection=%g lambda_limit=%g lambda_pose=%g lambda_smooth=%g lambda_floor=%g seed=%llu\n",
	       s->backend == MC_BACKEND_OPENCL ? "opencl" : "reference", s->width, s->height, s->iterations,
	       s->pixel_fraction, s->dropout, s->step, s->momentum, s->lambda_detection, s->lambda_limit,
	       s->lambda_pose, s->lambda_smooth, s->lambda_floor, (unsigned long long)s->seed);
}

/* ---- the reference backend on a few frames, for a speed ratio ----------- */

static double reference_ms_per_frame(const options *o, const mc_clip *clip, mc_err *err)
{
	mc_tracker_settings s = o->s;
	s.backend = MC_BACKEND_REFERENCE;
	mc_tracker *t = start_tracker(o, clip, &s, err);
	if (!t)
		return -1;
	bench_stats st = {0};
	options q = *o;
	q.quiet = true;
	q.overlay_dir = NULL; /* the tracked run's overlays stay */
	int rc = track_clip(&q, t, NULL, clip, o->reference_frames, NULL, &st, err);
	bench_timing tm = bench_timing_of(st.ms, st.frames);
	free(st.ms);
	mc_tracker_destroy(t);
	return rc < 0 ? -1 : tm.median;
}

/* ---- the thesis' ch. 4 configuration (bench/thesis.c) ----------------- */

/* From the tracker's initial pose, as the tracking starts. */
static int run_thesis_config(const options *o, const mc_clip *clip, mc_err *err)
{
	mc_tracker_settings s = o->s;
	s.backend = MC_BACKEND_REFERENCE;
	mc_tracker *t = start_tracker(o, clip, &s, err);
	if (!t)
		return -1;
	double pose[MC_MAX_DOF];
	memcpy(pose, mc_tracker_pose(t), sizeof(double) * mc_tracker_model(t)->ndof);
	int rc = bench_thesis_run(mc_tracker_model(t), pose, clip, o->s.cl_platform, o->s.cl_device, err);
	mc_tracker_destroy(t);
	return rc;
}

/* ---- main -------------------------------------------------------------- */

/* Gradient iterations per frame set, averaged over the clip. */
static double iterations_per_set(const bench_stats *st)
{
	return st->frames ? (double)st->iterations / st->frames : 0;
}

static void print_speed(const options *o, const mc_clip *clip, const bench_stats *st, mc_err *err)
{
	bench_timing tm = bench_timing_of(st->ms, st->frames);
	double iterations = iterations_per_set(st);
	printf("speed: per frame median %.2f ms, p95 %.2f ms, p99 %.2f ms, mean %.2f ms; %.1f frames/s, "
	       "%.1f iterations per frame set, %.0f iterations/s\n",
	       tm.median, tm.p95, tm.p99, tm.mean, 1e3 / tm.mean, iterations, iterations * 1e3 / tm.mean);
	if (o->reference_frames > 0) {
		double ref = reference_ms_per_frame(o, clip, err);
		if (ref > 0)
			printf("reference backend: %.1f ms per frame (median of %d frames): %s is %.1fx faster\n", ref,
			       o->reference_frames, o->s.backend == MC_BACKEND_OPENCL ? "opencl" : "reference",
			       ref / tm.median);
	}
}

/* The reports after tracking: accuracy, the detector's, speed, the thesis
 * configuration, then the lines for scripts (RESULT, JITTER). */
static void report(const options *o, const mc_clip *clip, bench_detector *bd, const bench_stats *st,
		   const char *device_name, bool thesis, mc_err *err)
{
	bench_print_accuracy(clip, st);
	if (bd)
		bench_detector_report(bd, clip);
	print_speed(o, clip, st, err);
	if (thesis && run_thesis_config(o, clip, err) < 0)
		fprintf(stderr, "mocap-bench: thesis configuration: %s\n", err->msg);
	char device[160];
	snprintf(device, sizeof(device), "%s", device_name);
	for (char *p = device; *p; p++)
		if (*p == ' ')
			*p = '_';
	bench_timing tm = bench_timing_of(st->ms, st->frames);
	printf("RESULT clip=%s frames=%d mpjpe_cm=%.2f fps=%.1f ms_p99=%.2f device=%s cameras=%d iterations=%.1f\n",
	       clip->name, st->frames, clip->has_gt ? 100.0 * bench_mpjpe(st) : NAN, 1e3 / tm.mean, tm.p99, device,
	       clip->rig.ncams, iterations_per_set(st));
	if (clip->has_gt) {
		bench_print_jitter(clip, st);
		bench_print_limbs(clip, st);
	}
	if (o->simulated_detector_px >= 0)
		bench_print_simdet(clip, &st->sim);
}

/* Reads --keypoints-in, opens --out and --keypoints-out; -1 (with err)
 * when one cannot be read or written, with nothing left open. */
static int open_outputs(options *o, const mc_tracker *t, const mc_clip *clip, FILE **out, mc_err *err)
{
	*out = NULL;
	if (o->keypoints_in_path &&
	    bench_keypoints_read(o->keypoints_in_path, &clip->rig, mc_tracker_model(t), clip->gt.nframes, &o->keypoints_in,
				 err) < 0)
		return -1;
	if (o->out_path && !(*out = fopen(o->out_path, "w"))) {
		bench_keypoints_in_free(&o->keypoints_in);
		return mc_err_set(err, "%s: cannot write", o->out_path);
	}
	if (o->keypoints_out_path && !(o->keypoints_file = fopen(o->keypoints_out_path, "w"))) {
		if (*out)
			fclose(*out);
		*out = NULL;
		bench_keypoints_in_free(&o->keypoints_in);
		return mc_err_set(err, "%s: cannot write", o->keypoints_out_path);
	}
	return 0;
}

static void close_outputs(options *o, FILE *out)
{
	if (out)
		fclose(out);
	if (o->keypoints_file)
		fclose(o->keypoints_file);
	o->keypoints_file = NULL;
	bench_keypoints_in_free(&o->keypoints_in);
}

static void print_clip(const mc_clip *clip, int nframes)
{
	printf("clip: %s (%d frames, %s, %d camera%s:", clip->name, nframes,
	       clip->layout == MC_CLIP_OUTSIDE ? "outside-in" : "head-mounted", clip->rig.ncams,
	       clip->rig.ncams == 1 ? "" : "s");
	for (int c = 0; c < clip->rig.ncams; c++)
		printf(" %s", clip->rig.cams[c].name);
	printf(")\n");
}

/* --detector: the model, its threshold and what it does; -1 with err. */
static int open_detector(const options *o, const mc_tracker *t, const mc_clip *clip, int nframes,
			 bench_detector *det, mc_err *err)
{
	if (bench_detector_open(det, o->detector_path, mc_tracker_model(t), clip, o->detector_every, nframes, err) < 0)
		return -1;
	if (o->detector_threshold >= 0)
		mc_detector_set_threshold(det->det, (float)o->detector_threshold);
	mc_detector_set_flip(det->det, o->detector_flip);
	printf("detector: %s, every %d frame set(s), %s%s, lambda_detection %.3g, lambda_color %.3g\n",
	       o->detector_path, det->every, o->detector_serial ? "serial (detect, then track)" : "pipelined (as in mocapd)",
	       o->detector_flip ? ", flip test" : "", o->s.lambda_detection, o->s.lambda_color);
	return 0;
}

/* Tracks the opened clip with tracker t and reports. */
/* How far the views' keypoints agreed at the end, and the keypoint
 * term's weight that gave (docs/TRACKER.md, "Trusting keypoints that agree"). */
static void print_keypoint_trust(const options *o, const mc_tracker *t)
{
	double spread, trust = mc_tracker_keypoint_trust(t, &spread);
	if (spread > 0)
		printf("keypoints: the views' spread %.2f px at 128 wide, the keypoint term's weight x%.2f "
		       "(--detection-trust-max %g)\n", spread, trust, o->s.detection_trust_max);
}

static int run_tracker(options *o, mc_tracker *t, const mc_clip *clip, int nframes, bool thesis, mc_err *err)
{
	FILE *out;
	if (open_outputs(o, t, clip, &out, err) < 0)
		return -1;
	print_clip(clip, nframes);
	print_settings(&o->s, mc_tracker_device_name(t));
	if (o->keypoints_in_path)
		printf("keypoints: %s, %d of them, lambda_detection %.3g\n", o->keypoints_in_path, o->keypoints_in.nkp,
		       o->s.lambda_detection);
	if (o->simulated_detector_px >= 0)
		printf("WARNING: simulated detector: keypoints from the ground truth, %.1f px noise, %.0f%% missed, "
		       "collapse %.2f, swap %.2f, occluded on the wrong limb %.2f, outliers %.2f (lasting %d frame "
		       "sets), confidences %s. Not the evaluation protocol.\n",
		       o->simulated_detector_px, 100 * MC_CLIP_SIMULATED_MISS, o->sim.collapse, o->sim.swap,
		       o->sim.occluded_wrong, o->sim.outlier, o->sim.persist > 1 ? o->sim.persist : 1,
		       o->sim.blind_confidence ? "blind" : "1");
	bench_detector det, *bd = NULL;
	if (o->detector_path && open_detector(o, t, clip, nframes, &det, err) < 0) {
		close_outputs(o, out);
		return -1;
	}
	if (o->detector_path)
		bd = &det;
	bench_stats st = {0};
	int rc = track_clip(o, t, bd, clip, nframes, out, &st, err);
	close_outputs(o, out);
	if (rc == 0 && o->init_detect)
		bench_print_init_report(t, clip, &st);
	if (rc == 0) {
		print_keypoint_trust(o, t);
		report(o, clip, bd, &st, mc_tracker_device_name(t), thesis, err);
	}
	if (bd)
		bench_detector_close(bd);
	free(st.ms);
	return rc;
}

/* A clip without gt.json (real footage) is tracked, not scored: it can
 * start only from the detections. */
static int check_unscored(const options *o, const mc_clip *clip, mc_err *err)
{
	if (o->model_floor)
		return mc_err_set(err, "%s has no gt.json: --model-floor fits the ground truth", clip->dir);
	if (o->simulated_detector_px >= 0)
		return mc_err_set(err, "%s has no gt.json: --simulated-detector projects the ground truth", clip->dir);
	if (!o->init_detect)
		return mc_err_set(err, "%s has no gt.json, so no frame 0 to start from: give --init detect --detector MODEL",
				  clip->dir);
	return 0;
}

static int run(const options *cmdline, bool thesis, mc_err *err)
{
	mc_clip clip;
	options opts = *cmdline, *o = &opts;
	if (mc_clip_open(o->clip, o->use_ocam, &clip, err) < 0)
		return -1;
	if ((o->cameras && mc_clip_select_cameras(&clip, o->cameras, err) < 0) ||
	    (!clip.has_gt && check_unscored(o, &clip, err) < 0)) {
		mc_clip_close(&clip);
		return -1;
	}
	/* as mocapd does on an outside-in rig: the settings not given on the
	 * command line take their outside-in values */
	if (clip.layout == MC_CLIP_OUTSIDE)
		mc_tracker_settings_outside_in(&o->s, clip.rig.ncams, o->given);
	if (o->fps > 0)
		clip.gt.fps = o->fps;
	if (o->model_floor) {
		int rc = bench_model_floor(&clip, o->model_path, err);
		mc_clip_close(&clip);
		return rc;
	}
	int nframes = o->max_frames > 0 && o->max_frames < clip.gt.nframes ? o->max_frames : clip.gt.nframes;
	mc_tracker *t = start_tracker(o, &clip, &o->s, err);
	int rc = t ? run_tracker(o, t, &clip, nframes, thesis, err) : -1;
	mc_tracker_destroy(t);
	mc_clip_close(&clip);
	return rc;
}

int main(int argc, char **argv)
{
	options o;
	bool thesis = true;
	bench_options_init(&o);
	if (bench_parse_options(argc, argv, &o, &thesis) < 0)
		return 2;
	mc_err err = {{0}};
	if (run(&o, thesis, &err) < 0) {
		fprintf(stderr, "mocap-bench: %s\n", err.msg);
		return 1;
	}
	return 0;
}
