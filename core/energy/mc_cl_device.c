/* OpenCL backend of the colour energy, device side: error names, the
 * choice of platform and device, and what the chosen device can do
 * (shared memory, SIMD width).  The rest is in mc_cl.c and mc_cl_eval.c
 * (mc_cl_internal.h). */
#include "energy/mc_cl_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *mc_cl_error_name(cl_int rc)
{
	switch (rc) {
	case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
	case CL_DEVICE_NOT_AVAILABLE: return "CL_DEVICE_NOT_AVAILABLE";
	case CL_COMPILER_NOT_AVAILABLE: return "CL_COMPILER_NOT_AVAILABLE";
	case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
	case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
	case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
	case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
	case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
	case CL_INVALID_PLATFORM: return "CL_INVALID_PLATFORM";
	case CL_INVALID_DEVICE: return "CL_INVALID_DEVICE";
	case CL_INVALID_CONTEXT: return "CL_INVALID_CONTEXT";
	case CL_INVALID_COMMAND_QUEUE: return "CL_INVALID_COMMAND_QUEUE";
	case CL_INVALID_MEM_OBJECT: return "CL_INVALID_MEM_OBJECT";
	case CL_INVALID_BUILD_OPTIONS: return "CL_INVALID_BUILD_OPTIONS";
	case CL_INVALID_PROGRAM_EXECUTABLE: return "CL_INVALID_PROGRAM_EXECUTABLE";
	case CL_INVALID_KERNEL_NAME: return "CL_INVALID_KERNEL_NAME";
	case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
	case CL_INVALID_ARG_INDEX: return "CL_INVALID_ARG_INDEX";
	case CL_INVALID_ARG_VALUE: return "CL_INVALID_ARG_VALUE";
	case CL_INVALID_ARG_SIZE: return "CL_INVALID_ARG_SIZE";
	case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
	case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
	case -1001: return "CL_PLATFORM_NOT_FOUND_KHR";
	default: return "OpenCL error";
	}
}

int mc_cl_fail(mc_err *err, const char *what, cl_int rc)
{
	return mc_err_set(err, "OpenCL: %s failed: %s (%d)", what, mc_cl_error_name(rc), (int)rc);
}

/* ---- device choice ---- */

void mc_cl_platform_name(cl_platform_id p, char *buf, size_t len)
{
	buf[0] = 0;
	clGetPlatformInfo(p, CL_PLATFORM_NAME, len, buf, NULL);
	buf[len - 1] = 0;
}

void mc_cl_device_name(cl_device_id d, char *buf, size_t len)
{
	buf[0] = 0;
	clGetDeviceInfo(d, CL_DEVICE_NAME, len, buf, NULL);
	buf[len - 1] = 0;
}

/* The devices of platform p (caller frees), or NULL with *n = 0. */
static cl_device_id *platform_devices(cl_platform_id p, cl_uint *n)
{
	*n = 0;
	if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, NULL, n) != CL_SUCCESS || *n == 0) {
		*n = 0;
		return NULL;
	}
	cl_device_id *d = calloc(*n, sizeof(*d));
	if (!d || clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, *n, d, NULL) != CL_SUCCESS) {
		free(d);
		*n = 0;
		return NULL;
	}
	return d;
}

cl_device_type mc_cl_device_type(cl_device_id d)
{
	cl_device_type t = 0;
	clGetDeviceInfo(d, CL_DEVICE_TYPE, sizeof(t), &t, NULL);
	return t;
}

/* Of the devices of platform p: the first of type `want` (0: the first of
 * any type).  Returns 0 and sets *out, or -1. */
static int first_of_type(cl_platform_id p, cl_device_type want, cl_device_id *out)
{
	cl_uint n;
	cl_device_id *d = platform_devices(p, &n);
	int found = -1;
	for (cl_uint i = 0; i < n && found < 0; i++)
		if (!want || (mc_cl_device_type(d[i]) & want)) {
			*out = d[i];
			found = 0;
		}
	free(d);
	return found;
}

/* "0 'name', 1 'name'" for error messages. */
static void list_platforms(const cl_platform_id *p, cl_uint n, char *buf, size_t len)
{
	buf[0] = 0;
	for (cl_uint i = 0; i < n; i++) {
		char name[128];
		mc_cl_platform_name(p[i], name, sizeof(name));
		size_t used = strlen(buf);
		snprintf(buf + used, len - used, "%s%u '%s'", i ? ", " : "", i, name);
	}
}

int mc_cl_choose_device(int platform, int device, cl_platform_id *out_p, cl_device_id *out_d, mc_err *err)
{
	cl_uint np = 0;
	cl_int rc = clGetPlatformIDs(0, NULL, &np);
	if (rc == -1001 || (rc == CL_SUCCESS && np == 0))
		return mc_err_set(err, "OpenCL: no platform found (install an ICD, e.g. pocl-opencl-icd)");
	if (rc != CL_SUCCESS)
		return mc_cl_fail(err, "clGetPlatformIDs", rc);
	cl_platform_id plats[16];
	if (np > 16)
		np = 16;
	rc = clGetPlatformIDs(np, plats, NULL);
	if (rc != CL_SUCCESS)
		return mc_cl_fail(err, "clGetPlatformIDs", rc);

	if (platform < -1 || platform >= (int)np || (platform == -1 && device != -1)) {
		char list[384];
		list_platforms(plats, np, list, sizeof(list));
		if (platform == -1)
			return mc_err_set(err, "OpenCL: device %d given without a platform index (platforms: %s)",
					  device, list);
		return mc_err_set(err, "OpenCL: platform %d does not exist (platforms: %s)", platform, list);
	}
	if (platform == -1) {
		/* The first GPU anywhere, else the first CPU, else anything. */
		static const cl_device_type order[3] = {CL_DEVICE_TYPE_GPU, CL_DEVICE_TYPE_CPU, 0};
		for (int t = 0; t < 3; t++)
			for (cl_uint i = 0; i < np; i++)
				if (first_of_type(plats[i], order[t], out_d) == 0) {
					*out_p = plats[i];
					return 0;
				}
		return mc_err_set(err, "OpenCL: no device on any platform");
	}

	*out_p = plats[platform];
	cl_uint nd;
	cl_device_id *devs = platform_devices(plats[platform], &nd);
	if (device == -1) {
		free(devs);
		if (first_of_type(plats[platform], CL_DEVICE_TYPE_GPU, out_d) == 0 ||
		    first_of_type(plats[platform], 0, out_d) == 0)
			return 0;
		return mc_err_set(err, "OpenCL: platform %d has no device", platform);
	}
	if (device < -1 || device >= (int)nd) {
		char pname[128], list[384] = "";
		mc_cl_platform_name(plats[platform], pname, sizeof(pname));
		for (cl_uint i = 0; i < nd; i++) {
			char name[128];
			mc_cl_device_name(devs[i], name, sizeof(name));
			size_t used = strlen(list);
			snprintf(list + used, sizeof(list) - used, "%s%u '%s'", i ? ", " : "", i, name);
		}
		free(devs);
		return mc_err_set(err, "OpenCL: device %d does not exist on platform %d '%s' (devices: %s)", device,
				  platform, pname, nd ? list : "none");
	}
	*out_d = devs[device];
	free(devs);
	return 0;
}

/* ---- what the device can do ---- */

/* Whether the device reads and writes host memory directly (OpenCL 2.0
 * fine-grained SVM buffers: PoCL's CPU devices have them).  With it an
 * evaluation is one command, the kernel, instead of three (upload, kernel,
 * read back); PoCL hands each command to its worker threads, and the
 * tracker runs 50 evaluations per frame set (about 5 % of the tracker's CPU
 * time here; docs/OPENCL.md, "Shared memory"). */
bool mc_cl_shared_memory(cl_device_id dev)
{
	char version[512] = ""; /* "OpenCL 3.0 PoCL HSTR: pthread-x86_64-...": a short buffer is an error */
	clGetDeviceInfo(dev, CL_DEVICE_VERSION, sizeof(version) - 1, version, NULL);
	int major = 0;
	if (sscanf(version, "OpenCL %d", &major) != 1 || major < 2)
		return false;
	cl_device_svm_capabilities caps = 0;
	if (clGetDeviceInfo(dev, CL_DEVICE_SVM_CAPABILITIES, sizeof(caps), &caps, NULL) != CL_SUCCESS)
		return false;
	return (caps & CL_DEVICE_SVM_FINE_GRAIN_BUFFER) != 0;
}

/* Lanes over which the kernel evaluates ray Gaussians together: the CPU's
 * float SIMD width (PoCL reports 16 with AVX-512, 8 with AVX2); 1 on GPUs,
 * which run work-items in lock-step already. */
int mc_cl_vector_width(cl_device_id dev)
{
	if (mc_cl_device_type(dev) & CL_DEVICE_TYPE_GPU)
		return 1;
	cl_uint w = 0;
	clGetDeviceInfo(dev, CL_DEVICE_PREFERRED_VECTOR_WIDTH_FLOAT, sizeof(w), &w, NULL);
	return w >= 16 ? 16 : w >= 8 ? 8 : 4;
}
