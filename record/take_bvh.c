/* take_bvh: a take's skeleton as BVH (take.h), for mocap-export and
 * mocap-graph.  The HIERARCHY comes from the skeleton definition (rest
 * offsets in centimetres, every joint's frame aligned at rest); each pose
 * is a line of the root's position and every joint's rotation relative to
 * its parent, as Z X Y Euler angles in degrees. */
#include "base/mc_math.h"
#include "take.h"

#include <math.h>
#include <stdbool.h>

static int nchildren(const take_def *d, int j)
{
	int n = 0;
	for (int k = j + 1; k < d->njoints; k++)
		n += d->joints[k].parent == j;
	return n;
}

static void indent(FILE *f, int depth)
{
	for (int i = 0; i < depth; i++)
		fputc('\t', f);
}

/* A joint's name as one BVH token.  BVH has no quoting: a space, a brace
 * or a line break in a name (a crafted take's) would end the token and
 * could inject HIERARCHY or MOTION lines (issue 34), so every character
 * outside A-Z a-z 0-9 _ - . (the model loader's joint-name characters)
 * is written as '_', and an empty name as jointN. */
static void bvh_name(FILE *f, const take_def *d, int j)
{
	const char *name = d->joints[j].name;
	if (!name[0]) {
		fprintf(f, "joint%d", j);
		return;
	}
	for (const char *c = name; *c; c++) {
		bool ok = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '_' ||
			  *c == '-' || *c == '.';
		fputc(ok ? *c : '_', f);
	}
}

/* Joint j and its subtree; rest offsets in centimetres. */
static void bvh_joint(FILE *f, const take_def *d, int j, int depth)
{
	const take_joint_def *jd = &d->joints[j];
	indent(f, depth);
	fprintf(f, "%s ", jd->parent < 0 ? "ROOT" : "JOINT");
	bvh_name(f, d, j);
	fputc('\n', f);
	indent(f, depth);
	fprintf(f, "{\n");
	indent(f, depth + 1);
	fprintf(f, "OFFSET %.6f %.6f %.6f\n", jd->offset[0] * 100, jd->offset[1] * 100, jd->offset[2] * 100);
	indent(f, depth + 1);
	if (jd->parent < 0)
		fprintf(f, "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n");
	else
		fprintf(f, "CHANNELS 3 Zrotation Xrotation Yrotation\n");
	for (int k = j + 1; k < d->njoints; k++)
		if (d->joints[k].parent == j)
			bvh_joint(f, d, k, depth + 1);
	if (nchildren(d, j) == 0) {
		indent(f, depth + 1);
		fprintf(f, "End Site\n");
		indent(f, depth + 1);
		fprintf(f, "{\n");
		indent(f, depth + 2);
		fprintf(f, "OFFSET 0.000000 0.000000 0.000000\n");
		indent(f, depth + 1);
		fprintf(f, "}\n");
	}
	indent(f, depth);
	fprintf(f, "}\n");
}

/* R = Rz(a) Rx(b) Ry(c), in degrees: the BVH channel order written above. */
static void euler_zxy(mc_mat3 R, double *a, double *b, double *c)
{
	double sx = fmax(-1, fmin(1, R.m[2][1]));
	*b = asin(sx);
	if (fabs(sx) < 1 - 1e-9) {
		*c = atan2(-R.m[2][0], R.m[2][2]);
		*a = atan2(-R.m[0][1], R.m[1][1]);
	} else { /* gimbal lock: the y turn folds into z */
		*c = 0;
		*a = atan2(R.m[1][0], R.m[0][0]);
	}
	*a *= 180 / M_PI;
	*b *= 180 / M_PI;
	*c *= 180 / M_PI;
}

/* A joint the skeleton lacks (take_poses_load refuses such takes; other
 * callers may not) is at rest: never memory the pose did not set. */
static mc_mat3 joint_rot(const take_pose *p, int j)
{
	if (j >= p->njoints)
		return mc_m3_identity();
	const double *q = p->joints[j].orientation;
	return mc_quat_to_m3(mc_quat_normalize((mc_quat){q[0], q[1], q[2], q[3]}));
}

/* The channels of one pose, in HIERARCHY order (depth first from the root). */
static void bvh_values(FILE *f, const take_def *d, const take_pose *p, int j)
{
	mc_mat3 r = joint_rot(p, j);
	if (d->joints[j].parent < 0 && j >= p->njoints)
		fprintf(f, "0.000000 0.000000 0.000000");
	else if (d->joints[j].parent < 0)
		fprintf(f, "%.6f %.6f %.6f", p->joints[j].position[0] * 100, p->joints[j].position[1] * 100,
			p->joints[j].position[2] * 100);
	else /* relative to the parent: the rest pose has every frame aligned */
		r = mc_m3_mul(mc_m3_transpose(joint_rot(p, d->joints[j].parent)), r);
	double a, b, c;
	euler_zxy(r, &a, &b, &c);
	fprintf(f, " %.6f %.6f %.6f", a, b, c);
	for (int k = j + 1; k < d->njoints; k++)
		if (d->joints[k].parent == j)
			bvh_values(f, d, p, k);
}

void take_bvh_write_hierarchy(FILE *f, const take_def *d)
{
	fprintf(f, "HIERARCHY\n");
	for (int j = 0; j < d->njoints; j++)
		if (d->joints[j].parent < 0)
			bvh_joint(f, d, j, 0);
}

void take_bvh_write_motion(FILE *f, int nframes, double frame_time)
{
	fprintf(f, "MOTION\nFrames: %d\nFrame Time: %.6f\n", nframes, frame_time);
}

void take_bvh_write_pose(FILE *f, const take_def *d, const take_pose *p)
{
	for (int j = 0; j < d->njoints; j++)
		if (d->joints[j].parent < 0)
			bvh_values(f, d, p, j);
	fputc('\n', f);
}
