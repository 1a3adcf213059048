/* mocap-bench's command line: its options and their parsing (the
 * option list and what each does: usage(), docs/man/mocap-bench.1.scd). */
#ifndef BENCH_OPTIONS_H
#define BENCH_OPTIONS_H

#include "bench/keypoints_in.h"
#include "eval/mc_simdet.h"
#include "track/mc_tracker.h"

#include <stdbool.h>
#include <stdio.h>

typedef struct {
	const char *clip;
	const char *model_path;
	const char *prior_path; /* --pose-prior FILE; NULL: none */
	const char *out_path;
	const char *keypoints_out_path; /* --keypoints-out FILE */
	FILE *keypoints_file;           /* open while tracking (bench/keypoints_out.h) */
	const char *keypoints_in_path;  /* --keypoints-in FILE */
	bench_keypoints_in keypoints_in; /* read from it while tracking */
	const char *overlay_dir;
	const char *cameras; /* --cameras 0,2: the clip cameras used, NULL: all */
	int overlay_every;
	int max_frames;
	int frame_step; /* track every Nth frame set of the clip (a camera rate 1/N of the clip's) */
	int reference_frames;
	bool use_ocam;
	bool quiet;
	bool model_floor; /* --model-floor: fit the model to the ground truth, no tracking */
	/* > = 0: feed keypoints projected from the ground truth with this much
	 * noise (native pixels): a stand-in for a 2D detector, which is not
	 * the evaluation protocol */
	double simulated_detector_px;
	/* its gross errors: --sim-preset, then the rates given one by one
	 * (-1: not given) on top (bench_parse_options fills sim) */
	const char *sim_preset;
	double sim_collapse, sim_swap, sim_outlier, sim_occluded_wrong;
	int sim_persist; /* --sim-persist, -1: the preset's */
	bool sim_blind_confidence;
	mc_simdet sim;
	const char *detector_path; /* --detector MODEL: the 2D joint detector feeds the tracker */
	int detector_every;        /* detect on every Nth frame set */
	bool detector_serial;      /* detect and track one after the other (default: pipelined) */
	bool detector_flip;        /* heatmap models: the flip test (mc_detector_set_flip) */
	bool detector_hint;        /* --detector-hint pose: MoveNet looks where the tracked pose is */
	int keypoints_at_iteration; /* > 0: keypoints join the tracking at this iteration */
	double detector_threshold; /* < 0: the model's own */
	double fps;                /* > 0: the clip's frame rate (--fps), else gt.json's or 30 */
	/* --init detect: start from the detections alone, nothing from gt.json
	 * (not even frame 0); false: frame 0's ground truth (the protocol's gt0) */
	bool init_detect;
	mc_tracker_settings s;
	/* given on the command line: kept on outside-in clips, whose other
	 * settings take their outside-in values (mc_tracker_outside_in) */
	unsigned given; /* MC_GIVEN_* */
} options;

/* The defaults: the source tree's body model, else the installed one. */
void bench_options_init(options *o);
/* Parses argv into o (exits after --help and --version); -1 after printing
 * what is wrong. */
int bench_parse_options(int argc, char **argv, options *o, bool *thesis);

#endif
