/* mocap-render: renders the body model through a rig's cameras, and draws
 * projected skeletons over images.  A debugging tool; see docs/RENDER.md.
 *
 *   mocap-render --rig R.json --model M.json [--pose P.json | --rest]
 *                [--width W --height H] [--background grey|black]
 *                [--cam NAME] [--skeleton] --out PREFIX
 *   mocap-render --rig R.json --model M.json [--pose P.json | --rest]
 *                --cam NAME --overlay IMAGE [--gt gt.json --frame K] --out PREFIX
 *
 * The first form writes PREFIX_<cam>.png for every camera (or only NAME):
 * the model's image formation (mc_ray_render_rgb) at the working resolution.
 * The second writes PREFIX_<cam>_overlay.png: IMAGE with the posed model's
 * skeleton, and optionally a ground-truth skeleton, projected on it. */
#include "geom/mc_camera.h"
#include "image/mc_draw.h"
#include "energy/mc_energy.h"
#include "image/mc_image.h"
#include "base/mc_json.h"
#include "eval/mc_gt.h"
#include "base/mc_time.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "mc_install_paths.h" /* generated: MC_VERSION */

#include <errno.h>
#include <getopt.h>
#include <png.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define DEG (M_PI / 180.0)

typedef struct {
	const char *rig_path, *model_path, *pose_path, *out, *cam, *overlay, *gt_path;
	int width, height, frame;
	int scale; /* --overlay: the image enlarged this many times (1: as it is) */
	bool skeleton;
	double background[3];
} options;

typedef mc_canvas image;

/* ---- command line -------------------------------------------------------- */

static void usage(FILE *f)
{
	fprintf(f, "usage: mocap-render --rig RIG.json --model MODEL.json [--pose POSE.json | --rest]\n"
		   "                    [--width W --height H] [--background grey|black] [--cam NAME]\n"
		   "                    [--skeleton] --out PREFIX\n"
		   "       mocap-render --rig RIG.json --model MODEL.json [--pose POSE.json | --rest]\n"
		   "                    --cam NAME --overlay IMAGE [--gt gt.json --frame K] [--scale N] --out PREFIX\n"
		   "Renders the body model through every rig camera into PREFIX_<cam>.png, or draws\n"
		   "the projected skeleton over IMAGE into PREFIX_<cam>_overlay.png (--scale N: IMAGE\n"
		   "enlarged N times first, 1..8, so that thin bones stay visible). See docs/RENDER.md.\n");
}

static int parse_int(const char *opt, const char *s, int lo, int hi, int *out)
{
	char *end;
	long v = strtol(s, &end, 10);
	if (*s == 0 || *end || v < lo || v > hi) {
		fprintf(stderr, "mocap-render: %s: expected an integer %d..%d, got '%s'\n", opt, lo, hi, s);
		return -1;
	}
	*out = (int)v;
	return 0;
}

static int parse_args(int argc, char **argv, options *o)
{
	static const struct option longopts[] = {
		{"rig", required_argument, 0, 'r'},    {"model", required_argument, 0, 'm'},
		{"pose", required_argument, 0, 'p'},   {"rest", no_argument, 0, 'R'},
		{"width", required_argument, 0, 'W'},  {"height", required_argument, 0, 'H'},
		{"background", required_argument, 0, 'b'}, {"cam", required_argument, 0, 'c'},
		{"skeleton", no_argument, 0, 's'},     {"overlay", required_argument, 0, 'o'},
		{"gt", required_argument, 0, 'g'},     {"frame", required_argument, 0, 'f'},
		{"out", required_argument, 0, 'O'},    {"help", no_argument, 0, 'h'},
		{"scale", required_argument, 0, 'S'},
		{"version", no_argument, 0, 'V'},      {0, 0, 0, 0},
	};
	memset(o, 0, sizeof(*o));
	o->frame = -1;
	o->scale = 1;
	o->background[0] = o->background[1] = o->background[2] = 0.5;
	int ch;
	while ((ch = getopt_long(argc, argv, "hV", longopts, NULL)) != -1) {
		switch (ch) {
		case 'r': o->rig_path = optarg; break;
		case 'm': o->model_path = optarg; break;
		case 'p': o->pose_path = optarg; break;
		case 'R': o->pose_path = NULL; break;
		case 'W': if (parse_int("--width", optarg, 1, 4096, &o->width)) return -1; break;
		case 'H': if (parse_int("--height", optarg, 1, 4096, &o->height)) return -1; break;
		case 'f': if (parse_int("--frame", optarg, 0, 1000000, &o->frame)) return -1; break;
		case 'S': if (parse_int("--scale", optarg, 1, 8, &o->scale)) return -1; break;
		case 'c': o->cam = optarg; break;
		case 's': o->skeleton = true; break;
		case 'o': o->overlay = optarg; break;
		case 'g': o->gt_path = optarg; break;
		case 'O': o->out = optarg; break;
		case 'b':
			if (strcmp(optarg, "grey") == 0 || strcmp(optarg, "gray") == 0) {
				o->background[0] = o->background[1] = o->background[2] = 0.5;
			} else if (strcmp(optarg, "black") == 0) {
				o->background[0] = o->background[1] = o->background[2] = 0;
			} else {
				fprintf(stderr, "mocap-render: --background: expected grey or black, got '%s'\n", optarg);
				return -1;
			}
			break;
		case 'h': usage(stdout); exit(0);
		case 'V': printf("mocap-render %s\n", MC_VERSION); exit(0);
		default: usage(stderr); return -1;
		}
	}
	const char *missing = !o->rig_path ? "--rig" : !o->model_path ? "--model" : !o->out ? "--out" : NULL;
	if (missing) {
		fprintf(stderr, "mocap-render: %s is required\n", missing);
		usage(stderr);
		return -1;
	}
	if (optind < argc) {
		fprintf(stderr, "mocap-render: unexpected argument '%s'\n", argv[optind]);
		return -1;
	}
	if ((o->width > 0) != (o->height > 0)) {
		fprintf(stderr, "mocap-render: give both --width and --height, or neither\n");
		return -1;
	}
	if (o->overlay && !o->cam) {
		fprintf(stderr, "mocap-render: --overlay needs --cam NAME (the camera that took the image)\n");
		return -1;
	}
	if (o->scale != 1 && !o->overlay) {
		fprintf(stderr, "mocap-render: --scale goes with --overlay\n");
		return -1;
	}
	if ((o->gt_path != NULL) != (o->frame >= 0) || (o->gt_path && !o->overlay)) {
		fprintf(stderr, "mocap-render: --gt and --frame go together, with --overlay\n");
		return -1;
	}
	return 0;
}

/* ---- pose file ------------------------------------------------------------- */

/* {"pose": [ndof numbers]} in the model's units (radians, metres), or
 * {"dofs": {"left_elbow.x": 45, ...}} with angles in degrees (root.tx..tz in
 * metres); unnamed dofs keep their rest value. */
static int load_pose(const char *path, const mc_model *model, double *pose, mc_err *err)
{
	json_t *root, *dofs;
	if (mc_json_load_file(path, &root, err))
		return -1;
	static const char *const keys[] = {"pose", "dofs", "note", NULL};
	int r = -1;
	if (mc_json_check_keys(root, path, keys, err))
		goto out;
	size_t n = 0;
	int has_vec = mc_json_numbers_var(root, "pose", path, pose, MC_MAX_DOF, &n, false, err);
	if (has_vec < 0)
		goto out;
	if (has_vec == 0 && (int)n != model->ndof) {
		mc_err_set(err, "%s: pose: the model has %d dofs, got %zu numbers", path, model->ndof, n);
		goto out;
	}
	int has_map = mc_json_object(root, "dofs", path, &dofs, false, err);
	if (has_map < 0)
		goto out;
	if (has_vec == 0 && has_map == 0) {
		mc_err_set(err, "%s: give pose or dofs, not both", path);
		goto out;
	}
	if (has_vec == 1 && has_map == 1) {
		mc_err_set(err, "%s: pose: missing (or dofs)", path);
		goto out;
	}
	if (has_map == 0) {
		const char *key;
		json_t *v;
		char where[512];
		snprintf(where, sizeof(where), "%s: dofs", path);
		json_object_foreach(dofs, key, v) {
			int k;
			char name[96];
			for (k = 0; k < model->ndof; k++) {
				mc_model_dof_name(model, k, name, sizeof(name));
				if (strcmp(name, key) == 0)
					break;
			}
			if (k == model->ndof) {
				mc_err_set(err, "%s.%s: no such dof in the model (names look like left_elbow.x)", where,
					   key);
				goto out;
			}
			double x;
			if (mc_json_number(dofs, key, where, &x, true, err))
				goto out;
			bool translation = model->root_free && k < 3;
			pose[k] = translation ? x : x * DEG;
		}
	}
	r = 0;
out:
	json_decref(root);
	return r;
}

/* ---- drawing ----------------------------------------------------------------- */

/* Bones of the model skeleton (parent -> child), then joints as discs. */
static void draw_skeleton(image *im, const mc_camera *cam, const mc_model *model, const mc_fk *fk)
{
	mc_vec3 pos[MC_MAX_JOINTS];
	int parent[MC_MAX_JOINTS];
	const char *names[MC_MAX_JOINTS];
	for (int j = 0; j < model->njoints; j++) {
		pos[j] = fk->rig_from_joint[j].t;
		parent[j] = model->joints[j].parent;
		names[j] = model->joints[j].name;
	}
	mc_draw_skeleton(im, cam, model->njoints, pos, parent, NULL, names, NULL, mc_draw_thickness(im));
}

/* Ground truth: frames[K].joints_left_cam of the evaluation data's gt.json,
 * taken as rig-frame points (the ego rigs' frame is the left camera's).
 * Bones follow the model's tree, skipping joints gt.json lacks. */
static int draw_ground_truth(image *im, const mc_camera *cam, const mc_model *model, const char *path, int frame,
			     mc_err *err)
{
	mc_gt gt;
	if (mc_gt_load(path, "joints_left_cam", &gt, err))
		return -1;
	if (frame >= gt.nframes) {
		mc_err_set(err, "%s: frames: no frame %d (the file has %d)", path, frame, gt.nframes);
		mc_gt_free(&gt);
		return -1;
	}
	mc_vec3 pos[MC_MAX_JOINTS];
	bool have[MC_MAX_JOINTS];
	int parent[MC_MAX_JOINTS];
	for (int j = 0; j < model->njoints; j++) {
		int g = mc_gt_joint(&gt, model->joints[j].name);
		have[j] = g >= 0;
		pos[j] = have[j] ? mc_gt_at(&gt, frame, g) : (mc_vec3){0, 0, 0};
		parent[j] = model->joints[j].parent;
	}
	mc_draw_skeleton(im, cam, model->njoints, pos, parent, have, NULL, MC_DRAW_GT, 0.6 * mc_draw_thickness(im));
	mc_gt_free(&gt);
	return 0;
}

/* ---- rendering ---------------------------------------------------------------------- */

static uint8_t to_byte(double x)
{
	return (uint8_t)lround(fmin(1, fmax(0, x)) * 255);
}

/* The model's image formation through one camera at w x h: every valid
 * pixel's colour is sum_q V_q albedo_q + B * background; pixels outside
 * the lens' field are black. */
static int render_camera(const mc_camera *cam, const mc_scene *scene, const double (*albedo)[3],
			 const double bg[3], int w, int h, image *im, mc_err *err)
{
	mc_raytable rt;
	if (mc_raytable_build(cam, w, h, &rt, err))
		return -1;
	im->width = w, im->height = h;
	im->rgb = calloc((size_t)w * h, 3);
	if (!im->rgb) {
		mc_raytable_free(&rt);
		return mc_err_set(err, "out of memory for a %dx%d image", w, h);
	}
	for (int k = 0; k < w * h; k++) {
		if (!rt.valid[k])
			continue;
		double rgb[3];
		mc_ray_render_rgb(scene, albedo, rt.origin, rt.dir[k], bg, rgb);
		for (int ch = 0; ch < 3; ch++)
			im->rgb[(size_t)k * 3 + ch] = to_byte(rgb[ch]);
	}
	mc_raytable_free(&rt);
	return 0;
}

static int output_path(char *buf, size_t cap, const char *prefix, const char *cam, const char *suffix,
		       mc_err *err)
{
	if ((size_t)snprintf(buf, cap, "%s_%s%s.png", prefix, cam, suffix) >= cap)
		return mc_err_set(err, "%s: output path too long", prefix);
	return 0;
}

static int run_render(const options *o, const mc_rig *rig, const mc_model *model, const mc_fk *fk, mc_err *err)
{
	static mc_scene scene;
	double albedo[MC_MAX_GAUSSIANS][3];
	mc_scene_from_model(model, fk, &scene);
	for (int q = 0; q < model->ngauss; q++)
		memcpy(albedo[q], model->gauss[q].rgb, sizeof(albedo[q]));
	for (int i = 0; i < rig->ncams; i++) {
		const mc_camera *cam = &rig->cams[i];
		if (o->cam && strcmp(o->cam, cam->name) != 0)
			continue;
		int w = o->width ? o->width : cam->width, h = o->height ? o->height : cam->height;
		image im = {0};
		char path[4096];
		uint64_t t0 = mc_now_ns();
		if (output_path(path, sizeof(path), o->out, cam->name, "", err) ||
		    render_camera(cam, &scene, (const double(*)[3])albedo, o->background, w, h, &im, err))
			return -1;
		if (o->skeleton)
			draw_skeleton(&im, cam, model, fk);
		int r = mc_draw_write_png(path, &im, err);
		free(im.rgb);
		if (r)
			return -1;
		printf("%s: %dx%d, %.2f s\n", path, w, h, mc_ms_since(t0) / 1e3);
	}
	return 0;
}

/* Enlarges im n times, each pixel a block (the camera's pixels stay
 * visible under the skeleton). */
static int enlarge(image *im, int n, mc_err *err)
{
	if (n == 1)
		return 0;
	uint8_t *big = malloc((size_t)im->width * n * im->height * n * 3);
	if (!big)
		return mc_err_set(err, "out of memory");
	for (int y = 0; y < im->height * n; y++)
		for (int x = 0; x < im->width * n; x++)
			memcpy(big + ((size_t)y * im->width * n + x) * 3, im->rgb + ((size_t)(y / n) * im->width + x / n) * 3,
			       3);
	free(im->rgb);
	im->rgb = big;
	im->width *= n;
	im->height *= n;
	return 0;
}

static int run_overlay(const options *o, const mc_rig *rig, const mc_model *model, const mc_fk *fk, mc_err *err)
{
	const mc_camera *cam = &rig->cams[mc_rig_find(rig, o->cam)];
	mc_image_conv *conv = mc_image_conv_new(err);
	if (!conv)
		return -1;
	image im = {0};
	int r = mc_image_load(conv, o->overlay, &im.rgb, &im.width, &im.height, err);
	mc_image_conv_free(conv);
	if (r)
		return -1;
	if (im.width * cam->height != im.height * cam->width)
		fprintf(stderr, "mocap-render: warning: %s is %dx%d, camera '%s' is %dx%d: aspect ratios differ\n",
			o->overlay, im.width, im.height, cam->name, cam->width, cam->height);
	char path[4096];
	r = enlarge(&im, o->scale, err);
	if (r == 0)
		r = output_path(path, sizeof(path), o->out, cam->name, "_overlay", err);
	if (r == 0 && o->gt_path)
		r = draw_ground_truth(&im, cam, model, o->gt_path, o->frame, err);
	if (r == 0) {
		draw_skeleton(&im, cam, model, fk);
		r = mc_draw_write_png(path, &im, err);
	}
	free(im.rgb);
	if (r == 0)
		printf("%s: %dx%d\n", path, im.width, im.height);
	return r;
}

int main(int argc, char **argv)
{
	options o;
	if (parse_args(argc, argv, &o))
		return 2;
	static mc_rig rig;
	static mc_model model;
	static mc_fk fk;
	double pose[MC_MAX_DOF];
	mc_err err = {0};
	if (mc_rig_load(o.rig_path, &rig, &err) || mc_model_load(o.model_path, &model, &err))
		goto fail;
	/* as the tracker does: outside-in, the body has a free root */
	if (rig.kind == MC_RIG_OUTSIDE_IN && mc_model_make_root_free(&model, &err))
		goto fail;
	if (o.cam && mc_rig_find(&rig, o.cam) < 0) {
		mc_err_set(&err, "%s: no camera named '%s'", o.rig_path, o.cam);
		goto fail;
	}
	mc_model_rest_pose(&model, pose);
	if (o.pose_path && load_pose(o.pose_path, &model, pose, &err))
		goto fail;
	double clamped[MC_MAX_DOF];
	memcpy(clamped, pose, sizeof(double) * model.ndof);
	mc_model_clamp_pose(&model, clamped);
	for (int k = 0; k < model.ndof; k++) {
		if (clamped[k] != pose[k]) {
			char name[96];
			mc_model_dof_name(&model, k, name, sizeof(name));
			fprintf(stderr, "mocap-render: warning: %s clamped into its limits\n", name);
		}
	}
	mc_model_fk(&model, clamped, &fk);
	if (o.overlay ? run_overlay(&o, &rig, &model, &fk, &err) : run_render(&o, &rig, &model, &fk, &err))
		goto fail;
	return 0;
fail:
	fprintf(stderr, "mocap-render: %s\n", err.msg);
	return 1;
}
