#include "bench/options.h"

#include "base/mc_parse.h"
#include "mc_install_paths.h" /* generated: MC_INSTALL_DATA_DIR, MC_VERSION */

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static void usage(FILE *f)
{
	fprintf(f, "usage: mocap-bench --clip DIR [options]\n"
		   "  --model PATH          body model (default config/models/default.json, else the installed\n"
		   "                        " MC_INSTALL_DATA_DIR "/models/default.json)\n"
		   "  --out FILE            write per-frame estimates as JSON lines (joints in the rig frame:\n"
		   "                        left camera, or the world frame of an outside-in clip)\n"
		   "  --keypoints-out FILE  write the keypoints the tracker was given (detector or simulated) as\n"
		   "                        JSON lines, one per tracked frame set, native pixels\n"
		   "  --keypoints-in FILE   track from the keypoints in FILE (--keypoints-out's format, joints\n"
		   "                        named as the body model names them) instead of a detector's\n"
		   "  --cameras LIST        outside-in: use only these clip cameras, e.g. 0,2 (default: all)\n"
		   "  --lambda-floor L      outside-in: weight of the floor prior (default: mocapd's outside-in value)\n"
		   "  --pose-prior FILE     the learned pose prior (default config/models/pose_prior.json when\n"
		   "                        there; 'none': without one)\n"
		   "  --lambda-prior L      weight of the pose prior (default 6e-3 head-mounted, 1e-3 outside-in)\n"
		   "  --frames N            track only the first N frames\n"
		   "  --fps F               the clip's frame rate (default: gt.json's, else 30)\n"
		   "  --frame-step N        track every Nth frame set only, as cameras at 1/N of the clip's rate\n"
		   "                        (scored on those; default 1)\n"
		   "  --backend opencl|reference\n"
		   "  --width W --height H  working resolution per camera (default 128x128)\n"
		   "  --iterations N        gradient iterations per frame (default 50; outside-in clips 320 shared\n"
		   "                        among the cameras, within 40..160: 80 with four cameras)\n"
		   "  --pixel-fraction F    share of candidate pixels per iteration (default 0.07; outside-in 0.14)\n"
		   "  --dropout P           per-pixel Gaussian dropout probability\n"
		   "  --step S --momentum M --lambda-smooth L --lambda-pose L --lambda-limit L\n"
		   "  --platform N --device N   OpenCL device (default: first GPU, else first CPU)\n"
		   "  --seed N              random seed\n"
		   "  --ocam                use the clip's OCam polynomial instead of the equidistant model\n"
		   "  --reference-frames N  frames tracked by the reference backend for the speed ratio (default 3, 0 = skip)\n"
		   "  --no-thesis           skip the thesis ch. 4 configuration\n"
		   "  --overlay-dir DIR     write DIR/overlay_K.png: left image, estimate and ground truth\n"
		   "  --overlay-every N     every Nth frame (default 10)\n"
		   "  --quiet               no per-frame progress\n"
		   "  --simulated-detector PX  feed the tracker keypoints projected from the ground truth with PX\n"
		   "                        pixels of noise (15%% missed), standing in for the rig's shipped 2D\n"
		   "                        detector (its joints); NOT the evaluation protocol, which uses no\n"
		   "                        ground truth after frame 0\n"
		   "  --sim-preset ego|outside|none  the simulated detector's gross errors as measured on the\n"
		   "                        shipped head-mounted or outside-in detector (default none: noise only)\n"
		   "  --sim-collapse R      share of left/right pairs per view with both channels at one limb\n"
		   "  --sim-swap R          share of left/right pairs per view with their labels exchanged\n"
		   "  --sim-occluded-wrong R  share of occluded paired joints placed on the other limb\n"
		   "  --sim-outlier R       share of keypoints moved 1.5-5x 10 px (at 128-wide scale) off\n"
		   "  --sim-persist N       an outlier stays for runs of N frame sets (ego preset 5; 0: drawn\n"
		   "                        afresh each frame set)\n"
		   "  --sim-blind-confidence  confidences uniform in [0.3, 1] for good and wrong keypoints alike\n"
		   "                        (rates override the preset; docs/man/mocap-bench.1 gives the sources)\n"
		   "  --lambda-detection L  weight of the keypoint term\n"
		   "  --detection-trust-max F  the keypoint term's weight grows up to F times while the cameras'\n"
		   "                        keypoints agree closely (default 3; outside-in 2, 1 with two cameras)\n"
		   "  --color-sight-cut F   the share of each camera's colour gradient toward that camera along\n"
		   "                        its line of sight that is dropped (default 0.5; outside-in 0; 0: the\n"
		   "                        thesis' gradient; docs/TRACKER.md)\n"
		   "  --detector MODEL      the 2D joint detector (ONNX, docs/DETECTOR.md) feeds the tracker, and a\n"
		   "                        2D report follows; as in mocapd, frame set k + 1 is detected on a\n"
		   "                        thread of its own while k is tracked, and the speed counts the\n"
		   "                        tracking and any wait for the detection\n"
		   "  --detector-serial     detect, then track, one frame set after the other (both timed)\n"
		   "  --detector-flip       heatmap models: also detect on the mirrored view and average (twice the cost)\n"
		   "  --detector-hint pose|none  MoveNet models look once where the tracked pose is, as mocapd\n"
		   "                        does, and at the whole view only when that misses (default none)\n"
		   "  --keypoints-at-iteration N  the keypoints (detector or simulated) join the tracking at\n"
		   "                        gradient iteration N instead of before it, as in mocapd when the\n"
		   "                        detection finishes after the tracking of its frame set began (before\n"
		   "                        it while waiting for a first pose, as mocapd does)\n"
		   "  --detector-every N    detect on every Nth frame set only (default 1)\n"
		   "  --detector-threshold T  keypoints below confidence T are dropped (default: the model's)\n"
		   "  --lambda-color L      weight of the colour term (default 1; 0: detections and priors only)\n"
		   "  --init gt0|detect     gt0 (default): pose and bone lengths from frame 0's ground truth;\n"
		   "                        detect: from the detections alone (needs --detector or\n"
		   "                        --simulated-detector), nothing from gt.json\n"
		   "  --no-recover          never re-fit the pose to the detections when lost or stuck\n"
		   "  --ray-fit on|off      fit the predicted pose to the keypoints' rays before the iterations,\n"
		   "                        limb by limb where the colours agree (default on; outside-in with\n"
		   "                        3 cameras or more)\n"
		   "  --sides labels|tracker  who decides left from right: the detector's labels (default on\n"
		   "                        head-mounted rigs) or the views' agreement and the tracked pose\n"
		   "                        (default outside-in; docs/TRACKER.md \"Sides\")\n"
		   "  --fit-limbs           after the actor's size, scale each limb pair on its own\n"
		   "                        (settings.fit_limbs, off by default: not yet shown to help)\n"
		   "  --model-floor         no tracking: fit the body model to each frame's ground truth by\n"
		   "                        inverse kinematics and print its error (FLOOR line), the\n"
		   "                        skeleton's own floor\n");
}

static int parse_number(const char *opt, const char *arg, double lo, double hi, double *out)
{
	double v;
	if (!mc_parse_double(arg, &v) || v < lo || v > hi) {
		fprintf(stderr, "mocap-bench: %s: expected a number in [%g, %g], got '%s'\n", opt, lo, hi, arg);
		return -1;
	}
	*out = v;
	return 0;
}

enum { OPT_MODEL = 256, OPT_OUT, OPT_FRAMES, OPT_BACKEND, OPT_WIDTH, OPT_HEIGHT, OPT_ITER, OPT_FRAC, OPT_DROP,
       OPT_STEP, OPT_MOM, OPT_LSMOOTH, OPT_LPOSE, OPT_LLIMIT, OPT_PLAT, OPT_DEV, OPT_SEED, OPT_OCAM, OPT_REF,
       OPT_NOTHESIS, OPT_QUIET, OPT_CLIP, OPT_HELP, OPT_OVERLAY, OPT_OVERLAY_EVERY, OPT_LANCHOR,
       OPT_SIMDET, OPT_LDET, OPT_TRUST, OPT_DETECTOR, OPT_DET_EVERY, OPT_LCOLOR, OPT_DET_THRESHOLD, OPT_INIT,
       OPT_NORECOVER, OPT_RAY_FIT, OPT_CAMERAS, OPT_LFLOOR, OPT_DET_SERIAL, OPT_KP_AT, OPT_FRAME_STEP, OPT_KP_OUT, OPT_KP_IN, OPT_FPS, OPT_SIM_PRESET, OPT_SIM_COLLAPSE, OPT_SIM_SWAP, OPT_SIM_OUTLIER, OPT_SIM_OCC,
       OPT_SIM_BLIND, OPT_SIDES, OPT_FIT_LIMBS, OPT_PRIOR, OPT_LPRIOR, OPT_DET_HINT, OPT_DET_FLIP, OPT_MODEL_FLOOR, OPT_SIM_PERSIST, OPT_SIGHT_CUT,
       OPT_VERSION = 'V' };

static int apply_option(options *o, int c, const char *name, const char *arg, bool *thesis)
{
	double v = 0;
	mc_tracker_settings *s = &o->s;
	switch (c) {
	case OPT_CLIP: o->clip = arg; return 0;
	case OPT_CAMERAS: o->cameras = arg; return 0;
	case OPT_MODEL: o->model_path = arg; return 0;
	case OPT_OUT: o->out_path = arg; return 0;
	case OPT_KP_OUT: o->keypoints_out_path = arg; return 0;
	case OPT_KP_IN: o->keypoints_in_path = arg; return 0;
	case OPT_DETECTOR: o->detector_path = arg; return 0;
	case OPT_PRIOR: o->prior_path = strcmp(arg, "none") == 0 ? NULL : arg; return 0;
	case OPT_OVERLAY: o->overlay_dir = arg; return 0;
	case OPT_OCAM: o->use_ocam = true; return 0;
	case OPT_NOTHESIS: *thesis = false; return 0;
	case OPT_QUIET: o->quiet = true; return 0;
	case OPT_NORECOVER: o->s.recover = false; return 0;
	case OPT_RAY_FIT:
		if (strcmp(arg, "on") && strcmp(arg, "off")) {
			fprintf(stderr, "mocap-bench: --ray-fit: expected on or off, got '%s'\n", arg);
			return -1;
		}
		o->s.ray_fit = !strcmp(arg, "on");
		o->given |= MC_GIVEN_RAY_FIT;
		return 0;
	case OPT_FIT_LIMBS: o->s.fit_limbs = true; return 0;
	case OPT_MODEL_FLOOR: o->model_floor = true; return 0;
	case OPT_SIDES:
		if (strcmp(arg, "labels") != 0 && strcmp(arg, "tracker") != 0) {
			fprintf(stderr, "mocap-bench: --sides: expected labels or tracker, got '%s'\n", arg);
			return -1;
		}
		o->s.assign_sides = strcmp(arg, "tracker") == 0;
		o->given |= MC_GIVEN_ASSIGN_SIDES;
		return 0;
	case OPT_DET_SERIAL: o->detector_serial = true; return 0;
	case OPT_DET_FLIP: o->detector_flip = true; return 0;
	case OPT_DET_HINT:
		if (strcmp(arg, "pose") != 0 && strcmp(arg, "none") != 0) {
			fprintf(stderr, "mocap-bench: --detector-hint: expected pose or none, got '%s'\n", arg);
			return -1;
		}
		o->detector_hint = strcmp(arg, "pose") == 0;
		return 0;
	case OPT_SIM_PRESET: o->sim_preset = arg; return 0;
	case OPT_SIM_BLIND: o->sim_blind_confidence = true; return 0;
	case OPT_INIT:
		if (!strcmp(arg, "gt0") || !strcmp(arg, "detect")) {
			o->init_detect = !strcmp(arg, "detect");
			return 0;
		}
		fprintf(stderr, "mocap-bench: --init: expected gt0 or detect, got '%s'\n", arg);
		return -1;
	case OPT_BACKEND:
		if (!strcmp(arg, "opencl") || !strcmp(arg, "reference")) {
			s->backend = !strcmp(arg, "opencl") ? MC_BACKEND_OPENCL : MC_BACKEND_REFERENCE;
			return 0;
		}
		fprintf(stderr, "mocap-bench: --backend: expected opencl or reference, got '%s'\n", arg);
		return -1;
	}
	if (parse_number(name, arg, -1, 1e9, &v) < 0)
		return -1;
	switch (c) {
	case OPT_FRAMES: o->max_frames = (int)v; break;
	case OPT_REF: o->reference_frames = (int)v; break;
	case OPT_OVERLAY_EVERY: o->overlay_every = v >= 1 ? (int)v : 1; break;
	case OPT_WIDTH: s->width = (int)v; break;
	case OPT_HEIGHT: s->height = (int)v; break;
	case OPT_ITER: s->iterations = (int)v; o->given |= MC_GIVEN_ITERATIONS; break;
	case OPT_FRAC: s->pixel_fraction = v; o->given |= MC_GIVEN_PIXEL_FRACTION; break;
	case OPT_DROP: s->dropout = v; break;
	case OPT_STEP: s->step = v; break;
	case OPT_MOM: s->momentum = v; break;
	case OPT_LSMOOTH: s->lambda_smooth = v; o->given |= MC_GIVEN_LAMBDA_SMOOTH; break;
	case OPT_LPOSE: s->lambda_pose = v; break;
	case OPT_LLIMIT: s->lambda_limit = v; break;
	case OPT_LANCHOR: s->lambda_anchor = v; break;
	case OPT_LPRIOR: s->lambda_prior = v; o->given |= MC_GIVEN_LAMBDA_PRIOR; break;
	case OPT_LFLOOR: s->lambda_floor = v; o->given |= MC_GIVEN_LAMBDA_FLOOR; break;
	case OPT_LDET: s->lambda_detection = v; o->given |= MC_GIVEN_LAMBDA_DETECTION; break;
	case OPT_LCOLOR: s->lambda_color = v; break;
	case OPT_TRUST: s->detection_trust_max = v; o->given |= MC_GIVEN_DETECTION_TRUST; break;
	case OPT_SIGHT_CUT: s->color_sight_cut = v; o->given |= MC_GIVEN_COLOR_SIGHT_CUT; break;
	case OPT_DET_EVERY: o->detector_every = v >= 1 ? (int)v : 1; break;
	case OPT_KP_AT: o->keypoints_at_iteration = (int)v; break;
	case OPT_FRAME_STEP: o->frame_step = v >= 1 ? (int)v : 1; break;
	case OPT_DET_THRESHOLD: o->detector_threshold = v; break;
	case OPT_SIMDET: o->simulated_detector_px = v; break;
	case OPT_PLAT: s->cl_platform = (int)v; break;
	case OPT_DEV: s->cl_device = (int)v; break;
	case OPT_SEED: s->seed = (uint64_t)v; break;
	case OPT_FPS: o->fps = v; break;
	case OPT_SIM_COLLAPSE: o->sim_collapse = v; break;
	case OPT_SIM_SWAP: o->sim_swap = v; break;
	case OPT_SIM_OUTLIER: o->sim_outlier = v; break;
	case OPT_SIM_OCC: o->sim_occluded_wrong = v; break;
	case OPT_SIM_PERSIST: o->sim_persist = (int)v; break;
	}
	return 0;
}

/* The simulated detector: --simulated-detector's noise, the preset, then
 * each rate given; -1 after printing what is wrong. */
static int sim_settings(options *o)
{
	const double given[4] = {o->sim_collapse, o->sim_swap, o->sim_outlier, o->sim_occluded_wrong};
	static const char *const names[4] = {"--sim-collapse", "--sim-swap", "--sim-outlier", "--sim-occluded-wrong"};
	bool any = o->sim_preset || o->sim_blind_confidence || o->sim_persist >= 0;
	for (int i = 0; i < 4; i++) {
		if (given[i] > 1) {
			fprintf(stderr, "mocap-bench: %s: expected a rate in [0, 1], got %g\n", names[i], given[i]);
			return -1;
		}
		any = any || given[i] >= 0;
	}
	if (any && o->simulated_detector_px < 0) {
		fprintf(stderr, "mocap-bench: --sim-* options need --simulated-detector PX\n");
		return -1;
	}
	o->sim = (mc_simdet){.noise_px = o->simulated_detector_px, .seed = o->s.seed};
	if (o->sim_preset && !mc_simdet_preset(o->sim_preset, &o->sim)) {
		fprintf(stderr, "mocap-bench: --sim-preset: expected ego, outside or none, got '%s'\n", o->sim_preset);
		return -1;
	}
	double *rate[4] = {&o->sim.collapse, &o->sim.swap, &o->sim.outlier, &o->sim.occluded_wrong};
	for (int i = 0; i < 4; i++)
		if (given[i] >= 0)
			*rate[i] = given[i];
	o->sim.blind_confidence = o->sim.blind_confidence || o->sim_blind_confidence;
	if (o->sim_persist >= 0)
		o->sim.persist = o->sim_persist;
	if (o->sim.collapse + o->sim.swap > 1) {
		fprintf(stderr, "mocap-bench: --sim-collapse and --sim-swap add up to more than 1\n");
		return -1;
	}
	return 0;
}

int bench_parse_options(int argc, char **argv, options *o, bool *thesis)
{
	static const struct option longopts[] = {
		{"clip", 1, 0, OPT_CLIP}, {"model", 1, 0, OPT_MODEL}, {"out", 1, 0, OPT_OUT},
		{"frames", 1, 0, OPT_FRAMES}, {"backend", 1, 0, OPT_BACKEND}, {"width", 1, 0, OPT_WIDTH},
		{"height", 1, 0, OPT_HEIGHT}, {"iterations", 1, 0, OPT_ITER}, {"pixel-fraction", 1, 0, OPT_FRAC},
		{"dropout", 1, 0, OPT_DROP}, {"step", 1, 0, OPT_STEP}, {"momentum", 1, 0, OPT_MOM},
		{"lambda-smooth", 1, 0, OPT_LSMOOTH}, {"lambda-pose", 1, 0, OPT_LPOSE},
		{"lambda-limit", 1, 0, OPT_LLIMIT}, {"lambda-anchor", 1, 0, OPT_LANCHOR},
		{"pose-prior", 1, 0, OPT_PRIOR}, {"lambda-prior", 1, 0, OPT_LPRIOR},
		{"detector-hint", 1, 0, OPT_DET_HINT},
		{"lambda-detection", 1, 0, OPT_LDET}, {"detection-trust-max", 1, 0, OPT_TRUST}, {"simulated-detector", 1, 0, OPT_SIMDET},
		{"detector", 1, 0, OPT_DETECTOR}, {"detector-every", 1, 0, OPT_DET_EVERY},
		{"lambda-color", 1, 0, OPT_LCOLOR}, {"detector-threshold", 1, 0, OPT_DET_THRESHOLD},
		{"color-sight-cut", 1, 0, OPT_SIGHT_CUT},
		{"platform", 1, 0, OPT_PLAT}, {"device", 1, 0, OPT_DEV},
		{"seed", 1, 0, OPT_SEED}, {"ocam", 0, 0, OPT_OCAM}, {"reference-frames", 1, 0, OPT_REF},
		{"no-thesis", 0, 0, OPT_NOTHESIS}, {"overlay-dir", 1, 0, OPT_OVERLAY},
		{"overlay-every", 1, 0, OPT_OVERLAY_EVERY}, {"quiet", 0, 0, OPT_QUIET}, {"help", 0, 0, OPT_HELP},
		{"init", 1, 0, OPT_INIT}, {"no-recover", 0, 0, OPT_NORECOVER}, {"ray-fit", 1, 0, OPT_RAY_FIT}, {"sides", 1, 0, OPT_SIDES}, {"fit-limbs", 0, 0, OPT_FIT_LIMBS}, {"model-floor", 0, 0, OPT_MODEL_FLOOR}, {"cameras", 1, 0, OPT_CAMERAS},
		{"lambda-floor", 1, 0, OPT_LFLOOR}, {"detector-serial", 0, 0, OPT_DET_SERIAL},
		{"detector-flip", 0, 0, OPT_DET_FLIP},
		{"keypoints-at-iteration", 1, 0, OPT_KP_AT}, {"frame-step", 1, 0, OPT_FRAME_STEP},
		{"keypoints-out", 1, 0, OPT_KP_OUT}, {"keypoints-in", 1, 0, OPT_KP_IN},
		{"fps", 1, 0, OPT_FPS}, {"sim-preset", 1, 0, OPT_SIM_PRESET},
		{"sim-collapse", 1, 0, OPT_SIM_COLLAPSE}, {"sim-swap", 1, 0, OPT_SIM_SWAP},
		{"sim-outlier", 1, 0, OPT_SIM_OUTLIER}, {"sim-occluded-wrong", 1, 0, OPT_SIM_OCC},
		{"sim-persist", 1, 0, OPT_SIM_PERSIST},
		{"sim-blind-confidence", 0, 0, OPT_SIM_BLIND},
		{"version", 0, 0, OPT_VERSION},
		{0, 0, 0, 0}};
	int c, idx;
	while ((c = getopt_long(argc, argv, "hV", longopts, &idx)) != -1) {
		if (c == OPT_HELP || c == 'h') {
			usage(stdout);
			exit(0);
		}
		if (c == OPT_VERSION) {
			printf("mocap-bench %s\n", MC_VERSION);
			exit(0);
		}
		if (c == '?' || apply_option(o, c, longopts[idx].name, optarg, thesis) < 0) {
			usage(stderr);
			return -1;
		}
	}
	if (o->init_detect && !o->detector_path && o->simulated_detector_px < 0 && !o->keypoints_in_path) {
		fprintf(stderr, "mocap-bench: --init detect needs --detector MODEL (or --simulated-detector PX, or "
				"--keypoints-in FILE)\n");
		return -1;
	}
	if (sim_settings(o) < 0)
		return -1;
	if ((o->detector_path != NULL) + (o->simulated_detector_px >= 0) + (o->keypoints_in_path != NULL) > 1) {
		fprintf(stderr, "mocap-bench: --detector, --simulated-detector and --keypoints-in exclude each other\n");
		return -1;
	}
	if (!o->clip) {
		fprintf(stderr, "mocap-bench: --clip DIR is required\n");
		usage(stderr);
		return -1;
	}
	/* the overlay directory is made here, so that a bad path fails at once
	 * rather than once per overlay */
	if (o->overlay_dir && mkdir(o->overlay_dir, 0755) < 0 && errno != EEXIST) {
		fprintf(stderr, "mocap-bench: --overlay-dir %s: %s\n", o->overlay_dir, strerror(errno));
		return -1;
	}
	return 0;
}

void bench_options_init(options *o)
{
	memset(o, 0, sizeof(*o));
	o->model_path = access("config/models/default.json", R_OK) == 0 ? "config/models/default.json"
									 : MC_INSTALL_DATA_DIR "/models/default.json";
	/* The pose prior is used when there is one, as mocapd does. */
	if (access("config/models/pose_prior.json", R_OK) == 0)
		o->prior_path = "config/models/pose_prior.json";
	else if (access(MC_INSTALL_DATA_DIR "/models/pose_prior.json", R_OK) == 0)
		o->prior_path = MC_INSTALL_DATA_DIR "/models/pose_prior.json";
	o->reference_frames = 3;
	o->overlay_every = 10;
	o->frame_step = 1;
	o->simulated_detector_px = -1;
	o->sim_collapse = o->sim_swap = o->sim_outlier = o->sim_occluded_wrong = -1;
	o->sim_persist = -1;
	o->detector_threshold = -1;
	mc_tracker_settings_default(&o->s);
}
