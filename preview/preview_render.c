/* preview_render: camera frame -> RGB -> shrunk -> overlay -> JPEG
 * (preview_render.h). */
#include "preview_render.h"

#include "image/mc_draw.h"
#include "image/mc_image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const uint8_t PREVIEW_GAUSS_COLOR[3] = {120, 255, 255};

struct preview_renderer {
	mc_image_conv *conv;
	int max_width, quality;
	uint8_t *full, *small; /* RGB at the native and the shown size */
	size_t full_cap, small_cap;
};

preview_renderer *render_new(int max_width, int quality, mc_err *err)
{
	preview_renderer *r = calloc(1, sizeof(*r));
	if (!r) {
		mc_err_set(err, "out of memory");
		return NULL;
	}
	r->conv = mc_image_conv_new(err);
	if (!r->conv) {
		free(r);
		return NULL;
	}
	r->max_width = max_width;
	r->quality = quality;
	return r;
}

void render_free(preview_renderer *r)
{
	if (!r)
		return;
	mc_image_conv_free(r->conv);
	free(r->full);
	free(r->small);
	free(r);
}

void preview_overlay_set(preview_overlay *ov, const mocap_skeleton_def *def, const mocap_skeleton_frame *f,
			 const mc_model *model)
{
	memset(ov, 0, sizeof(*ov));
	if (f->njoints != def->njoints || f->skeleton_id != def->id || f->njoints > MC_MAX_JOINTS)
		return;
	ov->valid = f->njoints > 0;
	ov->njoints = f->njoints;
	for (int j = 0; j < ov->njoints; j++) {
		ov->pos[j] = mc_v3(f->joints[j].position[0], f->joints[j].position[1], f->joints[j].position[2]);
		ov->parent[j] = def->joints[j].parent;
		snprintf(ov->names[j], sizeof(ov->names[j]), "%s", def->joints[j].name);
	}
	if (!model || model->njoints != ov->njoints)
		return;
	for (int j = 0; j < ov->njoints; j++)
		if (strcmp(model->joints[j].name, def->joints[j].name) != 0)
			return;
	/* Bone scale: the daemon's rest offset is the model's times the actor's
	 * scale (ipc/server/fanout.c); a root has no offset, so scale 1. */
	double scale[MC_MAX_JOINTS];
	for (int j = 0; j < ov->njoints; j++) {
		const double *o = def->joints[j].rest_offset;
		double model_len = mc_v3_norm(model->joints[j].offset);
		scale[j] = model_len > 1e-9 ? mc_v3_norm(mc_v3(o[0], o[1], o[2])) / model_len : 1.0;
	}
	for (int g = 0; g < model->ngauss; g++) {
		const mc_gauss_def *gd = &model->gauss[g];
		const double *q = f->joints[gd->joint].orientation;
		mc_quat rot = mc_quat_normalize((mc_quat){q[0], q[1], q[2], q[3]});
		double s = gd->scale_joint >= 0 && gd->scale_joint < ov->njoints ? scale[gd->scale_joint] : 1.0;
		ov->gauss_centre[g] = mc_v3_add(ov->pos[gd->joint], mc_quat_rotate(rot, mc_v3_scale(gd->offset, s)));
		ov->gauss_radius[g] = gd->radius * s;
	}
	ov->ngauss = model->ngauss;
}

/* The outline of a sphere as the camera sees it: the circle of its radius
 * about its centre, square to the ray from the camera, through 16 points.
 * Each piece is short, so it is drawn straight even through a fisheye
 * (projecting every piece in steps, as mc_draw_segment does, cost the most
 * CPU of the whole preview). */
static void draw_sphere_outline(mc_canvas *im, const mc_camera *cam, mc_xform cam_from_rig, mc_vec3 c, double radius)
{
	mc_vec3 ray = mc_v3_sub(c, cam->rig_from_cam.t);
	if (mc_v3_norm(ray) < 1e-6)
		return;
	ray = mc_v3_normalize(ray);
	mc_vec3 any = fabs(ray.x) < 0.9 ? mc_v3(1, 0, 0) : mc_v3(0, 1, 0);
	mc_vec3 e1 = mc_v3_normalize(mc_v3_cross(ray, any)), e2 = mc_v3_cross(ray, e1);
	const int pieces = 16;
	double px = 0, py = 0;
	bool prev = false;
	for (int i = 0; i <= pieces; i++) {
		double a = 2 * M_PI * i / pieces, u, v;
		mc_vec3 p = mc_v3_add(c, mc_v3_add(mc_v3_scale(e1, radius * cos(a)), mc_v3_scale(e2, radius * sin(a))));
		bool ok = mc_camera_project(cam, mc_xform_apply(cam_from_rig, p), &u, &v);
		double x = (u + 0.5) * im->width / cam->width - 0.5, y = (v + 0.5) * im->height / cam->height - 0.5;
		if (ok && prev)
			mc_draw_line(im, px, py, x, y, 1.0, PREVIEW_GAUSS_COLOR);
		prev = ok, px = x, py = y;
	}
}

static void draw_overlay(mc_canvas *im, const mc_camera *cam, const preview_overlay *ov)
{
	mc_xform cam_from_rig = mc_xform_inverse(cam->rig_from_cam);
	for (int g = 0; g < ov->ngauss; g++)
		draw_sphere_outline(im, cam, cam_from_rig, ov->gauss_centre[g], ov->gauss_radius[g]);
	const char *names[MC_MAX_JOINTS];
	for (int j = 0; j < ov->njoints; j++)
		names[j] = ov->names[j];
	mc_draw_skeleton(im, cam, ov->njoints, ov->pos, ov->parent, NULL, names, NULL, mc_draw_thickness(im));
}

static int grow(uint8_t **buf, size_t *cap, size_t need, mc_err *err)
{
	if (need <= *cap)
		return 0;
	uint8_t *p = realloc(*buf, need);
	if (!p)
		return mc_err_set(err, "out of memory (%zu bytes for a frame)", need);
	*buf = p;
	*cap = need;
	return 0;
}

int render_frame(preview_renderer *r, const mc_ring_meta *meta, const uint8_t *data, const mc_camera *cam,
		 const preview_overlay *ov, uint8_t **jpeg, size_t *bytes, int *width, int *height, mc_err *err)
{
	int w = (int)meta->width, h = (int)meta->height;
	if (w <= 0 || h <= 0 || w > MC_CAMERA_SIZE_MAX || h > MC_CAMERA_SIZE_MAX)
		return mc_err_set(err, "frame of %dx%d pixels", w, h);
	mc_image_frame f = {.pixfmt = meta->pixfmt,
			    .width = meta->width,
			    .height = meta->height,
			    .stride = meta->stride,
			    .data = data,
			    .bytes = (size_t)meta->bytesused};
	if (grow(&r->full, &r->full_cap, (size_t)w * h * 3, err) < 0 ||
	    mc_image_to_rgb24(r->conv, &f, r->full, r->full_cap, err) < 0)
		return -1;
	int sw = w > r->max_width ? r->max_width : w;
	int sh = (int)lround((double)h * sw / w);
	sh = sh < 1 ? 1 : sh;
	uint8_t *shown = r->full; /* a frame small enough already is shown as it is */
	if (sw != w) {
		if (grow(&r->small, &r->small_cap, (size_t)sw * sh * 3, err) < 0 ||
		    mc_image_resize_rgb24(r->full, w, h, r->small, sw, sh, err) < 0)
			return -1;
		shown = r->small;
	}
	mc_canvas im = {.rgb = shown, .width = sw, .height = sh};
	if (cam && ov && ov->valid)
		draw_overlay(&im, cam, ov);
	*width = sw;
	*height = sh;
	return mc_image_encode_jpeg(r->conv, shown, sw, sh, r->quality, jpeg, bytes, err);
}
