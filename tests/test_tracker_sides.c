/* Left and right decided by the views and the tracked pose (core/track/
 * mc_sides.c, docs/TRACKER.md "Sides"), on the outside-in test rig (four
 * cameras, tests/data/outside/rig.json) and the default body model at its
 * rest pose, with keypoints projected from the pose itself:
 *   - one view's wrist labels exchanged: put back by the other views;
 *   - three of four views exchanged: the views agree on the wrong sides,
 *     and the tracked pose puts all four back;
 *   - one view's pair collapsed onto the left wrist: only the left keeps a
 *     ray there;
 *   - three views that do not settle it (two cameras facing each other,
 *     one of them exchanged, and a third view's keypoints well off): the
 *     tracked pose puts the exchanged view back (before the views had to
 *     settle it clearly, their best labelling kept it exchanged);
 *   - no pose yet (initialising): the views alone put one exchanged view
 *     back;
 *   - with assign_sides off the labels stay as the detector gave them (and
 *     the check across cameras drops the exchanged view's rays). */
#include "test_util.h"

#include "track/mc_tracker_internal.h"

#include <string.h>

static mc_rig rig;
static mc_model model;
static const mc_model *tracked; /* the tracker's (outside-in: with a free root) */
static int left_wrist, right_wrist;

/* Both wrists projected into every camera. */
static int wrists(const double *pose, mc_keypoint *kp)
{
	mc_fk fk;
	mc_model_fk(tracked, pose, &fk);
	int n = 0;
	for (int c = 0; c < rig.ncams; c++)
		for (int s = 0; s < 2; s++) {
			int j = s ? right_wrist : left_wrist;
			double u, v;
			if (mc_camera_project_rig(&rig.cams[c], fk.rig_from_joint[j].t, &u, &v))
				kp[n++] = (mc_keypoint){.cam = c, .joint = j, .u = (float)u, .v = (float)v, .conf = 0.9f};
		}
	return n;
}

/* Exchanges the labels of camera c's two keypoints. */
static void exchange_view(mc_keypoint *kp, int n, int c)
{
	for (int i = 0; i < n; i++)
		if (kp[i].cam == c)
			kp[i].joint = kp[i].joint == left_wrist ? right_wrist : left_wrist;
}

/* How many rays (of cameras other than `skip`; -1: all) carry a label
 * whose joint (at pose) they do not pass within 2 cm of; dropped rays
 * (weight 0) count in *dropped. */
static int wrong_labels(const double *pose, const mc_trk_keypoint_ray *r, const int *cam, int n, int skip,
			int *dropped)
{
	mc_fk fk;
	mc_model_fk(tracked, pose, &fk);
	int wrong = 0;
	*dropped = 0;
	for (int i = 0; i < n; i++) {
		if (cam[i] == skip)
			continue;
		if (!(r[i].weight > 0)) {
			(*dropped)++;
			continue;
		}
		mc_vec3 d = mc_v3_sub(fk.rig_from_joint[r[i].joint].t, r[i].origin);
		wrong += mc_v3_norm(mc_v3_reject(d, r[i].dir)) > 0.02;
	}
	return wrong;
}

/* The wrong labels after the sides are decided, camera `skip`'s left out. */
static int prepare_skip(mc_tracker *t, const mc_keypoint *kp, int n, mc_trk_keypoint_ray *r, int *dropped,
			const double *pose, int skip)
{
	int cam[MC_TRK_MAX_KEYPOINTS];
	int nr = mc_trk_prepare_keypoints(t, kp, n, r, cam);
	CHECK(nr == n);
	return wrong_labels(pose, r, cam, nr, skip, dropped);
}

static int prepare(mc_tracker *t, const mc_keypoint *kp, int n, mc_trk_keypoint_ray *r, int *dropped,
		   const double *pose)
{
	return prepare_skip(t, kp, n, r, dropped, pose, -1);
}

int main(void)
{
	mc_err err = {{0}};
	CHECK_MSG(mc_rig_load("tests/data/outside/rig.json", &rig, &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_model_load("config/models/default.json", &model, &err) == 0, "%s", err.msg);
	left_wrist = mc_model_find_joint(&model, "left_wrist");
	right_wrist = mc_model_find_joint(&model, "right_wrist");
	CHECK(rig.ncams == 4 && left_wrist >= 0 && right_wrist >= 0);
	mc_tracker_settings s;
	mc_tracker_settings_default(&s);
	CHECK(!s.assign_sides); /* head-mounted rigs: the detector's labels */
	mc_tracker_settings_outside_in(&s, rig.ncams, MC_GIVEN_ASSIGN_SIDES);
	CHECK(!s.assign_sides); /* a setting given stays */
	mc_tracker_settings_outside_in(&s, rig.ncams, 0);
	CHECK(s.assign_sides); /* outside-in: the views and the pose */
	mc_tracker *t = mc_tracker_create(&rig, &model, &s, &err);
	CHECK_MSG(t, "%s", err.msg);
	if (!t)
		return mc_test_finish("test_tracker_sides");
	tracked = mc_tracker_model(t);
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(tracked, pose);
	mc_tracker_set_pose(t, pose);
	memcpy(pose, mc_tracker_pose(t), sizeof(double) * (size_t)tracked->ndof); /* as clamped */
	t->init.waiting = false;
	mc_keypoint kp[2 * MC_MAX_CAMERAS];
	mc_trk_keypoint_ray r[MC_TRK_MAX_KEYPOINTS];
	int n = wrists(pose, kp), dropped;
	CHECK(n == 8);
	CHECK(prepare(t, kp, n, r, &dropped, pose) == 0 && dropped == 0);

	exchange_view(kp, n, 2);
	CHECK_MSG(prepare(t, kp, n, r, &dropped, pose) == 0 && dropped == 0, "one view exchanged: not put back");

	exchange_view(kp, n, 0);
	exchange_view(kp, n, 1); /* views 0, 1, 2 exchanged, 3 right */
	CHECK_MSG(prepare(t, kp, n, r, &dropped, pose) == 0 && dropped == 0, "three views exchanged: not put back");

	n = wrists(pose, kp);
	for (int i = 0; i < n; i++) /* view 1: both labels on the left wrist */
		if (kp[i].cam == 1 && kp[i].joint == right_wrist) {
			kp[i].u = kp[i - 1].u;
			kp[i].v = kp[i - 1].v;
		}
	CHECK_MSG(prepare(t, kp, n, r, &dropped, pose) == 0 && dropped == 1, "collapsed: %d dropped", dropped);

	n = wrists(pose, kp);
	int kept = 0;
	for (int i = 0; i < n; i++) /* cameras 0 and 2 face each other; 3 out */
		if (kp[i].cam != 3)
			kp[kept++] = kp[i];
	n = kept;
	exchange_view(kp, n, 2);
	/* View 1's two keypoints 10-28 px off (at 320 wide) in their own
	 * directions: no labelling of the three views meets well, and the
	 * best one keeps view 2 exchanged (its rays meet view 0's at ghost
	 * points between the wrists). */
	const float off[2][2] = {{10.3f, -26.2f}, {15.5f, 5.5f}};
	for (int i = 0, k = 0; i < n; i++)
		if (kp[i].cam == 1) {
			kp[i].u += off[k][0];
			kp[i].v += off[k][1];
			k++;
		}
	CHECK_MSG(prepare_skip(t, kp, n, r, &dropped, pose, 1) == 0 && dropped == 0,
		  "views that do not settle it: view 2 not put back");

	n = wrists(pose, kp);
	exchange_view(kp, n, 3);
	t->init.waiting = true;
	CHECK_MSG(prepare(t, kp, n, r, &dropped, pose) == 0, "no pose yet: the views did not put view 3 back");
	t->init.waiting = false;

	s.assign_sides = false;
	mc_tracker_destroy(t);
	t = mc_tracker_create(&rig, &model, &s, &err);
	CHECK_MSG(t, "%s", err.msg);
	if (t) {
		tracked = mc_tracker_model(t);
		mc_tracker_set_pose(t, pose);
		/* View 3's labels stay exchanged: the check across cameras then
		 * drops both of its rays. */
		CHECK(prepare(t, kp, n, r, &dropped, pose) == 0 && dropped == 2);
		mc_tracker_destroy(t);
	}
	return mc_test_finish("test_tracker_sides");
}
