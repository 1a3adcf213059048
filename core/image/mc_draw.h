/* mc_draw: drawing projected skeletons over RGB images, and PNG output.
 * Used by mocap-render, mocap-bench's overlays and the daemon's demo. */
#ifndef MC_DRAW_H
#define MC_DRAW_H

#include "geom/mc_camera.h"
#include "base/mc_error.h"

#include <stdint.h>

typedef struct {
	uint8_t *rgb; /* packed RGB24, width * 3 bytes per row */
	int width, height;
} mc_canvas;

extern const uint8_t MC_DRAW_LEFT[3], MC_DRAW_RIGHT[3], MC_DRAW_MID[3], MC_DRAW_GT[3];

void mc_draw_disc(mc_canvas *im, double cx, double cy, double r, const uint8_t c[3]);
void mc_draw_line(mc_canvas *im, double x0, double y0, double x1, double y1, double thick, const uint8_t c[3]);
/* Projects a rig-frame point into the canvas, which may be scaled from the
 * camera's native resolution. */
bool mc_draw_project(const mc_camera *cam, const mc_canvas *im, mc_vec3 p_rig, double *x, double *y);
/* A 3D segment is a curve through a fisheye: drawn piece by piece. */
void mc_draw_segment(mc_canvas *im, const mc_camera *cam, mc_vec3 a, mc_vec3 b, double thick, const uint8_t c[3]);
/* Colour for a joint by side: left_*, right_*, others. */
const uint8_t *mc_draw_side_color(const char *name);
/* Bones (parent -> child, skipping joints where have[j] is false, linking
 * to the nearest drawn ancestor) then joints as discs.  names picks colours
 * by side unless one_color is given; have may be NULL (all present). */
void mc_draw_skeleton(mc_canvas *im, const mc_camera *cam, int njoints, const mc_vec3 *pos, const int *parent,
		      const bool *have, const char *const *names, const uint8_t *one_color, double thick);
/* Default line thickness for a canvas. */
double mc_draw_thickness(const mc_canvas *im);

int mc_draw_write_png(const char *path, const mc_canvas *im, mc_err *err);

#endif
