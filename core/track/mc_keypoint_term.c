/* The keypoint term of the tracker (thesis ch. 6.2.2): 2D detections as
 * rays that pull their joints, with a robust loss and a check across the
 * cameras that keep a detector's mistakes from pulling the pose. */
#include "body/mc_fit_joints.h"
#include "geom/mc_ray.h"
#include "track/mc_tracker_internal.h"

#include <math.h>
#include <stdbool.h>

/* Keypoints of joints that are no landmarks (mc_fit_joints_is_landmark:
 * the spine, the pelvis, head_top) pull neither in the keypoint term nor
 * in the ray fit.  They are points on the model's chain that skeletons
 * place differently: fitted to frame 0's ground truth of the held-out
 * clips' skeletons (DAZ and iClone retargets of CMU), the model's spine
 * still sat 19-21 cm and its pelvis 16 cm from the joints of those names,
 * its hips and shoulders within 1.5 cm.  The shipped detector, trained on
 * renders of such skeletons, puts its keypoints at theirs, and they bent
 * the model's torso.  They still count where only an agreement of the
 * views is asked: the triangulation that starts and re-fits the pose
 * (mc_init.c; left out there too, `--init detect` on the dev walk got 0.6
 * cm worse).  A joint fixed to a head rig (head_top there) stays as it
 * was: no pose moves it, and its keypoints keep their share of the term's
 * mean.  The shipped detector's keypoints replayed: held-out 20.09 ->
 * 19.30 cm (seeds 1-3), 20.36 -> 19.61 (4-6); the dev clips, whose
 * skeletons agree with the model there, within the seeds' spread
 * (docs/BENCHMARKS.md, stop 61). */
void mc_trk_find_unpulled(mc_tracker *t)
{
	for (int j = 0; j < t->model.njoints; j++)
		t->unpulled[j] = !t->fixed_joint[j] && !mc_fit_joints_is_landmark(t->model.joints[j].name);
}

/* Rays of the usable keypoints; returns the count. */
static int keypoint_rays(const mc_tracker *t, const mc_keypoint *kp, int nkp, mc_trk_keypoint_ray *out, int *cam)
{
	int n = 0;
	for (int i = 0; i < nkp && n < MC_TRK_MAX_KEYPOINTS; i++) {
		const mc_keypoint *k = &kp[i];
		mc_vec3 dir;
		if (k->cam < 0 || k->cam >= t->rig.ncams || k->joint < 0 || k->joint >= t->model.njoints ||
		    !(k->conf > 0) || !mc_camera_unproject_rig(&t->rig.cams[k->cam], k->u, k->v, &dir))
			continue;
		out[n] = (mc_trk_keypoint_ray){k->joint, t->rig.cams[k->cam].rig_from_cam.t, dir, fmin(k->conf, 1.0)};
		cam[n++] = k->cam;
	}
	return n;
}

int mc_trk_ray_closest(const mc_trk_keypoint_ray *a, const mc_trk_keypoint_ray *b, mc_vec3 *pa, mc_vec3 *pb)
{
	mc_vec3 w = mc_v3_sub(a->origin, b->origin);
	double k = mc_v3_dot(a->dir, b->dir), d = mc_v3_dot(a->dir, w), e = mc_v3_dot(b->dir, w), den = 1 - k * k;
	if (den < 1e-9)
		return 0;
	double sa = (k * e - d) / den, sb = (e - k * d) / den; /* along each ray */
	if (sa <= 0 || sb <= 0)
		return -1;
	*pa = mc_v3_axpy(sa, a->dir, a->origin);
	*pb = mc_v3_axpy(sb, b->dir, b->origin);
	return 1;
}

/* Two cameras' detections of one joint must see one point: when the
 * closest distance of their rays exceeds STEREO_GATE_M (or they meet
 * behind a camera), at least one is wrong.  Parallel rays agree. */
#define STEREO_GATE_M 0.10
static bool rays_disagree(const mc_trk_keypoint_ray *a, const mc_trk_keypoint_ray *b)
{
	mc_vec3 pa, pb;
	int meet = mc_trk_ray_closest(a, b, &pa, &pb);
	return meet < 0 || (meet > 0 && mc_v3_norm(mc_v3_sub(pa, pb)) > STEREO_GATE_M);
}

/* Each detection is checked against the other cameras' detections of its
 * joint and dropped when it disagrees with more of them than it agrees
 * with, so that a detector's confusions (the other foot, a limb's shadow)
 * do not pull the pose; the colour term decides there.  With two cameras
 * that disagree, both go (either may be the wrong one); with three or more,
 * the odd one out goes and the others stay. */
static void gate_views(mc_trk_keypoint_ray *r, const int *cam, int n)
{
	int agree[MC_TRK_MAX_KEYPOINTS] = {0}, disagree[MC_TRK_MAX_KEYPOINTS] = {0};
	for (int i = 0; i < n; i++)
		for (int j = i + 1; j < n; j++) {
			if (r[i].joint != r[j].joint || cam[i] == cam[j])
				continue;
			int *count = rays_disagree(&r[i], &r[j]) ? disagree : agree;
			count[i]++;
			count[j]++;
		}
	for (int i = 0; i < n; i++)
		if (disagree[i] > agree[i])
			r[i].weight = 0;
}

int mc_trk_prepare_keypoints(const mc_tracker *t, const mc_keypoint *kp, int nkp, mc_trk_keypoint_ray *out, int *cam)
{
	if (!kp || nkp <= 0)
		return 0;
	int n = keypoint_rays(t, kp, nkp, out, cam);
	mc_trk_assign_sides(t, out, cam, n);
	gate_views(out, cam, n);
	return n;
}

/* E_detection, a Cauchy loss of each detected joint's distance from its
 * keypoint's ray: lambda trust conf 0.5 log(1 + (r / tau)^2) / n, r the
 * joint's distance from the ray, tau = DETECTION_SCALE_M.  Quadratic near
 * the ray; far from it the pull falls off as 1/r, so a wrong detection
 * pulls much less than a right one near the joint (docs/TRACKER.md).
 *
 * The trust (mc_keypoint_trust.c) is the keypoints' precision against the
 * shipped detector's.  On a head rig the scale shrinks with it too, tau /
 * sqrt(trust): keypoints that agree closely hold their joints stiffly
 * (trust^2 near the ray) while a wrong one far from its joint still pulls
 * with only trust / r.  That is what a foreshortened limb needs: a forearm
 * along the cameras' rays, its wrist 37 cm too near, sat 5-9 cm from both
 * rays, where a 10 cm scale hardly pulls.  Outside-in the scale stays: the
 * views' agreement overstates the precision there (wide baselines hide
 * errors along the epipolar lines), and the dev clips got 0.2-0.3 cm worse. */
#define DETECTION_SCALE_M 0.10
static double detection_scale(const mc_tracker *t, double trust)
{
	return t->rig.kind == MC_RIG_OUTSIDE_IN ? DETECTION_SCALE_M : DETECTION_SCALE_M / sqrt(trust);
}

double mc_trk_detection_term(mc_tracker *t, const double *pose, const mc_fk *fk, const mc_trk_keypoint_ray *kp, int n,
			     double *grad)
{
	mc_vec3 djoint[MC_MAX_JOINTS] = {{0, 0, 0}};
	double E = 0;
	int used = 0;
	if (t->s.lambda_detection <= 0)
		return 0;
	double trust = mc_tracker_keypoint_trust(t, NULL), tau = detection_scale(t, trust);
	for (int i = 0; i < n; i++) {
		double w = kp[i].weight;
		if (w <= 0 || t->unpulled[kp[i].joint])
			continue;
		mc_vec3 d = mc_v3_sub(fk->rig_from_joint[kp[i].joint].t, kp[i].origin);
		mc_vec3 r = mc_ray_offset(d, kp[i].dir, MC_RAY_NEAR_M);
		double dist = mc_v3_norm(r), x = dist / tau;
		E += w * 0.5 * log(1 + x * x);
		used++;
		/* dE/dr = w x / (1 + x^2) / tau * r / |r|, through dr/dp */
		mc_vec3 pull = mc_ray_offset_pull(d, kp[i].dir, MC_RAY_NEAR_M, r);
		djoint[kp[i].joint] = mc_v3_axpy(w / ((1 + x * x) * tau * tau), pull, djoint[kp[i].joint]);
	}
	if (!used)
		return 0;
	double scale = t->s.lambda_detection * trust / used;
	mc_vec3 *J = t->jacobian;
	mc_model_joint_jacobian(&t->model, pose, fk, J);
	for (int j = 0; j < t->model.njoints; j++)
		for (int k = 0; k < t->model.ndof; k++)
			grad[k] += scale * mc_v3_dot(djoint[j], J[j * t->model.ndof + k]);
	return scale * E;
}
