/* mocapd without ground truth, end to end (docs/TRACKER.md, "Starting
 * without ground truth"; docs/CONFIG.md, [tracker] actor): mocapd plays
 * the bundled clip in a loop with no init_joints.
 *
 * - Without a detector nothing can start it: the tracker reports
 *   "initialising" in FRAME and STATUS, and `actor save` is refused ("no
 *   actor yet").
 * - With the shipped detector it leaves "initialising" by itself; then
 *   `actor save NAME` writes actor_dir/NAME.json, a model file with the
 *   calibrated colours, and a name that is not one path component is
 *   refused.
 * - A second start with `[tracker] actor` = that file keeps its colours
 *   (the log says so) and tracks again from the detections; `--check`
 *   fails on an actor with init_joints, and on an actor file of another
 *   model, naming the config line.
 * The log names the clients that connect (HELLO's client_name).
 * Skips when the live detector model (config/models/ego_detector.onnx) is
 * not there. */
#include "daemon/harness.h"
#include "tracking_thread.h"
#include "body/mc_model.h"
#include "mocap.h"
#include "test_util.h"

#include <unistd.h>

#define RATE 10

static char repo[PATH_MAX], detector_model[2 * PATH_MAX];

/* The bundled clip, looping, no init_joints; `tracker_extra` and
 * `extra` are added to [tracker] and at the end. */
static void write_config(mcd_run *r, const char *tracker_extra, const char *extra)
{
	char text[8 * PATH_MAX], tracker[2 * PATH_MAX + 64];
	snprintf(tracker, sizeof(tracker), "actor_dir = %s/actors\n%s", r->dir, tracker_extra);
	mcd_demo_clip_config(text, sizeof(text), repo, RATE, "status_interval_s = 0.5\n", "", tracker, extra);
	mcd_run_config(r, text);
}

/* Polls the status until the tracker state is one of ok, uncertain, lost
 * (started) or the time is up; returns the last state. */
static int wait_started(mcd_run *r, mocap_client *c, int timeout_ms)
{
	mocap_daemon_status st;
	int state = -1;
	for (uint64_t t0 = mcd_now_ms(); mcd_now_ms() - t0 < (uint64_t)timeout_ms; mcd_sleep_ms(200)) {
		mcd_run_read_notify(r); /* as systemd would: a full notify socket blocks sd_notify */
		if (mocap_get_status(c, &st) != 0)
			return -1;
		state = st.tracker_state;
		if (state <= MOCAP_TRACK_LOST)
			break;
	}
	return state;
}

static mocap_client *start(mcd_run *r, const char *tracker_extra, const char *extra)
{
	CHECK(mcd_run_init(r));
	write_config(r, tracker_extra, extra);
	CHECK(mcd_run_start(r, NULL, NULL));
	if (!mcd_run_wait_notify(r, "READY=1", 60000)) {
		mcd_run_dump(r, "start");
		CHECK_MSG(false, "mocapd did not become ready");
		return NULL;
	}
	mocap_client *c = mocap_connect(r->sock, "test_daemon_actor");
	CHECK_MSG(c, "connect: %s", mocap_errmsg());
	return c;
}

static void stop(mcd_run *r, mocap_client *c)
{
	mocap_close(c);
	mcd_run_terminate(r, 20000, "actor");
}

static void test_no_detector(void)
{
	mcd_run r;
	mocap_client *c = start(&r, "", "");
	if (!c) {
		mcd_run_cleanup(&r);
		return;
	}
	mocap_skeleton_frame *f = calloc(1, sizeof(*f));
	CHECK(f && mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
	int frames = 0, initialising = 0;
	while (f && frames < 5 && mocap_read_frame(c, f, 10000) == 1) {
		frames++;
		initialising += f->state == MOCAP_TRACK_INITIALISING;
	}
	free(f);
	CHECK_MSG(frames == 5 && initialising == 5, "%d of %d frames initialising", initialising, frames);
	mocap_close(c);
	c = mocap_connect(r.sock, "test_daemon_actor");
	mocap_daemon_status st;
	CHECK(c && mocap_get_status(c, &st) == 0 && st.tracker_state == MOCAP_TRACK_INITIALISING);
	CHECK(strcmp(mocap_track_state_name(MOCAP_TRACK_INITIALISING), "initialising") == 0);
	char msg[600] = "";
	CHECK(mocap_control(c, MOCAP_CMD_ACTOR_SAVE, "early", msg, sizeof(msg)) == MOCAP_E_FAILED);
	CHECK_MSG(strstr(mocap_errmsg(), "no actor yet"), "refusal says '%s'", mocap_errmsg());
	printf("no detector: 5 of 5 frames initialising; save refused: %s\n", mocap_errmsg());
	/* The log names each client after its HELLO, with its control
	 * characters replaced (issue 20, defect 9). */
	mocap_client *evil = mocap_connect(r.sock, "evil\nmocapd: error: forged");
	CHECK(evil != NULL);
	mocap_close(evil);
	CHECK(mcd_run_wait_log(&r, "client 'test_daemon_actor' connected (pid ", 2000));
	CHECK(mcd_run_wait_log(&r, "client 'evil?mocapd: error: forged' connected", 2000));
	CHECK(!mcd_run_wait_log(&r, "\nmocapd: error: forged", 0));
	mocap_close(c);
	mcd_run_stop(&r, 20000, "no detector");
}

/* Saves an actor in run r's folder (cleaned up by the caller); returns
 * the file (in a static buffer) or NULL. */
static const char *test_save(mcd_run *rr)
{
	static char saved[PATH_MAX + 32];
	char det[2 * PATH_MAX + 32];
	snprintf(det, sizeof(det), "[detector]\nmodel = %s\n", detector_model);
	mcd_run *r = rr;
	mocap_client *c = start(r, "", det);
	if (!c)
		return NULL;
	int state = wait_started(r, c, 60000);
	CHECK_MSG(state >= 0 && state <= MOCAP_TRACK_LOST, "still %s after 60 s",
		  mocap_track_state_name((mocap_track_state)state));
	CHECK(mcd_run_wait_log(r, "first pose found from the detections", 5000));
	char msg[600] = "";
	CHECK(mocap_control(c, MOCAP_CMD_ACTOR_SAVE, "../evil", msg, sizeof(msg)) == MOCAP_E_FAILED);
	CHECK_MSG(strstr(mocap_errmsg(), "is not a name"), "'../evil' refused with '%s'", mocap_errmsg());
	CHECK_MSG(mocap_control(c, MOCAP_CMD_ACTOR_SAVE, "alice", msg, sizeof(msg)) == 0, "save: %s", mocap_errmsg());
	snprintf(saved, sizeof(saved), "%s/actors/alice.json", r->dir);
	CHECK_MSG(strstr(msg, saved), "the answer '%s' does not name %s", msg, saved);
	stop(r, c);

	/* It is a model file with the calibrated colours. */
	mc_model *actor = calloc(1, sizeof(*actor)), *model = calloc(1, sizeof(*model));
	mc_err err = {{0}};
	CHECK_MSG(mc_model_load(saved, actor, &err) == 0, "%s", err.msg);
	CHECK(mc_model_load("config/models/default.json", model, &err) == 0);
	int changed = 0;
	for (int q = 0; q < model->ngauss && q < actor->ngauss; q++)
		changed += fabs(actor->gauss[q].rgb[0] - model->gauss[q].rgb[0]) > 1e-3;
	printf("saved %s: %d of %d Gaussians with calibrated colours\n", saved, changed, model->ngauss);
	CHECK(actor->ngauss == model->ngauss && changed > model->ngauss / 4);
	free(actor);
	free(model);
	return saved;
}

static void test_load(const char *actor)
{
	char tracker[PATH_MAX + 32], det[2 * PATH_MAX + 32];
	snprintf(tracker, sizeof(tracker), "actor = %s\n", actor);
	snprintf(det, sizeof(det), "[detector]\nmodel = %s\n", detector_model);
	mcd_run r;
	mocap_client *c = start(&r, tracker, det);
	if (!c) {
		mcd_run_cleanup(&r);
		return;
	}
	CHECK(mcd_run_wait_log(&r, "(its size and colours)", 5000));
	int state = wait_started(&r, c, 60000);
	CHECK_MSG(state >= 0 && state <= MOCAP_TRACK_LOST, "with the actor: still %s after 60 s",
		  mocap_track_state_name((mocap_track_state)state));
	stop(&r, c);

	/* --check: an actor with init_joints, and an actor of another model. */
	const char *const check[] = {"--check", NULL};
	char both[2 * PATH_MAX + 64];
	snprintf(both, sizeof(both), "actor = %s\ninit_joints = %s/tests/data/ego_demo/gt.json\n", actor, repo);
	write_config(&r, both, "");
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 20000) == 1);
	CHECK_MSG(mcd_run_wait_log(&r, "[tracker] actor: excludes init_joints", 0), "--check: actor with init_joints");
	char other[PATH_MAX + 64];
	snprintf(other, sizeof(other), "actor = %s/tests/data/models/good_tiny.json\n", repo);
	write_config(&r, other, "");
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 20000) == 1);
	CHECK_MSG(mcd_run_wait_log(&r, "[tracker] actor: ", 0) && mcd_run_wait_log(&r, "made for another model", 0),
		  "--check: an actor of another model");
	mcd_run_cleanup(&r);
}

/* When the log says the first pose was found.  The first frame set the
 * tracking thread sees can already give it (the detector was quick):
 * the line was missing then, and test_save waited for it in vain. */
static void test_first_pose_rule(void)
{
	CHECK(mcd_first_pose_found(MC_TRACK_INITIALISING, MC_TRACK_OK, 1));
	CHECK(mcd_first_pose_found(-1, MC_TRACK_OK, 1));
	CHECK(mcd_first_pose_found(-1, MC_TRACK_UNCERTAIN, 1));
	CHECK(!mcd_first_pose_found(-1, MC_TRACK_OK, 0)); /* init_joints: not from detections */
	CHECK(!mcd_first_pose_found(-1, MC_TRACK_INITIALISING, 0));
	CHECK(!mcd_first_pose_found(MC_TRACK_OK, MC_TRACK_OK, 1));
	CHECK(!mcd_first_pose_found(MC_TRACK_LOST, MC_TRACK_OK, 2)); /* a recovery, not the first */
}

int main(void)
{
	test_first_pose_rule();
	mcd_require_build_and_clip(repo, sizeof(repo));
	snprintf(detector_model, sizeof(detector_model), "%s/%s", repo, MC_TEST_LIVE_EGO_MODEL);
	if (access(detector_model, R_OK) != 0)
		TEST_SKIP("no shipped detector model (%s)", MC_TEST_LIVE_EGO_MODEL);
	test_no_detector();
	mcd_run saving;
	const char *actor = test_save(&saving);
	if (actor) {
		test_load(actor);
		unlink(actor);
	}
	char dir[sizeof(saving.dir) + 16];
	snprintf(dir, sizeof(dir), "%s/actors", saving.dir);
	rmdir(dir);
	mcd_run_cleanup(&saving);
	return mc_test_finish("test_daemon_actor");
}
