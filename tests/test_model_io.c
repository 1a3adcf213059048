/* Tests of core/body/mc_model's files: the JSON format (round trip and
 * every bad-input fixture in tests/data/models) and the default human
 * model's proportions (against the evaluation data's frame 0 when
 * ../shared/data is present).  The kinematics are tested in test_model.c. */
#include "base/mc_json.h"
#include "body/mc_model.h"
#include "model_fixture.h"
#include "test_util.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

static const char *const OUTPUT_JOINTS[] = {
	"head_top", "neck", "spine", "pelvis", "left_shoulder", "left_elbow", "left_wrist", "left_hip",
	"left_knee", "left_ankle", "left_toe", "right_shoulder", "right_elbow", "right_wrist", "right_hip",
	"right_knee", "right_ankle", "right_toe"};
#define NOUTPUT ((int)(sizeof(OUTPUT_JOINTS) / sizeof(OUTPUT_JOINTS[0])))

/* ---- JSON ---- */

static bool same_model(const mc_model *a, const mc_model *b)
{
	bool ok = strcmp(a->name, b->name) == 0 && a->njoints == b->njoints && a->ngauss == b->ngauss &&
		  a->ndof == b->ndof && a->root_free == b->root_free && fabs(a->smoothness_m - b->smoothness_m) < 1e-15;
	for (int i = 0; ok && i < 3; i++) {
		ok = fabs(a->rig_from_root.t.x - b->rig_from_root.t.x) < 1e-15 || a->root_free;
		for (int j = 0; j < 3; j++)
			ok = ok && (a->root_free || fabs(a->rig_from_root.R.m[i][j] - b->rig_from_root.R.m[i][j]) < 1e-12);
	}
	for (int j = 0; ok && j < a->njoints; j++) {
		const mc_joint *x = &a->joints[j], *y = &b->joints[j];
		ok = strcmp(x->name, y->name) == 0 && x->parent == y->parent && vdist(x->offset, y->offset) == 0 &&
		     x->ndof == y->ndof && x->dof0 == y->dof0 && a->bone_scale[j] == b->bone_scale[j];
		for (int k = 0; ok && k < x->ndof; k++)
			ok = x->axis[k] == y->axis[k] && fabs(x->lower[k] - y->lower[k]) < 1e-14 &&
			     fabs(x->upper[k] - y->upper[k]) < 1e-14;
	}
	for (int q = 0; ok && q < a->ngauss; q++) {
		const mc_gauss_def *x = &a->gauss[q], *y = &b->gauss[q];
		ok = x->joint == y->joint && x->scale_joint == y->scale_joint && vdist(x->offset, y->offset) == 0 &&
		     x->radius == y->radius && x->sigma == y->sigma && x->c == y->c && x->rgb[0] == y->rgb[0] &&
		     x->rgb[1] == y->rgb[1] && x->rgb[2] == y->rgb[2];
	}
	return ok;
}

static void test_round_trip(void)
{
	mc_model m, back;
	mc_err err;
	if (!load_default(&m))
		return;
	/* Per-actor changes must survive: bone scales, calibrated colours,
	 * another smoothness, a different rig placement. */
	m.bone_scale[4] = 1.0 / 3.0;
	m.bone_scale[12] = 1.1;
	m.gauss[5].rgb[0] = 0.123456789012345;
	m.smoothness_m = 0.2;
	m.rig_from_root.R = mc_m3_from_rotvec(mc_v3(0.1, -0.2, 0.3));
	CHECK(mc_model_update_gaussians(&m, &err) == 0);
	char path[] = "/tmp/test_model_XXXXXX";
	int fd = mkstemp(path);
	CHECK(fd >= 0);
	close(fd);
	CHECK(mc_model_save(&m, path, &err) == 0);
	if (mc_model_load(path, &back, &err)) {
		fprintf(stderr, "reload: %s\n", err.msg);
		mc_test_failures++;
	} else {
		CHECK(same_model(&m, &back));
	}
	/* The free-root variant too. */
	m.root_free = true;
	CHECK(mc_model_finalize(&m, &err) == 0);
	CHECK(mc_model_save(&m, path, &err) == 0);
	CHECK(mc_model_load(path, &back, &err) == 0 && same_model(&m, &back) && back.ndof == 38);
	/* An invalid model is not written. */
	m.gauss[0].radius = -1;
	CHECK(mc_model_save(&m, path, &err) == -1 && strstr(err.msg, "not saved"));
	unlink(path);
	/* A missing file names itself. */
	CHECK(mc_model_load("tests/data/models/no_such_file.json", &back, &err) == -1);
	CHECK(strstr(err.msg, "no_such_file.json") != NULL);
}

/* Colours as "#rrggbb" and defaults of optional fields. */
static void test_parse_details(void)
{
	mc_model m;
	mc_err err;
	if (mc_model_load("tests/data/models/good_tiny.json", &m, &err)) {
		fprintf(stderr, "good_tiny.json: %s\n", err.msg);
		mc_test_failures++;
		return;
	}
	CHECK(!m.root_free && m.ndof == 4 && m.njoints == 5 && m.ngauss == 2);
	CHECK_NEAR(m.gauss[0].rgb[0], 0xd8 / 255.0, 1e-15);
	CHECK_NEAR(m.gauss[0].rgb[2], 0x88 / 255.0, 1e-15);
	CHECK_NEAR(m.smoothness_m, 0.1, 0);
	CHECK(m.bone_scale[3] == 1.0);
	CHECK(vdist(m.rig_from_root.t, mc_v3(0, 0, 0)) == 0 && m.rig_from_root.R.m[1][1] == 1);
	/* Default bones: the bone to the only child (head -> neck, spine -> pelvis). */
	CHECK(m.gauss[0].scale_joint == 1 && m.gauss[1].scale_joint == 3);
	double s = 0, c = 0;
	mc_sphere_to_gaussian(0.09, 0.1, &s, &c);
	CHECK(m.gauss[1].sigma == s && m.gauss[1].c == c);
	/* A radius of 5e-324 m (fuzz_model) made sigma 0 and c infinite, in a
	 * model the loader accepted: radii below 1 mm are refused. */
	const char *tiny = "{\"name\": \"t\", \"root\": \"free\", \"joints\": [{\"name\": \"a\"}], \"gaussians\": "
			   "[{\"joint\": \"a\", \"offset\": [0, 0, 0], \"radius\": 5e-324, \"color\": \"#ffffff\"}]}";
	mc_model t;
	CHECK(mc_model_parse(tiny, "tiny.json", &t, &err) == -1 &&
	      strstr(err.msg, "tiny.json: gaussians[0].radius: 4.94066e-324 m is smaller than 0.001 m"));
	CHECK(m.joints[2].dof0 == 1 && m.joints[4].dof0 == 3);
	CHECK_NEAR(m.joints[2].upper[0], M_PI / 2, 1e-15);
}

typedef struct {
	const char *file;
	const char *field;   /* must appear in the message after the file name */
	const char *problem; /* must appear too */
} bad_case;

static const bad_case BAD_CASES[] = {
	{"missing_joints.json", "missing_joints.json: joints", "missing"},
	{"missing_radius.json", "gaussians[1].radius", "missing"},
	{"missing_joint_name.json", "joints[2].name", "missing"},
	{"wrong_type_offset.json", "joints[1].offset", "expected an array"},
	{"wrong_type_radius.json", "gaussians[0].radius", "expected a number"},
	{"wrong_type_joints.json", "joints", "expected an array"},
	{"short_offset.json", "gaussians[1].offset", "expected 3 numbers"},
	{"nan_number.json", "nan_number.json:", "invalid token"},
	{"inf_number.json", "inf_number.json:", "real number overflow"},
	{"radius_zero.json", "gaussians[1].radius", "positive"},
	{"radius_negative.json", "gaussians[0].radius", "positive"},
	{"unknown_parent.json", "joints[3].parent", "unknown joint 'chest'"},
	{"unknown_gauss_joint.json", "gaussians[1].joint", "unknown joint 'hand'"},
	{"unknown_bone.json", "gaussians[0].bone", "unknown joint 'skull'"},
	{"cycle.json", "joints[1].parent", "cycle through 'pelvis'"},
	{"self_parent.json", "joints[4].parent", "cycle through 'left_hip'"},
	{"parent_after_child.json", "joints[2].parent", "listed later"},
	{"two_roots.json", "joints[3].parent", "only one root"},
	{"duplicate_name.json", "joints[4].name", "duplicate joint name 'spine'"},
	{"empty_name.json", "joints[4].name", "empty"},
	{"name_quote.json", "joints[4].name", "character 2 (byte 0x22) is not allowed in a joint name"},
	{"unknown_axis.json", "joints[2].dofs[1].axis", "unknown axis 'w'"},
	{"repeated_axis.json", "joints[2].dofs[1].axis", "same axis"},
	{"min_gt_max.json", "joints[1].dofs[0]", "min_deg (30) is greater than max_deg (10)"},
	{"missing_limit.json", "joints[1].dofs[0].max_deg", "missing"},
	{"four_dofs.json", "joints[2].dofs", "at most 3"},
	{"bad_hex_color.json", "gaussians[0].color", "hex colour"},
	{"color_range.json", "gaussians[1].color[1]", "outside [0, 1]"},
	{"unknown_field.json", "gaussians[1].raduis", "unknown field"},
	{"bad_root_kind.json", "bad_root_kind.json: root", "\"fixed\" or \"free\""},
	{"free_with_rig_from_root.json", "rig_from_root", "only allowed"},
	{"rig_from_root_scaled.json", "rig_from_root", "rotation"},
	{"smoothness_range.json", "smoothness_m", "out of range"},
	{"bone_scale_zero.json", "joints[2].bone_scale", "out of range"},
	{"offset_huge.json", "joints[2].offset", "within"},
	{"note_not_string.json", "note", "expected a string"},
	{"empty_joints.json", "joints", "at least 1"},
	{"too_many_joints.json", "joints", "at most 32"},
	{"too_many_dofs.json", "joints[30].dofs", "more than 96 degrees of freedom"},
	{"too_many_gaussians.json", "gaussians", "at most 128"},
	{"top_level_array.json", "top_level_array.json", "top level"},
};

static void test_bad_inputs(void)
{
	for (size_t i = 0; i < sizeof(BAD_CASES) / sizeof(BAD_CASES[0]); i++) {
		const bad_case *b = &BAD_CASES[i];
		char path[256];
		snprintf(path, sizeof(path), "tests/data/models/%s", b->file);
		mc_model m;
		mc_err err = {{0}};
		int r = mc_model_load(path, &m, &err);
		CHECK_MSG(r == -1, "%s: loaded", b->file);
		const char *at = strstr(err.msg, path);
		CHECK_MSG(at == err.msg, "%s: message does not start with the file: %s", b->file, err.msg);
		CHECK_MSG(strstr(err.msg, b->field) != NULL, "%s: message lacks the field '%s': %s", b->file, b->field,
			  err.msg);
		CHECK_MSG(strstr(err.msg, b->problem) != NULL, "%s: message lacks '%s': %s", b->file, b->problem, err.msg);
	}
	/* The brief's example message, verbatim in shape. */
	mc_model m;
	mc_err err;
	mc_model_load("tests/data/models/cycle.json", &m, &err);
	printf("e.g. %s\n", err.msg);
	/* Text input names its origin the same way. */
	CHECK(mc_model_parse("{\"name\": 3}", "inline.json", &m, &err) == -1);
	CHECK(strstr(err.msg, "inline.json: name: expected a string") == err.msg);
	CHECK(mc_model_parse("{", "inline.json", &m, &err) == -1 && strstr(err.msg, "inline.json:1:") == err.msg);
}

/* ---- the default human model ---- */

static mc_vec3 root_coords(const mc_model *m, const mc_fk *fk, const char *joint)
{
	int j = mc_model_find_joint(m, joint);
	return mc_xform_apply(mc_xform_inverse(m->rig_from_root), fk->rig_from_joint[j < 0 ? 0 : j].t);
}

static void test_default_model(void)
{
	mc_model m;
	if (!load_default(&m))
		return;
	CHECK(!m.root_free && strcmp(m.joints[0].name, "head") == 0);
	CHECK(m.njoints >= 15 && m.njoints <= 20);
	CHECK(m.ngauss >= 60 && m.ngauss <= 90);
	CHECK(m.ndof >= 30 && m.ndof <= 40);
	for (int i = 0; i < NOUTPUT; i++)
		CHECK_MSG(mc_model_find_joint(&m, OUTPUT_JOINTS[i]) >= 0, "%s missing", OUTPUT_JOINTS[i]);
	double pose[MC_MAX_DOF], clamped[MC_MAX_DOF];
	mc_model_rest_pose(&m, pose);
	for (int k = 0; k < m.ndof; k++)
		CHECK(pose[k] == 0); /* zero is inside every limit */
	memcpy(clamped, pose, sizeof(pose));
	mc_model_clamp_pose(&m, clamped);
	CHECK(memcmp(clamped, pose, sizeof(pose)) == 0);
	static mc_fk fk;
	mc_model_fk(&m, pose, &fk);
	/* Root frame: x to the actor's right, y down, z forward. */
	double height = root_coords(&m, &fk, "left_ankle").y - root_coords(&m, &fk, "head_top").y;
	double shoulders = vdist(root_coords(&m, &fk, "left_shoulder"), root_coords(&m, &fk, "right_shoulder"));
	double hips = vdist(root_coords(&m, &fk, "left_hip"), root_coords(&m, &fk, "right_hip"));
	printf("default model: %d joints, %d dofs, %d Gaussians; head_top to ankle %.3f m, shoulders %.3f m, "
	       "hips %.3f m\n",
	       m.njoints, m.ndof, m.ngauss, height, shoulders, hips);
	CHECK(height >= 1.6 && height <= 1.75);
	CHECK(shoulders >= 0.35 && shoulders <= 0.45);
	CHECK(hips >= 0.2 && hips <= 0.3);
	for (int j = 0; j < m.njoints; j++) {
		double x = root_coords(&m, &fk, m.joints[j].name).x;
		if (strncmp(m.joints[j].name, "left_", 5) == 0)
			CHECK_MSG(x < -0.05, "%s x = %g", m.joints[j].name, x);
		if (strncmp(m.joints[j].name, "right_", 6) == 0)
			CHECK_MSG(x > 0.05, "%s x = %g", m.joints[j].name, x);
	}
	CHECK(root_coords(&m, &fk, "left_toe").z > root_coords(&m, &fk, "left_ankle").z + 0.1);
	/* Left and right halves mirror each other (x -> -x). */
	mc_mat3 mirror = {{{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
	mc_xform root_from_rig = mc_xform_inverse(m.rig_from_root);
	double floor_y = root_coords(&m, &fk, "left_ankle").y + 0.08;
	for (int q = 0; q < m.ngauss; q++) {
		mc_vec3 p = mc_xform_apply(root_from_rig, fk.mu[q]), mp = mc_m3_apply(mirror, p);
		int twin = -1;
		for (int r = 0; r < m.ngauss; r++)
			if (vdist(mc_xform_apply(root_from_rig, fk.mu[r]), mp) < 1e-9 && m.gauss[r].radius == m.gauss[q].radius)
				twin = r;
		CHECK_MSG(twin >= 0, "gaussians[%d] has no mirror image", q);
		/* Nothing pokes through the floor by more than 1 cm; the body's
		 * width stays human. */
		CHECK_MSG(p.y + m.gauss[q].radius < floor_y + 0.01, "gaussians[%d] below the floor", q);
		CHECK(fabs(p.x) < 0.35);
		CHECK_NEAR(m.gauss[q].sigma / m.gauss[q].radius, 0.6223, 1e-3);
	}
}

/* Frame 0 of the evaluation clips: the default model's proportions, scaled
 * to the actor's height, are within 20% of the ground truth's segment
 * lengths, and its rest placement in the rig puts the neck where the
 * data's helmet rig has it. */
static void test_default_against_data(void)
{
	const char *dir = mc_test_data_dir();
	if (!dir) {
		printf("note: proportion check against the evaluation data skipped\n");
		return;
	}
	mc_model m;
	if (!load_default(&m))
		return;
	double pose[MC_MAX_DOF];
	static mc_fk fk;
	mc_model_rest_pose(&m, pose);
	mc_model_fk(&m, pose, &fk);
	static const char *const segs[][2] = {
		{"head_top", "neck"}, {"neck", "pelvis"}, {"left_shoulder", "right_shoulder"},
		{"left_shoulder", "left_elbow"}, {"left_elbow", "left_wrist"}, {"right_shoulder", "right_elbow"},
		{"right_elbow", "right_wrist"}, {"left_hip", "left_knee"}, {"left_knee", "left_ankle"},
		{"right_hip", "right_knee"}, {"right_knee", "right_ankle"}, {"left_ankle", "left_toe"},
		{"left_hip", "right_hip"}};
	const char *clips[] = {"walk_131_01", "jumps_01_01"};
	for (int c = 0; c < 2; c++) {
		char path[512];
		snprintf(path, sizeof(path), "%s/ego/%s/gt.json", dir, clips[c]);
		json_t *gt;
		mc_err err;
		if (mc_json_load_file(path, &gt, &err)) {
			printf("note: %s\n", err.msg);
			continue;
		}
		double height = json_number_value(json_object_get(gt, "height_m"));
		json_t *joints = json_object_get(json_array_get(json_object_get(gt, "frames"), 0), "joints_left_cam");
		CHECK(height > 1 && json_is_object(joints));
		double worst = 0;
		for (size_t s = 0; s < sizeof(segs) / sizeof(segs[0]) && json_is_object(joints); s++) {
			mc_vec3 a, b;
			CHECK(mc_json_vec3(joints, segs[s][0], path, &a, true, &err) == 0);
			CHECK(mc_json_vec3(joints, segs[s][1], path, &b, true, &err) == 0);
			double data = vdist(a, b);
			double model = vdist(fk.rig_from_joint[mc_model_find_joint(&m, segs[s][0])].t,
					     fk.rig_from_joint[mc_model_find_joint(&m, segs[s][1])].t) *
				       height / 1.75;
			double ratio = model / data;
			worst = fmax(worst, fabs(ratio - 1));
			CHECK_MSG(ratio > 0.8 && ratio < 1.2, "%s: %s-%s model %.3f m, data %.3f m", clips[c], segs[s][0],
				  segs[s][1], model, data);
		}
		mc_vec3 neck;
		if (json_is_object(joints) && mc_json_vec3(joints, "neck", path, &neck, true, &err) == 0) {
			double d = vdist(neck, fk.rig_from_joint[mc_model_find_joint(&m, "neck")].t);
			CHECK_MSG(d < 0.02, "%s: rest neck %.3f m from frame 0", clips[c], d);
			printf("%s: worst segment length deviation %.0f%%, neck %.1f cm from frame 0\n", clips[c],
			       100 * worst, 100 * d);
		}
		json_decref(gt);
	}
}

int main(void)
{
	test_round_trip();
	test_parse_details();
	test_bad_inputs();
	test_default_model();
	test_default_against_data();
	return mc_test_finish("test_model_io");
}
