/* Rigs: the JSON rig format (docs/RIG_FORMAT.md) and ray tables.  The
 * importers of other formats are in mc_rig_import.c. */
#include "geom/mc_rig.h"

#include "base/mc_file.h"
#include "base/mc_json.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEG (M_PI / 180.0)

static const char *const kind_names[] = {"egocentric", "outside-in"};

int mc_rig_find(const mc_rig *rig, const char *name)
{
	for (int i = 0; i < rig->ncams; i++)
		if (strcmp(rig->cams[i].name, name) == 0)
			return i;
	return -1;
}

bool mc_rig_sees(const mc_rig *rig, mc_vec3 p)
{
	double u, v;
	for (int c = 0; c < rig->ncams; c++)
		if (mc_camera_project_rig(&rig->cams[c], p, &u, &v))
			return true;
	return false;
}

/* Re-labels a camera-level error ("fx: must be positive") with its place in
 * the file ("rig.json: cameras[0].fx: must be positive"). */
int mc_rig_check_camera_name(const char *name, const char *where, mc_err *err)
{
	char p[384];
	if (name[0] == 0)
		return mc_err_set(err, "%s: must not be empty", mc_json_path(p, sizeof(p), where, "name"));
	return 0;
}

static int camera_error(mc_err *err, const char *where)
{
	if (!err)
		return -1;
	char msg[sizeof(err->msg)];
	memcpy(msg, err->msg, sizeof(msg));
	return mc_err_set(err, "%s.%s", where, msg);
}

/* ---- parsing ------------------------------------------------------------ */

/* rig_from_cam: a 4x4 matrix, or {"rotation": 3x3, "translation": [3]}. */
static int parse_pose(const json_t *jc, const char *where, mc_xform *pose, mc_err *err)
{
	json_t *v = json_object_get(jc, "rig_from_cam");
	char p[384];
	mc_json_path(p, sizeof(p), where, "rig_from_cam");
	if (json_is_object(v)) {
		static const char *const keys[] = {"rotation", "translation", NULL};
		if (mc_json_check_keys(v, p, keys, err) || mc_json_mat3(v, "rotation", p, &pose->R, true, err) ||
		    mc_json_vec3(v, "translation", p, &pose->t, true, err))
			return -1;
		return 0;
	}
	double m[4][4];
	if (!v || json_is_null(v))
		return mc_err_set(err, "%s: missing", p);
	if (!json_is_array(v))
		return mc_err_set(err, "%s: expected a 4x4 matrix or {\"rotation\", \"translation\"}", p);
	if (mc_json_mat4(jc, "rig_from_cam", where, m, true, err))
		return -1;
	if (m[3][0] != 0 || m[3][1] != 0 || m[3][2] != 0 || m[3][3] != 1)
		return mc_err_set(err, "%s[3]: last row of a rigid transform must be [0, 0, 0, 1]", p);
	*pose = mc_xform_from_4x4((const double(*)[4])m);
	return 0;
}

/* max_theta_deg, or fov_deg (the full angle); exactly one of them. */
static int parse_field_of_view(const json_t *jc, const char *where, double *max_theta, mc_err *err)
{
	double deg;
	int r1 = mc_json_number_range(jc, "max_theta_deg", where, MC_RIG_MAX_THETA_MIN_DEG, MC_RIG_MAX_THETA_MAX_DEG, &deg,
				      false, err);
	if (r1 < 0)
		return -1;
	double fov;
	int r2 = mc_json_number_range(jc, "fov_deg", where, 2 * MC_RIG_MAX_THETA_MIN_DEG, 2 * MC_RIG_MAX_THETA_MAX_DEG, &fov,
				      false, err);
	if (r2 < 0)
		return -1;
	char p[384];
	if (r1 == 0 && r2 == 0)
		return mc_err_set(err, "%s: give max_theta_deg or fov_deg, not both",
				  mc_json_path(p, sizeof(p), where, "fov_deg"));
	if (r1 == 1 && r2 == 1)
		return mc_err_set(err, "%s: missing (or fov_deg)", mc_json_path(p, sizeof(p), where, "max_theta_deg"));
	*max_theta = (r1 == 0 ? deg : fov / 2) * DEG;
	return 0;
}

/* fx and fy, or f for both. */
static int parse_focal(const json_t *jc, const char *where, mc_camera *cam, mc_err *err)
{
	double f;
	int r = mc_json_positive(jc, "f", where, &f, false, err);
	if (r < 0)
		return -1;
	char p[384];
	if (r == 0) {
		if (json_object_get(jc, "fx") || json_object_get(jc, "fy"))
			return mc_err_set(err, "%s: give f or fx and fy, not both", mc_json_path(p, sizeof(p), where, "f"));
		cam->fx = cam->fy = f;
		return 0;
	}
	if (mc_json_positive(jc, "fx", where, &cam->fx, true, err) ||
	    mc_json_positive(jc, "fy", where, &cam->fy, true, err))
		return -1;
	return 0;
}

static int parse_distortion(const json_t *jc, const char *where, mc_camera *cam, mc_err *err)
{
	if (cam->model == MC_CAM_EQUIDISTANT)
		return mc_json_numbers(jc, "k", where, cam->k, 4, false, err) < 0 ? -1 : 0;
	/* pinhole: k1 k2 p1 p2 [k3], OpenCV's order */
	size_t n = 0;
	int r = mc_json_numbers_var(jc, "k", where, cam->k, 5, &n, false, err);
	char p[384];
	if (r < 0)
		return -1;
	if (r == 0 && n < 4)
		return mc_err_set(err, "%s: expected 4 or 5 numbers (k1 k2 p1 p2 [k3]), got %zu",
				  mc_json_path(p, sizeof(p), where, "k"), n);
	return 0;
}

static int parse_ocam(const json_t *jc, const char *where, mc_camera *cam, mc_err *err)
{
	size_t n = 0;
	if (mc_json_numbers_var(jc, "pol", where, cam->ocam_pol, MC_OCAM_POLY_MAX, &n, true, err))
		return -1;
	cam->ocam_pol_len = (int)n;
	n = 0;
	if (mc_json_numbers_var(jc, "invpol", where, cam->ocam_invpol, MC_OCAM_POLY_MAX * 2, &n, false, err) < 0)
		return -1;
	cam->ocam_invpol_len = (int)n;
	cam->ocam_c = 1, cam->ocam_d = 0, cam->ocam_e = 0;
	if (mc_json_number(jc, "xc", where, &cam->ocam_xc, true, err) ||
	    mc_json_number(jc, "yc", where, &cam->ocam_yc, true, err) ||
	    mc_json_number(jc, "c", where, &cam->ocam_c, false, err) < 0 ||
	    mc_json_number(jc, "d", where, &cam->ocam_d, false, err) < 0 ||
	    mc_json_number(jc, "e", where, &cam->ocam_e, false, err) < 0)
		return -1;
	return 0;
}

static const char *const pinhole_keys[] = {"name", "model", "width", "height", "f", "fx", "fy", "cx", "cy", "k",
					   "max_theta_deg", "fov_deg", "rig_from_cam", "note", NULL};
static const char *const ocam_keys[] = {"name", "model", "width", "height", "pol", "invpol", "xc", "yc", "c", "d",
					"e", "max_theta_deg", "fov_deg", "rig_from_cam", "note", NULL};

static int parse_camera(const json_t *jc, const char *where, mc_camera *cam, mc_err *err)
{
	char model[32], p[384];
	memset(cam, 0, sizeof(*cam));
	if (!json_is_object(jc))
		return mc_err_set(err, "%s: expected an object", where);
	if (mc_json_string(jc, "name", where, cam->name, sizeof(cam->name), true, err) ||
	    mc_json_string(jc, "model", where, model, sizeof(model), true, err))
		return -1;
	if (mc_rig_check_camera_name(cam->name, where, err))
		return -1;
	if (mc_camera_model_parse(model, &cam->model))
		return mc_err_set(err, "%s: unknown camera model '%s' (pinhole, equidistant or ocam)",
				  mc_json_path(p, sizeof(p), where, "model"), model);
	if (mc_json_check_keys(jc, where, cam->model == MC_CAM_OCAM ? ocam_keys : pinhole_keys, err) ||
	    mc_json_int(jc, "width", where, 1, MC_CAMERA_SIZE_MAX, &cam->width, true, err) ||
	    mc_json_int(jc, "height", where, 1, MC_CAMERA_SIZE_MAX, &cam->height, true, err) ||
	    parse_field_of_view(jc, where, &cam->max_theta, err) || parse_pose(jc, where, &cam->rig_from_cam, err))
		return -1;
	if (cam->model == MC_CAM_OCAM) {
		if (parse_ocam(jc, where, cam, err))
			return -1;
	} else if (parse_focal(jc, where, cam, err) || mc_json_number(jc, "cx", where, &cam->cx, true, err) ||
		   mc_json_number(jc, "cy", where, &cam->cy, true, err) || parse_distortion(jc, where, cam, err)) {
		return -1;
	}
	if (mc_camera_validate(cam, err))
		return camera_error(err, where);
	return 0;
}

static int rig_from_json(const json_t *root, const char *origin, mc_rig *rig, mc_err *err)
{
	static const char *const keys[] = {"name", "kind", "cameras", "note", NULL};
	char kind[32];
	json_t *cams;
	memset(rig, 0, sizeof(*rig));
	if (!json_is_object(root))
		return mc_err_set(err, "%s: expected a JSON object at the top level", origin);
	if (mc_json_check_keys(root, origin, keys, err) ||
	    mc_json_string(root, "name", origin, rig->name, sizeof(rig->name), true, err) ||
	    mc_json_string(root, "kind", origin, kind, sizeof(kind), true, err))
		return -1;
	if (strcmp(kind, kind_names[0]) == 0)
		rig->kind = MC_RIG_EGOCENTRIC;
	else if (strcmp(kind, kind_names[1]) == 0)
		rig->kind = MC_RIG_OUTSIDE_IN;
	else
		return mc_err_set(err, "%s: kind: unknown rig kind '%s' (egocentric or outside-in)", origin, kind);
	if (mc_json_array(root, "cameras", origin, 1, MC_MAX_CAMERAS, &cams, true, err))
		return -1;
	for (size_t i = 0; i < json_array_size(cams); i++) {
		char where[384];
		mc_json_path_index(where, sizeof(where), origin, "cameras", i);
		if (parse_camera(json_array_get(cams, i), where, &rig->cams[i], err))
			return -1;
		if (mc_rig_find(rig, rig->cams[i].name) >= 0)
			return mc_err_set(err, "%s.name: camera name '%s' is used twice", where, rig->cams[i].name);
		rig->ncams = (int)i + 1;
	}
	return 0;
}

int mc_rig_parse(const char *json_text, const char *origin, mc_rig *rig, mc_err *err)
{
	json_t *root;
	if (mc_json_load_text(json_text, origin, &root, err))
		return -1;
	int r = rig_from_json(root, origin, rig, err);
	json_decref(root);
	return r;
}

int mc_rig_load(const char *path, mc_rig *rig, mc_err *err)
{
	json_t *root;
	if (mc_json_load_file(path, &root, err))
		return -1;
	int r = rig_from_json(root, path, rig, err);
	json_decref(root);
	return r;
}

/* ---- saving ------------------------------------------------------------- */

static json_t *json_numbers(const double *a, int n)
{
	json_t *arr = json_array();
	for (int i = 0; i < n; i++)
		json_array_append_new(arr, json_real(a[i]));
	return arr;
}

static json_t *pose_to_json(const mc_xform *x)
{
	json_t *rot = json_array();
	for (int i = 0; i < 3; i++)
		json_array_append_new(rot, json_numbers(x->R.m[i], 3));
	double t[3] = {x->t.x, x->t.y, x->t.z};
	json_t *o = json_object();
	json_object_set_new(o, "rotation", rot);
	json_object_set_new(o, "translation", json_numbers(t, 3));
	return o;
}

static json_t *camera_to_json(const mc_camera *cam)
{
	json_t *o = json_object();
	json_object_set_new(o, "name", json_string(cam->name));
	json_object_set_new(o, "model", json_string(mc_camera_model_name(cam->model)));
	json_object_set_new(o, "width", json_integer(cam->width));
	json_object_set_new(o, "height", json_integer(cam->height));
	if (cam->model == MC_CAM_OCAM) {
		json_object_set_new(o, "pol", json_numbers(cam->ocam_pol, cam->ocam_pol_len));
		if (cam->ocam_invpol_len > 0)
			json_object_set_new(o, "invpol", json_numbers(cam->ocam_invpol, cam->ocam_invpol_len));
		json_object_set_new(o, "xc", json_real(cam->ocam_xc));
		json_object_set_new(o, "yc", json_real(cam->ocam_yc));
		json_object_set_new(o, "c", json_real(cam->ocam_c));
		json_object_set_new(o, "d", json_real(cam->ocam_d));
		json_object_set_new(o, "e", json_real(cam->ocam_e));
	} else {
		json_object_set_new(o, "fx", json_real(cam->fx));
		json_object_set_new(o, "fy", json_real(cam->fy));
		json_object_set_new(o, "cx", json_real(cam->cx));
		json_object_set_new(o, "cy", json_real(cam->cy));
		json_object_set_new(o, "k", json_numbers(cam->k, cam->model == MC_CAM_PINHOLE ? 5 : 4));
	}
	/* Clamped: degrees from radians may round just past the range. */
	double deg = fmin(fmax(cam->max_theta / DEG, MC_RIG_MAX_THETA_MIN_DEG), MC_RIG_MAX_THETA_MAX_DEG);
	json_object_set_new(o, "max_theta_deg", json_real(deg));
	json_object_set_new(o, "rig_from_cam", pose_to_json(&cam->rig_from_cam));
	return o;
}

static json_t *rig_to_json(const mc_rig *rig)
{
	json_t *root = json_object();
	json_object_set_new(root, "name", json_string(rig->name));
	json_object_set_new(root, "kind", json_string(kind_names[rig->kind == MC_RIG_OUTSIDE_IN]));
	json_t *cams = json_array();
	for (int i = 0; i < rig->ncams; i++)
		json_array_append_new(cams, camera_to_json(&rig->cams[i]));
	json_object_set_new(root, "cameras", cams);
	return root;
}

int mc_rig_save(const mc_rig *rig, const char *path, mc_err *err)
{
	json_t *root = rig_to_json(rig);
	int r = mc_json_save_file(root, path, err);
	json_decref(root);
	return r;
}

char *mc_rig_to_json(const mc_rig *rig, mc_err *err)
{
	json_t *root = rig_to_json(rig);
	char *text = json_dumps(root, JSON_INDENT(1) | JSON_PRESERVE_ORDER | JSON_REAL_PRECISION(17));
	json_decref(root);
	if (!text)
		mc_err_set(err, "rig '%s': out of memory writing JSON", rig->name);
	return text;
}

/* ---- ray tables ----------------------------------------------------------- */

int mc_raytable_build(const mc_camera *cam, int width, int height, mc_raytable *rt, mc_err *err)
{
	memset(rt, 0, sizeof(*rt));
	if (mc_camera_validate(cam, err))
		return mc_err_prefix(err, "camera '%s'", cam->name);
	if (width < 1 || height < 1 || width > MC_CAMERA_SIZE_MAX || height > MC_CAMERA_SIZE_MAX)
		return mc_err_set(err, "camera '%s': ray table size %dx%d out of range", cam->name, width, height);
	size_t n = (size_t)width * height;
	rt->dir = calloc(n, sizeof(*rt->dir));
	rt->valid = calloc(n, 1);
	if (!rt->dir || !rt->valid) {
		mc_raytable_free(rt);
		return mc_err_set(err, "camera '%s': out of memory for a %dx%d ray table", cam->name, width, height);
	}
	rt->width = width, rt->height = height;
	rt->scale_x = (double)cam->width / width;
	rt->scale_y = (double)cam->height / height;
	rt->origin = cam->rig_from_cam.t;
	for (int j = 0; j < height; j++) {
		for (int i = 0; i < width; i++) {
			double u = (i + 0.5) * rt->scale_x - 0.5, v = (j + 0.5) * rt->scale_y - 0.5;
			size_t k = (size_t)j * width + i;
			if (!mc_camera_unproject_rig(cam, u, v, &rt->dir[k]))
				continue;
			rt->valid[k] = 1;
			rt->nvalid++;
		}
	}
	if (rt->nvalid == 0) { /* nothing could ever be seen: a broken calibration */
		mc_raytable_free(rt);
		return mc_err_set(err, "camera '%s': no pixel has a ray (check its intrinsics and field of view)",
				  cam->name);
	}
	return 0;
}

void mc_raytable_free(mc_raytable *rt)
{
	free(rt->dir);
	free(rt->valid);
	memset(rt, 0, sizeof(*rt));
}
