/* mc_camera: intrinsic camera models (projection and unprojection).
 *
 * All models use OpenCV camera axes: x right, y down, z forward.  Pixel
 * coordinates are continuous with the centre of the top-left pixel at
 * (0, 0), as in OpenCV; the image covers [-0.5, width - 0.5) x
 * [-0.5, height - 0.5).  docs/RIG_FORMAT.md gives every formula.
 *
 * project() and unproject() are exact inverses of each other (Newton
 * iterations to 1e-12; tests/test_camera.c checks 1e-6 px over whole images)
 * and assume a camera that passed mc_camera_validate().
 *
 * Models:
 *   pinhole     - OpenCV radial-tangential distortion (k1 k2 p1 p2 k3).
 *   equidistant - Kannala-Brandt as in OpenCV cv::fisheye:
 *                 r = f * theta_d, theta_d = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8).
 *   ocam        - Scaramuzza / OCamCalib: (u, v) -> inverse affine [c d; e 1]
 *                 about (xc, yc) -> (u', v'), rho = |(u', v')|, ray (u', v', w(rho)).
 *                 Stored here already converted to OpenCV axes (see mc_rig's
 *                 OCamCalib importer for the conversion from the toolbox's own).
 */
#ifndef MC_CAMERA_H
#define MC_CAMERA_H

#include "base/mc_error.h"
#include "base/mc_math.h"

#include <stdbool.h>

#define MC_CAMERA_NAME_MAX 64
#define MC_OCAM_POLY_MAX 16
/* Largest image width or height accepted, pixels. */
#define MC_CAMERA_SIZE_MAX 32768
/* Largest focal length or principal point coordinate accepted, pixels. */
#define MC_CAMERA_COORD_MAX 1e7
/* A focal length below a pixel, or a camera farther than this from the rig
 * origin, is a broken calibration, not a camera (issue 20, defect 8). */
#define MC_CAMERA_FOCAL_MIN 1.0
#define MC_CAMERA_OFFSET_MAX_M 1000.0

typedef enum {
	MC_CAM_PINHOLE = 0,
	MC_CAM_EQUIDISTANT = 1,
	MC_CAM_OCAM = 2,
} mc_camera_model;

typedef struct {
	char name[MC_CAMERA_NAME_MAX];
	mc_camera_model model;
	int width, height; /* native (calibration) resolution, pixels */

	/* pinhole and equidistant */
	double fx, fy, cx, cy;
	double k[5]; /* pinhole: k1 k2 p1 p2 k3; equidistant: k1 k2 k3 k4 (k[4] unused) */

	/* ocam: w(rho) = sum_i pol[i] rho^i, positive along +z (forward). */
	double ocam_pol[MC_OCAM_POLY_MAX];
	int ocam_pol_len;
	/* Optional inverse polynomial: rho = sum_i invpol[i] t^i with
	 * t = theta - pi/2 and theta the ray's angle from the optical axis (t is
	 * the toolbox's world2cam angle atan(z/|(x, y)|) in its own axes), rho in
	 * the same units as ocam_pol's argument. Projection uses it only as the
	 * starting point of a root find on w(rho), so that project() is the exact
	 * inverse of unproject(); it may be absent (invpol_len == 0). */
	double ocam_invpol[MC_OCAM_POLY_MAX * 2];
	int ocam_invpol_len;
	double ocam_xc, ocam_yc;  /* distortion centre, pixels (u, v) */
	double ocam_c, ocam_d, ocam_e; /* affine [c d; e 1] */

	/* Largest angle between a valid ray and the optical axis, radians.
	 * pi/2 for a 180-degree fisheye. Pixels beyond it are invalid. */
	double max_theta;

	/* Pose of the camera in the rig frame. */
	mc_xform rig_from_cam;
} mc_camera;

/* Projects a point in camera coordinates to a pixel. Returns false (and
 * leaves u, v undefined) if the point is behind the valid field of view or
 * lands outside the image. */
bool mc_camera_project(const mc_camera *cam, mc_vec3 p_cam, double *u, double *v);

/* The same for a point in the rig frame (through cam->rig_from_cam). */
bool mc_camera_project_rig(const mc_camera *cam, mc_vec3 p_rig, double *u, double *v);

/* The same formula without the field-of-view and image-bounds checks
 * (pinhole: any point in front; equidistant: any direction; ocam as
 * mc_camera_project without the image bounds), for calibration, whose
 * parameters move while corners near the edge must keep a residual. */
bool mc_camera_project_unbounded(const mc_camera *cam, mc_vec3 p_cam, double *u, double *v);

/* Unit ray in camera coordinates through pixel (u, v). Returns false if the
 * pixel is outside the valid image (e.g. outside a fisheye's image circle). */
bool mc_camera_unproject(const mc_camera *cam, double u, double v, mc_vec3 *ray);
/* The same ray in the rig frame (unit length; it starts at the camera's
 * centre, cam->rig_from_cam.t). */
bool mc_camera_unproject_rig(const mc_camera *cam, double u, double v, mc_vec3 *dir_rig);

/* Checks parameters for sanity (finite, positive sizes, max_theta in (0, pi),
 * pinhole max_theta < pi/2, polynomial lengths in range, a distortion that
 * does not fold back inside max_theta, rig_from_cam a rotation to 1e-5). The
 * message starts with the offending field ("fx: must be in (0, 1e+07]
 * pixels, got -1"), for loaders to prefix with file and path. Returns 0 or
 * -1. */
int mc_camera_validate(const mc_camera *cam, mc_err *err);

/* Sets max_theta of a pinhole or equidistant camera whose source gave no
 * field of view (an OpenCV calibration): the widest image corner's angle
 * with a 10% margin, narrowed while the distortion folds back inside it, so
 * that every pixel has exactly one ray.  Validates the camera; returns 0 or
 * -1 with the validation message. */
int mc_camera_fit_max_theta(mc_camera *cam, mc_err *err);

const char *mc_camera_model_name(mc_camera_model m);
/* Returns 0 and sets *m, or -1 for an unknown name. */
int mc_camera_model_parse(const char *name, mc_camera_model *m);

#endif
