/* preview_render: one camera frame as a small JPEG with the tracked
 * skeleton and the body model's Gaussians drawn over it.
 *
 * The frame comes from a camera ring as the driver delivered it (any
 * mc_pixfmt), is converted to RGB, shrunk by area averaging to at most
 * max_width pixels wide (the page shows several cameras side by side; a
 * full-size JPEG per camera would cost the CPU the daemon tracks on) and
 * drawn on with mc_draw: bones and joints in the side colours of
 * mocap-render, each Gaussian as the outline of the sphere it stands for. */
#ifndef PREVIEW_RENDER_H
#define PREVIEW_RENDER_H

#include "base/mc_error.h"
#include "body/mc_model.h"
#include "geom/mc_camera.h"
#include "mocap.h"
#include "ring/mc_ring.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* What to draw, in the rig frame. */
typedef struct {
	bool valid; /* false: the frame alone (no skeleton yet, or lost) */
	int njoints;
	mc_vec3 pos[MC_MAX_JOINTS];
	int parent[MC_MAX_JOINTS];
	char names[MC_MAX_JOINTS][MC_JOINT_NAME_MAX];
	int ngauss; /* 0: no model to place Gaussians from */
	mc_vec3 gauss_centre[MC_MAX_GAUSSIANS];
	double gauss_radius[MC_MAX_GAUSSIANS];
} preview_overlay;

/* The overlay for one published skeleton (rig frame): its joints, and,
 * with a model whose joints match the skeleton's by name and order, every
 * Gaussian at its joint's published pose.  The actor's bone scale, which
 * the daemon applies, is recovered from the definition's rest offsets.
 * model may be NULL (joints only). */
void preview_overlay_set(preview_overlay *ov, const mocap_skeleton_def *def, const mocap_skeleton_frame *f,
			 const mc_model *model);

/* The Gaussian colour (light cyan): not a side colour, so the skeleton
 * stays readable over the outlines. */
extern const uint8_t PREVIEW_GAUSS_COLOR[3];

typedef struct preview_renderer preview_renderer;

preview_renderer *render_new(int max_width, int quality, mc_err *err);
void render_free(preview_renderer *r);

/* Converts, shrinks, draws (cam may be NULL: no overlay; ov may be NULL)
 * and encodes.  *jpeg is malloc'd (free it); *width and *height are the
 * JPEG's.  Returns 0 or -1 with err. */
int render_frame(preview_renderer *r, const mc_ring_meta *meta, const uint8_t *data, const mc_camera *cam,
		 const preview_overlay *ov, uint8_t **jpeg, size_t *bytes, int *width, int *height, mc_err *err);

#endif
