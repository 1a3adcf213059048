/* mocap-bench --keypoints-in FILE: keypoints from a file instead of a
 * detector, in --keypoints-out's format (bench/keypoints_out.h), so that
 * any 2D detector's output, or a detector run once, can be tracked and
 * scored again and again (docs/man/mocap-bench.1).
 *
 * Frame sets without a line get no keypoints. Views of cameras the rig
 * lacks are skipped (a file written with four cameras serves --cameras
 * 0,2), but a file none of whose views names a rig camera is an error. */
#ifndef BENCH_KEYPOINTS_IN_H
#define BENCH_KEYPOINTS_IN_H

#include "base/mc_error.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "track/mc_tracker.h"

typedef struct {
	int nframes;       /* frame sets 0..nframes-1 */
	int *first, *count; /* frame set k's keypoints: kp[first[k]], count[k] of them */
	mc_keypoint *kp;
	int nkp;
} bench_keypoints_in;

/* Reads path for a clip of nframes frame sets; -1 with err naming the file,
 * the line and what is wrong (bad JSON, an index out of range or given
 * twice, a joint the body model lacks, a value that is not [u, v,
 * confidence] with confidence in [0, 1]), with nothing left allocated. */
int bench_keypoints_read(const char *path, const mc_rig *rig, const mc_model *m, int nframes, bench_keypoints_in *in,
			 mc_err *err);
/* Frame set k's keypoints into out (at most cap); the count. */
int bench_keypoints_frame(const bench_keypoints_in *in, int k, mc_keypoint *out, int cap);
void bench_keypoints_in_free(bench_keypoints_in *in);

#endif
