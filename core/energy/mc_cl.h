/* mc_cl: the OpenCL backend of the colour energy and its gradient.
 *
 * Computes what mc_energy_color() computes (thesis eq. 4.13 with the HSV
 * dissimilarity of ch. 6.2.1), summed over the cameras of a rig, in float on
 * an OpenCL device: PoCL on CPUs, any OpenCL GPU where present.  The ray
 * tables are uploaded once; each frame uploads the cameras' HSV images;
 * each optimiser iteration uploads the scene and the sampled pixels.
 * Per pixel, Gaussians can be dropped at random (stochastic optimisation,
 * thesis ch. 6.2.3); a dropped Gaussian neither contributes nor occludes.
 * See docs/OPENCL.md for device selection, the kernel and its precision.
 *
 * An mc_cl_energy is not thread-safe: one thread uses it at a time. */
#ifndef MC_CL_H
#define MC_CL_H

#include "energy/mc_energy.h"
#include "base/mc_error.h"
#include "geom/mc_rig.h"

#include <stdbool.h>
#include <stdint.h>

typedef struct mc_cl_energy mc_cl_energy;

/* Opens an OpenCL device and uploads the ray tables (tables[0..ncams-1],
 * rig frame; ncams <= MC_MAX_CAMERAS).
 * platform, device: indices as listed by `clinfo -l`.  platform -1: the
 * first GPU of any platform, else the first CPU device, else the first
 * device.  platform >= 0, device -1: the first GPU of that platform, else its
 * first device.  An index that does not exist is an error naming the
 * platforms or devices there are.  Returns NULL with err set on failure
 * (no OpenCL platform, kernel build error with its log, out of memory). */
mc_cl_energy *mc_cl_energy_create(int platform, int device, const mc_raytable *tables, int ncams,
				  mc_err *err);

/* Launch settings, for tuning and tests; 0 = chosen from the device. */
typedef struct {
	int vector_width;    /* SIMD lanes per work-item: 1, 4, 8 or 16 (CPUs:
	                      * the preferred float width; GPUs: 1) */
	int work_group_size; /* work-items per group (CPUs 8, GPUs 64, or less
	                      * where local memory is short) */
	int max_groups;      /* work-groups per launch at most (CPUs 4, GPUs 16
	                      * per compute unit), shared out among the
	                      * cameras (each camera's pixels get at least a
	                      * group of their own); each work-item loops over
	                      * its share of its group's pixels */
	bool copy_buffers;   /* true: upload and read back through buffers even
	                      * where the device shares host memory (OpenCL 2.0
	                      * fine-grained SVM, used when there; for tests) */
} mc_cl_options;

/* mc_cl_energy_create with settings (opts NULL: all chosen). */
mc_cl_energy *mc_cl_energy_create_opts(int platform, int device, const mc_raytable *tables, int ncams,
				       const mc_cl_options *opts, mc_err *err);

/* "platform name: device name". */
const char *mc_cl_energy_device(const mc_cl_energy *e);

/* The settings in use. */
void mc_cl_energy_config(const mc_cl_energy *e, mc_cl_options *out);

/* Sets camera cam's image: working-resolution HSV (3 floats per pixel of
 * its ray table, each in [0, 1], row-major), copied.  hsv NULL marks the
 * camera missing: its pixels are ignored by mc_cl_energy_eval() until an
 * image is set again.  Cameras start missing. */
int mc_cl_energy_set_image(mc_cl_energy *e, int cam, const float *hsv, mc_err *err);

/* E_color over sampled pixels of every camera that has an image.
 * pixels[cam][0..npixels[cam]-1] are indices into camera cam's ray table
 * (invalid pixels contribute nothing); pixels NULL, or pixels[cam] NULL,
 * means every valid pixel of that camera (npixels may then be NULL).
 * dropout in [0, 1]: the probability that a Gaussian is left out at a pixel,
 * decided by mc_cl_dropped(seed, cam, pixel, q, dropout).
 * Sets *energy and ADDS the gradient into dmu[q] and dsigma[q] (each
 * scene->n long, may be NULL), like mc_energy_color().
 * Returns 0, or -1 with err naming the bad argument (scene values,
 * pixel index out of range) or the failing OpenCL call. */
int mc_cl_energy_eval(mc_cl_energy *e, const mc_scene *scene, const int *const *pixels,
		      const int *npixels, double dropout, uint32_t seed, double *energy, mc_vec3 *dmu,
		      double *dsigma, mc_err *err);

/* As mc_cl_energy_eval() in one launch, keeping each camera's gradient
 * apart: ADDS camera c's into dmu_cam[c * scene->n + q] (ncams *
 * scene->n long).  *energy is over every camera. */
int mc_cl_energy_eval_cameras(mc_cl_energy *e, const mc_scene *scene, const int *const *pixels,
			      const int *npixels, double dropout, uint32_t seed, double *energy, mc_vec3 *dmu_cam,
			      mc_err *err);

void mc_cl_energy_destroy(mc_cl_energy *e);

/* The dropout decision, the same function as in the kernel: Gaussian q is
 * left out at pixel `pixel` of camera `cam` when a 24-bit hash of (seed,
 * cam, pixel, q) falls below dropout * 2^24. */
static inline uint32_t mc_cl_lowbias32(uint32_t x)
{
	x ^= x >> 16;
	x *= 0x7feb352du;
	x ^= x >> 15;
	x *= 0x846ca68bu;
	x ^= x >> 16;
	return x;
}

static inline uint32_t mc_cl_dropout_threshold(double dropout)
{
	if (!(dropout > 0))
		return 0;
	if (dropout >= 1)
		return 1u << 24;
	return (uint32_t)(dropout * 16777216.0);
}

static inline bool mc_cl_dropped(uint32_t seed, int cam, int pixel, int q, double dropout)
{
	uint32_t key = (uint32_t)pixel * 0x9E3779B1u + (uint32_t)cam * 0x85EBCA77u + (uint32_t)q * 0xC2B2AE3Du;
	return (mc_cl_lowbias32(mc_cl_lowbias32(seed) ^ key) >> 8) < mc_cl_dropout_threshold(dropout);
}

#endif
