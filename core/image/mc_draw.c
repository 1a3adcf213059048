#include "image/mc_draw.h"

#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <string.h>

const uint8_t MC_DRAW_LEFT[3] = {255, 64, 64}, MC_DRAW_RIGHT[3] = {64, 160, 255}, MC_DRAW_MID[3] = {255, 230, 64},
	      MC_DRAW_GT[3] = {64, 255, 96};

static void put_pixel(mc_canvas *im, int x, int y, const uint8_t c[3])
{
	if (x < 0 || y < 0 || x >= im->width || y >= im->height)
		return;
	memcpy(im->rgb + ((size_t)y * im->width + x) * 3, c, 3);
}

void mc_draw_disc(mc_canvas *im, double cx, double cy, double r, const uint8_t c[3])
{
	for (int y = (int)floor(cy - r); y <= (int)ceil(cy + r); y++)
		for (int x = (int)floor(cx - r); x <= (int)ceil(cx + r); x++)
			if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r)
				put_pixel(im, x, y, c);
}

void mc_draw_line(mc_canvas *im, double x0, double y0, double x1, double y1, double thick, const uint8_t c[3])
{
	double len = hypot(x1 - x0, y1 - y0);
	int steps = (int)ceil(len * 2) + 1;
	for (int i = 0; i <= steps; i++) {
		double t = (double)i / steps;
		mc_draw_disc(im, x0 + t * (x1 - x0), y0 + t * (y1 - y0), thick / 2, c);
	}
}

bool mc_draw_project(const mc_camera *cam, const mc_canvas *im, mc_vec3 p_rig, double *x, double *y)
{
	double u, v;
	if (!mc_camera_project_rig(cam, p_rig, &u, &v))
		return false;
	*x = (u + 0.5) * im->width / cam->width - 0.5;
	*y = (v + 0.5) * im->height / cam->height - 0.5;
	return true;
}

void mc_draw_segment(mc_canvas *im, const mc_camera *cam, mc_vec3 a, mc_vec3 b, double thick, const uint8_t c[3])
{
	const int pieces = 24;
	double px = 0, py = 0;
	bool prev = false;
	for (int i = 0; i <= pieces; i++) {
		double x, y;
		bool ok = mc_draw_project(cam, im, mc_v3_axpy((double)i / pieces, mc_v3_sub(b, a), a), &x, &y);
		if (ok && prev)
			mc_draw_line(im, px, py, x, y, thick, c);
		prev = ok, px = x, py = y;
	}
}

const uint8_t *mc_draw_side_color(const char *name)
{
	if (strncmp(name, "left_", 5) == 0)
		return MC_DRAW_LEFT;
	if (strncmp(name, "right_", 6) == 0)
		return MC_DRAW_RIGHT;
	return MC_DRAW_MID;
}

double mc_draw_thickness(const mc_canvas *im)
{
	return fmax(1.5, im->width / 200.0);
}

void mc_draw_skeleton(mc_canvas *im, const mc_camera *cam, int njoints, const mc_vec3 *pos, const int *parent,
		      const bool *have, const char *const *names, const uint8_t *one_color, double thick)
{
	for (int j = 0; j < njoints; j++) {
		int p = parent[j];
		while (have && p >= 0 && !have[p])
			p = parent[p];
		const uint8_t *c = one_color ? one_color : mc_draw_side_color(names ? names[j] : "");
		if ((!have || have[j]) && p >= 0)
			mc_draw_segment(im, cam, pos[p], pos[j], thick, c);
	}
	for (int j = 0; j < njoints; j++) {
		double x, y;
		const uint8_t *c = one_color ? one_color : mc_draw_side_color(names ? names[j] : "");
		if ((!have || have[j]) && mc_draw_project(cam, im, pos[j], &x, &y))
			mc_draw_disc(im, x, y, thick * 1.6, c);
	}
}

int mc_draw_write_png(const char *path, const mc_canvas *im, mc_err *err)
{
	FILE *f = fopen(path, "wb");
	if (!f)
		return mc_err_set(err, "%s: cannot create: %s", path, strerror(errno));
	png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
	png_infop info = png ? png_create_info_struct(png) : NULL;
	if (!png || !info || setjmp(png_jmpbuf(png))) {
		png_destroy_write_struct(&png, &info);
		fclose(f);
		return mc_err_set(err, "%s: PNG encoding failed", path);
	}
	png_init_io(png, f);
	png_set_IHDR(png, info, im->width, im->height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
		     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
	png_write_info(png, info);
	for (int y = 0; y < im->height; y++)
		png_write_row(png, im->rgb + (size_t)y * im->width * 3);
	png_write_end(png, NULL);
	png_destroy_write_struct(&png, &info);
	if (fclose(f) != 0)
		return mc_err_set(err, "%s: write failed: %s", path, strerror(errno));
	return 0;
}
