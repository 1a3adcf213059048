/* mc_model_io: the JSON body-model format (docs/MODEL_FORMAT.md).
 *
 * Parsing goes in passes so that every error can name its field: joint
 * names first, then the tree (unknown parents, cycles, order), then each
 * joint's offset and dofs, then the Gaussians.  mc_model_finalize() does
 * the remaining bookkeeping (dof layout, sigma and c). */
#include "base/mc_json.h"
#include "body/mc_model.h"

#include <stdio.h>
#include <string.h>

#define WHERE_CAP 400
#define MAX_OFFSET_M 10.0  /* as MODEL_MAX_EXTENT in mc_model.c */
/* A smaller sphere has no size the tracker could see, and its sigma
 * (radius / 1.6) can underflow to 0, which makes c infinite. */
#define MIN_RADIUS_M 1e-3
#define MAX_BONE_SCALE 10.0
#define MAX_LIMIT_DEG 360.0

static const char *const AXIS_STRINGS[3] = {"x", "y", "z"};

static double deg_to_rad(double d) { return d * (M_PI / 180.0); }
static double rad_to_deg(double r) { return r * (180.0 / M_PI); }

/* "origin: key[i]" */
static char *element_where(char *buf, const char *where, const char *key, size_t i)
{
	return mc_json_path_index(buf, WHERE_CAP, where, key, i);
}

/* An array element that must be a JSON object with only `allowed` keys. */
static int element_object(const json_t *arr, size_t i, const char *where, const char *const *allowed, json_t **out,
			  mc_err *err)
{
	json_t *v = json_array_get(arr, i);
	if (!json_is_object(v))
		return mc_err_set(err, "%s: expected an object", where);
	*out = v;
	return mc_json_check_keys(v, where, allowed, err);
}

/* A vector whose components lie within MAX_OFFSET_M. */
static int offset_field(const json_t *obj, const char *key, const char *where, mc_vec3 *out, bool required,
			mc_err *err)
{
	int r = mc_json_vec3(obj, key, where, out, required, err);
	if (r)
		return r;
	if (fabs(out->x) > MAX_OFFSET_M || fabs(out->y) > MAX_OFFSET_M || fabs(out->z) > MAX_OFFSET_M) {
		char p[WHERE_CAP];
		return mc_err_set(err, "%s: components must be within +-%g m", mc_json_path(p, sizeof(p), where, key),
				  MAX_OFFSET_M);
	}
	return 0;
}

/* ---- joints ---- */

static const char *const JOINT_KEYS[] = {"name", "parent", "offset", "dofs", "bone_scale", NULL};
static const char *const DOF_KEYS[] = {"axis", "min_deg", "max_deg", NULL};

/* A joint name's first character outside A-Z a-z 0-9 _ - ., or NULL.  The
 * names travel into takes and from there into JSON, CSV and BVH exports
 * and the protocol's joint lists: a quote, a comma, a space or a newline
 * in one would break or inject into those (issue 34). */
static const char *bad_name_char(const char *name)
{
	for (const char *c = name; *c; c++)
		if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '_' ||
		      *c == '-' || *c == '.'))
			return c;
	return NULL;
}

/* Pass 1: names, unique, non-empty, of the joint-name characters. */
static int parse_joint_names(const json_t *joints, const char *origin, mc_model *m, mc_err *err)
{
	char where[WHERE_CAP], p[WHERE_CAP];
	for (size_t i = 0; i < json_array_size(joints); i++) {
		json_t *jo = NULL;
		element_where(where, origin, "joints", i);
		if (element_object(joints, i, where, JOINT_KEYS, &jo, err))
			return -1;
		char *name = m->joints[i].name;
		if (mc_json_string(jo, "name", where, name, MC_JOINT_NAME_MAX, true, err))
			return -1;
		if (!name[0])
			return mc_err_set(err, "%s: must not be empty", mc_json_path(p, sizeof(p), where, "name"));
		const char *bad = bad_name_char(name);
		if (bad)
			return mc_err_set(err, "%s: character %d (byte 0x%02x) is not allowed in a joint name (A-Z a-z 0-9 "
					  "_ - . only)", mc_json_path(p, sizeof(p), where, "name"), (int)(bad - name) + 1,
					  (unsigned char)*bad);
		for (size_t k = 0; k < i; k++)
			if (strcmp(m->joints[k].name, name) == 0)
				return mc_err_set(err, "%s: duplicate joint name '%s' (also joints[%zu])",
						  mc_json_path(p, sizeof(p), where, "name"), name, k);
		m->njoints = (int)i + 1;
	}
	return 0;
}

/* Writes "a -> b -> ... -> a" for the cycle through joint i. */
static void describe_cycle(const mc_model *m, int i, char *buf, size_t cap)
{
	size_t len = (size_t)snprintf(buf, cap, "%s", m->joints[i].name);
	for (int j = m->joints[i].parent, n = 0; n < m->njoints && len < cap; j = m->joints[j].parent, n++) {
		len += (size_t)snprintf(buf + len, cap - len, " -> %s", m->joints[j].name);
		if (j == i)
			break;
	}
}

/* Pass 2: resolves parent names, then rejects cycles, several roots and
 * parents listed after their children (the pose layout follows file order,
 * so the loader does not reorder). */
static int parse_joint_tree(const json_t *joints, const char *origin, mc_model *m, mc_err *err)
{
	char where[WHERE_CAP], p[WHERE_CAP];
	for (int i = 0; i < m->njoints; i++) {
		json_t *jo = json_array_get(joints, (size_t)i);
		char parent[MC_JOINT_NAME_MAX];
		element_where(where, origin, "joints", (size_t)i);
		int r = mc_json_string(jo, "parent", where, parent, sizeof(parent), false, err);
		if (r < 0)
			return -1;
		m->joints[i].parent = -1;
		if (r == 0) {
			m->joints[i].parent = mc_model_find_joint(m, parent);
			if (m->joints[i].parent < 0)
				return mc_err_set(err, "%s: unknown joint '%s'", mc_json_path(p, sizeof(p), where, "parent"),
						  parent);
		}
	}
	for (int i = 0; i < m->njoints; i++) {
		/* Joint i is on a cycle if walking up from it comes back to it. */
		int j = m->joints[i].parent;
		for (int n = 0; j >= 0 && j != i && n < m->njoints; n++)
			j = m->joints[j].parent;
		if (j == i) {
			char cycle[256];
			describe_cycle(m, i, cycle, sizeof(cycle));
			element_where(where, origin, "joints", (size_t)i);
			return mc_err_set(err, "%s: cycle through '%s' (%s)", mc_json_path(p, sizeof(p), where, "parent"),
					  m->joints[m->joints[i].parent].name, cycle);
		}
	}
	int root = -1;
	for (int i = 0; i < m->njoints; i++) {
		int parent = m->joints[i].parent;
		element_where(where, origin, "joints", (size_t)i);
		if (parent < 0 && root >= 0)
			return mc_err_set(err, "%s: missing (only one root: joints[%d] '%s' has no parent)",
					  mc_json_path(p, sizeof(p), where, "parent"), root, m->joints[root].name);
		if (parent < 0)
			root = i;
		else if (parent > i)
			return mc_err_set(err, "%s: '%s' is listed later (joints[%d]); list parents before their children",
					  mc_json_path(p, sizeof(p), where, "parent"), m->joints[parent].name, parent);
	}
	return 0;
}

static int parse_axis(const json_t *dof, const char *where, int *axis, mc_err *err)
{
	char s[8];
	if (mc_json_string(dof, "axis", where, s, sizeof(s), true, err)) {
		char p[WHERE_CAP];
		/* "x"/"y"/"z" are short: a too-long string is just a wrong axis. */
		if (json_is_string(json_object_get(dof, "axis")))
			return mc_err_set(err, "%s: unknown axis (expected \"x\", \"y\" or \"z\")",
					  mc_json_path(p, sizeof(p), where, "axis"));
		return -1;
	}
	for (int a = 0; a < 3; a++)
		if (strcmp(s, AXIS_STRINGS[a]) == 0) {
			*axis = a;
			return 0;
		}
	char p[WHERE_CAP];
	return mc_err_set(err, "%s: unknown axis '%s' (expected \"x\", \"y\" or \"z\")",
			  mc_json_path(p, sizeof(p), where, "axis"), s);
}

static int parse_dofs(const json_t *jo, const char *where, mc_joint *jt, int *total, mc_err *err)
{
	json_t *dofs;
	int r = mc_json_array(jo, "dofs", where, 0, 3, &dofs, false, err);
	if (r < 0)
		return -1;
	jt->ndof = r == 0 ? (int)json_array_size(dofs) : 0;
	for (int a = 0; a < jt->ndof; a++) {
		char dw[WHERE_CAP], p[WHERE_CAP];
		json_t *dof = NULL;
		element_where(dw, where, "dofs", (size_t)a);
		if (element_object(dofs, (size_t)a, dw, DOF_KEYS, &dof, err) || parse_axis(dof, dw, &jt->axis[a], err))
			return -1;
		if (a > 0 && jt->axis[a] == jt->axis[a - 1])
			return mc_err_set(err, "%s: same axis as the previous dof (redundant)",
					  mc_json_path(p, sizeof(p), dw, "axis"));
		double lo, hi;
		if (mc_json_number_range(dof, "min_deg", dw, -MAX_LIMIT_DEG, MAX_LIMIT_DEG, &lo, true, err) ||
		    mc_json_number_range(dof, "max_deg", dw, -MAX_LIMIT_DEG, MAX_LIMIT_DEG, &hi, true, err))
			return -1;
		if (lo > hi)
			return mc_err_set(err, "%s: min_deg (%g) is greater than max_deg (%g)", dw, lo, hi);
		jt->lower[a] = deg_to_rad(lo);
		jt->upper[a] = deg_to_rad(hi);
	}
	*total += jt->ndof;
	if (*total > MC_MAX_DOF) {
		char p[WHERE_CAP];
		return mc_err_set(err, "%s: the model has more than %d degrees of freedom",
				  mc_json_path(p, sizeof(p), where, "dofs"), MC_MAX_DOF);
	}
	return 0;
}

/* Pass 3: offsets, bone scales and dofs. */
static int parse_joint_bodies(const json_t *joints, const char *origin, mc_model *m, mc_err *err)
{
	int total = m->root_free ? MC_ROOT_FREE_DOFS : 0;
	for (int i = 0; i < m->njoints; i++) {
		char where[WHERE_CAP];
		json_t *jo = json_array_get(joints, (size_t)i);
		mc_joint *jt = &m->joints[i];
		element_where(where, origin, "joints", (size_t)i);
		/* The root may omit its offset (it sits at its parent frame). */
		if (offset_field(jo, "offset", where, &jt->offset, jt->parent >= 0, err) < 0)
			return -1;
		m->bone_scale[i] = 1.0;
		if (mc_json_number_range(jo, "bone_scale", where, 1e-3, MAX_BONE_SCALE, &m->bone_scale[i], false, err) <
		    0)
			return -1;
		if (parse_dofs(jo, where, jt, &total, err))
			return -1;
	}
	return 0;
}

/* ---- Gaussians ---- */

static const char *const GAUSS_KEYS[] = {"joint", "offset", "radius", "color", "bone", NULL};

static int hex_digit(char c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	if (c >= 'a' && c <= 'f')
		return c - 'a' + 10;
	if (c >= 'A' && c <= 'F')
		return c - 'A' + 10;
	return -1;
}

/* "#rrggbb" or [r, g, b] in 0..1. */
static int parse_color(const json_t *go, const char *where, double rgb[3], mc_err *err)
{
	char p[WHERE_CAP];
	mc_json_path(p, sizeof(p), where, "color");
	json_t *v = json_object_get(go, "color");
	if (json_is_string(v)) {
		const char *s = json_string_value(v);
		if (strlen(s) != 7 || s[0] != '#')
			return mc_err_set(err, "%s: expected \"#rrggbb\", got \"%.32s\"", p, s);
		for (int i = 0; i < 3; i++) {
			int hi = hex_digit(s[1 + 2 * i]), lo = hex_digit(s[2 + 2 * i]);
			if (hi < 0 || lo < 0)
				return mc_err_set(err, "%s: \"%s\" is not a hex colour \"#rrggbb\"", p, s);
			rgb[i] = (hi * 16 + lo) / 255.0;
		}
		return 0;
	}
	if (mc_json_numbers(go, "color", where, rgb, 3, true, err))
		return -1;
	for (int i = 0; i < 3; i++)
		if (rgb[i] < 0 || rgb[i] > 1)
			return mc_err_set(err, "%s[%d]: %g is outside [0, 1]", p, i, rgb[i]);
	return 0;
}

/* A joint named by field `key` of obj. */
static int joint_field(const json_t *obj, const char *key, const char *where, const mc_model *m, int *out,
		       bool required, mc_err *err)
{
	char name[MC_JOINT_NAME_MAX], p[WHERE_CAP];
	int r = mc_json_string(obj, key, where, name, sizeof(name), required, err);
	if (r)
		return r;
	*out = mc_model_find_joint(m, name);
	if (*out < 0)
		return mc_err_set(err, "%s: unknown joint '%s'", mc_json_path(p, sizeof(p), where, key), name);
	return 0;
}

/* The default bone of a Gaussian on joint j: the bone it lies along, i.e.
 * the one to j's only child; with no child or several, j's own bone. */
static int default_bone(const mc_model *m, int j)
{
	int child = -1, nchildren = 0;
	for (int k = j + 1; k < m->njoints; k++)
		if (m->joints[k].parent == j) {
			child = k;
			nchildren++;
		}
	return nchildren == 1 ? child : j;
}

static int parse_gaussians(const json_t *root, const char *origin, mc_model *m, mc_err *err)
{
	json_t *arr;
	if (mc_json_array(root, "gaussians", origin, 1, MC_MAX_GAUSSIANS, &arr, true, err))
		return -1;
	m->ngauss = (int)json_array_size(arr);
	for (int q = 0; q < m->ngauss; q++) {
		char where[WHERE_CAP], p[WHERE_CAP];
		json_t *go = NULL;
		mc_gauss_def *g = &m->gauss[q];
		element_where(where, origin, "gaussians", (size_t)q);
		if (element_object(arr, (size_t)q, where, GAUSS_KEYS, &go, err) ||
		    joint_field(go, "joint", where, m, &g->joint, true, err) ||
		    offset_field(go, "offset", where, &g->offset, true, err) ||
		    mc_json_positive(go, "radius", where, &g->radius, true, err) || parse_color(go, where, g->rgb, err))
			return -1;
		if (g->radius > MAX_OFFSET_M)
			return mc_err_set(err, "%s: %g m is larger than %g m", mc_json_path(p, sizeof(p), where, "radius"),
					  g->radius, MAX_OFFSET_M);
		if (g->radius < MIN_RADIUS_M)
			return mc_err_set(err, "%s: %g m is smaller than %g m", mc_json_path(p, sizeof(p), where, "radius"),
					  g->radius, MIN_RADIUS_M);
		g->scale_joint = default_bone(m, g->joint);
		if (joint_field(go, "bone", where, m, &g->scale_joint, false, err) < 0)
			return -1;
	}
	return 0;
}

/* ---- top level ---- */

/* "note" is free text for people (JSON has no comments); it is not kept. */
static const char *const MODEL_KEYS[] = {"name",   "note",      "root", "rig_from_root", "smoothness_m",
					 "joints", "gaussians", NULL};

/* Matrices in files are often printed with 4-6 digits: accept a rotation to
 * 1e-3 and re-orthonormalise it. */
static bool is_near_rotation(mc_mat3 R)
{
	mc_mat3 RtR = mc_m3_mul(mc_m3_transpose(R), R);
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			if (!(fabs(RtR.m[i][j] - (i == j)) <= 1e-3))
				return false;
	mc_vec3 x = mc_v3(R.m[0][0], R.m[1][0], R.m[2][0]), y = mc_v3(R.m[0][1], R.m[1][1], R.m[2][1]);
	mc_vec3 z = mc_v3(R.m[0][2], R.m[1][2], R.m[2][2]);
	return mc_v3_dot(mc_v3_cross(x, y), z) > 0;
}

static int parse_rig_from_root(const json_t *root, const char *origin, mc_model *m, mc_err *err)
{
	double M[4][4];
	char p[WHERE_CAP];
	m->rig_from_root = mc_xform_identity();
	int r = mc_json_mat4(root, "rig_from_root", origin, M, false, err);
	if (r)
		return r < 0 ? -1 : 0;
	mc_json_path(p, sizeof(p), origin, "rig_from_root");
	if (m->root_free)
		return mc_err_set(err, "%s: only allowed with \"root\": \"fixed\" (a free root is posed by p[0..5])", p);
	if (M[3][0] != 0 || M[3][1] != 0 || M[3][2] != 0 || M[3][3] != 1)
		return mc_err_set(err, "%s: the last row must be [0, 0, 0, 1]", p);
	m->rig_from_root = mc_xform_from_4x4(M);
	if (!is_near_rotation(m->rig_from_root.R))
		return mc_err_set(err, "%s: the 3x3 block must be a rotation (orthonormal to 1e-3, det +1)", p);
	/* Remove the rounding of a matrix printed with few digits. */
	m->rig_from_root.R = mc_m3_orthonormalize(m->rig_from_root.R);
	return 0;
}

static int parse_model(const json_t *root, const char *origin, mc_model *m, mc_err *err)
{
	memset(m, 0, sizeof(*m));
	if (!json_is_object(root))
		return mc_err_set(err, "%s: expected a JSON object at the top level", origin);
	if (mc_json_check_keys(root, origin, MODEL_KEYS, err) ||
	    mc_json_string(root, "name", origin, m->name, sizeof(m->name), true, err))
		return -1;
	json_t *note = json_object_get(root, "note");
	char p0[WHERE_CAP];
	if (note && !json_is_string(note))
		return mc_err_set(err, "%s: expected a string", mc_json_path(p0, sizeof(p0), origin, "note"));
	char kind[16], p[WHERE_CAP];
	if (mc_json_string(root, "root", origin, kind, sizeof(kind), true, err) < 0) {
		if (json_is_string(json_object_get(root, "root")))
			return mc_err_set(err, "%s: expected \"fixed\" or \"free\"", mc_json_path(p, sizeof(p), origin, "root"));
		return -1;
	}
	if (strcmp(kind, "fixed") != 0 && strcmp(kind, "free") != 0)
		return mc_err_set(err, "%s: expected \"fixed\" or \"free\", got \"%s\"",
				  mc_json_path(p, sizeof(p), origin, "root"), kind);
	m->root_free = strcmp(kind, "free") == 0;
	if (parse_rig_from_root(root, origin, m, err))
		return -1;
	m->smoothness_m = 0.1;
	if (mc_json_number_range(root, "smoothness_m", origin, MC_SMOOTHNESS_MIN, MC_SMOOTHNESS_MAX, &m->smoothness_m,
				 false, err) < 0)
		return -1;
	json_t *joints;
	if (mc_json_array(root, "joints", origin, 1, MC_MAX_JOINTS, &joints, true, err) ||
	    parse_joint_names(joints, origin, m, err) || parse_joint_tree(joints, origin, m, err) ||
	    parse_joint_bodies(joints, origin, m, err) || parse_gaussians(root, origin, m, err))
		return -1;
	/* Everything the format can express has been checked above; this
	 * assigns the dof layout and sigma, c (and would catch a gap). */
	if (mc_model_finalize(m, err))
		return mc_err_prefix(err, "%s", origin);
	return 0;
}

int mc_model_parse(const char *json_text, const char *origin, mc_model *model, mc_err *err)
{
	json_t *root;
	if (mc_json_load_text(json_text, origin, &root, err))
		return -1;
	int r = parse_model(root, origin, model, err);
	json_decref(root);
	return r;
}

int mc_model_load(const char *path, mc_model *model, mc_err *err)
{
	json_t *root;
	if (mc_json_load_file(path, &root, err))
		return -1;
	int r = parse_model(root, path, model, err);
	json_decref(root);
	return r;
}

/* ---- saving ---- */

static json_t *vec3_json(mc_vec3 v)
{
	return json_pack("[fff]", v.x, v.y, v.z);
}

static json_t *joint_json(const mc_model *m, int j)
{
	const mc_joint *jt = &m->joints[j];
	json_t *o = json_object();
	json_object_set_new(o, "name", json_string(jt->name));
	if (jt->parent >= 0)
		json_object_set_new(o, "parent", json_string(m->joints[jt->parent].name));
	json_object_set_new(o, "offset", vec3_json(jt->offset));
	json_t *dofs = json_array();
	for (int a = 0; a < jt->ndof; a++)
		json_array_append_new(dofs, json_pack("{s:s, s:f, s:f}", "axis", AXIS_STRINGS[jt->axis[a]], "min_deg",
						      rad_to_deg(jt->lower[a]), "max_deg", rad_to_deg(jt->upper[a])));
	json_object_set_new(o, "dofs", dofs);
	if (m->bone_scale[j] != 1.0)
		json_object_set_new(o, "bone_scale", json_real(m->bone_scale[j]));
	return o;
}

static json_t *gauss_json(const mc_model *m, int q)
{
	const mc_gauss_def *g = &m->gauss[q];
	/* Colours as numbers: a calibrated albedo is not a multiple of 1/255. */
	return json_pack("{s:s, s:o, s:f, s:[fff], s:s}", "joint", m->joints[g->joint].name, "offset",
			 vec3_json(g->offset), "radius", g->radius, "color", g->rgb[0], g->rgb[1], g->rgb[2], "bone",
			 m->joints[g->scale_joint].name);
}

static json_t *model_json(const mc_model *m)
{
	json_t *o = json_object();
	json_object_set_new(o, "name", json_string(m->name));
	json_object_set_new(o, "root", json_string(m->root_free ? "free" : "fixed"));
	if (!m->root_free) {
		double M[4][4];
		mc_xform_to_4x4(m->rig_from_root, M);
		json_t *rows = json_array();
		for (int i = 0; i < 4; i++)
			json_array_append_new(rows, json_pack("[ffff]", M[i][0], M[i][1], M[i][2], M[i][3]));
		json_object_set_new(o, "rig_from_root", rows);
	}
	json_object_set_new(o, "smoothness_m", json_real(m->smoothness_m));
	json_t *joints = json_array(), *gaussians = json_array();
	for (int j = 0; j < m->njoints; j++)
		json_array_append_new(joints, joint_json(m, j));
	for (int q = 0; q < m->ngauss; q++)
		json_array_append_new(gaussians, gauss_json(m, q));
	json_object_set_new(o, "joints", joints);
	json_object_set_new(o, "gaussians", gaussians);
	return o;
}

int mc_model_save(const mc_model *model, const char *path, mc_err *err)
{
	if (mc_model_validate(model, err))
		return mc_err_prefix(err, "%s: not saved", path);
	json_t *root = model_json(model);
	if (!root)
		return mc_err_set(err, "%s: out of memory", path);
	int r = mc_json_save_file(root, path, err);
	json_decref(root);
	return r;
}
