/* Rig importers: the evaluation data's calib.json (head-mounted stereo) and
 * cameras.json (outside-in, OpenCV intrinsics and world_to_camera), and
 * OCamCalib's calib_results.txt (docs/RIG_FORMAT.md, "Importers"). */
#include "geom/mc_rig.h"

#include "base/mc_file.h"
#include "base/mc_json.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEG (M_PI / 180.0)

/* ---- import: the evaluation data's calib.json --------------------------- */

static int ego_lens(const json_t *root, const char *path, bool use_ocam, mc_camera *cam, mc_err *err)
{
	double f, fov;
	memset(cam, 0, sizeof(*cam));
	if (mc_json_int(root, "width", path, 1, MC_CAMERA_SIZE_MAX, &cam->width, true, err) ||
	    mc_json_int(root, "height", path, 1, MC_CAMERA_SIZE_MAX, &cam->height, true, err) ||
	    mc_json_positive(root, "f", path, &f, true, err) || mc_json_number(root, "cx", path, &cam->cx, true, err) ||
	    mc_json_number(root, "cy", path, &cam->cy, true, err) ||
	    mc_json_number_range(root, "fov_deg", path, 2 * MC_RIG_MAX_THETA_MIN_DEG, 2 * MC_RIG_MAX_THETA_MAX_DEG, &fov,
				 true, err))
		return -1;
	cam->max_theta = fov / 2 * DEG;
	if (!use_ocam) {
		cam->model = MC_CAM_EQUIDISTANT;
		cam->fx = cam->fy = f;
		return 0;
	}
	/* w(rho) = a0 + a2 rho^2 + a3 rho^3 + a4 rho^4, already in OpenCV axes. */
	json_t *poly;
	char where[384];
	if (mc_json_object(root, "ocam_poly", path, &poly, true, err))
		return -1;
	mc_json_path(where, sizeof(where), path, "ocam_poly");
	static const char *const names[] = {"a0", "a1", "a2", "a3", "a4"};
	for (int i = 0; i < 5; i++)
		if (mc_json_number(poly, names[i], where, &cam->ocam_pol[i], i != 1, err) < 0)
			return -1;
	cam->model = MC_CAM_OCAM;
	cam->ocam_pol_len = 5;
	cam->ocam_xc = cam->cx, cam->ocam_yc = cam->cy;
	cam->ocam_c = 1, cam->ocam_d = 0, cam->ocam_e = 0;
	cam->cx = cam->cy = 0;
	return 0;
}

int mc_rig_import_ego_calib(const char *path, bool use_ocam, mc_rig *rig, mc_err *err)
{
	json_t *root;
	double m[4][4];
	memset(rig, 0, sizeof(*rig));
	if (mc_json_load_file(path, &root, err))
		return -1;
	int r = -1;
	mc_camera lens;
	if (ego_lens(root, path, use_ocam, &lens, err) || mc_json_mat4(root, "right_from_left", path, m, true, err))
		goto out;
	snprintf(rig->name, sizeof(rig->name), "ego_stereo%s", use_ocam ? "_ocam" : "");
	rig->kind = MC_RIG_EGOCENTRIC;
	rig->ncams = 2;
	rig->cams[0] = rig->cams[1] = lens;
	snprintf(rig->cams[0].name, sizeof(rig->cams[0].name), "left");
	snprintf(rig->cams[1].name, sizeof(rig->cams[1].name), "right");
	rig->cams[0].rig_from_cam = mc_xform_identity();
	/* The rig frame is the left camera's: the right camera's pose in it is
	 * the inverse of right_from_left. */
	rig->cams[1].rig_from_cam = mc_xform_inverse(mc_xform_from_4x4((const double(*)[4])m));
	if (mc_camera_validate(&rig->cams[0], err)) {
		mc_err_prefix(err, "%s", path);
		goto out;
	}
	if (mc_camera_validate(&rig->cams[1], err)) {
		/* Only the pose differs between the two cameras. */
		mc_err_set(err, "%s: right_from_left: not a rigid transform", path);
		goto out;
	}
	/* The file stores single-precision rotations: make them exact. */
	rig->cams[1].rig_from_cam.R = mc_m3_orthonormalize(rig->cams[1].rig_from_cam.R);
	r = 0;
out:
	json_decref(root);
	return r;
}

/* ---- import: OCamCalib calib_results.txt -------------------------------- */

/* Numbers of the file in order, with the line each came from; '#' lines are
 * comments, as in the toolbox's own reader. */
typedef struct {
	double *val;
	int *line;
	char (*text)[32];
	size_t n, cap, next;
	const char *path;
} token_list;

static int tokens_read(const char *path, token_list *tl, mc_err *err)
{
	/* The whole file at once (a regular file of at most 1 MiB), split at
	 * newlines: no line is cut, whatever its length. */
	uint8_t *data;
	size_t bytes;
	if (mc_file_read(path, 1u << 20, &data, &bytes, err) < 0)
		return -1;
	char *text = (char *)data;
	if (strlen(text) != bytes) {
		free(data);
		return mc_err_set(err, "%s: contains a NUL byte; not a text file", path);
	}
	int lineno = 0, r = 0;
	for (char *next = text; r == 0 && next && *next;) {
		char *line = next, *nl = strchr(line, '\n');
		if (nl)
			*nl = 0;
		next = nl ? nl + 1 : NULL;
		lineno++;
		char *s = line + strspn(line, " \t\r");
		if (*s == '#')
			continue;
		char *save = NULL;
		for (char *tok = strtok_r(s, " \t\r", &save); tok && r == 0; tok = strtok_r(NULL, " \t\r", &save)) {
			if (tl->n == tl->cap) {
				size_t cap = tl->cap ? tl->cap * 2 : 64;
				double *val = realloc(tl->val, cap * sizeof(*val));
				if (val)
					tl->val = val;
				int *line = realloc(tl->line, cap * sizeof(*line));
				if (line)
					tl->line = line;
				char(*text)[32] = realloc(tl->text, cap * sizeof(*text));
				if (text)
					tl->text = text;
				if (!val || !line || !text) {
					r = mc_err_set(err, "%s: out of memory", path);
					break;
				}
				tl->cap = cap;
			}
			char *end;
			errno = 0;
			double x = strtod(tok, &end);
			if (*end || end == tok || errno == ERANGE || !isfinite(x))
				r = mc_err_set(err, "%s:%d: '%.40s' is not a finite number", path, lineno, tok);
			tl->val[tl->n] = x;
			tl->line[tl->n] = lineno;
			snprintf(tl->text[tl->n], sizeof(tl->text[0]), "%s", tok);
			tl->n++;
		}
	}
	free(data);
	return r;
}

static void tokens_free(token_list *tl)
{
	free(tl->val);
	free(tl->line);
	free(tl->text);
}

/* The next number, named `what` in errors. */
static int token_next(token_list *tl, const char *what, double *out, mc_err *err)
{
	if (tl->next >= tl->n)
		return mc_err_set(err, "%s: file ends before %s", tl->path, what);
	*out = tl->val[tl->next++];
	return 0;
}

static int token_count(token_list *tl, const char *what, int max, int min, int *out, mc_err *err)
{
	double x = 0;
	if (token_next(tl, what, &x, err))
		return -1;
	if (x != floor(x) || x < min || x > max)
		return mc_err_set(err, "%s:%d: %s: expected an integer %d..%d, got '%s'", tl->path,
				  tl->line[tl->next - 1], what, min, max, tl->text[tl->next - 1]);
	*out = (int)x;
	return 0;
}

int mc_rig_import_ocamcalib(const char *path, double max_theta, mc_camera *cam, mc_err *err)
{
	token_list tl = {.path = path};
	memset(cam, 0, sizeof(*cam));
	int r = tokens_read(path, &tl, err);
	int npol = 0, ninv = 0, h = 0, w = 0;
	double pol[MC_OCAM_POLY_MAX], inv[MC_OCAM_POLY_MAX * 2], row_c = 0, col_c = 0, c = 0, d = 0, e = 0;
	if (r == 0)
		r = token_count(&tl, "length of the direct polynomial", MC_OCAM_POLY_MAX, 1, &npol, err);
	for (int i = 0; r == 0 && i < npol; i++)
		r = token_next(&tl, "the direct polynomial's coefficients", &pol[i], err);
	if (r == 0)
		r = token_count(&tl, "length of the inverse polynomial", MC_OCAM_POLY_MAX * 2, 0, &ninv, err);
	for (int i = 0; r == 0 && i < ninv; i++)
		r = token_next(&tl, "the inverse polynomial's coefficients", &inv[i], err);
	if (r == 0)
		r = token_next(&tl, "the centre (row)", &row_c, err);
	if (r == 0)
		r = token_next(&tl, "the centre (column)", &col_c, err);
	if (r == 0)
		r = token_next(&tl, "affine parameter c", &c, err);
	if (r == 0)
		r = token_next(&tl, "affine parameter d", &d, err);
	if (r == 0)
		r = token_next(&tl, "affine parameter e", &e, err);
	if (r == 0)
		r = token_count(&tl, "image height", MC_CAMERA_SIZE_MAX, 1, &h, err);
	if (r == 0)
		r = token_count(&tl, "image width", MC_CAMERA_SIZE_MAX, 1, &w, err);
	tokens_free(&tl);
	if (r)
		return -1;
	if (!(fabs(c) > 1e-6))
		return mc_err_set(err, "%s: affine parameter c must not be 0", path);
	/* The toolbox's pixels are (row, column) and its axes are (down, right,
	 * backward) in OpenCV terms. Swapping the image axes turns [c d; e 1]
	 * into [1 e; d c]; dividing by c restores the [c' d'; e' 1] form and
	 * scales the undistorted plane by c, hence the polynomial's rescaling.
	 * docs/RIG_FORMAT.md derives it. */
	cam->model = MC_CAM_OCAM;
	cam->width = w, cam->height = h;
	cam->ocam_xc = col_c, cam->ocam_yc = row_c;
	cam->ocam_c = 1 / c, cam->ocam_d = e / c, cam->ocam_e = d / c;
	cam->ocam_pol_len = npol;
	double scale = c; /* c^(1 - i) for i = 0 */
	for (int i = 0; i < npol; i++, scale /= c)
		cam->ocam_pol[i] = -pol[i] * scale;
	cam->ocam_invpol_len = ninv;
	for (int i = 0; i < ninv; i++)
		cam->ocam_invpol[i] = c * inv[i];
	cam->max_theta = max_theta;
	cam->rig_from_cam = mc_xform_identity();
	snprintf(cam->name, sizeof(cam->name), "ocam");
	if (mc_camera_validate(cam, err))
		return mc_err_prefix(err, "%s", path);
	return 0;
}


/* ---- import: outside-in cameras.json (OpenCV intrinsics, world_to_camera) -- */

static int opencv_camera(const json_t *jc, const char *where, mc_camera *cam, mc_err *err)
{
	static const char *const keys[] = {"name", "model", "width", "height", "fx", "fy", "cx", "cy",
					   "dist", "world_to_camera", "note", NULL};
	char model[32];
	double dist[5] = {0}, m[4][4];
	size_t ndist = 0;
	memset(cam, 0, sizeof(*cam));
	if (mc_json_check_keys(jc, where, keys, err) ||
	    mc_json_string(jc, "name", where, cam->name, sizeof(cam->name), true, err) ||
	    mc_json_string(jc, "model", where, model, sizeof(model), true, err) ||
	    mc_rig_check_camera_name(cam->name, where, err)) /* what the rig loader refuses */
		return -1;
	if (strcmp(model, "pinhole") != 0)
		return mc_err_set(err, "%s.model: only 'pinhole' cameras can be imported, got '%s'", where, model);
	if (mc_json_int(jc, "width", where, 1, MC_CAMERA_SIZE_MAX, &cam->width, true, err) ||
	    mc_json_int(jc, "height", where, 1, MC_CAMERA_SIZE_MAX, &cam->height, true, err) ||
	    mc_json_number_range(jc, "fx", where, MC_CAMERA_FOCAL_MIN, MC_CAMERA_COORD_MAX, &cam->fx, true, err) ||
	    mc_json_number_range(jc, "fy", where, MC_CAMERA_FOCAL_MIN, MC_CAMERA_COORD_MAX, &cam->fy, true, err) ||
	    mc_json_number_range(jc, "cx", where, -MC_CAMERA_COORD_MAX, MC_CAMERA_COORD_MAX, &cam->cx, true, err) ||
	    mc_json_number_range(jc, "cy", where, -MC_CAMERA_COORD_MAX, MC_CAMERA_COORD_MAX, &cam->cy, true, err) ||
	    mc_json_mat4(jc, "world_to_camera", where, m, true, err) ||
	    mc_json_numbers_var(jc, "dist", where, dist, 5, &ndist, false, err) < 0) /* 1: absent */
		return -1;
	if (ndist != 0 && ndist != 4 && ndist != 5)
		return mc_err_set(err, "%s.dist: expected 4 or 5 numbers (k1 k2 p1 p2 [k3]), got %zu", where, ndist);
	cam->model = MC_CAM_PINHOLE;
	for (int i = 0; i < 5; i++)
		cam->k[i] = dist[i];
	/* The rig frame is the world frame: the camera's pose in it is the
	 * inverse of world_to_camera (single precision in files written by
	 * Blender or float tools: made exact). */
	cam->rig_from_cam = mc_xform_inverse(mc_xform_from_4x4((const double(*)[4])m));
	cam->rig_from_cam.R = mc_m3_orthonormalize(cam->rig_from_cam.R);
	if (mc_camera_fit_max_theta(cam, err) < 0)
		return mc_err_prefix(err, "%s", where);
	return 0;
}

int mc_rig_import_cameras_json(const char *path, mc_rig *rig, mc_err *err)
{
	json_t *root, *cams;
	memset(rig, 0, sizeof(*rig));
	if (mc_json_load_file(path, &root, err))
		return -1;
	int r = -1;
	static const char *const keys[] = {"cameras", "note", NULL};
	if (mc_json_check_keys(root, path, keys, err) ||
	    mc_json_array(root, "cameras", path, 1, MC_MAX_CAMERAS, &cams, true, err))
		goto out;
	snprintf(rig->name, sizeof(rig->name), "outside_in");
	rig->kind = MC_RIG_OUTSIDE_IN;
	for (size_t i = 0; i < json_array_size(cams); i++) {
		char where[384];
		mc_json_path_index(where, sizeof(where), path, "cameras", i);
		if (opencv_camera(json_array_get(cams, i), where, &rig->cams[i], err))
			goto out;
		if (mc_rig_find(rig, rig->cams[i].name) >= 0) {
			mc_err_set(err, "%s.name: '%s' is used twice", where, rig->cams[i].name);
			goto out;
		}
		rig->ncams = (int)i + 1;
	}
	r = 0;
out:
	json_decref(root);
	return r;
}
