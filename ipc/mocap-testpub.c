/* mocap-testpub: a stand-in for mocapd that serves the client socket with
 * the real server library and publishes a synthetic, waving skeleton.  The
 * Python module's tests and anyone writing a client use it when no daemon
 * (or no camera) is at hand.
 *
 *   mocap-testpub --socket PATH [--rate HZ] [--frames N] [--tcp HOST:PORT --token T]
 *
 * Prints "ready" on stdout once clients can connect ("ready tcp=PORT" with
 * a TCP listener: port 0 takes a free one).  Stops after N frames
 * (0: never) or on SIGINT/SIGTERM.  Answers control requests itself:
 * reload succeeds, recording fails with a message. */
#include "base/mc_time.h"
#include "server.h"

#include <errno.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static volatile sig_atomic_t stop;
static void on_signal(int sig) { (void)sig; stop = 1; }

/* The output joints of DESIGN.md, as a small tree with rest offsets. */
static const struct {
	const char *name;
	int parent;
	double x, y, z;
} joints[] = {
	{"pelvis", -1, 0, 0, 0},          {"spine", 0, 0, -0.25, 0},         {"neck", 1, 0, -0.30, 0},
	{"head_top", 2, 0, -0.25, 0},     {"left_shoulder", 2, 0.18, 0, 0},  {"left_elbow", 4, 0.28, 0, 0},
	{"left_wrist", 5, 0.25, 0, 0},    {"right_shoulder", 2, -0.18, 0, 0}, {"right_elbow", 7, -0.28, 0, 0},
	{"right_wrist", 8, -0.25, 0, 0},  {"left_hip", 0, 0.10, 0.05, 0},    {"left_knee", 10, 0, 0.42, 0},
	{"left_ankle", 11, 0, 0.42, 0},   {"left_toe", 12, 0, 0.05, 0.12},   {"right_hip", 0, -0.10, 0.05, 0},
	{"right_knee", 14, 0, 0.42, 0},   {"right_ankle", 15, 0, 0.42, 0},   {"right_toe", 16, 0, 0.05, 0.12},
};
#define NJOINTS ((int)(sizeof(joints) / sizeof(joints[0])))

static const char rig_json[] =
	"{\n  \"name\": \"testpub\",\n  \"kind\": \"outside-in\",\n  \"cameras\": [\n"
	"    {\"name\": \"cam0\", \"width\": 640, \"height\": 480, \"model\": \"pinhole\",\n"
	"     \"fx\": 500, \"fy\": 500, \"cx\": 320, \"cy\": 240}\n  ]\n}\n";

/* Forward kinematics of the rest pose with the left arm waving. */
static void make_skeleton(mc_skeleton *sk, double t, uint64_t capture_ns)
{
	memset(sk, 0, sizeof(*sk));
	sk->timestamp_ns = capture_ns;
	sk->state = MC_TRACK_OK;
	sk->njoints = NJOINTS;
	for (int j = 0; j < NJOINTS; j++) {
		mc_skeleton_joint *o = &sk->joints[j];
		snprintf(o->name, sizeof(o->name), "%s", joints[j].name);
		o->parent = joints[j].parent;
		mc_vec3 off = mc_v3(joints[j].x, joints[j].y, joints[j].z);
		mc_quat q = mc_quat_identity();
		if (o->parent >= 0) {
			const mc_skeleton_joint *p = &sk->joints[o->parent];
			if (j == 5) /* left elbow swings about z */
				q = mc_quat_from_rotvec(mc_v3(0, 0, 0.8 * sin(2 * M_PI * 0.5 * t)));
			q = mc_quat_mul(p->orientation, q);
			o->position = mc_v3_add(p->position, mc_quat_rotate(p->orientation, off));
		} else {
			o->position = mc_v3(0.1 * sin(t), 0, 3.0);
		}
		o->orientation = q;
		o->confidence = 0.9f;
	}
}

static void answer_controls(srv_server *srv)
{
	srv_control ctl;
	while (srv_poll_control(srv, &ctl) == 1) {
		if (ctl.command == MC_CONTROL_RELOAD)
			srv_control_done(srv, ctl.token, 0, "reloaded (test publisher)");
		else
			srv_control_done(srv, ctl.token, 1, "recording is not supported by the test publisher");
	}
	srv_keypoints kp; /* the test publisher tracks nothing: keypoints are taken and dropped */
	while (srv_inbox_pop_keypoints(srv_keypoints_inbox(srv), &kp) == 1) {
	}
}

int main(int argc, char **argv)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.daemon_version, sizeof(cfg.daemon_version), "mocap-testpub");
	double rate = 60;
	long frames = 0;
	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--socket") && i + 1 < argc)
			snprintf(cfg.path, sizeof(cfg.path), "%s", argv[++i]);
		else if (!strcmp(argv[i], "--rate") && i + 1 < argc)
			rate = atof(argv[++i]);
		else if (!strcmp(argv[i], "--frames") && i + 1 < argc)
			frames = atol(argv[++i]);
		else if (!strcmp(argv[i], "--tcp") && i + 1 < argc)
			snprintf(cfg.tcp_listen, sizeof(cfg.tcp_listen), "%s", argv[++i]);
		else if (!strcmp(argv[i], "--token") && i + 1 < argc)
			snprintf(cfg.tcp_token, sizeof(cfg.tcp_token), "%s", argv[++i]);
		else {
			fprintf(stderr, "usage: mocap-testpub [--socket PATH] [--rate HZ] [--frames N] "
					"[--tcp HOST:PORT --token T]\n");
			return 2;
		}
	}
	if (!(rate > 0 && rate <= 10000)) {
		fprintf(stderr, "mocap-testpub: --rate must be in (0, 10000]\n");
		return 2;
	}
	cfg.socket_mode = 0666;
	mc_err err = {{0}};
	srv_server *srv = srv_create(&cfg, &err);
	if (!srv) {
		fprintf(stderr, "mocap-testpub: %s\n", err.msg);
		return 1;
	}
	mc_skeleton *sk = malloc(sizeof(*sk));
	make_skeleton(sk, 0, mc_now_ns());
	srv_skeleton_def *def = calloc(1, sizeof(*def));
	def->njoints = NJOINTS;
	def->rig_is_world = true;
	for (int j = 0; j < NJOINTS; j++) {
		snprintf(def->name[j], sizeof(def->name[j]), "%s", joints[j].name);
		def->parent[j] = joints[j].parent;
		def->rest_offset[j] = mc_v3(joints[j].x, joints[j].y, joints[j].z);
	}
	if (srv_set_skeleton_def(srv, def, &err) || srv_set_rig(srv, rig_json, 1, &err)) {
		fprintf(stderr, "mocap-testpub: %s\n", err.msg);
		return 1;
	}
	struct sigaction sa = {.sa_handler = on_signal};
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	srv_status st = {0};
	st.tracker_state = SRV_TRACKER_OK;
	st.start_ns = mc_now_ns();
	snprintf(st.device, sizeof(st.device), "synthetic");
	st.ncams = 1;
	snprintf(st.cams[0].name, sizeof(st.cams[0].name), "cam0");
	st.cams[0].width = 640;
	st.cams[0].height = 480;
	/* A detector with fixed figures, so that clients can test reading them. */
	st.detector.state = SRV_DETECTOR_RUNNING;
	st.detector.rate = 30;
	st.detector.used_rate = 29;
	st.detector.ms_mean = 1.25;
	st.detector.ms_last = 1.5;
	st.detector.ms_max = 2.5;
	st.detector.views = 300;
	st.detector.skipped = 3;
	st.detector.used = 290;
	st.latency.window = 600;
	for (int s = 0; s < SRV_LAT_NSTAGES; s++)
		st.latency.stage[s].p50 = st.latency.stage[s].p99 = st.latency.stage[s].max = s + 1;
	st.latency.stage[SRV_LAT_TOTAL].p99 = 12.5;
	st.latency.skipped_behind = 4;
	st.latency.skipped_stale = 2;
	st.latency.incomplete = 1;
	snprintf(st.detector.model, sizeof(st.detector.model), "synthetic.onnx");
	/* The status is there before "ready": a client that asks at once must
	 * not get an empty one (test_aio's first status read "" as the
	 * device once, under load). */
	srv_set_status(srv, &st);
	if (srv_tcp_port(srv))
		printf("ready tcp=%d\n", srv_tcp_port(srv));
	else
		printf("ready\n");
	fflush(stdout);

	uint64_t period = (uint64_t)(1e9 / rate), next = mc_now_ns(), t0 = next;
	for (uint64_t seq = 1; !stop && (frames <= 0 || seq <= (uint64_t)frames); seq++) {
		uint64_t t = mc_now_ns();
		make_skeleton(sk, (double)(t - t0) * 1e-9, t - 2000000);
		if (srv_publish(srv, sk, seq, &err))
			fprintf(stderr, "mocap-testpub: %s\n", err.msg);
		st.frames_published = seq;
		st.publish_fps = rate;
		st.cams[0].fps = rate;
		st.cams[0].frames = seq;
		srv_set_status(srv, &st);
		/* Sleep until the next frame, answering requests meanwhile. */
		next += period;
		for (;;) {
			answer_controls(srv);
			uint64_t n = mc_now_ns();
			if (n >= next || stop)
				break;
			struct pollfd p = {.fd = srv_event_fd(srv), .events = POLLIN};
			poll(&p, 1, (int)((next - n) / 1000000 + 1 > 100 ? 100 : (next - n) / 1000000 + 1));
		}
	}
	/* Give "all" clients a moment to take the last frames. */
	usleep(200000);
	srv_destroy(srv);
	free(sk);
	free(def);
	return 0;
}
