/* Recording end to end: mocapd tracks the bundled clip and records a take
 * while this test subscribes to every frame; mocapd is killed with SIGKILL
 * in the middle; the take opens, holds every skeleton this test received
 * (bar at most the last one) with the same joints, and its camera files
 * open.  Restarted, mocapd lists the take as cut, records and stops a new
 * one cleanly, and mocap-export exports it.  A file-size limit standing in
 * for a full disk (a small tmpfs when this test may mount one) stops a
 * take with the reason in the record status and the log, while tracking
 * goes on. */
#include "daemon/harness.h"
#include "eval/mc_gt.h"
#include <libavformat/avformat.h>
#include "mocap.h"
#include "take.h"
#include "test_util.h"

#include <sys/mount.h>
#include <sys/resource.h>
#include <unistd.h>

static char repo[PATH_MAX], mocapctl[PATH_MAX + 32], export_bin[PATH_MAX + 32];

static void write_config(mcd_run *r, const char *takes, const char *record_extra)
{
	static char conf[65536];
	char extra[PATH_MAX + 512];
	/* The test detector (a fixed keypoint) feeds the tracker: its
	 * keypoints go into the take. */
	snprintf(extra, sizeof(extra), "[record]\ndirectory = %s\n%s[detector]\nmodel = %s/detect/tests/data/fixed_wrist.onnx\n",
		 takes, record_extra, repo);
	/* The demo's settings (config/demo.conf): the actor's colours learnt
	 * on the first frame set, so that the take holds a calibrated
	 * actor.json, which mocap-track once tracked every frame set of as
	 * lost (issue 31). */
	char tracker[PATH_MAX + 128];
	snprintf(tracker, sizeof(tracker), "init_joints = %s/tests/data/ego_demo/gt.json\ncalibrate_colors = true\n", repo);
	mcd_demo_clip_config(conf, sizeof(conf), repo, 15, "", "", tracker, extra);
	mcd_run_config(r, conf);
}

static int control(mocap_client *c, mocap_command cmd, const char *arg, char *msg, size_t cap)
{
	return mocap_control(c, cmd, arg, msg, cap);
}

static mocap_skeleton_frame seen[64]; /* the newest frames received, by seq % 64 */
static uint64_t seen_seq[64];

/* Reads frames for ms milliseconds; the last seq received. */
static uint64_t read_for(mocap_client *c, int ms, uint64_t *first)
{
	static mocap_skeleton_frame f;
	uint64_t end = mcd_now_ms() + (uint64_t)ms, last = 0;
	while (mcd_now_ms() < end)
		if (mocap_read_frame(c, &f, 50) == 1) {
			seen[f.seq % 64] = f;
			seen_seq[f.seq % 64] = f.seq;
			if (first && !*first)
				*first = f.seq;
			last = f.seq;
		}
	return last;
}

/* The take of a daemon killed mid-take. */
static void check_killed_take(const char *take, uint64_t last_received)
{
	take_info info;
	mc_err err = {""};
	CHECK_MSG(take_info_read(take, &info, &err) == 0, "%s", err.msg);
	CHECK_MSG(!info.complete, "a killed take says complete");
	take_poses t;
	if (take_poses_load(take, NULL, &t, &err) < 0) {
		CHECK_MSG(false, "the killed take does not open: %s", err.msg);
		return;
	}
	uint64_t last = t.nposes ? t.poses[t.nposes - 1].seq : 0;
	printf("killed take: %d poses (seq %llu..%llu), torn tail %d; the test received up to seq %llu\n", t.nposes,
	       t.nposes ? (unsigned long long)t.poses[0].seq : 0ull, (unsigned long long)last, t.torn,
	       (unsigned long long)last_received);
	CHECK_MSG(t.nposes > 10 && last + 1 >= last_received, "the take ends at %llu, %llu was published",
		  (unsigned long long)last, (unsigned long long)last_received);
	CHECK(t.gap_frames == 0);
	/* Every pose the test also received holds the same joints. */
	int compared = 0;
	for (int i = 0; i < t.nposes; i++) {
		const take_pose *p = &t.poses[i];
		if (seen_seq[p->seq % 64] != p->seq)
			continue;
		const mocap_skeleton_frame *f = &seen[p->seq % 64];
		CHECK(p->njoints == f->njoints && p->capture_ns == f->capture_ns);
		for (int j = 0; j < p->njoints && j < f->njoints; j++)
			for (int k = 0; k < 3; k++)
				CHECK_NEAR(p->joints[j].position[k], f->joints[j].position[k], 1e-12);
		if (i > 0)
			CHECK(p->seq == t.poses[i - 1].seq + 1);
		compared++;
	}
	CHECK_MSG(compared > 5, "only %d poses compared", compared);
	take_poses_free(&t);
	/* the camera files open and hold whole frames */
	for (int c = 0; c < 2; c++) {
		char path[PATH_MAX + 64];
		snprintf(path, sizeof(path), "%s/cam-%s.mcr", take, c ? "right" : "left");
		take_reader r;
		CHECK_MSG(take_reader_open(&r, path, &err) == 0, "%s", err.msg);
		take_record_type type;
		const uint8_t *p;
		size_t n;
		int frames = 0;
		while (take_reader_next(&r, &type, &p, &n, NULL) == 1) {
			take_frame_meta m;
			CHECK(type == TAKE_FRAME && take_decode_frame_meta(p, n, &m) == 0 && m.pixfmt != 0);
			frames++;
		}
		CHECK_MSG(frames > 10, "%s: %d frames", path, frames);
		take_reader_close(&r);
	}
}

static char *run_ctl(const char *sock, const char *args, int *rc)
{
	char cmd[PATH_MAX * 2 + 256];
	static char out[8192];
	snprintf(cmd, sizeof(cmd), "%s --socket %s %s 2>&1", mocapctl, sock, args);
	*rc = mc_test_run(cmd, out, sizeof(out));
	return out;
}

static void check_head_poses(const char *take)
{
	char path[PATH_MAX + 32];
	snprintf(path, sizeof(path), "%s/poses.mcr", take);
	take_reader r;
	mc_err err = {""};
	int n = 0, keypoint_sets = 0;
	if (take_reader_open(&r, path, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return;
	}
	take_record_type type;
	const uint8_t *p;
	size_t size;
	while (take_reader_next(&r, &type, &p, &size, NULL) == 1) {
		take_head_pose h;
		keypoint_sets += type == TAKE_KEYPOINTS;
		if (type != TAKE_HEAD_POSE)
			continue;
		CHECK(take_decode_head_pose(p, size, &h) == 0);
		CHECK_NEAR(h.position[0], 0.1 * n, 1e-12);
		CHECK_NEAR(h.position[1], 1.6, 1e-12);
		CHECK(h.orientation[0] == 1 && h.timestamp_ns > 0);
		n++;
	}
	take_reader_close(&r);
	CHECK_MSG(n == 3, "%d head poses in the take, 3 sent", n);
	CHECK_MSG(keypoint_sets > 0, "no keypoints in the take (the test detector ran)");
}

/* Restarted: the cut take is listed; a new take starts and stops cleanly
 * and exports. */
static void check_restart(mcd_run *r, const char *takes)
{
	int rc;
	char *out = run_ctl(r->sock, "record list", &rc);
	char want[PATH_MAX + 64];
	snprintf(want, sizeof(want), "%s/killed\tcut\t", takes);
	CHECK_MSG(rc == 0 && strstr(out, want), "record list (exit %d): %s", rc, out);
	/* The names come in the reply itself, for a client that cannot read
	 * the daemon's directory (TCP): the directory, then one take a line. */
	mocap_client *lc = mocap_connect(r->sock, "test_recording list");
	char list[1024] = "";
	snprintf(want, sizeof(want), "%s\nkilled", takes);
	CHECK_MSG(lc && control(lc, MOCAP_CMD_RECORD_LIST, NULL, list, sizeof(list)) == 0 && strcmp(list, want) == 0,
		  "record list reply: '%s'", list);
	mocap_close(lc);
	out = run_ctl(r->sock, "record start --name second", &rc);
	CHECK_MSG(rc == 0 && strstr(out, "recording ") && strstr(out, "/second"), "exit %d: %s", rc, out);
	/* STATUS says so at once (it lagged up to status_interval_s). */
	mocap_client *st = mocap_connect(r->sock, "test_recording status");
	mocap_daemon_status ds = {0};
	CHECK_MSG(st && mocap_get_status(st, &ds) == 0 && ds.recording == 1, "STATUS recording %d right after the start",
		  st ? ds.recording : -1);
	/* A VR runtime's head poses go into the take. */
	mocap_client *vr = mocap_connect(r->sock, "test_recording vr");
	CHECK(vr != NULL);
	for (int k = 0; vr && k < 3; k++) {
		double pos[3] = {0.1 * k, 1.6, -0.2}, q[4] = {1, 0, 0, 0};
		CHECK(mocap_send_head_pose(vr, mocap_now_ns(), pos, q) == 0);
	}
	CHECK(vr && mocap_ping(vr, NULL) == 0); /* the poses are in before this returns */
	mocap_close(vr);
	mcd_sleep_ms(1500);
	out = run_ctl(r->sock, "record status", &rc);
	CHECK_MSG(rc == 0 && strstr(out, "recording ") && strstr(out, " poses"), "exit %d: %s", rc, out);
	out = run_ctl(r->sock, "record start --name third", &rc);
	CHECK_MSG(rc == 1 && strstr(out, "already recording"), "exit %d: %s", rc, out);
	out = run_ctl(r->sock, "record stop", &rc);
	CHECK_MSG(rc == 0 && strstr(out, "stopped by request"), "exit %d: %s", rc, out);
	CHECK_MSG(st && mocap_get_status(st, &ds) == 0 && ds.recording == 0, "STATUS recording %d right after the stop",
		  st ? ds.recording : -1);
	mocap_close(st);
	out = run_ctl(r->sock, "record stop", &rc);
	CHECK_MSG(rc == 1 && strstr(out, "not recording"), "exit %d: %s", rc, out);
	out = run_ctl(r->sock, "record start --name second", &rc);
	CHECK_MSG(rc == 1 && strstr(out, "exists already"), "exit %d: %s", rc, out);
	out = run_ctl(r->sock, "record start --name ../escape", &rc);
	CHECK_MSG(rc == 1 && strstr(out, "a take name is letters"), "exit %d: %s", rc, out);
	char take[PATH_MAX + 16];
	snprintf(take, sizeof(take), "%s/second", takes);
	check_head_poses(take);
	take_info info;
	mc_err err = {""};
	CHECK(take_info_read(take, &info, &err) == 0 && info.complete && info.poses > 5 &&
	      strcmp(info.stop_reason, "stopped by request") == 0);
	char cmd[PATH_MAX * 3 + 128], res[4096];
	snprintf(cmd, sizeof(cmd), "%s --bvh %s/second.bvh --json %s/second.json %s 2>&1", export_bin, r->dir, r->dir,
		 take);
	rc = mc_test_run(cmd, res, sizeof(res));
	CHECK_MSG(rc == 0 && strstr(res, " poses (0 missed by the recorder)"), "mocap-export: exit %d: %s", rc, res);
	/* The left camera as a video: MJPEG in Matroska, every frame. */
	snprintf(cmd, sizeof(cmd), "%s --video %s/left.mkv --camera left %s 2>&1", export_bin, r->dir, take);
	rc = mc_test_run(cmd, res, sizeof(res));
	CHECK_MSG(rc == 0, "mocap-export --video: exit %d: %s", rc, res);
	char mkv[PATH_MAX + 16];
	snprintf(mkv, sizeof(mkv), "%s/left.mkv", r->dir);
	AVFormatContext *ic = NULL;
	int packets = 0;
	if (avformat_open_input(&ic, mkv, NULL, NULL) == 0 && avformat_find_stream_info(ic, NULL) >= 0) {
		CHECK(ic->streams[0]->codecpar->codec_id == AV_CODEC_ID_MJPEG && ic->streams[0]->codecpar->width == 256);
		AVPacket *pkt = av_packet_alloc();
		while (pkt && av_read_frame(ic, pkt) == 0) {
			packets++;
			av_packet_unref(pkt);
		}
		av_packet_free(&pkt);
		avformat_close_input(&ic);
	}
	CHECK_MSG(packets > 5 && (uint64_t)packets == info.frames[0], "%s: %d packets for %llu frames", mkv, packets,
		  (unsigned long long)info.frames[0]);
}

/* Mean joint error (cm) of a track's pose against the clip's ground truth
 * at clip frame k; -1 when no joint is in both. */
static double pose_error(const mc_gt *gt, int k, const take_def *def, const take_pose *p)
{
	double sum = 0;
	int n = 0;
	for (int j = 0; j < p->njoints; j++) {
		int g = mc_gt_joint(gt, def->joints[j].name);
		if (g < 0 || !strcmp(def->joints[j].name, "head_top"))
			continue;
		mc_vec3 t = mc_gt_at(gt, k, g);
		const double *q = p->joints[j].position;
		sum += mc_v3_norm(mc_v3_sub(mc_v3(q[0], q[1], q[2]), t));
		n++;
	}
	return n ? 100 * sum / n : -1;
}

/* Errors of both tracks on the frame sets both have; how many. */
static int compare_to_truth(const char *take, const take_poses *live, const take_poses *again, double *live_cm,
			    double *again_cm)
{
	mc_gt gt;
	mc_err err = {""};
	static uint64_t t[1024], seq[1024];
	int nf = 0, n = 0;
	*live_cm = *again_cm = 0;
	if (mc_gt_load("tests/data/ego_demo/gt.json", "joints_left_cam", &gt, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return 0;
	}
	char path[PATH_MAX + 32];
	snprintf(path, sizeof(path), "%s/cam-left.mcr", take);
	take_reader r;
	if (take_reader_open(&r, path, &err) == 0) {
		take_frame_meta m;
		const uint8_t *bytes;
		size_t k;
		while (nf < 1024 && take_reader_next_frame(&r, &m, &bytes, &k) == 1) {
			t[nf] = m.capture_ns;
			seq[nf++] = m.driver_sequence;
		}
		take_reader_close(&r);
	}
	for (int i = 0; i < again->nposes; i++)
		for (int k = 0; k < live->nposes; k++)
			for (int f = 0; f < nf && live->poses[k].capture_ns == again->poses[i].capture_ns; f++) {
				if (t[f] != again->poses[i].capture_ns)
					continue;
				int frame = (int)(seq[f] % (uint64_t)gt.nframes);
				double a = pose_error(&gt, frame, &live->def, &live->poses[k]);
				double b = pose_error(&gt, frame, &again->def, &again->poses[i]);
				if (a >= 0 && b >= 0) {
					*live_cm += a;
					*again_cm += b;
					n++;
				}
			}
	if (n) {
		*live_cm /= n;
		*again_cm /= n;
	}
	mc_gt_free(&gt);
	return n;
}

/* mocap-track tracks the take again offline: a pose per frame set, close
 * to those tracked live; mocap-export exports that track. */
static void check_retrack(const char *take, const char *scratch)
{
	char cmd[PATH_MAX * 6], out[8192], track_bin[PATH_MAX + 32];
	snprintf(track_bin, sizeof(track_bin), "%s/bin/mocap-track", mcd_build_dir);
	snprintf(cmd, sizeof(cmd), "%s %s 2>&1", track_bin, take);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "mocap-track: ") && strstr(out, " ok, "), "mocap-track: exit %d: %s", rc, out);
	/* Most frame sets tracked, not lost: the take's actor (calibrated
	 * colours) with a tracking baseline measured offline too. */
	const char *counts = strstr(out, " ok, ");
	int ok = 0, lost = 0, sets = 0;
	while (counts && counts > out && counts[-1] >= '0' && counts[-1] <= '9')
		counts--;
	CHECK_MSG(counts && sscanf(counts, "%d ok, %*d uncertain, %d lost", &ok, &lost) == 2, "%s", out);
	const char *in = strstr(out, "mocap-track: ");
	CHECK(in && sscanf(in, "mocap-track: %d frame sets", &sets) == 1);
	printf("%s", out);
	CHECK_MSG(sets > 0 && ok * 2 > sets, "offline: %d of %d frame sets ok, %d lost: %s", ok, sets, lost, out);
	const char *used = strstr(out, "; ");
	CHECK_MSG(used && atoi(used + 2) > 0 && strstr(out, " with the keypoints recorded live"),
		  "the recorded keypoints were not used: %s", out);
	take_poses live, again;
	take_info info;
	mc_err err = {""};
	CHECK(take_info_read(take, &info, &err) == 0);
	if (take_poses_load(take, NULL, &live, &err) < 0 || take_poses_load(take, "retrack", &again, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return;
	}
	CHECK_MSG((uint64_t)again.nposes == info.frames[0], "%d poses for %llu frame sets", again.nposes,
		  (unsigned long long)info.frames[0]);
	/* Against the clip's ground truth, on the frame sets both tracked: the
	 * files driver delivered clip frame (driver_sequence mod the clip's
	 * length) at each capture time. */
	double live_cm, again_cm;
	int n = compare_to_truth(take, &live, &again, &live_cm, &again_cm);
	printf("retrack: %d poses; error against the clip's ground truth over %d frame sets: live %.2f cm, "
	       "offline at the default budget %.2f cm\n",
	       again.nposes, n, live_cm, again_cm);
	/* "It tracks as well as live", within what a few frame sets of the
	 * stochastic optimiser spread: offline minus live was +0.2 to +2.4 cm
	 * over 14 runs here, and +4.2 cm once under the sanitizers while the
	 * rest of `make check` loaded the machine (live had its best run,
	 * 13.2 cm; which sets live tracks depends on the timing).  Both use
	 * the test detector's keypoints, a fixed point that pulls one wrist
	 * off, so neither is near mocap-bench's 9-10 cm for this clip. */
	CHECK_MSG(n > 5 && again_cm < live_cm + 5.0, "retracked %.2f cm, live %.2f cm (%d sets)", again_cm, live_cm, n);
	take_poses_free(&live);
	take_poses_free(&again);
	snprintf(cmd, sizeof(cmd), "%s --track retrack --csv %s/retrack.csv %s 2>&1", export_bin, scratch, take);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "mocap-export --track: exit %d: %s", rc, out);
	/* Offline tracking is deterministic: two runs give the same skeletons. */
	for (int run = 0; run < 2; run++) {
		snprintf(cmd, sizeof(cmd), "%s --quiet --iterations 20 --name det%d %s 2>&1 && %s --track det%d --csv %s/det%d.csv %s 2>&1",
			 track_bin, run, take, export_bin, run, scratch, run, take);
		rc = mc_test_run(cmd, out, sizeof(out));
		CHECK_MSG(rc == 0, "run %d: exit %d: %s", run, rc, out);
	}
	snprintf(cmd, sizeof(cmd), "cmp %s/det0.csv %s/det1.csv 2>&1", scratch, scratch);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "two offline tracks of one take differ: %s", out);
	snprintf(cmd, sizeof(cmd), "%s --track nosuch --csv %s/x.csv %s 2>&1", export_bin, scratch, take);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "poses-nosuch.mcr"), "exit %d: %s", rc, out);
}

/* mocap-track --detector: the shipped head-mounted model's keypoints on
 * every frame set instead of those recorded live; a model that is not
 * there is refused with its file named. */
static void check_redetect(const char *take)
{
	const char *model = "config/models/ego_detector.onnx";
	if (access(model, R_OK) != 0) {
		printf("mocap-track --detector: skipped (%s is not there: run from the repository root)\n", model);
		return;
	}
	char cmd[PATH_MAX * 3], out[8192], track_bin[PATH_MAX + 32];
	snprintf(track_bin, sizeof(track_bin), "%s/bin/mocap-track", mcd_build_dir);
	snprintf(cmd, sizeof(cmd), "%s --quiet --iterations 20 --name redetect --detector %s %s 2>&1", track_bin, model,
		 take);
	int rc = mc_test_run(cmd, out, sizeof(out));
	int sets = 0, ok = 0, used = 0;
	const char *in = strstr(out, "mocap-track: ");
	CHECK_MSG(rc == 0 && in && sscanf(in, "mocap-track: %d frame sets", &sets) == 1, "exit %d: %s", rc, out);
	const char *counts = strstr(out, "/poses-redetect.mcr: ");
	const char *with = strstr(out, " with keypoints from --detector");
	CHECK_MSG(counts && sscanf(counts, "/poses-redetect.mcr: %d ok", &ok) == 1 && with, "%s", out);
	while (with && with > out && with[-1] >= '0' && with[-1] <= '9')
		with--;
	used = with ? atoi(with) : 0;
	printf("%s", out);
	CHECK_MSG(sets > 0 && used * 10 >= sets * 9 && ok * 2 > sets,
		  "--detector: %d frame sets, %d with keypoints, %d ok: %s", sets, used, ok, out);
	snprintf(cmd, sizeof(cmd), "%s --quiet --name nomodel --detector /nonexistent/model.onnx %s 2>&1", track_bin,
		 take);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "/nonexistent/model.onnx"), "exit %d: %s", rc, out);
	char left[PATH_MAX + 32];
	snprintf(left, sizeof(left), "%s/poses-nomodel.mcr", take);
	CHECK_MSG(access(left, F_OK) != 0, "%s was left behind by a model that did not load", left);
}

/* The frames of a camera file: their capture times, and a hash of their
 * bytes each. */
static int read_frames(const char *take, const char *cam, uint64_t *t, uint64_t *hash, int max)
{
	char path[PATH_MAX + 64];
	snprintf(path, sizeof(path), "%s/cam-%s.mcr", take, cam);
	take_reader r;
	mc_err err = {""};
	if (take_reader_open(&r, path, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return 0;
	}
	take_frame_meta m;
	const uint8_t *p;
	size_t n;
	int k = 0;
	while (k < max && take_reader_next_frame(&r, &m, &p, &n) == 1) {
		uint64_t h = 1469598103934665603ull; /* FNV-1a */
		for (size_t i = 0; i < n; i++)
			h = (h ^ p[i]) * 1099511628211ull;
		t[k] = m.capture_ns;
		hash[k++] = h;
	}
	take_reader_close(&r);
	return k;
}

/* The take driver plays a take's frames, as recorded and with their
 * timing, through mocapd, which tracks them; recording the replay gives
 * the same frames back. */
static void check_replay(const char *takes)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	static char conf[65536];
	char source[PATH_MAX];
	snprintf(source, sizeof(source), "%s/second", takes);
	snprintf(conf, sizeof(conf),
		 "[daemon]\nplugin_dir = %s/drivers\n"
		 "[camera left]\ndriver = take\nrig_camera = left\ntake = %s\ncamera = left\n"
		 "[camera right]\ndriver = take\nrig_camera = right\ntake = %s\ncamera = right\n"
		 "[tracker]\nrig = %s/config/rigs/ego_stereo.json\nmodel = %s/config/models/default.json\n"
		 "init_joints = %s/tests/data/ego_demo/gt.json\n[socket]\npath = @SOCK@\n"
		 "[record]\ndirectory = %s/takes\n",
		 mcd_build_dir, source, source, repo, repo, repo, r.dir);
	mcd_run_config(&r, conf);
	const char *const args[] = {NULL};
	if (!mcd_run_start_ready(&r, args))
		return;
	mocap_client *c = mocap_connect(r.sock, "test_recording");
	char msg[1024] = "";
	CHECK(c && mocap_subscribe(c, MOCAP_LATEST, MOCAP_SPACE_RIG, 0) == 0);
	CHECK_MSG(c && control(c, MOCAP_CMD_RECORD_START, "replayed", msg, sizeof(msg)) == 0, "%s", msg);
	uint64_t first = 0, last = c ? read_for(c, 1000, &first) : 0;
	CHECK_MSG(last > first && first > 0, "the replay is not tracked (%llu..%llu)", (unsigned long long)first,
		  (unsigned long long)last);
	CHECK(c && control(c, MOCAP_CMD_RECORD_STOP, NULL, msg, sizeof(msg)) == 0);
	mocap_close(c);
	mcd_run_terminate(&r, 20000, "replay");

	static uint64_t t0[512], h0[512], t1[512], h1[512];
	char replayed[PATH_MAX];
	snprintf(replayed, sizeof(replayed), "%s/takes/replayed", r.dir);
	int n0 = read_frames(source, "left", t0, h0, 512), n1 = read_frames(replayed, "left", t1, h1, 512);
	CHECK_MSG(n1 >= 5 && n1 <= n0, "%d frames replayed of %d", n1, n0);
	/* The replayed frames are a run of the recorded ones, in order, with
	 * the recorded intervals. */
	int at = -1;
	for (int k = 0; k < n0 && at < 0 && n1 > 0; k++)
		at = h0[k] == h1[0] ? k : -1;
	CHECK_MSG(at >= 0, "the first replayed frame is none of the recorded ones");
	double worst = 0;
	for (int k = 1; at >= 0 && k < n1 && at + k < n0; k++) {
		CHECK_MSG(h1[k] == h0[at + k], "replayed frame %d differs from recorded frame %d", k, at + k);
		double d = fabs(((double)(t1[k] - t1[k - 1]) - (double)(t0[at + k] - t0[at + k - 1])) * 1e-6);
		worst = d > worst ? d : worst;
	}
	printf("replay: %d frames, the same bytes as recorded; intervals within %.2f ms of the recorded ones\n", n1,
	       worst);
	CHECK_MSG(worst < 1.0, "intervals %.2f ms off", worst);
	if (mc_test_failures)
		mcd_run_dump(&r, "replay");
	mcd_run_cleanup(&r);
}

/* A take that outgrows what the disk takes stops, saying why; tracking
 * goes on.  A 1 MB tmpfs when mount(2) is allowed, else RLIMIT_FSIZE. */
static void check_full_disk(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char small[128];
	snprintf(small, sizeof(small), "%s/small", r.dir);
	mkdir(small, 0755);
	bool tmpfs = mount("tmpfs", small, "tmpfs", 0, "size=1m") == 0;
	struct rlimit old;
	getrlimit(RLIMIT_FSIZE, &old);
	if (!tmpfs) {
		printf("no tmpfs (mount: %s): a 1 MB file-size limit stands in for the full disk\n", strerror(errno));
		struct rlimit lim = {1 << 20, old.rlim_max};
		signal(SIGXFSZ, SIG_IGN); /* inherited: write() then fails with EFBIG */
		setrlimit(RLIMIT_FSIZE, &lim);
	}
	write_config(&r, small, "");
	const char *const args[] = {NULL};
	bool up = mcd_run_start_ready(&r, args);
	setrlimit(RLIMIT_FSIZE, &old);
	if (!up) {
		if (tmpfs)
			umount(small);
		return;
	}
	mocap_client *c = mocap_connect(r.sock, "test_recording");
	char msg[1024] = "";
	CHECK(c && mocap_subscribe(c, MOCAP_LATEST, MOCAP_SPACE_RIG, 0) == 0);
	CHECK_MSG(c && control(c, MOCAP_CMD_RECORD_START, "big", msg, sizeof(msg)) == 0, "%s", msg);
	uint64_t end = mcd_now_ms() + 20000;
	while (c && mcd_now_ms() < end) {
		control(c, MOCAP_CMD_RECORD_STATUS, NULL, msg, sizeof(msg));
		if (strncmp(msg, "not recording", 13) == 0)
			break;
		mcd_sleep_ms(200);
	}
	const char *why = tmpfs ? "No space left on device" : "File too large";
	printf("full disk: %s\n", msg);
	CHECK_MSG(strstr(msg, "error: ") && strstr(msg, why), "record status: %s", msg);
	CHECK_MSG(mcd_run_wait_log(&r, "record: last take", 5000), "the log does not say the take stopped");
	uint64_t first = 0, last = c ? read_for(c, 1500, &first) : 0;
	CHECK_MSG(last > first && first > 0, "tracking stopped with the take (%llu..%llu)", (unsigned long long)first,
		  (unsigned long long)last);
	char take[256];
	snprintf(take, sizeof(take), "%s/big", small);
	take_poses t;
	mc_err err = {""};
	CHECK_MSG(take_poses_load(take, NULL, &t, &err) == 0 && t.nposes > 0, "the stopped take: %s", err.msg);
	take_poses_free(&t);
	mocap_close(c);
	mcd_run_terminate(&r, 20000, "full disk");
	if (mc_test_failures > r.failures_at_init)
		mcd_run_dump(&r, "full disk");
	if (tmpfs)
		umount(small);
	mcd_run_cleanup(&r);
}

int main(void)
{
	if (!mcd_find_build_up(3)) /* <build>/record/tests/test_recording */
		TEST_SKIP("mocapd is not built");
	if (!getcwd(repo, sizeof(repo)) || access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
	snprintf(mocapctl, sizeof(mocapctl), "%s/bin/mocapctl", mcd_build_dir);
	snprintf(export_bin, sizeof(export_bin), "%s/bin/mocap-export", mcd_build_dir);
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char takes[160];
	snprintf(takes, sizeof(takes), "%s/takes", r.dir);
	write_config(&r, takes, "");
	const char *const args[] = {NULL};
	if (!mcd_run_start_ready(&r, args))
		return mc_test_finish("test_recording");
	mocap_client *c = mocap_connect(r.sock, "test_recording");
	char msg[1024] = "";
	CHECK(c && mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
	CHECK_MSG(c && control(c, MOCAP_CMD_RECORD_START, "killed", msg, sizeof(msg)) == 0, "%s", msg);
	uint64_t last = c ? read_for(c, 2500, NULL) : 0;
	mcd_run_signal(&r, SIGKILL);
	mcd_run_wait_exit(&r, 10000);
	/* Frames already in this client's socket were published before the
	 * kill: the take must hold them too (bar the last). */
	static mocap_skeleton_frame late;
	while (c && mocap_read_frame(c, &late, 0) == 1)
		last = late.seq > last ? late.seq : last;
	mocap_close(c);
	char take[200];
	snprintf(take, sizeof(take), "%s/killed", takes);
	check_killed_take(take, last);

	CHECK(mcd_run_start_ready(&r, args));
	check_restart(&r, takes);
	mcd_run_terminate(&r, 20000, "recording");
	if (mc_test_failures > r.failures_at_init)
		mcd_run_dump(&r, "recording");
	check_replay(takes);
	char second[PATH_MAX];
	snprintf(second, sizeof(second), "%s/second", takes);
	check_retrack(second, r.dir);
	check_redetect(second);
	mcd_run_cleanup(&r);

	check_full_disk();
	return mc_test_finish("test_recording");
}
