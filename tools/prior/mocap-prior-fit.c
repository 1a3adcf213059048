/* mocap-prior-fit: joint positions (tools/prior/export_joints.py) to the
 * body model's joint angles, by inverse kinematics, for training the pose
 * prior (tools/prior/train_prior.py, docs/TRACKER.md "Pose prior").
 *
 *     mocap-prior-fit MODEL.json < joints.txt > poses.txt
 *
 * Input: a "# joints: NAME ..." line, then one line per frame,
 * "CLIP MIRROR FRAME x y z ...".  Output: a "# dofs: NAME ..." line, then
 * "CLIP MIRROR FRAME RMS p0 p1 ..." per frame, RMS the fit's residual in
 * metres.  The root's placement is solved with the pose (the data's head
 * axes need not match the model's root), and each frame starts from the
 * previous frame of the same clip, so that the angles follow the motion
 * rather than jumping between equivalent solutions. */
#include "body/mc_ik.h"
#include "body/mc_model.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_NAMES 32
#define LINE_MAX_BYTES 8192

typedef struct {
	int njoints;
	int model_joint[MAX_NAMES]; /* the model's joint for each input column */
	double weight[MAX_NAMES];
} columns;

/* The skeleton families place the spine and pelvis joints differently
 * (Spine1, abdomen or Spine01; Hips or hip) and end the foot at the ball or
 * the tip of the toes (docs/CONVENTIONS.md, mocap-train's README).  Fitted
 * at full weight they bent the model's spine by 60 degrees on one family
 * and not on the others; the shoulders and hips fix the spine's angles
 * alone, and the toes count less. */
static double target_weight(const char *name)
{
	if (strcmp(name, "spine") == 0 || strcmp(name, "pelvis") == 0)
		return 0.0;
	return strstr(name, "_toe") ? 0.3 : 1.0;
}

static int read_header(const char *line, const mc_model *m, columns *c)
{
	const char *prefix = "# joints:";
	if (strncmp(line, prefix, strlen(prefix)) != 0) {
		fprintf(stderr, "mocap-prior-fit: stdin line 1: expected \"%s NAME ...\"\n", prefix);
		return -1;
	}
	char buf[LINE_MAX_BYTES];
	snprintf(buf, sizeof(buf), "%s", line + strlen(prefix));
	c->njoints = 0;
	for (char *tok = strtok(buf, " \t\n"); tok; tok = strtok(NULL, " \t\n")) {
		int j = mc_model_find_joint(m, tok);
		if (j < 0 || c->njoints == MAX_NAMES) {
			fprintf(stderr, "mocap-prior-fit: stdin line 1: joint '%s' is not in the model\n", tok);
			return -1;
		}
		c->weight[c->njoints] = target_weight(tok);
		c->model_joint[c->njoints++] = j;
	}
	return c->njoints >= 3 ? 0 : -1;
}

static void print_dof_names(const mc_model *m)
{
	printf("# dofs:");
	for (int k = 0; k < m->ndof; k++) {
		char name[64];
		mc_model_dof_name(m, k, name, sizeof(name));
		printf(" %s", name);
	}
	printf("\n");
}

/* Parses "CLIP MIRROR FRAME x y z ..." into targets (those of weight 0
 * left out, also from the bone lengths' fit); their count, or -1. */
static int parse_frame(char *line, const columns *c, char *clip, int *mirror, int *frame, mc_ik_target *t)
{
	int n = 0;
	int used = 0;
	if (sscanf(line, "%127s %d %d%n", clip, mirror, frame, &used) != 3)
		return -1;
	const char *p = line + used;
	for (int i = 0; i < c->njoints; i++) {
		double v[3];
		for (int a = 0; a < 3; a++) {
			char *end;
			v[a] = strtod(p, &end);
			if (end == p)
				return -1;
			p = end;
		}
		if (c->weight[i] > 0)
			t[n++] = (mc_ik_target){c->model_joint[i], mc_v3(v[0], v[1], v[2]), c->weight[i], mc_v3(0, 0, 0)};
	}
	return n;
}

/* The model's rest pose turned and moved onto the targets as one rigid
 * body: the solve then starts near the answer.  (From the model's own
 * rest orientation, a quarter turn away from the data's head axes, it
 * settled in bent spines and elbows.) */
static void place_rest_pose(mc_model *m, const double *pose, const mc_ik_target *t, int n)
{
	mc_fk fk;
	mc_vec3 from[MAX_NAMES], to[MAX_NAMES];
	double w[MAX_NAMES];
	m->rig_from_root = mc_xform_identity();
	mc_model_fk(m, pose, &fk);
	for (int i = 0; i < n; i++) {
		from[i] = fk.rig_from_joint[t[i].joint].t;
		to[i] = t[i].position;
		w[i] = t[i].weight;
	}
	m->rig_from_root = mc_xform_fit_rigid(from, to, w, n);
}

int main(int argc, char **argv)
{
	if (argc != 2) {
		fprintf(stderr, "usage: mocap-prior-fit MODEL.json < joints.txt > poses.txt\n");
		return 2;
	}
	mc_err err = {{0}};
	mc_model base;
	if (mc_model_load(argv[1], &base, &err) < 0) {
		fprintf(stderr, "mocap-prior-fit: %s\n", err.msg);
		return 1;
	}
	char line[LINE_MAX_BYTES], clip[128], last_clip[128] = "";
	columns cols;
	if (!fgets(line, sizeof(line), stdin) || read_header(line, &base, &cols) < 0)
		return 1;
	print_dof_names(&base);
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.fit_root = true;
	o.fit_bone_scale = true;
	mc_model m = base;
	double pose[MC_MAX_DOF];
	int last_mirror = -1, lineno = 1;
	while (fgets(line, sizeof(line), stdin)) {
		lineno++;
		mc_ik_target t[MAX_NAMES];
		int mirror, frame;
		int nt = parse_frame(line, &cols, clip, &mirror, &frame, t);
		if (nt < 0) {
			fprintf(stderr, "mocap-prior-fit: stdin line %d: expected CLIP MIRROR FRAME and %d x y z\n",
				lineno, cols.njoints);
			return 1;
		}
		if (strcmp(clip, last_clip) != 0 || mirror != last_mirror) {
			m = base; /* a new clip starts from the rest pose, placed on it */
			mc_model_rest_pose(&m, pose);
			place_rest_pose(&m, pose, t, nt);
			snprintf(last_clip, sizeof(last_clip), "%s", clip);
			last_mirror = mirror;
			o.restarts = true;
		} else {
			/* From the previous frame's angles: restarts (tried while the
			 * residual is over 2 mm, which the skeletons' different
			 * proportions always leave) would only make it slower. */
			o.restarts = false;
		}
		double rms = mc_ik_solve(&m, pose, t, nt, &o, &err);
		if (rms < 0) {
			fprintf(stderr, "mocap-prior-fit: stdin line %d: %s\n", lineno, err.msg);
			continue;
		}
		printf("%s %d %d %.4f", clip, mirror, frame, rms);
		for (int k = 0; k < m.ndof; k++)
			printf(" %.5f", pose[k]);
		printf("\n");
	}
	return 0;
}
