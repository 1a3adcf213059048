/* mc_view_agreement: keypoints checked against the other cameras' (see
 * mc_view_agreement.h). */
#include "eval/mc_view_agreement.h"

#include <math.h>

/* A ray in the rig frame. */
typedef struct {
	mc_vec3 origin, dir;
} ray;

/* The point nearest to the rays (least squares), false when they are near
 * parallel. */
static bool nearest_point(const ray *r, int n, mc_vec3 *out)
{
	mc_vec3 o[MC_MAX_CAMERAS], d[MC_MAX_CAMERAS];
	for (int i = 0; i < n; i++) {
		o[i] = r[i].origin;
		d[i] = r[i].dir;
	}
	return mc_rays_nearest_point(o, d, NULL, n, out);
}

static bool to_ray(const mc_camera *cam, double u, double v, ray *out)
{
	out->origin = cam->rig_from_cam.t;
	return mc_camera_unproject_rig(cam, u, v, &out->dir);
}

/* Keypoint `self` against the rays of the other cameras' keypoints of its
 * joint (others[0..n-1]); 1 agreed, 0 not, -1 not checked. */
static int check_one(const mc_rig *rig, const mc_keypoint *self, const ray *others, int n, double px_at_640)
{
	mc_vec3 x;
	if (n < 3 || !nearest_point(others, n, &x))
		return -1;
	const mc_camera *cam = &rig->cams[self->cam];
	double u, v;
	if (!mc_camera_project_unbounded(cam, mc_xform_apply(mc_xform_inverse(cam->rig_from_cam), x), &u, &v))
		return 0;
	int side = cam->width > cam->height ? cam->width : cam->height;
	return hypot(u - self->u, v - self->v) <= px_at_640 * side / 640.0;
}

void mc_view_agreement_add(mc_view_agreement *a, const mc_rig *rig, const mc_keypoint *kp, int nkp, double min_conf,
			   double px_at_640)
{
	for (int i = 0; i < nkp; i++) {
		const mc_keypoint *k = &kp[i];
		if (k->cam < 0 || k->cam >= rig->ncams || !(k->conf >= min_conf))
			continue;
		ray others[MC_MAX_CAMERAS];
		int n = 0;
		bool used[MC_MAX_CAMERAS] = {false};
		used[k->cam] = true;
		for (int j = 0; j < nkp && n < MC_MAX_CAMERAS; j++) {
			const mc_keypoint *o = &kp[j];
			if (o->joint != k->joint || o->cam < 0 || o->cam >= rig->ncams || used[o->cam] ||
			    !(o->conf >= min_conf) || !to_ray(&rig->cams[o->cam], o->u, o->v, &others[n]))
				continue;
			used[o->cam] = true;
			n++;
		}
		int r = check_one(rig, k, others, n, px_at_640);
		if (r < 0)
			continue;
		a->checked++;
		a->agreed += r;
	}
}
