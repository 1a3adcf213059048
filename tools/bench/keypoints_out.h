/* mocap-bench --keypoints-out FILE: the keypoints the tracker was given,
 * one JSON line per tracked frame set (issue 36; docs/man/mocap-bench.1):
 *   {"index": k, "views": [{"camera": NAME, "joints": {NAME: [u, v, confidence]}}]}
 * every rig camera in rig order (an empty "joints" when it got none), u and
 * v in the camera's native pixels, joints named as the body model names
 * them. */
#ifndef BENCH_KEYPOINTS_OUT_H
#define BENCH_KEYPOINTS_OUT_H

#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "track/mc_tracker.h"

#include <stdio.h>

void bench_keypoints_write(FILE *f, int k, const mc_rig *rig, const mc_model *m, const mc_keypoint *kp, int nkp);

#endif
