/* mocap-bench --model-floor: how closely the body model can follow a clip's
 * ground truth at all.  Each frame's evaluated joints are fitted by the
 * model's inverse kinematics (bone scales and, on a head-mounted rig, the
 * head's place from frame 0, as the tracker's start from the ground truth
 * takes them), with no images and no detections.  What remains is the
 * skeleton's own error (joints it cannot reach: no clavicles, one spine
 * bend, the joint limits), a floor no tracker on this model goes under. */
#ifndef BENCH_MODEL_FLOOR_H
#define BENCH_MODEL_FLOOR_H

#include "base/mc_error.h"
#include "eval/mc_clip.h"

/* Prints each evaluated joint's mean error and the machine-readable line
 *   FLOOR clip=NAME frames=N mpjpe_cm=X
 * Returns 0, or -1 with err set. */
int bench_model_floor(const mc_clip *clip, const char *model_path, mc_err *err);

#endif
