/* The in-process detector ([detector] in the config) end to end: mocapd
 * plays the bundled clip in a loop (files driver, 5 fps) and detects on
 * it with detect/tests/data/fixed_wrist.onnx, a test model whose only
 * joint is the right wrist at pixel (139.5, 75.5) of every 256x256 view.
 *
 * - good model: the status (STATUS on the socket, protocol version 2, and
 *   the sd_notify STATUS= line) reports the detector running with
 *   detections, their cost and views tracked with them, and the published
 *   right wrist, whose true place is never within 15 cm of that pixel's
 *   rays in the whole clip, comes onto them (within 5 cm) in some frame
 *   sets: the keypoints
 *   reached the tracker with the right capture time, camera and joint;
 *   a reload with `rate = 1` detects 1 view per second and camera.
 *   The tracking thread never waits for the detector, and at 5 fps it is
 *   idle when a frame set completes, so it starts at once and the
 *   detection ends a millisecond later: those keypoints join the tracking
 *   between its iterations (mc_tracker_set_keypoint_poll), so most views
 *   are `used` and the wrist is on the rays in most frame sets (before
 *   they could join, only a few were).  The same pixel on the right camera
 *   is another ray, so where both cameras' keypoints are used the wrist
 *   settles between the two rays;
 * - bad models (wrong output shape, not ONNX, a missing file): mocapd
 *   starts anyway, keeps publishing skeletons and reports the detector
 *   failed with the file and the mismatch in its status and log;
 *   `mocapd --check` fails on the config line. */
#include "daemon/harness.h"
#include "daemon/rays.h"
#include "eval/mc_gt.h"
#include "test_util.h"

#include <dirent.h>

#define RATE 5
#define FRAMES 25 /* 5 s */

static char repo[PATH_MAX];
static mc_rig rig;
static mc_gt gt; /* the clip's ground truth, rig frame */

static void write_config_flip(mcd_run *r, const char *model, double rate, const char *flip)
{
	char text[8 * PATH_MAX], detector[PATH_MAX + 96];
	snprintf(detector, sizeof(detector), "[detector]\nmodel = %s\nrate = %g\nflip = %s\n", model, rate, flip);
	mcd_demo_clip_config(text, sizeof(text), repo, RATE, "status_interval_s = 0.5\n", "", NULL, detector);
	mcd_run_config(r, text);
}

static void write_config(mcd_run *r, const char *model, double rate)
{
	write_config_flip(r, model, rate, "false");
}

/* Starts mocapd; false (and *skip set) when OpenCL is not usable here. */
static bool start(mcd_run *r, const char *model, bool *skip)
{
	*skip = false;
	CHECK(mcd_run_init(r));
	write_config(r, model, 0);
	CHECK(mcd_run_start(r, NULL, NULL));
	if (mcd_run_wait_notify(r, "READY=1", 60000))
		return true;
	char *log = mcd_read_file(r->log);
	*skip = log && strstr(log, "OpenCL") && strstr(log, "error");
	free(log);
	if (!*skip) {
		mcd_run_dump(r, "start");
		CHECK_MSG(false, "mocapd did not become ready with [detector] model = %s", model);
	}
	mcd_run_cleanup(r);
	return false;
}

static bool get_status(mocap_client *c, mocap_daemon_status *st)
{
	int rc = mocap_get_status(c, st);
	CHECK_MSG(rc == 0, "status: %s", mocap_errmsg());
	return rc == 0;
}

/* How far the wrist is from what the keypoints ask: the fixed pixel's ray
 * of one camera (only that camera's keypoints were in time), or, both
 * cameras' being used, the place between the two rays (the same pixel is
 * another ray in each camera): its distances to both sum to their gap. */
static double off_keypoints(mc_vec3 p, double gap)
{
	const double ku = 139.5, kv = 75.5;
	double dl = mcd_ray_distance(&rig.cams[0], ku, kv, p), dr = mcd_ray_distance(&rig.cams[1], ku, kv, p);
	double both = dl + dr - gap;
	return dl < dr && dl < both ? dl : dr < both ? dr : both;
}

/* The right wrist onto the fixed keypoint's rays. */
static void check_tracking(mocap_client *c, mocap_skeleton_frame *f, int wrist)
{
	double gap = mcd_ray_gap(&rig.cams[0], 139.5, 75.5, &rig.cams[1], 139.5, 75.5);
	/* Where the wrist really is: never near the rays in the whole clip. */
	int gw = mc_gt_joint(&gt, "right_wrist");
	double before = 1e9;
	for (int k = 0; gw >= 0 && k < gt.nframes; k++) {
		double d = off_keypoints(mc_gt_at(&gt, k, gw), gap);
		before = d < before ? d : before;
	}
	int on = 0, frames = 0;
	double closest = 1e9;
	char series[FRAMES * 8] = "";
	size_t len = 0;
	for (; frames < FRAMES && mocap_read_frame(c, f, 10000) == 1; frames++) {
		double d = off_keypoints(mcd_joint_position(f, wrist), gap);
		on += d < 0.05;
		closest = d < closest ? d : closest;
		len += (size_t)snprintf(series + len, sizeof(series) - len, " %.1f", 100 * d);
	}
	printf("right wrist off the keypoints' rays (the two rays are %.1f cm apart): the clip's true wrist at least "
	       "%.1f cm, the tracked wrist (cm):%s\n"
	       "%d of %d frames within 5 cm (closest %.1f cm)\n",
	       100 * gap, 100 * before, series, on, frames, 100 * closest);
	CHECK(frames == FRAMES);
	CHECK_MSG(before > 0.15, "the clip's wrist comes within %.1f cm of the rays", 100 * before);
	CHECK_MSG(on >= FRAMES / 2, "the wrist came within 5 cm of the keypoints' rays in %d of %d frames", on, frames);
}

static void check_running_status(mcd_run *r, mocap_client *c)
{
	mocap_daemon_status *st = calloc(1, sizeof(*st));
	if (!st || !get_status(c, st)) {
		free(st);
		return;
	}
	const mocap_detector_status *d = &st->detector;
	printf("detector in mocapd: %s, %.1f views/s, %.3f ms per view (last %.3f, max %.3f), %llu views, %llu skipped, "
	       "%llu tracked with its keypoints (%.1f/s; any others came too late for their frame set)\n",
	       d->state == MOCAP_DETECTOR_RUNNING ? "running" : "NOT RUNNING", d->rate, d->ms_mean, d->ms_last, d->ms_max,
	       (unsigned long long)d->views, (unsigned long long)d->skipped, (unsigned long long)d->used, d->used_rate);
	CHECK(d->state == MOCAP_DETECTOR_RUNNING && d->message[0] == 0);
	CHECK(strstr(d->model, "fixed_wrist.onnx") != NULL);
	/* Both cameras, 5 frames/s each, for more than 5 s. */
	CHECK_MSG(d->views >= 2 * FRAMES * 8 / 10, "%llu views detected", (unsigned long long)d->views);
	CHECK(d->rate > 2 * RATE * 0.5 && d->rate < 2 * RATE * 1.5);
	CHECK(d->ms_mean > 0 && d->ms_last > 0 && d->ms_max >= d->ms_last);
	/* most: a detection that ends after the tracking of its frame set began joins it */
	CHECK_MSG(d->used >= d->views / 2 && d->used <= d->views,
		  "only %llu of %llu views were tracked with the detector's keypoints", (unsigned long long)d->used,
		  (unsigned long long)d->views);
	free(st);
	mcd_run_read_notify(r);
	CHECK_MSG(r->notes && strstr(r->notes, "| detector ") && strstr(r->notes, "ms per view"),
		  "no detector figures in STATUS=");
}

/* Field `field` (1-based, as in proc(5)) of /proc/PID/task/TID/stat, or
 * INT_MIN; *comm gets the thread's name. */
static int task_stat_field(pid_t pid, int tid, int field, char *comm, size_t comm_size)
{
	char path[96];
	snprintf(path, sizeof(path), "/proc/%d/task/%d/stat", (int)pid, tid);
	char text[1024] = ""; /* proc files have no size to read by */
	FILE *f = fopen(path, "r");
	if (f) {
		if (!fgets(text, sizeof(text), f))
			text[0] = 0;
		fclose(f);
	}
	char *open = strchr(text, '('), *close = strrchr(text, ')');
	int value = INT_MIN;
	if (open && close && close > open) {
		snprintf(comm, comm_size, "%.*s", (int)(close - open - 1), open + 1);
		char *p = close + 1; /* the space before field 3 */
		for (int f = 3; f < field && p; f++)
			p = strchr(p + 1, ' ');
		if (p)
			value = atoi(p);
	}
	return value;
}

/* Nice is field 19: the detector's threads must be below the daemon's. */
static void check_detector_priority(pid_t pid)
{
	char path[64], comm[64];
	snprintf(path, sizeof(path), "/proc/%d/task", (int)pid);
	DIR *dir = opendir(path);
	CHECK_MSG(dir, "%s: %s", path, strerror(errno));
	if (!dir)
		return;
	int daemon_nice = task_stat_field(pid, (int)pid, 19, comm, sizeof(comm)), found = 0;
	int want = daemon_nice + 10 < 19 ? daemon_nice + 10 : 19;
	struct dirent *e;
	while ((e = readdir(dir))) {
		int tid = atoi(e->d_name);
		if (tid <= 0)
			continue;
		int nice = task_stat_field(pid, tid, 19, comm, sizeof(comm));
		if (strncmp(comm, "mocapd-detect", 13) != 0)
			continue;
		found++;
		CHECK_MSG(nice == want, "thread %s at nice %d, the daemon at %d", comm, nice, daemon_nice);
	}
	closedir(dir);
	printf("detector threads: %d at nice %d, the daemon at %d\n", found, want, daemon_nice);
	CHECK_MSG(found == 2, "%d threads named mocapd-detect*, one per camera expected", found);
}

/* A reload applies a new rate: 1 view/s per camera instead of every frame. */
static void check_reload(mcd_run *r, mocap_client *c, const char *model)
{
	mocap_daemon_status *st = calloc(1, sizeof(*st));
	if (!st || !get_status(c, st)) {
		free(st);
		return;
	}
	write_config(r, model, 1);
	mcd_run_signal(r, SIGHUP);
	CHECK(mcd_run_wait_log(r, "reload: ", 5000));
	uint64_t t0 = mcd_now_ms(), before = st->detector.views;
	mcd_sleep_ms(4000);
	if (get_status(c, st)) {
		double s = (double)(mcd_now_ms() - t0) / 1000;
		uint64_t n = st->detector.views - before;
		printf("after a reload with rate = 1: %llu views in %.1f s (at most %.0f expected; %d/s before)\n",
		       (unsigned long long)n, s, 2 * s + 4, 2 * RATE);
		CHECK(n <= (uint64_t)(2 * s + 4) && n >= 2);
	}
	free(st);
}

static void test_good(void)
{
	char model[PATH_MAX + 64];
	snprintf(model, sizeof(model), "%s/detect/tests/data/fixed_wrist.onnx", repo);
	mcd_run r;
	bool skip;
	if (!start(&r, model, &skip)) {
		if (skip)
			TEST_SKIP("the tracker cannot run here (no usable OpenCL device)");
		return;
	}
	mocap_client *c = mocap_connect(r.sock, "test_daemon_detector");
	CHECK_MSG(c, "connect: %s", mocap_errmsg());
	mocap_skeleton_def *def = calloc(1, sizeof(*def));
	mocap_skeleton_frame *f = calloc(1, sizeof(*f));
	int wrist = -1;
	if (c && def && f && mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0 && mocap_read_frame(c, f, 30000) == 1 &&
	    mocap_get_skeleton(c, def) == 0 && (wrist = mcd_find_joint(def, "right_wrist")) >= 0) {
		check_tracking(c, f, wrist);
		check_running_status(&r, c);
		check_detector_priority(r.pid);
		check_reload(&r, c, model);
	} else
		CHECK_MSG(false, "no skeleton from mocapd: %s", mocap_errmsg());
	free(def);
	free(f);
	mocap_close(c);
	mcd_run_stop(&r, 20000, "good model");
}

/* [detector] flip reaches the shipped head-rig model (the log line says
 * what the detector does, mc_detector_flip), and a reload turns it off. */
static void test_flip(void)
{
	char model[PATH_MAX + 64];
	snprintf(model, sizeof(model), "%s/%s", repo, MC_TEST_LIVE_EGO_MODEL);
	if (access(model, R_OK) != 0)
		return;
	mcd_run r;
	CHECK(mcd_run_init(&r));
	write_config_flip(&r, model, 0, "true");
	CHECK(mcd_run_start(&r, NULL, NULL));
	if (!mcd_run_wait_notify(&r, "READY=1", 60000)) {
		mcd_run_stop(&r, 20000, "flip");
		return; /* test_good said why */
	}
	CHECK_MSG(mcd_run_wait_log(&r, "threshold 0.30, flip test, ", 5000), "the detector's line lacks the flip test");
	write_config_flip(&r, model, 0, "false");
	mcd_run_signal(&r, SIGHUP);
	CHECK(mcd_run_wait_log(&r, "detector: flip test off from the next detection", 5000));
	mcd_run_stop(&r, 20000, "flip");
}

/* A bad model: tracking goes on, the status says failed and why. */
static void test_bad(const char *model, const char *file, const char *why)
{
	mcd_run r;
	bool skip;
	if (!start(&r, model, &skip))
		return;
	int failures = mc_test_failures;
	mocap_client *c = mocap_connect(r.sock, "test_daemon_detector");
	CHECK_MSG(c, "connect: %s", mocap_errmsg());
	mocap_skeleton_frame *f = calloc(1, sizeof(*f));
	mocap_daemon_status *st = calloc(1, sizeof(*st));
	int frames = 0;
	if (c && f && st && mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0) {
		while (frames < 5 && mocap_read_frame(c, f, 10000) == 1)
			frames += f->state == MOCAP_TRACK_OK || f->state == MOCAP_TRACK_UNCERTAIN;
		mcd_sleep_ms(700); /* one status interval after the frames */
		if (get_status(c, st)) {
			printf("%s: detector %s: %s; %d tracked skeletons\n", file,
			       st->detector.state == MOCAP_DETECTOR_FAILED ? "failed" : "NOT FAILED", st->detector.message,
			       frames);
			CHECK(st->detector.state == MOCAP_DETECTOR_FAILED && st->detector.views == 0);
			CHECK_MSG(strstr(st->detector.message, file) && strstr(st->detector.message, why),
				  "the status says '%s', not naming %s and '%s'", st->detector.message, file, why);
			CHECK(st->frames_published >= 5 && st->tracker_state != MOCAP_TRACK_IDLE);
		}
	}
	CHECK_MSG(frames == 5, "%d tracked skeletons with a bad detector model", frames);
	char want[PATH_MAX + 128];
	snprintf(want, sizeof(want), "%s:23: [detector] model: ", r.conf);
	CHECK_MSG(mcd_run_wait_log(&r, want, 0), "the log has no '%s'", want);
	CHECK(mcd_run_wait_log(&r, "tracking without the detector's keypoints", 0));
	mcd_run_read_notify(&r);
	CHECK_MSG(r.notes && strstr(r.notes, "| detector failed (") && strstr(r.notes, file),
		  "STATUS= does not say the detector failed");
	free(f);
	free(st);
	mocap_close(c);
	mcd_run_terminate(&r, 20000, "bad model");

	/* --check: an error of the config line. */
	const char *const check[] = {"--check", NULL};
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 20000) == 1);
	CHECK_MSG(mcd_run_wait_log(&r, want, 0) && mcd_run_wait_log(&r, why, 0), "--check: no '%s ... %s'", want, why);
	if (mc_test_failures != failures)
		mcd_run_dump(&r, file);
	mcd_run_cleanup(&r);
}

/* [detector] hint = pose on the bundled outside-in clip with MoveNet: once
 * the tracker has a pose, the detector looks once at the square around it
 * in most views, and the status line says so.  Without the hint no view
 * is looked at once (the line has no such count). */
static void test_hint(const char *hint, bool expect_one_look)
{
	static char text[16 * PATH_MAX], cams[8 * PATH_MAX];
	cams[0] = 0;
	for (int c = 0; c < 4; c++) {
		size_t n = strlen(cams);
		snprintf(cams + n, sizeof(cams) - n,
			 "[camera cam%d]\ndriver = files\nrig_camera = cam%d\npath = %s/tests/data/outside_demo/cam%d\n"
			 "rate = 10\nloop = true\n",
			 c, c, repo, c);
	}
	snprintf(text, sizeof(text),
		 "[daemon]\nstats_log_interval_s = 1\n%s[tracker]\nrig = %s/tests/data/outside_demo/cameras.json\n"
		 "rig_format = cameras-json\nmodel = %s/config/models/default.json\n"
		 "init_joints = %s/tests/data/outside_demo/gt.json\n[socket]\npath = @SOCK@\n"
		 "[detector]\nmodel = %s/config/models/outside_detector.onnx\nhint = %s\n",
		 cams, repo, repo, repo, repo, hint);
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, text);
	CHECK(mcd_run_start(&r, NULL, NULL));
	bool ready = mcd_run_wait_notify(&r, "READY=1", 60000);
	CHECK_MSG(ready, "mocapd did not start");
	if (ready) {
		/* the stats line comes every second; give the detector 4 of them */
		bool seen = mcd_run_wait_log(&r, ", one look in ", 8000);
		CHECK_MSG(seen == expect_one_look, "hint = %s: the status line %s 'one look'", hint,
			  seen ? "has" : "lacks");
	}
	mcd_run_stop(&r, 20000, hint);
}

int main(void)
{
	mcd_require_build_and_clip(repo, sizeof(repo));
	if (access("detect/tests/data/fixed_wrist.onnx", R_OK) != 0)
		TEST_SKIP("run from the repository root (detect/tests/data not found)");
	mc_err err = {{0}};
	if (mc_rig_load("config/rigs/ego_stereo.json", &rig, &err) < 0) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	if (mc_gt_load("tests/data/ego_demo/gt.json", "joints_left_cam", &gt, &err)) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	test_good();
	test_flip();
	char path[PATH_MAX + 64];
	snprintf(path, sizeof(path), "%s/detect/tests/data/bad_channels.onnx", repo);
	test_bad(path, "bad_channels.onnx", "17 heatmap channels");
	snprintf(path, sizeof(path), "%s/detect/tests/data/not_onnx.onnx", repo);
	test_bad(path, "not_onnx.onnx", "not an ONNX model");
	snprintf(path, sizeof(path), "%s/build/no/such/model.onnx", repo);
	test_bad(path, "no/such/model.onnx", "No such file or directory");
	if (access("config/models/outside_detector.onnx", R_OK) == 0) {
		test_hint("pose", true);
		test_hint("none", false);
	}
	mc_gt_free(&gt);
	return mc_test_finish("test_daemon_detector");
}
