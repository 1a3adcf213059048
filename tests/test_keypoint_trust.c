/* The keypoint term's trust (core/track/mc_keypoint_trust.c, docs/TRACKER.md
 * "Trusting keypoints that agree"), on the bundled head rig's calibration
 * and the default body model, keypoints projected from its rest pose:
 *   - both cameras' keypoints exact: the weight is detection_trust_max
 *     from the 30th frame set on, 1 before;
 *   - the cameras 3 px apart (at 128 wide) on every joint: it stays 1;
 *   - detection_trust_max 1, or keypoints from one camera only: it stays 1;
 *   - the detection term pulls joints near their rays trust^2 times as
 *     hard (its scale shrinks with the trust on a head rig), and joints
 *     far from them by the factor only; outside-in by the factor alone;
 *   - outside-in rigs get 2 (1 with two cameras) unless the setting was
 *     given; out-of-range values are refused by name;
 *   - the spine's and the pelvis' keypoints do not pull (skeletons do not
 *     agree on where those joints are), a hip's do. */
#include "test_util.h"

#include "eval/mc_clip.h"
#include "track/mc_tracker_internal.h"

#include <math.h>
#include <string.h>

static mc_rig rig;
static mc_model model;

/* Every joint not fixed to the rig, projected into the cameras of `cams`
 * (bit c: camera c) at pose, camera c's v moved by dv[c] native pixels. */
static int project_joints(const mc_tracker *t, const double *pose, unsigned cams, const double *dv, mc_keypoint *kp)
{
	mc_fk fk;
	mc_model_fk(&t->model, pose, &fk);
	int n = 0;
	for (int c = 0; c < t->rig.ncams; c++)
		for (int j = 0; j < t->model.njoints && (cams >> c & 1u); j++) {
			double u, v;
			if (!t->fixed_joint[j] &&
			    mc_camera_project_rig(&t->rig.cams[c], fk.rig_from_joint[j].t, &u, &v))
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

static mc_tracker *rig_tracker(const mc_rig *r, double trust_max)
{
	mc_tracker_settings s;
	mc_tracker_settings_default(&s);
	s.detection_trust_max = trust_max;
	mc_err err = {{0}};
	mc_tracker *t = mc_tracker_create(r, &model, &s, &err);
	CHECK_MSG(t, "%s", err.msg);
	return t;
}

static mc_tracker *tracker(double trust_max)
{
	return rig_tracker(&rig, trust_max);
}

/* How hard the detection term of t pulls at pose on the rays k: its
 * gradient's norm. */
static double grad_norm(mc_tracker *t, const double *pose, const mc_fk *fk, const mc_trk_frame_keypoints *k)
{
	double grad[MC_MAX_DOF] = {0}, sq = 0;
	mc_trk_detection_term(t, pose, fk, k->rays, k->nrays, grad);
	for (int d = 0; d < t->model.ndof; d++)
		sq += grad[d] * grad[d];
	return sqrt(sq);
}

/* How hard the term pulls with t's trust against fixed's (trust 1), on
 * t's rays at pose with every dof moved by `off` rad: whether the ratio
 * lies within [lo, hi]. */
static bool pull_ratio(mc_tracker *t, mc_tracker *fixed, const double *pose, double off, double lo, double hi)
{
	double moved[MC_MAX_DOF];
	memcpy(moved, pose, sizeof(moved));
	for (int d = 0; d < t->model.ndof; d++)
		moved[d] += off;
	mc_model_clamp_pose(&t->model, moved);
	mc_fk fk;
	mc_model_fk(&t->model, moved, &fk);
	double g3 = grad_norm(t, moved, &fk, t->fkp), g1 = grad_norm(fixed, moved, &fk, t->fkp);
	printf("every dof %.3f rad off: the term pulls x%.2f with trust 3\n", off, g1 > 0 ? g3 / g1 : 0);
	return g1 > 0 && g3 / g1 >= lo && g3 / g1 <= hi;
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

	/* the term near the rays: the weight and the scale both follow the
	 * trust, so joints a few mm off are held trust^2 = 9 times as stiffly */
	CHECK(pull_ratio(t, fixed, pose, 0.002, 8.5, 9.1));
	/* far from them (every dof 0.6 rad off, the joints tens of cm from
	 * their rays, as from a wrong keypoint), by the factor only */
	CHECK(pull_ratio(t, fixed, pose, 0.6, 2.8, 3.6));
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

/* Outside-in the scale stays (docs/TRACKER.md): the term pulls by the
 * factor alone, near the rays as far from them. */
static void test_outside_in_scale(void)
{
	mc_err err = {{0}};
	mc_clip clip;
	if (mc_clip_open("tests/data/outside_demo", false, &clip, &err) < 0) {
		CHECK_MSG(false, "tests/data/outside_demo: %s", err.msg);
		return;
	}
	mc_tracker *t = rig_tracker(&clip.rig, 3), *fixed = rig_tracker(&clip.rig, 1);
	mc_clip_close(&clip);
	if (t && fixed) {
		double pose[MC_MAX_DOF], spread;
		mc_model_rest_pose(&t->model, pose);
		mc_keypoint kp[MC_MAX_CAMERAS * MC_MAX_JOINTS];
		const double exact[MC_MAX_CAMERAS] = {0};
		int n = project_joints(t, pose, 0xfu, exact, kp);
		CHECK_MSG(n >= 40 && feed(t, kp, n, 90, &spread) == 3, "outside-in: %d keypoints", n);
		CHECK(pull_ratio(t, fixed, pose, 0.002, 2.95, 3.05));
	}
	mc_tracker_destroy(t);
	mc_tracker_destroy(fixed);
}

/* How hard both cameras' keypoints of joint j alone, 15 cm below where
 * the rest pose has it, pull the rest pose. */
static double pull_of_joint(mc_tracker *t, int j)
{
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(&t->model, pose);
	mc_fk fk;
	mc_model_fk(&t->model, pose, &fk);
	mc_vec3 below = mc_v3_add(fk.rig_from_joint[j].t, mc_v3(0, 0.15, 0)); /* rig y: down */
	mc_keypoint kp[MC_MAX_CAMERAS];
	int n = 0;
	for (int c = 0; c < t->rig.ncams; c++) {
		double u, v;
		if (mc_camera_project_rig(&t->rig.cams[c], below, &u, &v))
			kp[n++] = (mc_keypoint){.cam = c, .joint = j, .u = (float)u, .v = (float)v, .conf = 1};
	}
	feed(t, kp, n, 1, NULL);
	CHECK_MSG(t->fkp->nrays == 2, "%s: %d rays", t->model.joints[j].name, t->fkp->nrays);
	return grad_norm(t, pose, &fk, t->fkp);
}

static void test_unpulled(void)
{
	mc_tracker *t = tracker(1);
	if (!t)
		return;
	const char *joints[] = {"spine", "pelvis", "left_hip"};
	for (int i = 0; i < 3; i++) {
		double pull = pull_of_joint(t, mc_model_find_joint(&t->model, joints[i]));
		printf("%s's keypoints 15 cm off: the term pulls %.3g\n", joints[i], pull);
		CHECK_MSG(i < 2 ? pull == 0 : pull > 1e-3, "%s: pull %g", joints[i], pull);
	}
	mc_tracker_destroy(t);
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
	test_outside_in_scale();
	test_unpulled();
	test_settings();
	return mc_test_finish("test_keypoint_trust");
}
