/* Outside-in tracking end to end on a synthetic scene: the default model,
 * standing with a free root, is rendered by tools/mocap-render through the
 * four static cameras of tests/data/outside/rig.json while its root walks
 * 3 cm and turns 1.5 degrees per frame.  The tracker, started from frame
 * 0's joints (the evaluation protocol's gt0), must recover the pose and
 * follow the moving root from the images alone; started from keypoints
 * alone (perfect projections of the joints), it must find the first pose,
 * the root's place and the actor's size itself.  With the tracker deciding
 * the sides: keypoints labelled as if every camera saw the body from
 * behind must still start it facing the right way, and tracking that
 * faces the wrong way must be turned around; one camera's keypoints all
 * off must not keep it from starting.  Two facing cameras that give the
 * keypoints of only 7 joints must still bring back an arm whose colours
 * were learnt at a wrong place.  Also: the outside-in default settings
 * leave alone what the user gave. */
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "image/mc_image.h"
#include "track/mc_tracker.h"
#include "track/mc_tracker_internal.h"
#include "test_util.h"

#include <string.h>
#include <unistd.h>

#define NFRAMES 20
#define STEP_M 0.03
#define TURN_RAD (1.5 * M_PI / 180)
#define RIG "tests/data/outside/rig.json"
#define MODEL "config/models/default.json"

static char tool[4096], tmpdir[64];

/* The pose of frame k: the rest pose stood upright (head over the feet,
 * feet on the floor) and moved along x while it turns about z. */
static void frame_pose(const mc_model *m, int k, double *pose)
{
	mc_model_rest_pose(m, pose);
	mc_fk fk;
	mc_model_fk(m, pose, &fk);
	int top = mc_model_find_joint(m, "head_top"), la = mc_model_find_joint(m, "left_ankle"),
	    ra = mc_model_find_joint(m, "right_ankle");
	mc_vec3 feet = mc_v3_scale(mc_v3_add(fk.rig_from_joint[la].t, fk.rig_from_joint[ra].t), 0.5);
	mc_vec3 up = mc_v3_normalize(mc_v3_sub(fk.rig_from_joint[top].t, feet)), z = mc_v3(0, 0, 1);
	mc_vec3 axis = mc_v3_cross(up, z);
	double angle = atan2(mc_v3_norm(axis), mc_v3_dot(up, z));
	mc_mat3 upright = mc_m3_axis_angle(mc_v3_normalize(axis), angle);
	mc_mat3 R = mc_m3_mul(mc_m3_rot_axis(2, TURN_RAD * k), upright);
	double lowest = 1e9;
	for (int j = 0; j < m->njoints; j++)
		lowest = fmin(lowest, mc_m3_apply(R, fk.rig_from_joint[j].t).z);
	mc_vec3 w = mc_m3_to_rotvec(R);
	double root[6] = {STEP_M * k - 0.2, 0.1, 0.08 - lowest, w.x, w.y, w.z};
	memcpy(pose, root, sizeof(root));
}

/* Renders frame k into tmpdir/fK_camN.png with mocap-render. */
static bool render_frame(const mc_model *m, int k)
{
	double pose[MC_MAX_DOF];
	frame_pose(m, k, pose);
	char path[256], cmd[8192], out[4096];
	snprintf(path, sizeof(path), "%s/pose%d.json", tmpdir, k);
	FILE *f = fopen(path, "w");
	if (!f)
		return false;
	fprintf(f, "{\"pose\": [");
	for (int i = 0; i < m->ndof; i++)
		fprintf(f, "%s%.17g", i ? ", " : "", pose[i]);
	fprintf(f, "]}\n");
	fclose(f);
	snprintf(cmd, sizeof(cmd), "%s --rig %s --model %s --pose %s --width 160 --height 120 --out %s/f%d 2>&1", tool,
		 RIG, MODEL, path, tmpdir, k);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "mocap-render failed: %s", out);
	unlink(path);
	return rc == 0;
}

static bool load_views(const mc_rig *rig, int k, mc_frame_view *views)
{
	mc_err err = {0};
	mc_image_conv *conv = mc_image_conv_new(&err);
	bool ok = conv != NULL;
	memset(views, 0, sizeof(mc_frame_view) * MC_MAX_CAMERAS);
	for (int c = 0; ok && c < rig->ncams; c++) {
		char path[256];
		uint8_t *rgb = NULL;
		int w = 0, h = 0;
		snprintf(path, sizeof(path), "%s/f%d_%s.png", tmpdir, k, rig->cams[c].name);
		ok = mc_image_load(conv, path, &rgb, &w, &h, &err) == 0;
		CHECK_MSG(ok, "%s", err.msg);
		if (ok)
			views[c] = (mc_frame_view){w, h, 3 * w, rgb, (uint64_t)k * 33333333u};
		unlink(path);
	}
	mc_image_conv_free(conv);
	return ok;
}

static void free_views(mc_frame_view *views)
{
	for (int c = 0; c < MC_MAX_CAMERAS; c++)
		free((void *)views[c].rgb);
}

/* Mean distance (m) between the skeleton's joints `names` (NULL: every
 * joint, n of them) and the truth of frame k. */
static double joints_error(const mc_model *m, const mc_skeleton *sk, int k, const char *const *names, int n)
{
	double pose[MC_MAX_DOF], sum = 0;
	mc_fk fk;
	frame_pose(m, k, pose);
	mc_model_fk(m, pose, &fk);
	for (int e = 0; e < n; e++) {
		int j = names ? mc_model_find_joint(m, names[e]) : e;
		sum += mc_v3_norm(mc_v3_sub(sk->joints[j].position, fk.rig_from_joint[j].t));
	}
	return sum / n;
}

/* Mean joint distance (m) between the skeleton and the truth of frame k. */
static double joint_error(const mc_model *m, const mc_skeleton *sk, int k)
{
	return joints_error(m, sk, k, NULL, m->njoints);
}

/* The check across cameras: one camera's detection of a joint 40 px too low
 * is dropped and the three that agree are kept; with only two cameras
 * that disagree, both are dropped. */
static void test_view_gate(mc_tracker *t, const mc_rig *rig, const mc_model *m, mc_vec3 neck)
{
	int j = mc_model_find_joint(m, "neck");
	mc_keypoint kp[MC_MAX_CAMERAS];
	for (int c = 0; c < rig->ncams; c++) {
		double u = 0, v = 0;
		CHECK(mc_camera_project_rig(&rig->cams[c], neck, &u, &v));
		kp[c] = (mc_keypoint){c, j, u, v + (c == 3 ? 40 : 0), 0.9}; /* vertical: off every epipolar line */
	}
	mc_trk_keypoint_ray rays[MC_TRK_MAX_KEYPOINTS];
	int cam[MC_TRK_MAX_KEYPOINTS];
	int n = mc_trk_prepare_keypoints(t, kp, rig->ncams, rays, cam);
	CHECK(n == 4);
	for (int i = 0; i < n; i++)
		CHECK_MSG(rays[i].weight == (cam[i] == 3 ? 0 : 0.9), "camera %d: weight %g", cam[i], rays[i].weight);
	mc_keypoint two[2] = {kp[0], kp[3]};
	n = mc_trk_prepare_keypoints(t, two, 2, rays, cam);
	CHECK(n == 2 && rays[0].weight == 0 && rays[1].weight == 0);
}

/* Every joint of frame k projected into every camera: a perfect 2D
 * detector, for starting without frame 0's joints. */
static int frame_keypoints(const mc_rig *rig, const mc_model *m, int k, mc_keypoint *kp)
{
	double pose[MC_MAX_DOF];
	mc_fk fk;
	frame_pose(m, k, pose);
	mc_model_fk(m, pose, &fk);
	int n = 0;
	for (int c = 0; c < rig->ncams; c++)
		for (int j = 0; j < m->njoints; j++) {
			double u, v;
			if (mc_camera_project_rig(&rig->cams[c], fk.rig_from_joint[j].t, &u, &v))
				kp[n++] = (mc_keypoint){c, j, u, v, 1.0};
		}
	return n;
}

/* Every view's left/right labels exchanged, as MoveNet gives them for a
 * faceless body seen from behind that it takes for one facing it. */
static void exchange_labels(const mc_model *m, mc_keypoint *kp, int n)
{
	for (int i = 0; i < n; i++) {
		int other = mc_model_other_side(m, kp[i].joint);
		if (other >= 0)
			kp[i].joint = other;
	}
}

/* KEYPOINTS_CAMERA_OFF: camera 0's keypoints all CAMERA_OFF_PX to the
 * right (on a bystander, say), the three others right. */
enum { NO_KEYPOINTS, KEYPOINTS, KEYPOINTS_EXCHANGED, KEYPOINTS_CAMERA_OFF };
#define CAMERA_OFF_PX 20

typedef struct {
	double mean, last; /* joint error, m */
	int tracked;       /* frame sets out of the initialising state */
	int first;         /* the first of them */
	int lost;          /* frame sets in the lost state */
} walk_result;

/* Tracks frames[first_frame ..] with t (already started), from the images
 * alone or with keypoints (one of the enum above). */
static walk_result track_walk(mc_tracker *t, const mc_rig *rig, const mc_model *m,
			      mc_frame_view frames[][MC_MAX_CAMERAS], int first_frame, int keypoints)
{
	walk_result r = {0, 0, 0, -1, 0};
	double sum = 0;
	for (int k = first_frame; k < NFRAMES; k++) {
		mc_skeleton sk;
		mc_keypoint kp[MC_MAX_CAMERAS * MC_MAX_JOINTS];
		int nkp = keypoints != NO_KEYPOINTS ? frame_keypoints(rig, m, k, kp) : 0;
		if (keypoints == KEYPOINTS_EXCHANGED)
			exchange_labels(m, kp, nkp);
		for (int i = 0; keypoints == KEYPOINTS_CAMERA_OFF && i < nkp; i++)
			kp[i].u += kp[i].cam == 0 ? CAMERA_OFF_PX : 0;
		mc_err err = {0};
		if (mc_tracker_track(t, frames[k], rig->ncams, kp, nkp, &sk, &err) < 0) {
			CHECK_MSG(0, "%s", err.msg);
			break;
		}
		if (sk.state == MC_TRACK_INITIALISING)
			continue;
		if (r.first < 0)
			r.first = k;
		r.lost += sk.state == MC_TRACK_LOST;
		r.last = joint_error(m, &sk, k);
		sum += r.last;
		r.tracked++;
	}
	r.mean = r.tracked ? sum / r.tracked : 1e9;
	return r;
}

static mc_tracker *tracker_deciding_sides(const mc_rig *rig, const mc_model *m, const mc_tracker_settings *s)
{
	mc_tracker_settings sides = *s;
	sides.assign_sides = true;
	mc_err err = {0};
	mc_tracker *t = mc_tracker_create(rig, m, &sides, &err);
	CHECK_MSG(t != NULL, "%s", err.msg);
	return t;
}

/* Every camera sees the body from behind (every view's labels exchanged):
 * the first pose must still face the way the body does (docs/TRACKER.md,
 * "Facing"), and the tracking after it follow the body. */
static void test_start_facing(const mc_rig *rig, const mc_model *m, const mc_tracker_settings *s,
			      mc_frame_view frames[][MC_MAX_CAMERAS])
{
	mc_tracker *t = tracker_deciding_sides(rig, m, s);
	mc_err err = {0};
	if (!t || mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, &err) < 0) {
		CHECK_MSG(0, "%s", err.msg);
		mc_tracker_destroy(t);
		return;
	}
	walk_result r = track_walk(t, rig, m, frames, 0, KEYPOINTS_EXCHANGED);
	mc_tracker_init_info in;
	mc_tracker_get_init_info(t, &in);
	printf("outside-in synthetic walk from keypoints labelled as if seen from behind: first pose at frame set %d, "
	       "mean joint error %.2f cm, turned around %d times\n",
	       r.first, 100 * r.mean, in.turns);
	CHECK_MSG(r.first == 0, "first pose at frame set %d", r.first);
	CHECK_MSG(r.mean < 0.03, "mean joint error %.2f cm", 100 * r.mean);
	CHECK(in.turns == 1);
	mc_tracker_destroy(t);
}

/* One camera's keypoints all off while three agree: each joint is
 * triangulated from the three (the odd ray dropped), so the first pose
 * comes at once and follows the body.  Before stop 53 one ray that missed
 * the others' point cost the joint its triangulation: no first pose in 20
 * frame sets. */
static void test_start_camera_off(const mc_rig *rig, const mc_model *m, const mc_tracker_settings *s,
				  mc_frame_view frames[][MC_MAX_CAMERAS])
{
	mc_err err = {0};
	mc_tracker *t = mc_tracker_create(rig, m, s, &err);
	if (!t || mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, &err) < 0) {
		CHECK_MSG(0, "%s", err.msg);
		mc_tracker_destroy(t);
		return;
	}
	walk_result r = track_walk(t, rig, m, frames, 0, KEYPOINTS_CAMERA_OFF);
	printf("outside-in synthetic walk from keypoints, camera 0's %d px off: first pose at frame set %d, mean "
	       "joint error %.2f cm\n",
	       CAMERA_OFF_PX, r.first, 100 * r.mean);
	CHECK_MSG(r.first == 0, "first pose at frame set %d", r.first);
	CHECK_MSG(r.mean < 0.03, "mean joint error %.2f cm", 100 * r.mean);
	mc_tracker_destroy(t);
}

/* Starts t from frame 0's joints (with every left/right name exchanged:
 * the body turned around) and learns the colours there; at0 (NULL: not
 * wanted) gets frame 0's joints as a skeleton. */
static void start_at_frame0(mc_tracker *t, const mc_rig *rig, const mc_model *m, mc_frame_view frames[][MC_MAX_CAMERAS],
			    bool turned, mc_skeleton *at0)
{
	double pose0[MC_MAX_DOF];
	mc_fk fk0;
	frame_pose(m, 0, pose0);
	mc_model_fk(m, pose0, &fk0);
	const char *names[MC_MAX_JOINTS];
	mc_vec3 joints0[MC_MAX_JOINTS];
	for (int j = 0; j < m->njoints; j++) {
		int other = turned ? mc_model_other_side(m, j) : -1;
		names[j] = m->joints[other >= 0 ? other : j].name;
		joints0[j] = fk0.rig_from_joint[j].t;
	}
	if (at0) {
		memset(at0, 0, sizeof(*at0));
		at0->njoints = m->njoints;
		for (int j = 0; j < m->njoints; j++)
			at0->joints[j].position = joints0[j];
	}
	mc_err err = {0};
	CHECK_MSG(mc_tracker_init_from_joints(t, names, joints0, m->njoints, &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_tracker_calibrate_colors(t, frames[0], rig->ncams, &err) == 0, "%s", err.msg);
}

/* Tracking that faces the wrong way (started from frame 0's joints with
 * every left/right name exchanged, its colours learnt there) while the
 * keypoints are right: the sides follow the tracked pose and would keep
 * it so; the facing check must turn it around. */
static void test_turn_around(const mc_rig *rig, const mc_model *m, const mc_tracker_settings *s,
			     mc_frame_view frames[][MC_MAX_CAMERAS])
{
	mc_tracker *t = tracker_deciding_sides(rig, m, s);
	if (!t)
		return;
	start_at_frame0(t, rig, m, frames, true, NULL);
	walk_result r = track_walk(t, rig, m, frames, 1, KEYPOINTS);
	mc_tracker_init_info in;
	mc_tracker_get_init_info(t, &in);
	printf("outside-in synthetic walk started facing the wrong way: turned around %d times, last frame %.2f cm\n",
	       in.turns, 100 * r.last);
	CHECK(in.turns == 1);
	CHECK_MSG(r.last < 0.04, "last frame %.2f cm", 100 * r.last);
	mc_tracker_destroy(t);
}

/* Views whose colours no longer fit (noise) while every camera's
 * keypoints still see the walking body: the state reads lost, and the
 * pose must follow the keypoints, not stand where the colours last fitted
 * (docs/TRACKER.md, "Lost, with keypoints"). */
static void test_lost_with_keypoints(const mc_rig *rig, const mc_model *m, const mc_tracker_settings *s,
				     mc_frame_view frames[][MC_MAX_CAMERAS])
{
	static uint8_t noise[MC_MAX_CAMERAS][160 * 120 * 3];
	static mc_frame_view views[NFRAMES][MC_MAX_CAMERAS];
	unsigned long long rng = 7;
	for (int c = 0; c < rig->ncams; c++)
		for (size_t i = 0; i < sizeof(noise[c]); i++)
			noise[c][i] = (uint8_t)(mc_test_rand(&rng) * 256);
	for (int k = 0; k < NFRAMES; k++)
		for (int c = 0; c < rig->ncams; c++)
			views[k][c] = (mc_frame_view){160, 120, 3 * 160, noise[c], frames[k][c].timestamp_ns};
	mc_err err = {0};
	mc_tracker *t = mc_tracker_create(rig, m, s, &err);
	CHECK_MSG(t != NULL, "%s", err.msg);
	if (!t)
		return;
	start_at_frame0(t, rig, m, frames, false, NULL);
	walk_result r = track_walk(t, rig, m, views, 1, KEYPOINTS);
	printf("outside-in synthetic walk, noise views with keypoints: %d of %d frame sets lost, mean joint error %.2f "
	       "cm, last frame %.2f cm\n",
	       r.lost, r.tracked, 100 * r.mean, 100 * r.last);
	CHECK_MSG(r.lost > r.tracked / 2, "only %d of %d frame sets lost: the test proves nothing", r.lost, r.tracked);
	/* measured: 1.1 cm; 3.9 with the pose kept while lost (the re-fits
	 * after five lost frame sets catch it up, then it stands again) */
	CHECK_MSG(r.mean < 0.02, "mean joint error %.2f cm", 100 * r.mean);
	mc_tracker_destroy(t);
}

/* Only these joints' keypoints come (the others occluded, as on two
 * cameras with MoveNet's 12 joints): 7 joints, fewer than a whole-body fit
 * needs (mc_init.c, enough_for_fit). */
static const char *const few_joints[] = {"neck", "left_shoulder", "right_shoulder", "left_elbow",
					  "left_wrist", "left_hip", "right_hip"};
#define NFEW ((int)(sizeof(few_joints) / sizeof(few_joints[0])))

static int keypoints_of_few(const mc_rig *rig, const mc_model *m, int k, mc_keypoint *kp)
{
	mc_keypoint all[MC_MAX_CAMERAS * MC_MAX_JOINTS];
	int n = frame_keypoints(rig, m, k, all), kept = 0;
	for (int i = 0; i < n; i++)
		for (int e = 0; e < NFEW; e++)
			if (!strcmp(m->joints[all[i].joint].name, few_joints[e]))
				kp[kept++] = all[i];
	return kept;
}

/* A left arm raised where the actor's hangs, its colours learnt there (a
 * limb lost long enough for that), seen by two facing cameras (0 and 2,
 * with the outside-in settings for two: no ray fit) that give the
 * keypoints of only NFEW joints: the arm must be re-fitted to its
 * keypoints though the frame set could not fit the whole body (measured:
 * 80 cm off at the start, 9.6 at the last frame set).  Before stop 62
 * recovery ran only on frame sets with 8 triangulated joints, and the arm
 * stayed 70 cm off. */
static void test_arm_back_from_few_joints(const mc_rig *rig, const mc_model *m, const mc_tracker_settings *s,
					  mc_frame_view frames[][MC_MAX_CAMERAS])
{
	static const char *const left_arm[] = {"left_elbow", "left_wrist"};
	static mc_rig two;
	static mc_frame_view views[NFRAMES][MC_MAX_CAMERAS];
	two = *rig;
	two.ncams = 2;
	two.cams[1] = rig->cams[2];
	for (int k = 0; k < NFRAMES; k++)
		views[k][0] = frames[k][0], views[k][1] = frames[k][2];
	mc_tracker_settings s2 = *s;
	mc_tracker_settings_outside_in(&s2, 2, MC_GIVEN_ITERATIONS | MC_GIVEN_LAMBDA_SMOOTH);
	/* a tenth of the outside-in weight: the keypoints alone then cannot
	 * pull the arm away from where its colours were learnt.  With the
	 * default they pull it back within 6 frame sets here; on the clips
	 * they do not, where the legs overlap in both views. */
	s2.lambda_detection = 0.03;
	mc_err err = {0};
	mc_tracker *t = mc_tracker_create(&two, m, &s2, &err);
	CHECK_MSG(t != NULL, "%s", err.msg);
	if (!t)
		return;
	start_at_frame0(t, &two, m, views, false, NULL);
	double pose[MC_MAX_DOF];
	memcpy(pose, mc_tracker_pose(t), sizeof(double) * m->ndof);
	const mc_joint *shoulder = &m->joints[mc_model_find_joint(m, "left_shoulder")];
	pose[shoulder->dof0] = 0.8 * shoulder->upper[0];
	mc_tracker_set_pose(t, pose);
	CHECK_MSG(mc_tracker_calibrate_colors(t, views[0], two.ncams, &err) == 0, "%s", err.msg);
	double first = -1, last = 0;
	for (int k = 1; k < NFRAMES; k++) {
		mc_keypoint kp[MC_MAX_CAMERAS * MC_MAX_JOINTS];
		mc_skeleton sk;
		int nkp = keypoints_of_few(&two, m, k, kp);
		CHECK_MSG(mc_tracker_track(t, views[k], two.ncams, kp, nkp, &sk, &err) == 0, "%s", err.msg);
		last = joints_error(m, &sk, k, left_arm, 2);
		first = first < 0 ? last : first;
	}
	mc_tracker_init_info in;
	mc_tracker_get_init_info(t, &in);
	printf("outside-in, cameras 0 and 2, left arm raised and learnt there, keypoints of %d joints: arm %.1f cm off "
	       "at frame set 1, %.1f cm at the last (%d re-fits)\n",
	       NFEW, 100 * first, 100 * last, in.refits);
	CHECK_MSG(first > 0.25, "the arm was only %.1f cm off at the start: the test proves nothing", 100 * first);
	CHECK_MSG(last < 0.15, "the arm is still %.1f cm off at the last frame set", 100 * last);
	mc_tracker_destroy(t);
}

/* The outside-in defaults fill what the user did not give, and only that. */
static void test_outside_in_settings(void)
{
	mc_tracker_settings s;
	mc_tracker_settings_default(&s);
	CHECK(s.pixel_fraction == 0.07);
	mc_tracker_settings_outside_in(&s, 4, 0);
	CHECK(s.iterations == 80 && s.pixel_fraction == 0.14 && s.lambda_smooth == 0.01);
	mc_tracker_settings_default(&s);
	s.pixel_fraction = 0.05;
	s.iterations = 30;
	mc_tracker_settings_outside_in(&s, 2, MC_GIVEN_PIXEL_FRACTION | MC_GIVEN_ITERATIONS);
	CHECK(s.iterations == 30 && s.pixel_fraction == 0.05 && s.lambda_smooth == 0.01);
}

int main(int argc, char **argv)
{
	(void)argc;
	test_outside_in_settings();
	mc_test_find_tool(argv[0], "mocap-render", tool, sizeof(tool));
	static mc_rig rig;
	static mc_model model;
	static mc_frame_view frames[NFRAMES][MC_MAX_CAMERAS];
	mc_err err = {0};
	if (mc_rig_load(RIG, &rig, &err) || mc_model_load(MODEL, &model, &err) ||
	    mc_model_make_root_free(&model, &err)) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	snprintf(tmpdir, sizeof(tmpdir), "/tmp/mocap-test-outside-XXXXXX");
	if (!mkdtemp(tmpdir))
		return 1;
	bool ok = true;
	for (int k = 0; ok && k < NFRAMES; k++)
		ok = render_frame(&model, k) && load_views(&rig, k, frames[k]);
	rmdir(tmpdir);
	mc_tracker_settings s;
	mc_tracker_settings_default(&s);
	s.width = 160, s.height = 120, s.iterations = 80, s.lambda_smooth = 0.01;
	mc_tracker *t = ok ? mc_tracker_create(&rig, &model, &s, &err) : NULL;
	CHECK_MSG(t != NULL, "%s", err.msg);
	/* frame 0's joints start the tracker, as gt0 does on the clips */
	if (t) {
		mc_skeleton at0;
		start_at_frame0(t, &rig, &model, frames, false, &at0);
		test_view_gate(t, &rig, &model, at0.joints[mc_model_find_joint(&model, "neck")].position);
		walk_result r = track_walk(t, &rig, &model, frames, 1, NO_KEYPOINTS);
		double still = joint_error(&model, &at0, NFRAMES - 1);
		printf("outside-in synthetic walk from frame 0's joints: mean joint error %.2f cm over %d frames, last "
		       "%.2f cm (holding frame 0: %.2f cm)\n",
		       100 * r.mean, r.tracked, 100 * r.last, 100 * still);
		CHECK(r.tracked == NFRAMES - 1);
		CHECK_MSG(r.mean < 0.03, "mean joint error %.2f cm", 100 * r.mean);
		CHECK_MSG(r.last < 0.04, "last frame %.2f cm", 100 * r.last);
		CHECK(still > 0.3); /* the root really moved: standing still would fail */
		mc_tracker_destroy(t);
	}
	/* Nothing from frame 0's joints: the first pose, the free root's place
	 * and the actor's size come from the keypoints. */
	t = ok ? mc_tracker_create(&rig, &model, &s, &err) : NULL;
	if (t) {
		CHECK_MSG(mc_tracker_start_from_detections(t, MC_INIT_MEASURE_SIZE, &err) == 0, "%s", err.msg);
		walk_result r = track_walk(t, &rig, &model, frames, 0, KEYPOINTS);
		printf("outside-in synthetic walk from keypoints: first pose at frame set %d, mean joint error %.2f cm "
		       "over %d frames, last %.2f cm\n",
		       r.first, 100 * r.mean, r.tracked, 100 * r.last);
		CHECK_MSG(r.first == 0, "first pose at frame set %d", r.first);
		CHECK_MSG(r.mean < 0.03, "mean joint error %.2f cm", 100 * r.mean);
		mc_tracker_destroy(t);
	}
	if (ok) {
		test_start_camera_off(&rig, &model, &s, frames);
		test_start_facing(&rig, &model, &s, frames);
		test_turn_around(&rig, &model, &s, frames);
		test_lost_with_keypoints(&rig, &model, &s, frames);
		test_arm_back_from_few_joints(&rig, &model, &s, frames);
	}
	for (int k = 0; k < NFRAMES; k++)
		free_views(frames[k]);
	return mc_test_finish("test_outside_in");
}
