/* The keypoint term's trust (core/track/mc_keypoint_trust.c, docs/TRACKER.md
 * "Trusting keypoints that agree"), on the bundled head rig's calibration
 * and the default body model, keypoints projected from its rest pose:
 *   - both cameras' keypoints exact: the weight is detection_trust_max
 *     from the 30th frame set on, 1 before;
 *   - the cameras 3 px apart (at 128 wide) on every joint: it stays 1;
 *   - detection_trust_max 1, or keypoints from one camera only: it stays 1;
 *   - the detection term's energy grows by the factor;
 *   - outside-in rigs get 2 (1 with two cameras) unless the setting was
 *     given; out-of-range values are refused by name. */
#include "test_util.h"

#include "eval/mc_clip.h"
#include "track/mc_tracker_internal.h"

#include <string.h>

static mc_rig rig;
static mc_model model;

/* Every joint not fixed to the rig, projected into the cameras of `cams`
 * (bit c: camera c) at pose, camera c's v moved by dv[c] native pixels. */
static int project_joints(const mc_tracker *t, const double *pose, unsigned cams, const double dv[2], mc_keypoint *kp)
{
	mc_fk fk;
	mc_model_fk(&t->model, pose, &fk);
	int n = 0;
	for (int c = 0; c < rig.ncams; c++)
		for (int j = 0; j < t->model.njoints && (cams >> c & 1u); j++) {
			double u, v;
			if (!t->fixed_joint[j] &&
			    mc_camera_project_rig(&rig.cams[c], fk.rig_from_joint[j].t, &u, &v))
				kp[n++] = (mc_keypoint){.cam = c, .joint = j, .u = (float)u, .v = (float)(v + dv[c]), .conf = 1};
		}
	return n;
}

/* `frames` frame sets of the same keypoints through the trust's update, as
 * mc_tracker_track gives it each frame set's rays; returns the factor. */
static double feed(mc_tracker *t, const mc_keypoint *kp, int n, int frames, double *spread)
{
	mc_trk_frame_keypoints *k = t->fkp;
	for (int f = 0; f < frames; f++) {
		k->ngiven = n;
		memcpy(k->given, kp, sizeof(*kp) * (size_t)n);
		k->nrays = mc_trk_prepare_keypoints(t, k->given, n, k->rays, k->cam);
		mc_trk_update_trust(t);
	}
	return mc_tracker_keypoint_trust(t, spread);
}

static mc_tracker *tracker(double trust_max)
{
	mc_tracker_settings s;
	mc_tracker_settings_default(&s);
	s.detection_trust_max = trust_max;
	mc_err err = {{0}};
	mc_tracker *t = mc_tracker_create(&rig, &model, &s, &err);
	CHECK_MSG(t, "%s", err.msg);
	return t;
}

static void test_agreement(void)
{
	mc_tracker *t = tracker(3), *fixed = tracker(1);
	if (!t || !fixed) {
		mc_tracker_destroy(t);
		mc_tracker_destroy(fixed);
		return;
	}
	double pose[MC_MAX_DOF], spread;
	mc_model_rest_pose(&t->model, pose);
	mc_keypoint kp[2 * MC_MAX_JOINTS];
	const double exact[2] = {0, 0}, apart[2] = {3, -3}; /* native 256 wide: 3 px apart at 128 */
	int n = project_joints(t, pose, 3u, exact, kp);
	CHECK_MSG(n >= 20, "%d keypoints in view", n);
	double first = feed(t, kp, n, 29, &spread);
	CHECK_MSG(first == 1 && spread < 0.3, "29 frame sets set the trust to %.2f", first);
	double trust = feed(t, kp, n, 90, &spread);
	printf("exact keypoints: spread %.3f px, trust x%.2f\n", spread, trust);
	CHECK_MSG(trust == 3 && spread < 0.3, "exact keypoints: x%.2f, spread %.3f px", trust, spread);
	CHECK(feed(fixed, kp, n, 90, &spread) == 1);

	/* the term's energy at a pose off the rays, with the factor 3 and 1 */
	double off[MC_MAX_DOF], grad[MC_MAX_DOF] = {0};
	memcpy(off, pose, sizeof(off));
	for (int d = 0; d < t->model.ndof; d++)
		off[d] += 0.05;
	mc_model_clamp_pose(&t->model, off);
	mc_fk fk;
	mc_model_fk(&t->model, off, &fk);
	double e3 = mc_trk_detection_term(t, off, &fk, t->fkp->rays, t->fkp->nrays, grad);
	double e1 = mc_trk_detection_term(fixed, off, &fk, fixed->fkp->rays, fixed->fkp->nrays, grad);
	CHECK_MSG(e1 > 0 && fabs(e3 / e1 - 3) < 1e-9, "energies %g and %g", e3, e1);

	mc_tracker_destroy(t);
	t = tracker(3);
	if (t) {
		n = project_joints(t, pose, 3u, apart, kp);
		trust = feed(t, kp, n, 90, &spread);
		printf("keypoints 3 px apart: spread %.3f px, trust x%.2f\n", spread, trust);
		CHECK_MSG(trust == 1 && spread > 2, "3 px apart: x%.2f, spread %.3f px", trust, spread);
		mc_tracker_destroy(t);
	}
	t = tracker(3);
	if (t) { /* one camera: nothing to compare */
		n = project_joints(t, pose, 1u, exact, kp);
		CHECK(feed(t, kp, n, 30, &spread) == 1 && spread == 0);
		mc_tracker_destroy(t);
	}
	mc_tracker_destroy(fixed);
}

static void test_settings(void)
{
	mc_tracker_settings s;
	mc_tracker_settings_default(&s);
	CHECK(s.detection_trust_max == 3);
	mc_tracker_settings_outside_in(&s, 4, MC_GIVEN_DETECTION_TRUST);
	CHECK(s.detection_trust_max == 3); /* given: kept */
	mc_tracker_settings_outside_in(&s, 4, 0);
	CHECK(s.detection_trust_max == 2);
	mc_tracker_settings_outside_in(&s, 2, 0);
	CHECK(s.detection_trust_max == 1); /* two cameras: fixed */
	s.detection_trust_max = 0.5;
	mc_err err = {{0}};
	mc_tracker *t = mc_tracker_create(&rig, &model, &s, &err);
	CHECK_MSG(!t && strstr(err.msg, "detection_trust_max"), "0.5 accepted: '%s'", err.msg);
	mc_tracker_destroy(t);
}

int main(void)
{
	mc_err err = {{0}};
	mc_clip clip;
	if (mc_clip_open("tests/data/ego_demo", false, &clip, &err) < 0) {
		fprintf(stderr, "tests/data/ego_demo: %s\n", err.msg);
		return 1;
	}
	rig = clip.rig;
	mc_clip_close(&clip);
	CHECK_MSG(mc_model_load("config/models/default.json", &model, &err) == 0, "%s", err.msg);
	test_agreement();
	test_settings();
	return mc_test_finish("test_keypoint_trust");
}
