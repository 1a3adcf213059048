/* The joint groups mocap-bench reports accuracy by (3D and 2D): torso
 * (neck, shoulders), arms (elbows, wrists), legs (hips, knees), feet
 * (ankles, toes).  head_top, spine and pelvis are in none: they are not
 * evaluated (docs/CONVENTIONS.md). */
#ifndef BENCH_JOINT_GROUPS_H
#define BENCH_JOINT_GROUPS_H

#define BENCH_GROUPS 4

/* The group of an output joint name, or -1. */
int bench_joint_group(const char *joint);
const char *bench_group_name(int group);

#endif
