/* How much the keypoint term trusts the detections: the weight
 * lambda_detection is set for the shipped head-rig detector; a source of
 * keypoints whose cameras agree closely (a better detector, clean client
 * keypoints) gets more, as a Gaussian likelihood's 1 / noise^2 would give
 * it.  The noise is read off the detections alone: two cameras' rays of
 * one joint miss each other by about the keypoints' angular noise.  The
 * tracked pose is left out of it on purpose, since a pose that follows
 * the keypoints would make them look right and the trust feed itself.
 * docs/TRACKER.md, "Trusting keypoints that agree". */
#include "track/mc_tracker_internal.h"

#include "base/mc_stats.h"

#include <math.h>
#include <string.h>

/* The disagreement (pixels of an image 128 wide) above which
 * lambda_detection holds as set: about the shipped head-rig detector's
 * (1.4-1.5 at the end of the dev clips, x1.5 there; 1.8-5.5 on the
 * held-out clips); 2 made test_tracker_recovery's lost arms come back
 * late (docs/TRACKER.md) */
#define TRUST_REF_PX 1.75
#define TRUST_WIDTH_PX 128.0
/* The spread is the median of the last frame sets' own medians: a
 * detector right most of the time, not one with good stretches (the
 * shipped one has them: on the held-out salsa a tenth of the frame sets
 * spread under 1.4 px, and a running mean there gave it more weight and
 * 1.1 cm more error); and no trust before TRUST_MIN_FRAMES of them. */
#define TRUST_MIN_FRAMES 30
/* Rays that meet behind a camera, or a point a camera cannot see, count
 * as this far apart */
#define FAR_PX 50.0
#define MAX_PAIRS 256

/* Pixels (at 128 wide) between camera c's projections of p and q. */
static double camera_px(const mc_camera *cam, mc_vec3 p, mc_vec3 q)
{
	double pu, pv, qu, qv;
	if (!mc_camera_project_rig(cam, p, &pu, &pv) || !mc_camera_project_rig(cam, q, &qu, &qv))
		return FAR_PX;
	return hypot(pu - qu, pv - qv) * TRUST_WIDTH_PX / cam->width;
}

/* How far two cameras' rays of one joint miss each other, as pixels: the
 * closest point on each ray seen by both cameras, their distance in each
 * camera's image, the mean of the two. */
static double ray_gap_px(const mc_tracker *t, const mc_trk_keypoint_ray *a, int ca, const mc_trk_keypoint_ray *b,
			 int cb)
{
	mc_vec3 pa, pb;
	int meet = mc_trk_ray_closest(a, b, &pa, &pb);
	if (meet <= 0)
		return meet < 0 ? FAR_PX : 0; /* parallel rays agree */
	double gap = 0.5 * (camera_px(&t->rig.cams[ca], pa, pb) + camera_px(&t->rig.cams[cb], pa, pb));
	return fmin(gap, FAR_PX);
}

/* The median gap (pixels at 128 wide) over every pair of cameras' rays of one joint in the
 * frame set (joints fixed to the rig left out: their keypoints say
 * nothing the rig does not); -1 when no joint was seen twice. */
static double frame_spread(const mc_tracker *t)
{
	const mc_trk_frame_keypoints *k = t->fkp;
	double gap[MAX_PAIRS];
	int n = 0;
	for (int i = 0; i < k->nrays; i++)
		for (int j = i + 1; j < k->nrays && n < MAX_PAIRS; j++) {
			const mc_trk_keypoint_ray *a = &k->rays[i], *b = &k->rays[j];
			if (a->joint != b->joint || k->cam[i] == k->cam[j] || t->fixed_joint[a->joint])
				continue;
			gap[n++] = ray_gap_px(t, a, k->cam[i], b, k->cam[j]);
		}
	return n ? mc_stats_median(gap, (size_t)n) : -1;
}

void mc_trk_update_trust(mc_tracker *t)
{
	double s = frame_spread(t), recent[MC_TRK_TRUST_FRAMES];
	if (s < 0)
		return;
	mc_stats_window_add(t->kp_spreads, MC_TRK_TRUST_FRAMES, &t->kp_nspreads, &t->kp_next, s);
	memcpy(recent, t->kp_spreads, sizeof(*recent) * (size_t)t->kp_nspreads);
	t->kp_spread = mc_stats_median(recent, (size_t)t->kp_nspreads);
}

double mc_tracker_keypoint_trust(const mc_tracker *t, double *spread_px)
{
	if (spread_px)
		*spread_px = t->kp_spread;
	if (t->kp_nspreads < TRUST_MIN_FRAMES)
		return 1;
	double ratio = TRUST_REF_PX / fmax(t->kp_spread, 1e-3);
	return fmin(t->s.detection_trust_max, fmax(1.0, ratio * ratio));
}
