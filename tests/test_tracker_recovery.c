/* Starting without ground truth and recovering from loss (docs/TRACKER.md,
 * "Starting without ground truth"), on the bundled clip
 * (tests/data/ego_demo, 60 frames, the OpenCL tracker on PoCL).
 *
 * The keypoints come from a simulated detector (the ground truth
 * projected, 3 px of noise, 15% missed: mc_clip_simulated_keypoints), so
 * that these tests measure the tracker's logic and not the shipped
 * detector's accuracy, which test_detector_tracking and mocap-bench
 * --detector --init detect measure.
 *   1. Without keypoints the state is "initialising", with confidence 0;
 *      from detections alone tracking starts within 0.5 s and stays within
 *      a bound of the ground-truth start (gt0), and a model whose
 *      shoulders are too wide gets the clip's width from the keypoints.
 *   2. A wrong start (arms raised where the actor's hang, the body 15% too
 *      small, the colours learnt before the arms went wrong) is pulled
 *      back: the arms' error falls below a bound, with recovery and (since
 *      the offsets from rays near the cameras are angles) without.  With
 *      the arms raised halfway and the colours learnt there, the arms come
 *      back too (test_arms_learnt_wrong), and so does a wrist put at a
 *      camera's centre (test_wrist_at_camera) and a knee pulled up to 0.2
 *      m in front of one, the colours learnt there (test_knee_at_camera).
 *   3. Covered cameras (black images, no keypoints) for 0.5 s in the middle
 *      of the clip: within 0.5 s of the images coming back the state is
 *      tracked again and the error within a bound.
 *   4. 1 and 3 again with the keypoints joining at gradient iteration 10
 *      (mc_tracker_set_keypoint_poll) once a first pose is found, as in
 *      mocapd when the detection ends after the tracking began (3 also
 *      with only the second camera's late, as when one camera's detection
 *      ends before the tracking starts and the other's after): tracking
 *      starts as early and as well, and after the covered cameras a re-fit
 *      is tried with the late keypoints, and tracking is back as soon, within
 *      two frame sets (the re-fit used to look for keypoints only before
 *      the iterations, where none came). */
#include "test_util.h"

#include "body/mc_fit_joints.h"
#include "body/mc_ik.h"
#include "eval/mc_clip.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *const joints[] = {"neck", "left_shoulder", "left_elbow", "left_wrist", "left_hip",
				     "left_knee", "left_ankle", "left_toe", "right_shoulder", "right_elbow",
				     "right_wrist", "right_hip", "right_knee", "right_ankle", "right_toe"};
#define NJ ((int)(sizeof(joints) / sizeof(joints[0])))
static const char *const arm_joints[] = {"left_elbow", "left_wrist", "right_elbow", "right_wrist"};

#define NOISE_PX 3.0
/* bounds, cm (measured values in the comments at each check) */
#define DETECT_OVER_GT0_CM 3.0
#define ARMS_AFTER_CM 15.0
#define RECOVERED_CM 15.0

typedef struct {
	mc_clip clip;
	mc_model model;
	mc_tracker_settings s;
	uint64_t rng;
	int late_at; /* > 0: the keypoints join at this iteration once tracking */
	bool late_second_only; /* only the second camera's join late */
	double gt0_cm;  /* MPJPE from the ground-truth start (test 1) */
	int back_early; /* the frame set tracked again after the cover (test 3) */
} fixture;

/* Mean error (cm) over `names` of skeleton sk at frame k. */
static double error_cm(const fixture *f, const mc_skeleton *sk, int k, const char *const *names, int n)
{
	double sum = 0;
	for (int e = 0; e < n; e++) {
		int g = mc_clip_joint(&f->clip, names[e]), j = mc_model_find_joint(&f->model, names[e]);
		CHECK(g >= 0 && j >= 0);
		sum += mc_v3_norm(mc_v3_sub(sk->joints[j].position, mc_clip_gt(&f->clip, k, g)));
	}
	return 100 * sum / n;
}

/* Tracks frame k; blank: the cameras see black and no keypoints come. */
static void track(fixture *f, mc_tracker *t, int k, bool blank, mc_skeleton *sk)
{
	mc_frame_view v[MC_MAX_CAMERAS];
	mc_err err;
	CHECK_MSG(mc_clip_load_frame(&f->clip, k, v, &err) == 0, "%s", err.msg);
	mc_keypoint kp[2 * NJ];
	int nkp = 0;
	if (blank)
		for (int c = 0; c < 2; c++)
			memset((void *)v[c].rgb, 0, (size_t)v[c].stride * v[c].height);
	else
		nkp = mc_clip_simulated_keypoints(&f->clip, &f->model, joints, NJ, k, NOISE_PX, &f->rng, kp, 2 * NJ);
	/* Waiting for a first pose the tracker does not iterate; mocapd then
	 * gives it the newest detections up to 0.3 s old before it starts. */
	mc_tracker_init_info info;
	mc_tracker_get_init_info(t, &info);
	bool joins_late = f->late_at > 0 && !info.initialising;
	mc_keypoint early[2 * NJ], later[2 * NJ];
	int nearly = 0, nlater = 0;
	for (int i = 0; i < nkp; i++) {
		if (joins_late && (!f->late_second_only || kp[i].cam == 1))
			later[nlater++] = kp[i];
		else
			early[nearly++] = kp[i];
	}
	mc_keypoints_at late = {later, nlater, f->late_at};
	mc_tracker_set_keypoint_poll(t, joins_late ? mc_keypoints_at_poll : NULL, &late);
	CHECK_MSG(mc_tracker_track(t, v, 2, early, nearly, sk, &err) == 0, "%s", err.msg);
	mc_tracker_set_keypoint_poll(t, NULL, NULL);
	mc_clip_free_frame(v);
}

static mc_tracker *new_tracker(fixture *f)
{
	mc_err err;
	mc_tracker *t = mc_tracker_create(&f->clip.rig, &f->model, &f->s, &err);
	CHECK_MSG(t != NULL, "%s", err.msg);
	f->rng = 7;
	return t;
}

/* MPJPE (cm) over the clip from tracker t. */
static double run_clip(fixture *f, mc_tracker *t, int *first_tracked)
{
	double sum = 0;
	*first_tracked = -1;
	for (int k = 0; k < f->clip.gt.nframes; k++) {
		mc_skeleton sk;
		track(f, t, k, false, &sk);
		if (*first_tracked < 0 && sk.state != MC_TRACK_INITIALISING)
			*first_tracked = k;
		sum += error_cm(f, &sk, k, joints, NJ);
	}
	return sum / f->clip.gt.nframes;
}

static void test_start_from_detections(fixture *f)
{
	mc_err err;
	mc_tracker *t = new_tracker(f);
	CHECK(mc_clip_init_tracker(&f->clip, t, &err) == 0);
	int first;
	double gt0 = run_clip(f, t, &first);
	mc_tracker_destroy(t);

	t = new_tracker(f);
	CHECK(mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, &err) == 0);
	mc_skeleton sk;
	mc_frame_view v[MC_MAX_CAMERAS];
	CHECK(mc_clip_load_frame(&f->clip, 0, v, &err) == 0);
	CHECK(mc_tracker_track(t, v, 2, NULL, 0, &sk, &err) == 0);
	mc_clip_free_frame(v);
	CHECK_MSG(sk.state == MC_TRACK_INITIALISING, "no keypoints: state %s", mc_track_state_name(sk.state));
	CHECK(sk.njoints == f->model.njoints && sk.joints[3].confidence == 0);
	CHECK(strcmp(mc_track_state_name(MC_TRACK_INITIALISING), "initialising") == 0);
	mc_tracker_init_info info;
	mc_tracker_get_init_info(t, &info);
	CHECK(info.initialising && info.inits == 0);

	double detect = run_clip(f, t, &first);
	mc_tracker_get_init_info(t, &info);
	printf("start from detections: first pose at frame %d, MPJPE %.2f cm (gt0 start: %.2f cm), size measured: %s "
	       "(scale %.3f)\n",
	       first, detect, gt0, info.shape_measured ? "yes" : "no", info.scale);
	f->gt0_cm = gt0;
	CHECK(!info.initialising && info.inits == 1);
	CHECK_MSG(first >= 0 && first <= 15, "tracking started at frame %d, expected within 0.5 s", first);
	/* measured: 6.6 vs 4.4 cm */
	CHECK_MSG(detect <= gt0 + DETECT_OVER_GT0_CM, "from detections %.2f cm, gt0 %.2f cm", detect, gt0);
	CHECK(mc_tracker_actor_version(t) >= 1);

	/* The calibrated actor as the model, kept (an actor file): the
	 * colours stay as they are and tracking starts again. */
	mc_model actor = *mc_tracker_model(t);
	mc_tracker_destroy(t);
	t = mc_tracker_create(&f->clip.rig, &actor, &f->s, &err);
	CHECK_MSG(t && mc_tracker_start_from_detections(t, MC_INIT_KEEP_ACTOR, &err) == 0, "%s", err.msg);
	f->rng = 7;
	double again = run_clip(f, t, &first);
	const mc_model *m = mc_tracker_model(t);
	int same = 0;
	for (int q = 0; q < m->ngauss; q++)
		same += !memcmp(m->gauss[q].rgb, actor.gauss[q].rgb, sizeof(actor.gauss[q].rgb));
	printf("with the actor kept: first pose at frame %d, MPJPE %.2f cm, %d of %d colours unchanged\n", first,
	       again, same, m->ngauss);
	CHECK(same == m->ngauss && first >= 0 && first <= 15);
	CHECK_MSG(again <= gt0 + DETECT_OVER_GT0_CM, "with the actor %.2f cm, gt0 %.2f cm", again, gt0);
	mc_tracker_destroy(t);
}

/* Mean error (cm) over `names` of the tracker's current pose at frame k. */
static double pose_error_cm(const fixture *f, const mc_tracker *t, int k, const char *const *names, int n)
{
	mc_fk fk;
	const mc_model *m = mc_tracker_model(t);
	mc_model_fk(m, mc_tracker_pose(t), &fk);
	double sum = 0;
	for (int e = 0; e < n; e++)
		sum += mc_v3_norm(mc_v3_sub(fk.rig_from_joint[mc_model_find_joint(m, names[e])].t,
					    mc_clip_gt(&f->clip, k, mc_clip_joint(&f->clip, names[e]))));
	return 100 * sum / n;
}

/* The arms raised forward (shoulders at `share` of their forward limit,
 * elbows straight). */
static void raise_arms(const mc_model *m, double share, double *pose)
{
	for (int j = 0; j < m->njoints; j++) {
		const mc_joint *jt = &m->joints[j];
		for (int d = 0; d < jt->ndof && (strstr(jt->name, "shoulder") || strstr(jt->name, "elbow")); d++)
			pose[jt->dof0 + d] = strstr(jt->name, "shoulder") && d == 0 ? share * jt->upper[0] : 0;
	}
}

/* The colours learnt from frame 0's views at t's pose. */
static void learn_colours(fixture *f, mc_tracker *t)
{
	mc_err err;
	mc_frame_view v[MC_MAX_CAMERAS];
	CHECK(mc_clip_load_frame(&f->clip, 0, v, &err) == 0);
	CHECK_MSG(mc_tracker_calibrate_colors(t, v, 2, &err) == 0, "%s", err.msg);
	mc_clip_free_frame(v);
}

/* Tracks the whole clip with t; returns the mean error (cm) of the joints
 * `names` over its last 0.5 s, and *back the first frame set where they
 * are within ARMS_AFTER_CM (-1: none). */
static double track_part(fixture *f, mc_tracker *t, const char *const *names, int n, int *back)
{
	const int frames = f->clip.gt.nframes, within = 15;
	double last = 0;
	*back = -1;
	for (int k = 0; k < frames; k++) {
		mc_skeleton sk;
		track(f, t, k, false, &sk);
		double e = error_cm(f, &sk, k, names, n);
		if (*back < 0 && e <= ARMS_AFTER_CM)
			*back = k;
		if (k >= frames - within)
			last += e;
	}
	return last / within;
}

static double track_arms(fixture *f, mc_tracker *t, int *back)
{
	return track_part(f, t, arm_joints, 4, back);
}

/* Frame 0's ground truth with the body shrunk by 15% about the neck
 * (another actor's bone lengths), and then the arms raised forward
 * (shoulders at 80% of their forward limit, elbows straight) where the
 * actor's hang. */
static double wrong_start(fixture *f, bool recover)
{
	mc_err err;
	f->s.recover = recover;
	mc_tracker *t = new_tracker(f);
	f->s.recover = true;
	const char *names[MC_CLIP_MAX_JOINTS];
	mc_vec3 pos[MC_CLIP_MAX_JOINTS];
	int neck = mc_clip_joint(&f->clip, "neck");
	mc_vec3 c = mc_clip_gt(&f->clip, 0, neck);
	for (int j = 0; j < f->clip.gt.njoints; j++) {
		names[j] = f->clip.gt.joint_names[j];
		pos[j] = mc_v3_add(c, mc_v3_scale(mc_v3_sub(mc_clip_gt(&f->clip, 0, j), c), 0.85));
	}
	CHECK(mc_tracker_init_from_joints(t, names, pos, f->clip.gt.njoints, &err) == 0);
	/* the colours are learnt at the start pose, before the arms go wrong:
	 * a tracker that lost its arms, not one that never saw them */
	learn_colours(f, t);
	double pose[MC_MAX_DOF];
	memcpy(pose, mc_tracker_pose(t), sizeof(double) * f->model.ndof);
	raise_arms(&f->model, 0.8, pose);
	mc_tracker_set_pose(t, pose);
	double before = pose_error_cm(f, t, 0, arm_joints, 4);
	int back;
	double after = track_arms(f, t, &back);
	mc_tracker_init_info info;
	mc_tracker_get_init_info(t, &info);
	printf("wrong start, recovery %s: arms %.1f cm off at the start, %.1f cm over the last 0.5 s (%d re-fits)\n",
	       recover ? "on" : "off", before, after, info.refits);
	CHECK_MSG(before > 2 * ARMS_AFTER_CM, "the start was not wrong enough (%.1f cm)", before);
	mc_tracker_destroy(t);
	return after;
}

/* measured: 11.5 cm with recovery and without.  Raised forward, the
 * wrists are near the cameras' height, where the offsets from the rays'
 * lines were small; since those offsets are measured by the angle (stop
 * 54, geom/mc_ray.h) the keypoints bring the arms back without a re-fit
 * (before: 8.4 cm with recovery, 65 cm without). */
static void test_wrong_start(fixture *f)
{
	double with = wrong_start(f, true), without = wrong_start(f, false);
	CHECK_MSG(with <= ARMS_AFTER_CM, "arms still %.1f cm off at the end", with);
	CHECK_MSG(without <= ARMS_AFTER_CM, "without recovery the arms still %.1f cm off at the end", without);
}

/* 2b. The arms raised halfway (shoulders at half their forward limit)
 * where the actor's hang, with the colours learnt there: a limb lost long
 * enough for its colours to be learnt at the wrong place.  The colour
 * energy prefers the wrong arms, so only the cameras' agreement on the
 * keypoints can bring them back.  Returns the first frame set whose arms
 * are within ARMS_AFTER_CM; *last gets their mean error over the clip's
 * last 0.5 s. */
static int arms_learnt_wrong(fixture *f, double *last)
{
	mc_err err;
	mc_tracker *t = new_tracker(f);
	CHECK(mc_clip_init_tracker(&f->clip, t, &err) == 0);
	double pose[MC_MAX_DOF];
	memcpy(pose, mc_tracker_pose(t), sizeof(double) * f->model.ndof);
	raise_arms(&f->model, 0.5, pose);
	mc_tracker_set_pose(t, pose);
	learn_colours(f, t);
	int back;
	*last = track_arms(f, t, &back);
	mc_tracker_init_info info;
	mc_tracker_get_init_info(t, &info);
	printf("arms raised, colours learnt there: arms within %.0f cm from frame set %d, %.1f cm over the last 0.5 s "
	       "(%d re-fits)\n",
	       ARMS_AFTER_CM, back, *last, info.refits);
	mc_tracker_destroy(t);
	return back;
}

/* measured: back at frame set 16 and 5.2 cm over the last 0.5 s at stop
 * 59 (12 and 5.0 at stop 54; 27 and 5.7 before stop 54's angles near the
 * cameras); 25.0 cm there before stop 52, when a limb whose confidence stayed up was
 * re-fitted only after 30 frame sets and all the colours then learnt
 * again at that pose.  (Raised further, at 80 %, the arms stay about 35
 * cm off: from there the rays are out of a local fit's reach,
 * docs/TRACKER.md.) */
static void test_arms_learnt_wrong(fixture *f)
{
	double last;
	int back = arms_learnt_wrong(f, &last);
	CHECK_MSG(back >= 0 && back < 40, "the arms came back at frame set %d, not within 1.3 s", back);
	CHECK_MSG(last <= ARMS_AFTER_CM, "the arms were %.1f cm off over the last 0.5 s", last);
}

/* t's pose with joint `name` moved by the inverse kinematics to `ahead`
 * metres in front of the first camera's centre, every joint but it and
 * those below it held where they are.  Returns how far from there it got
 * (m). */
static double joint_to_camera(fixture *f, mc_tracker *t, const char *name, double ahead)
{
	mc_err err;
	mc_model m = *mc_tracker_model(t);
	double pose[MC_MAX_DOF];
	memcpy(pose, mc_tracker_pose(t), sizeof(double) * m.ndof);
	mc_fk fk;
	mc_model_fk(&m, pose, &fk);
	int joint = mc_model_find_joint(&m, name), n = 0;
	bool below[MC_MAX_JOINTS];
	CHECK(mc_model_subtree(&m, joint, below) > 0);
	mc_vec3 to = mc_xform_apply(f->clip.rig.cams[0].rig_from_cam, (mc_vec3){0, 0, ahead});
	mc_ik_target tg[MC_MAX_JOINTS];
	for (int j = 0; j < m.njoints; j++)
		if (j == joint)
			tg[n++] = (mc_ik_target){j, to, 100, {0, 0, 0}};
		else if (!below[j])
			tg[n++] = (mc_ik_target){j, fk.rig_from_joint[j].t, 1.0, {0, 0, 0}};
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.fit_bone_scale = false;
	o.fit_root = false;
	CHECK(mc_ik_solve(&m, pose, tg, n, &o, &err) >= 0);
	mc_tracker_set_pose(t, pose);
	mc_model_fk(&m, pose, &fk);
	return mc_v3_norm(mc_v3_sub(fk.rig_from_joint[joint].t, to));
}

/* Joint `name` moved to `ahead` metres in front of the first camera, the
 * colours learnt at the right pose or (learnt_there) at that one; then the
 * clip tracked.  Returns the
 * first frame set where the joints `part` are within ARMS_AFTER_CM;
 * *start and *last get their error at the start and over the last 0.5 s. */
static int joint_at_camera(fixture *f, const char *name, double ahead, bool learnt_there, const char *const *part,
			   int npart, double *start, double *last)
{
	mc_err err;
	mc_tracker *t = new_tracker(f);
	CHECK(mc_clip_init_tracker(&f->clip, t, &err) == 0);
	if (!learnt_there)
		learn_colours(f, t);
	double moved = joint_to_camera(f, t, name, ahead);
	if (learnt_there)
		learn_colours(f, t);
	CHECK_MSG(moved < 0.05, "the %s is %.1f cm from where it was put, not there", name, 100 * moved);
	*start = pose_error_cm(f, t, 0, part, npart);
	int back;
	*last = track_part(f, t, part, npart, &back);
	mc_tracker_init_info info;
	mc_tracker_get_init_info(t, &info);
	printf("%s %.2f m in front of a camera: %.1f cm off at the start, within %.0f cm from frame set %d, %.1f cm "
	       "over the last 0.5 s (%d re-fits)\n",
	       name, ahead, *start, ARMS_AFTER_CM, back, *last, info.refits);
	mc_tracker_destroy(t);
	return back;
}

/* 2c. The right wrist moved to the first camera's centre, as a hand beside
 * a head-mounted camera (the held-out salsa's right arm stayed there for
 * 1.2 s with 2 px keypoints in both views).  Every ray of that camera
 * passes through its centre, so measured from their lines the wrist sat
 * on all of them and only the other camera's far-off rays pulled, too
 * weakly (geom/mc_ray.h).  measured (stop 59): back at frame set 7, 4.2
 * cm over the last 0.5 s (stop 54: 20, 4.1); with the offsets from the
 * rays' lines (before stop 54) at frame set 58, 30.5 cm */
static void test_wrist_at_camera(fixture *f)
{
	double start, last;
	int back = joint_at_camera(f, "right_wrist", 0, false, arm_joints, 4, &start, &last);
	CHECK_MSG(start > 2 * ARMS_AFTER_CM, "the start was not wrong enough (%.1f cm)", start);
	CHECK_MSG(back >= 0 && back < 30, "the arms came back at frame set %d, not within 1 s", back);
	CHECK_MSG(last <= ARMS_AFTER_CM, "the arms were %.1f cm off over the last 0.5 s", last);
}

/* 2d. The left knee pulled up to 0.2 m in front of the first camera, the
 * leg folded at the face as the held-out icl02_04's knees for 3 s with
 * the shipped detector, and the colours learnt there, as after such a
 * while.  By the rays' lines the knee is near every ray of that camera, so
 * the recovery never counted it stuck, and a re-fit from where it was
 * kept it there (docs/TRACKER.md, "Caught at the cameras").  measured:
 * back at frame set 27, 5.2 cm over the last 0.5 s (1 re-fit); before
 * stop 59 never, 142.5 cm. */
static void test_knee_at_camera(fixture *f)
{
	static const char *const leg[] = {"left_knee", "left_ankle"};
	double start, last;
	int back = joint_at_camera(f, "left_knee", 0.2, true, leg, 2, &start, &last);
	CHECK_MSG(start > 2 * ARMS_AFTER_CM, "the start was not wrong enough (%.1f cm)", start);
	CHECK_MSG(back >= 0 && back < 40, "the leg came back at frame set %d, not within 1.3 s", back);
	CHECK_MSG(last <= ARMS_AFTER_CM, "the leg was %.1f cm off over the last 0.5 s", last);
}

/* Returns the first frame set tracked again within RECOVERED_CM after the
 * cover, or -1. */
static int covered_cameras(fixture *f, bool recover, int *tries)
{
	mc_err err;
	f->s.recover = recover;
	mc_tracker *t = new_tracker(f);
	f->s.recover = true;
	CHECK(mc_clip_init_tracker(&f->clip, t, &err) == 0);
	const int cover0 = 20, cover1 = 35, within = 15; /* frame sets: 0.5 s at 30 fps */
	const int last = f->clip.gt.nframes - 1;
	mc_skeleton sk;
	int back = -1;
	double err_back = 0, mean_after = 0;
	for (int i = 0; i < cover1 + within; i++) {
		/* After the cover the actor is elsewhere: the clip goes on from
		 * its last frame backwards (the body 0.8 s of walking away). */
		int k = i < cover1 ? i : last - (i - cover1);
		bool blank = i >= cover0 && i < cover1;
		track(f, t, k, blank, &sk);
		if (blank)
			CHECK_MSG(sk.state == MC_TRACK_LOST, "frame %d covered: state %s", k, mc_track_state_name(sk.state));
		double e = error_cm(f, &sk, k, joints, NJ);
		if (i >= cover1)
			mean_after += e / within;
		if (!blank && i >= cover1 && back < 0 && sk.state != MC_TRACK_LOST && e <= RECOVERED_CM) {
			back = i;
			err_back = e;
		}
	}
	mc_tracker_init_info info;
	mc_tracker_get_init_info(t, &info);
	printf("covered cameras, frame sets %d-%d, recovery %s: tracked again at frame set %d (%.1f cm), %.1f cm over "
	       "the 0.5 s after, %d re-fits (%d tried)\n",
	       cover0, cover1 - 1, recover ? "on" : "off", back, err_back, mean_after, info.refits, info.refit_tries);
	*tries = info.refit_tries;
	mc_tracker_destroy(t);
	return back;
}

static void test_covered_cameras(fixture *f)
{
	const int cover1 = 35, within = 15;
	int tries;
	int back = covered_cameras(f, true, &tries);
	CHECK_MSG(back >= cover1 && back < cover1 + within, "not recovered within 0.5 s (frame %d)", back);
	f->back_early = back;
	covered_cameras(f, false, &tries); /* printed: how much the re-fit brings here */
}

/* 4: the keypoints join at iteration 10 once a first pose is found. */
static void test_late_keypoints(fixture *f)
{
	mc_err err;
	f->late_at = 10;
	mc_tracker *t = new_tracker(f);
	CHECK(mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, &err) == 0);
	int first;
	double detect = run_clip(f, t, &first);
	printf("start from detections, keypoints at iteration %d: first pose at frame %d, MPJPE %.2f cm\n", f->late_at,
	       first, detect);
	CHECK_MSG(first >= 0 && first <= 15, "tracking started at frame %d, expected within 0.5 s", first);
	CHECK_MSG(detect <= f->gt0_cm + DETECT_OVER_GT0_CM, "from late detections %.2f cm, gt0 %.2f cm", detect,
		  f->gt0_cm);
	mc_tracker_destroy(t);

	/* The re-fit must be tried with the keypoints that came late; kept or
	 * not (the iterations, which had them from iteration 10, may already
	 * have the body where the fit puts it: measured, since stop 60's
	 * widths, the fit's colour energy -0.5184 against the tracked
	 * -0.5185), tracking is back within two frame sets of the early
	 * case's (stop 60: 37 and 36 against 35; before, 35 with a re-fit
	 * kept).  Taken only before the iterations, as it once was, no re-fit
	 * is tried at all. */
	for (int second_only = 0; second_only <= 1; second_only++) {
		f->late_second_only = second_only;
		int tries;
		int back = covered_cameras(f, true, &tries);
		CHECK_MSG(back >= 0 && back <= f->back_early + 2 && tries >= 1,
			  "%s keypoints at iteration %d: tracked again at frame set %d after %d re-fits tried (with "
			  "keypoints before the iterations: %d)",
			  second_only ? "the second camera's" : "all", f->late_at, back, tries, f->back_early);
	}
	f->late_second_only = false;
	f->late_at = 0;
}

/* Distance (m) between joint `left` of t's model and its other side at
 * the rest pose. */
static double pair_width(const mc_tracker *t, const char *left)
{
	const mc_model *m = mc_tracker_model(t);
	double rest[MC_MAX_DOF];
	mc_fk fk;
	mc_model_rest_pose(m, rest);
	mc_model_fk(m, rest, &fk);
	int l = mc_model_find_joint(m, left), r = mc_model_other_side(m, l);
	return mc_v3_norm(mc_v3_sub(fk.rig_from_joint[l].t, fk.rig_from_joint[r].t));
}

/* 1b. Started from detections with a model whose shoulders are 30 %
 * wider than the clip's skeleton's: their width is measured from the
 * keypoints (docs/TRACKER.md, "Hip and shoulder widths") and comes within
 * 2 cm of the skeleton's (measured: 42.2 cm for 42.5); the hips' is not
 * measured and stays, and so does a width within 3 cm of the measured.
 * Before stop 62 the head rig kept the model's. */
static void test_widths_from_detections(fixture *f)
{
	const char *const pairs[] = {"left_shoulder", "left_hip"};
	double truth[2], wide[2], measured[2];
	mc_model saved = f->model;
	for (int p = 0; p < 2; p++) {
		char right[32];
		snprintf(right, sizeof(right), "right_%s", pairs[p] + 5);
		truth[p] = mc_v3_norm(mc_v3_sub(mc_clip_gt(&f->clip, 0, mc_clip_joint(&f->clip, pairs[p])),
						mc_clip_gt(&f->clip, 0, mc_clip_joint(&f->clip, right))));
		CHECK(mc_fit_joints_set_pair_width(&f->model, mc_model_find_joint(&f->model, pairs[p]), 1.3 * truth[p]) ==
		      0);
	}
	mc_err err;
	mc_tracker *t = new_tracker(f);
	f->model = saved;
	for (int p = 0; p < 2; p++)
		wide[p] = pair_width(t, pairs[p]);
	CHECK(mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, &err) == 0);
	int first;
	run_clip(f, t, &first);
	for (int p = 0; p < 2; p++) {
		measured[p] = pair_width(t, pairs[p]);
		printf("start from detections, %s pair: %.1f cm in the model, %.1f after, %.1f in the clip\n",
		       pairs[p] + 5, 100 * wide[p], 100 * measured[p], 100 * truth[p]);
		CHECK_MSG(fabs(wide[p] - 1.3 * truth[p]) < 0.005, "the model's %s pair was %.1f cm", pairs[p] + 5,
			  100 * wide[p]);
	}
	CHECK_MSG(fabs(measured[0] - truth[0]) < 0.02, "shoulders %.1f cm apart, the clip's %.1f", 100 * measured[0],
		  100 * truth[0]);
	CHECK_MSG(fabs(measured[1] - wide[1]) < 1e-9, "the hips' width changed: %.1f cm", 100 * measured[1]);
	mc_tracker_destroy(t);

	/* the model's own shoulders, 1.5 cm narrower than the clip's: within
	 * the measurement's error, they stay as they are */
	t = new_tracker(f);
	double before = pair_width(t, pairs[0]);
	CHECK(mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, &err) == 0);
	run_clip(f, t, &first);
	double after = pair_width(t, pairs[0]);
	printf("start from detections, the model's own shoulders: %.1f cm, %.1f after\n", 100 * before, 100 * after);
	CHECK_MSG(after == before, "shoulders %.1f cm apart, the model's %.1f", 100 * after, 100 * before);
	mc_tracker_destroy(t);
}

int main(void)
{
	if (access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
	fixture f;
	mc_err err;
	memset(&f, 0, sizeof(f));
	CHECK_MSG(mc_clip_open("tests/data/ego_demo", false, &f.clip, &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_model_load("config/models/default.json", &f.model, &err) == 0, "%s", err.msg);
	mc_tracker_settings_default(&f.s);
	test_start_from_detections(&f);
	test_widths_from_detections(&f);
	test_wrong_start(&f);
	test_arms_learnt_wrong(&f);
	test_wrist_at_camera(&f);
	test_knee_at_camera(&f);
	test_covered_cameras(&f);
	test_late_keypoints(&f);
	mc_clip_close(&f.clip);
	return mc_test_finish("test_tracker_recovery");
}
