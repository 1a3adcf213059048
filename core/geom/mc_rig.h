/* mc_rig: a set of calibrated cameras in one rig frame, their file format,
 * importers, and per-camera ray tables at a working resolution.
 *
 * The rig file format is JSON, documented in docs/RIG_FORMAT.md. */
#ifndef MC_RIG_H
#define MC_RIG_H

#include "geom/mc_camera.h"
#include "base/mc_error.h"
#include "base/mc_limits.h"

#include <stdint.h>

typedef enum {
	MC_RIG_EGOCENTRIC = 0, /* rig frame = the skeleton's head (root) frame */
	MC_RIG_OUTSIDE_IN = 1, /* rig frame = world frame */
} mc_rig_kind;

typedef struct {
	char name[64];
	mc_rig_kind kind;
	int ncams;
	mc_camera cams[MC_MAX_CAMERAS];
} mc_rig;

/* Loads a rig JSON file. On error returns -1 with err naming the file and
 * field, e.g. "rig.json: cameras[0].model: unknown camera model 'foo'". */
int mc_rig_load(const char *path, mc_rig *rig, mc_err *err);
int mc_rig_save(const mc_rig *rig, const char *path, mc_err *err);
/* The rig in the rig file format, as malloc'ed text (free() it), e.g. for
 * clients of a daemon whose rig was imported from another format. */
char *mc_rig_to_json(const mc_rig *rig, mc_err *err);
/* Parses a rig from a JSON text; `origin` names it in error messages. */
int mc_rig_parse(const char *json_text, const char *origin, mc_rig *rig, mc_err *err);

/* Imports ../shared/data/ego/<clip>/calib.json: two equidistant cameras
 * "left" and "right"; the rig frame is the left camera frame.
 * use_ocam selects the fitted OCam polynomial instead of the equidistant model. */
int mc_rig_import_ego_calib(const char *path, bool use_ocam, mc_rig *rig, mc_err *err);

/* Imports an outside-in clip's cameras.json (../shared/data/outside/<clip>):
 * pinhole cameras with OpenCV intrinsics (fx fy cx cy, dist k1 k2 p1 p2 k3)
 * and a `world_to_camera` 4x4 each; the rig frame is the world frame.  The
 * field of view (max_theta) is the image's widest corner with a margin. */
int mc_rig_import_cameras_json(const char *path, mc_rig *rig, mc_err *err);

/* Imports one camera from OCamCalib's calib_results.txt, converted to OpenCV
 * axes. Width and height come from the file. rig_from_cam is identity and
 * max_theta is given by the caller (the toolbox does not store it). */
int mc_rig_import_ocamcalib(const char *path, double max_theta, mc_camera *cam, mc_err *err);

/* The field of view every rig reader accepts: max_theta_deg (the half
 * angle) within these, or fov_deg (the full angle) within twice them. */
#define MC_RIG_MAX_THETA_MIN_DEG 1e-6
#define MC_RIG_MAX_THETA_MAX_DEG 180.0

/* Index of the camera called `name`, or -1. */
int mc_rig_find(const mc_rig *rig, const char *name);
/* Whether the point p (rig frame) projects into some camera's image. */
bool mc_rig_sees(const mc_rig *rig, mc_vec3 p);
/* The rule every rig reader applies to a camera's name (not empty); the
 * error names `where`.name.  0 or -1. */
int mc_rig_check_camera_name(const char *name, const char *where, mc_err *err);

/* Rays of one camera at a working resolution, in the rig frame.
 * Working pixel (i, j) covers native pixels scaled by width/w, height/h and
 * samples the native position ((i + 0.5) * width / w - 0.5, ...). */
typedef struct {
	int width, height;  /* working resolution */
	double scale_x, scale_y; /* native pixels per working pixel */
	mc_vec3 origin;     /* camera centre in the rig frame */
	mc_vec3 *dir;       /* width*height unit rays, rig frame, row-major */
	uint8_t *valid;     /* 1 where the pixel sees a valid ray */
	int nvalid;
} mc_raytable;

int mc_raytable_build(const mc_camera *cam, int width, int height, mc_raytable *rt, mc_err *err);
void mc_raytable_free(mc_raytable *rt);

#endif
