#include "joint_groups.h"

#include <string.h>

static const struct {
	const char *name;
	const char *members[3];
} groups[BENCH_GROUPS] = {
	{"torso", {"neck", "shoulder", NULL}},
	{"arms", {"elbow", "wrist", NULL}},
	{"legs", {"hip", "knee", NULL}},
	{"feet", {"ankle", "toe", NULL}},
};

int bench_joint_group(const char *joint)
{
	for (int g = 0; g < BENCH_GROUPS; g++)
		for (int m = 0; groups[g].members[m]; m++)
			if (strstr(joint, groups[g].members[m]))
				return g;
	return -1;
}

const char *bench_group_name(int group)
{
	return group >= 0 && group < BENCH_GROUPS ? groups[group].name : "?";
}
