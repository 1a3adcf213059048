/* The thesis' ch. 4 configuration, measured by mocap-bench: about 10,000
 * pixels near the body, at most 72 Gaussians, no sampling; full gradient
 * iterations per second on the OpenCL and reference backends, for
 * comparison with the thesis' 8.1 on a 4-core 3.6 GHz CPU. */
#ifndef BENCH_THESIS_H
#define BENCH_THESIS_H

#include "eval/mc_clip.h"

/* Measures from `pose` of `model` on frame 0 of the clip's first camera,
 * and prints the figures. */
int bench_thesis_run(const mc_model *model, const double *pose, const mc_clip *clip, int cl_platform,
		     int cl_device, mc_err *err);

#endif
