/* mc_cl_internal: the OpenCL backend's state and the helpers that its
 * three files share: device choice (mc_cl_device.c), set-up and buffers
 * (mc_cl.c), and the per-frame and per-evaluation work (mc_cl_eval.c).
 * Not part of the public API (that is energy/mc_cl.h). */
#ifndef MC_CL_INTERNAL_H
#define MC_CL_INTERNAL_H

#define CL_TARGET_OPENCL_VERSION 200
#define CL_USE_DEPRECATED_OPENCL_1_2_APIS /* clCreateCommandQueue: 1.2 devices need it */
#include "energy/mc_cl.h"

#include <CL/cl.h>
#include <stddef.h>

#define ROW_MAX (4 * MC_MAX_GAUSSIANS + 1) /* floats per work-group result */
/* Gaussian buffer: 4 float4 per Gaussian, then mu.x, mu.y, mu.z and r2_max
 * of every Gaussian as four float arrays (for the SIMD culling test). */
#define GAUSS_FLOAT4S (5 * MC_MAX_GAUSSIANS)
/* Work-group rows a launch may have: max_groups, and one more per camera
 * as each camera's pixels get whole work-groups of their own. */
#define MC_CL_ROWS(e) ((e)->max_groups + MC_MAX_CAMERAS)

struct mc_cl_energy {
	char name[256];
	cl_context ctx;
	cl_device_id dev;
	cl_command_queue queue;
	cl_program prog;
	cl_kernel kernel;

	int ncams;
	int cam_first[MC_MAX_CAMERAS]; /* first ray index of each camera */
	int cam_npix[MC_MAX_CAMERAS];  /* width * height */
	bool has_image[MC_MAX_CAMERAS];
	int *valid[MC_MAX_CAMERAS];    /* the valid pixels, for "every pixel" */
	int nvalid[MC_MAX_CAMERAS];
	int total;                     /* rays over all cameras */

	int vw;            /* SIMD lanes in the kernel (-DVW) */
	bool shared;       /* input_host and partial_host are fine-grained SVM */
	size_t wg;         /* work-group size */
	size_t max_groups; /* work-groups per launch at most */

	cl_mem rays, image, origins, firsts, partial;
	/* Per evaluation, one upload: the Gaussian records (layout in
	 * color_energy.cl), then the ray indices of the sampled pixels. */
	cl_mem input;         /* unused with shared memory */
	size_t pixel_cap;     /* room for pixels in `input` and input_host */
	cl_float4 *input_host; /* GAUSS_FLOAT4S records, then pixel_cap indices */
	cl_uint *pixel_host;  /* = (cl_uint *)(input_host + GAUSS_FLOAT4S); after
			       * the pixels, each work-group's first pixel and
			       * the end (the group table) */
	int *group_cam;       /* the camera of each work-group's pixels */
	cl_float4 *image_host; /* one camera */
	float *partial_host;
	/* the scene's background colour model, as an albedo record; w = 1
	 * in bg_weights when there is one */
	cl_float4 bg_albedo, bg_weights;
};

/* ---- mc_cl_device.c: errors and device choice ---- */

/* The name of an OpenCL error code, e.g. "CL_OUT_OF_RESOURCES". */
const char *mc_cl_error_name(cl_int rc);
/* Sets err to "OpenCL: WHAT failed: NAME (CODE)"; returns -1. */
int mc_cl_fail(mc_err *err, const char *what, cl_int rc);
void mc_cl_platform_name(cl_platform_id p, char *buf, size_t len);
void mc_cl_device_name(cl_device_id d, char *buf, size_t len);
cl_device_type mc_cl_device_type(cl_device_id d);
/* The device that platform and device (-1: choose) name; the rules are in
 * mc_cl.h (mc_cl_energy_create).  Returns 0, or -1 with err set. */
int mc_cl_choose_device(int platform, int device, cl_platform_id *out_p, cl_device_id *out_d, mc_err *err);
bool mc_cl_shared_memory(cl_device_id dev);
int mc_cl_vector_width(cl_device_id dev);

/* ---- mc_cl.c: set-up ---- */

/* Makes room for `need` pixels, and the group table after them, in the
 * upload buffer and its host copy. */
int mc_cl_grow_input(mc_cl_energy *e, size_t need, mc_err *err);

/* ---- mc_cl_eval.c: per evaluation ---- */

/* Splits the npix packed pixels into work-groups, each camera's into
 * groups of their own (cam_count[c] pixels of camera c, in camera order;
 * NULL when npix is 0): writes the group table after the pixels and
 * group_cam.  Returns the number of groups (at least 1). */
size_t mc_cl_plan_groups(mc_cl_energy *e, const size_t *cam_count, size_t npix);

/* One evaluation on the device over the packed Gaussians, pixels and
 * group table (mc_cl_plan_groups); leaves a row per group in
 * partial_host. */
int mc_cl_launch(mc_cl_energy *e, int ngauss, size_t npix, size_t ngroups, uint32_t seed, uint32_t thr24,
		 mc_err *err);

#endif
