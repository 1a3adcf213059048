/* Skeleton frames against camera rays, for the tests that feed keypoints to
 * mocapd (test_daemon_keypoints, test_daemon_detector): where a published
 * joint is, and how far it is from the ray through a keypoint's pixel. */
#ifndef MCD_TEST_RAYS_H
#define MCD_TEST_RAYS_H

#include "../test_util.h"
#include "geom/mc_rig.h"
#include "mocap.h"

#include <math.h>
#include <stdio.h>
#include <stdbool.h>
#include <string.h>

static inline mc_vec3 mcd_joint_position(const mocap_skeleton_frame *f, int j)
{
	return mc_v3(f->joints[j].position[0], f->joints[j].position[1], f->joints[j].position[2]);
}

/* The ray through pixel (u, v) of camera cam, in the rig frame: from the
 * camera's centre along the unit vector *n.  False if (u, v) is outside
 * the lens model. */
static inline bool mcd_ray(const mc_camera *cam, double u, double v, mc_vec3 *n)
{
	mc_vec3 dir;
	if (!mc_camera_unproject(cam, u, v, &dir))
		return false;
	*n = mc_v3_normalize(mc_m3_apply(cam->rig_from_cam.R, dir));
	return true;
}

/* Distance of p (rig frame) from the ray through pixel (u, v) of camera cam. */
static inline double mcd_ray_distance(const mc_camera *cam, double u, double v, mc_vec3 p)
{
	mc_vec3 n;
	if (!mcd_ray(cam, u, v, &n))
		return 1e9;
	mc_vec3 d = mc_v3_sub(p, cam->rig_from_cam.t);
	return mc_v3_norm(mc_v3_reject(d, n));
}

/* The shortest distance between the lines of two such rays. */
static inline double mcd_ray_gap(const mc_camera *a, double ua, double va, const mc_camera *b, double ub, double vb)
{
	mc_vec3 na, nb;
	if (!mcd_ray(a, ua, va, &na) || !mcd_ray(b, ub, vb, &nb))
		return 1e9;
	mc_vec3 x = mc_v3_cross(na, nb);
	double len = mc_v3_norm(x);
	mc_vec3 d = mc_v3_sub(b->rig_from_cam.t, a->rig_from_cam.t);
	return len > 1e-9 ? fabs(mc_v3_dot(d, x)) / len : mc_v3_norm(mc_v3_reject(d, na));
}

static inline int mcd_find_joint(const mocap_skeleton_def *def, const char *name)
{
	for (int j = 0; j < def->njoints; j++)
		if (!strcmp(def->joints[j].name, name))
			return j;
	return -1;
}

/* Subscribes c (mode, rig space), reads the first frame into f and the
 * skeleton definition into def; the index of `joint`, or -1 with a failed
 * check counted. */
static inline int mcd_first_frame_joint(mocap_client *c, mocap_mode mode, mocap_skeleton_def *def,
					mocap_skeleton_frame *f, const char *joint)
{
	int j = -1;
	CHECK(def && f && mocap_subscribe(c, mode, MOCAP_SPACE_RIG, 0) == 0);
	CHECK(f && mocap_read_frame(c, f, 30000) == 1);
	CHECK(def && mocap_get_skeleton(c, def) == 0 && (j = mcd_find_joint(def, joint)) >= 0);
	return j;
}

/* The bundled head-mounted rig the demo clip was taken with; false with
 * the error printed. */
static inline bool mcd_load_ego_rig(mc_rig *rig)
{
	mc_err err = {{0}};
	if (mc_rig_load("config/rigs/ego_stereo.json", rig, &err) == 0)
		return true;
	fprintf(stderr, "%s\n", err.msg);
	return false;
}

#endif
