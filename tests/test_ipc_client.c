/* libmocap against the server library, with a test publisher thread in the
 * role of the daemon:
 *   - a client receives skeletons with the published contents;
 *   - 64 clients at once, each in its own thread, all get every frame;
 *   - a slow client in "all" mode gets gap messages and accounts for every
 *     frame, while the others keep their rate and publishing never blocks;
 *   - "latest" mode returns only the newest frame;
 *   - one client used by two threads at once (frames and requests);
 *   - control requests (privileged), refused for other users (when the
 *     test runs as root it re-executes itself as nobody);
 *   - keypoints and head poses reach the daemon; world-space frames;
 *   - camera rings are passed read-only;
 *   - the messages a user sees when the daemon is not there.
 * Run with no arguments. */
#include "ring/mc_ring.h"
#include "server.h"
#include "mocap.h"
#include "mdrv.h" /* both public headers in one unit: no clashes */
#include "test_util.h"

#include <errno.h>
#include <grp.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define NJ 18

/* The client library's public header cannot include the server's (it is
 * installed without the core): what both name must agree. */
_Static_assert((int)MOCAP_CMD_RELOAD == MC_CONTROL_RELOAD && (int)MOCAP_CMD_RECORD_START == MC_CONTROL_RECORD_START &&
		       (int)MOCAP_CMD_RECORD_STOP == MC_CONTROL_RECORD_STOP && (int)MOCAP_CMD_STEER == MC_CONTROL_STEER,
	       "control commands");
_Static_assert((int)MOCAP_TRACK_OK == SRV_TRACKER_OK && (int)MOCAP_TRACK_UNCERTAIN == SRV_TRACKER_UNCERTAIN &&
		       (int)MOCAP_TRACK_LOST == SRV_TRACKER_LOST && (int)MOCAP_TRACK_IDLE == SRV_TRACKER_IDLE,
	       "tracker states");
_Static_assert(MOCAP_NAME_MAX == SRV_NAME_MAX && MOCAP_MAX_RINGS == SRV_MAX_RINGS &&
		       MOCAP_MAX_KEYPOINTS == SRV_MAX_KEYPOINTS && MOCAP_MAX_CAMERAS >= MC_MAX_CAMERAS,
	       "limits");
_Static_assert(sizeof(MOCAP_DEFAULT_SOCKET) == sizeof(SRV_DEFAULT_PATH), "default socket path");

static char dir[48], path[96];

static uint64_t now_ns(void) { return mocap_now_ns(); }

static void sleep_ms(double ms)
{
	struct timespec ts = {(time_t)(ms / 1000), (long)(fmod(ms, 1000) * 1e6)};
	nanosleep(&ts, NULL);
}

static srv_server *make_server(int max_clients, int queue_len)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	cfg.max_clients = max_clients;
	cfg.queue_len = queue_len;
	cfg.socket_mode = 0666;
	mc_err err = {{0}};
	srv_server *srv = srv_create(&cfg, &err);
	CHECK_MSG(srv != NULL, "%s", err.msg);
	if (!srv)
		exit(1);
	srv_skeleton_def def = {0};
	def.njoints = NJ;
	for (int j = 0; j < NJ; j++) {
		snprintf(def.name[j], sizeof(def.name[j]), "joint_%d", j);
		def.parent[j] = j - 1;
		def.rest_offset[j] = mc_v3(0.01 * j, 0, 0);
	}
	CHECK(srv_set_skeleton_def(srv, &def, &err) == 0);
	return srv;
}

/* The skeleton of frame `seq`: values a client can check. */
static void make_skeleton(mc_skeleton *sk, uint64_t seq)
{
	memset(sk, 0, sizeof(*sk));
	sk->timestamp_ns = now_ns() - 1000000;
	sk->state = (mc_track_state)(seq % 3);
	sk->njoints = NJ;
	for (int j = 0; j < NJ; j++) {
		sk->joints[j].position = mc_v3((double)seq, j * 0.1, -1.0);
		sk->joints[j].orientation = mc_quat_from_rotvec(mc_v3(0, 0.01 * j, 0));
		sk->joints[j].confidence = 0.5f;
	}
}

static bool frame_matches(const mocap_skeleton_frame *f)
{
	if (f->njoints != NJ || f->state != (mocap_track_state)(f->seq % 3))
		return false;
	for (int j = 0; j < NJ; j++) {
		mc_quat q = mc_quat_from_rotvec(mc_v3(0, 0.01 * j, 0));
		const mocap_joint *jt = &f->joints[j];
		if (jt->position[0] != (double)f->seq || fabs(jt->position[1] - j * 0.1) > 1e-12 ||
		    jt->position[2] != -1.0 || jt->orientation[0] != q.w || jt->orientation[2] != q.y ||
		    jt->confidence != 0.5f)
			return false;
	}
	return true;
}

/* --- A publisher thread: the daemon's tracking loop. --- */

typedef struct {
	srv_server *srv;
	int frames;
	double rate_hz;
	uint64_t first_seq;
	atomic_int published;
	uint64_t max_publish_ns; /* longest srv_publish call */
	pthread_t thread;
} publisher;

static void *publish_loop(void *arg)
{
	publisher *p = arg;
	mc_skeleton *sk = malloc(sizeof(*sk));
	uint64_t period = (uint64_t)(1e9 / p->rate_hz), next = now_ns();
	for (int i = 0; i < p->frames; i++) {
		make_skeleton(sk, p->first_seq + (uint64_t)i);
		mc_err err;
		uint64_t t0 = now_ns();
		int rc = srv_publish(p->srv, sk, p->first_seq + (uint64_t)i, &err);
		uint64_t dt = now_ns() - t0;
		CHECK_MSG(rc == 0, "%s", err.msg);
		if (dt > p->max_publish_ns)
			p->max_publish_ns = dt;
		atomic_fetch_add(&p->published, 1);
		next += period;
		uint64_t t = now_ns();
		if (next > t)
			sleep_ms((double)(next - t) * 1e-6);
	}
	free(sk);
	return NULL;
}

static void publisher_start(publisher *p, srv_server *srv, int frames, double rate, uint64_t first_seq)
{
	memset(p, 0, sizeof(*p));
	p->srv = srv;
	p->frames = frames;
	p->rate_hz = rate;
	p->first_seq = first_seq;
	pthread_create(&p->thread, NULL, publish_loop, p);
}

/* --- Tests --- */

static void test_receive(void)
{
	srv_server *srv = make_server(8, 256);
	mocap_client *c = mocap_connect(path, "test");
	CHECK_MSG(c != NULL, "%s", mocap_errmsg());
	CHECK(mocap_is_privileged(c));
	mocap_skeleton_def *s = malloc(sizeof(*s));
	CHECK(mocap_get_skeleton(c, s) == 0 && s->njoints == NJ && strcmp(s->joints[3].name, "joint_3") == 0 &&
	      s->joints[3].parent == 2 && fabs(s->joints[3].rest_offset[0] - 0.03) < 1e-12);
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	CHECK(mocap_read_frame(c, f, 0) == MOCAP_E_ARG); /* not subscribed */
	CHECK(mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
	publisher p;
	publisher_start(&p, srv, 100, 500, 1);
	int got = 0;
	uint64_t expect = 1;
	while (got < 100) {
		int r = mocap_read_frame(c, f, 2000);
		CHECK(r == 1);
		if (r != 1)
			break;
		CHECK(f->seq == expect && f->missed == 0 && f->skeleton_id == s->id && f->space == MOCAP_SPACE_RIG);
		CHECK_MSG(frame_matches(f), "frame %llu differs from what was published", (unsigned long long)f->seq);
		CHECK(f->publish_ns >= f->capture_ns && f->receive_ns >= f->publish_ns);
		expect = f->seq + 1;
		got++;
	}
	pthread_join(p.thread, NULL);
	CHECK(mocap_read_frame(c, f, 50) == 0); /* nothing more: timeout */
	/* The pollable fd is quiet when nothing waits, readable when a frame does. */
	struct pollfd pf = {.fd = mocap_fd(c), .events = POLLIN};
	CHECK(poll(&pf, 1, 0) == 0);
	mc_skeleton sk;
	make_skeleton(&sk, 101);
	mc_err err;
	CHECK(srv_publish(srv, &sk, 101, &err) == 0);
	CHECK(poll(&pf, 1, 2000) == 1);
	CHECK(mocap_read_frame(c, f, 0) == 1 && f->seq == 101);
	mocap_close(c);
	free(s);
	free(f);
	srv_destroy(srv);
}

typedef struct {
	int index;
	int frames_wanted;
	int received, out_of_order, missed, bad;
	bool connected;
	atomic_int *ready;
} reader_arg;

static void *reader_thread(void *arg)
{
	reader_arg *r = arg;
	mocap_client *c = mocap_connect(path, "reader");
	if (!c) {
		fprintf(stderr, "reader %d: %s\n", r->index, mocap_errmsg());
		atomic_fetch_add(r->ready, 1);
		return NULL;
	}
	r->connected = mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0;
	atomic_fetch_add(r->ready, 1);
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	uint64_t expect = 1;
	while (r->connected && r->received < r->frames_wanted) {
		int rc = mocap_read_frame(c, f, 5000);
		if (rc != 1)
			break;
		r->received++;
		r->missed += (int)f->missed;
		r->out_of_order += f->seq != expect;
		r->bad += !frame_matches(f);
		expect = f->seq + 1;
	}
	free(f);
	mocap_close(c);
	return NULL;
}

static void test_64_clients(void)
{
	enum { N = 64, FRAMES = 120 };
	srv_server *srv = make_server(N, 256);
	pthread_t th[N];
	reader_arg args[N];
	atomic_int ready = 0;
	for (int i = 0; i < N; i++) {
		args[i] = (reader_arg){.index = i, .frames_wanted = FRAMES, .ready = &ready};
		pthread_create(&th[i], NULL, reader_thread, &args[i]);
	}
	while (atomic_load(&ready) < N)
		sleep_ms(5);
	srv_stats st;
	srv_get_stats(srv, &st);
	CHECK_MSG(st.clients == N, "%d clients connected", st.clients);
	publisher p;
	publisher_start(&p, srv, FRAMES, 120, 1);
	pthread_join(p.thread, NULL);
	int complete = 0;
	for (int i = 0; i < N; i++) {
		pthread_join(th[i], NULL);
		CHECK(args[i].connected);
		complete += args[i].received == FRAMES && !args[i].missed && !args[i].out_of_order && !args[i].bad;
	}
	CHECK_MSG(complete == N, "%d of %d clients got all %d frames intact and in order", complete, N, FRAMES);
	printf("64 clients: all %d received %d frames in order; longest publish call %.1f us\n", complete, FRAMES,
	       (double)p.max_publish_ns * 1e-3);
	srv_destroy(srv);
}

/* A client in "all" mode that reads too slowly must get gap messages, and
 * its frames plus the frames reported missing must account for every
 * frame published; a fast client keeps getting every frame on time, and
 * publishing never blocks, not even with a client that never reads. */
typedef struct {
	mocap_client *c;
	uint64_t last_seq;
	uint64_t received, missed, gaps;
	bool consistent;
} slow_arg;

static void *slow_reader(void *arg)
{
	slow_arg *a = arg;
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	uint64_t expect = 1;
	a->consistent = true;
	while (expect <= a->last_seq && mocap_read_frame(a->c, f, 3000) == 1) {
		a->received++;
		a->missed += f->missed;
		a->gaps += f->missed > 0;
		a->consistent &= f->seq == expect + f->missed && frame_matches(f);
		expect = f->seq + 1;
		sleep_ms(10); /* a slow consumer: 100 frames/s against 600 published */
	}
	free(f);
	return NULL;
}

static void test_slow_client(void)
{
	enum { FRAMES = 600 };
	srv_server *srv = make_server(8, 16);
	slow_arg slow = {.last_seq = FRAMES + 1};
	slow.c = mocap_connect(path, "slow");
	CHECK(slow.c && mocap_subscribe(slow.c, MOCAP_ALL, MOCAP_SPACE_RIG, 16) == 0);
	/* A stuck client: subscribed, never reads anything. */
	mocap_client *stuck = mocap_connect(path, "stuck");
	CHECK(stuck && mocap_subscribe(stuck, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
	reader_arg fast = {.index = 0, .frames_wanted = FRAMES};
	atomic_int ready = 0;
	fast.ready = &ready;
	pthread_t ft, st_thread;
	pthread_create(&ft, NULL, reader_thread, &fast);
	pthread_create(&st_thread, NULL, slow_reader, &slow);
	while (atomic_load(&ready) < 1)
		sleep_ms(5);

	publisher p;
	uint64_t t0 = now_ns();
	publisher_start(&p, srv, FRAMES, 600, 1);
	pthread_join(p.thread, NULL);
	double publish_s = (double)(now_ns() - t0) * 1e-9;
	pthread_join(ft, NULL);
	double fast_s = (double)(now_ns() - t0) * 1e-9;
	CHECK_MSG(fast.received == FRAMES && fast.missed == 0 && fast.out_of_order == 0,
		  "fast client: %d frames, %d missed, %d out of order", fast.received, fast.missed, fast.out_of_order);
	CHECK_MSG(fast_s < publish_s + 1.0, "fast client finished %.2f s after publishing ended", fast_s - publish_s);
	/* Publishing waits for no client: a call that waited for the stuck
	 * one would never return.  The bound only allows for a loaded
	 * machine descheduling the publisher; bench_ipc reports the figures. */
	CHECK_MSG(p.max_publish_ns < 200000000, "a publish call took %.2f ms", (double)p.max_publish_ns * 1e-6);

	/* A last frame once the slow client has caught up: the gap of the
	 * tail it lost is reported with it. */
	sleep_ms(1500);
	mc_skeleton sk;
	make_skeleton(&sk, FRAMES + 1);
	mc_err err;
	srv_publish(srv, &sk, FRAMES + 1, &err);
	pthread_join(st_thread, NULL);
	CHECK_MSG(slow.gaps >= 1, "the slow client saw %llu gaps", (unsigned long long)slow.gaps);
	CHECK_MSG(slow.consistent, "a frame's seq does not follow the previous one plus its gap");
	CHECK_MSG(slow.received + slow.missed == FRAMES + 1, "received %llu + missed %llu != %d",
		  (unsigned long long)slow.received, (unsigned long long)slow.missed, FRAMES + 1);
	CHECK(slow.received < FRAMES);
	srv_stats st;
	srv_get_stats(srv, &st);
	CHECK(st.client_drops > 0);
	mocap_daemon_status ds;
	CHECK(mocap_get_status(slow.c, &ds) == 0 && ds.client_drops >= st.client_drops && ds.clients == 2);
	printf("slow client: %llu frames, %llu missed in %llu gaps; fast client on time; publish <= %.1f us\n",
	       (unsigned long long)slow.received, (unsigned long long)slow.missed, (unsigned long long)slow.gaps,
	       (double)p.max_publish_ns * 1e-3);
	mocap_close(slow.c);
	mocap_close(stuck);
	srv_destroy(srv);
}

static void test_latest(void)
{
	srv_server *srv = make_server(8, 256);
	mocap_client *c = mocap_connect(path, "vr");
	CHECK(c && mocap_subscribe(c, MOCAP_LATEST, MOCAP_SPACE_RIG, 0) == 0);
	mc_skeleton sk;
	mc_err err;
	for (uint64_t s = 1; s <= 50; s++) {
		make_skeleton(&sk, s);
		srv_publish(srv, &sk, s, &err);
	}
	/* The reply to a ping comes after every frame published before it. */
	CHECK(mocap_ping(c, NULL) == 0);
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	CHECK(mocap_read_frame(c, f, 1000) == 1 && f->seq == 50 && frame_matches(f));
	CHECK(mocap_read_frame(c, f, 50) == 0); /* older frames are gone, not queued */
	free(f);
	mocap_close(c);
	srv_destroy(srv);
}

/* One client, two threads: one reads every frame, the other makes
 * requests meanwhile.  Replies reach the asking thread; no frame is lost
 * or reordered although the requester may have read them off the socket. */
typedef struct {
	mocap_client *c;
	int ok, failed;
} requester_arg;

static void *requester(void *arg)
{
	requester_arg *r = arg;
	for (int i = 0; i < 150; i++) {
		mocap_daemon_status st;
		mocap_skeleton_def *s = malloc(sizeof(*s));
		int a = mocap_get_status(r->c, &st);
		int b = mocap_ping(r->c, NULL);
		int d = mocap_get_skeleton(r->c, s);
		if (!a && !b && !d && s->njoints == NJ)
			r->ok++;
		else
			r->failed++;
		free(s);
	}
	return NULL;
}

static void test_threads(void)
{
	enum { FRAMES = 300 };
	srv_server *srv = make_server(8, 1024);
	mocap_client *c = mocap_connect(path, "threads");
	CHECK(c && mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 1024) == 0);
	requester_arg ra = {c, 0, 0};
	pthread_t rt;
	pthread_create(&rt, NULL, requester, &ra);
	publisher p;
	publisher_start(&p, srv, FRAMES, 400, 1);
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	uint64_t expect = 1;
	int got = 0, bad = 0;
	while (got < FRAMES && mocap_read_frame(c, f, 3000) == 1) {
		bad += f->seq != expect || f->missed || !frame_matches(f);
		expect = f->seq + 1;
		got++;
	}
	pthread_join(p.thread, NULL);
	pthread_join(rt, NULL);
	CHECK_MSG(got == FRAMES && bad == 0, "reader: %d frames, %d bad", got, bad);
	CHECK_MSG(ra.ok == 150 && ra.failed == 0, "requester: %d ok, %d failed (%s)", ra.ok, ra.failed, mocap_errmsg());
	free(f);
	mocap_close(c);
	srv_destroy(srv);
}

/* The daemon's side of control: poll, run, answer. */
typedef struct {
	srv_server *srv;
	atomic_bool stop;
	int handled;
	srv_control last;
} daemon_arg;

static void *daemon_loop(void *arg)
{
	daemon_arg *d = arg;
	while (!atomic_load(&d->stop)) {
		struct pollfd pf = {.fd = srv_event_fd(d->srv), .events = POLLIN};
		if (poll(&pf, 1, 20) <= 0)
			continue;
		srv_control ctl;
		while (srv_poll_control(d->srv, &ctl) == 1) {
			d->last = ctl;
			d->handled++;
			if (ctl.command == MC_CONTROL_RELOAD)
				srv_control_done(d->srv, ctl.token, 0, "reloaded mocapd.conf");
			else
				srv_control_done(d->srv, ctl.token, 1, "cannot record: disk full");
		}
		/* The event fd is reset once no control request is left. */
		pf.revents = 0;
		if (poll(&pf, 1, 0) == 1 && srv_poll_control(d->srv, &ctl) == 0)
			CHECK_MSG(poll(&pf, 1, 0) == 0, "event fd readable with no control request waiting");
	}
	return NULL;
}

static void test_control(void)
{
	srv_server *srv = make_server(8, 256);
	daemon_arg d = {.srv = srv};
	pthread_t dt;
	pthread_create(&dt, NULL, daemon_loop, &d);
	mocap_client *c = mocap_connect(path, "ctl");
	char msg[256];
	CHECK(mocap_control(c, MOCAP_CMD_RELOAD, NULL, msg, sizeof(msg)) == 0 && strcmp(msg, "reloaded mocapd.conf") == 0);
	CHECK(d.last.command == MC_CONTROL_RELOAD && d.last.pid == getpid() && d.last.uid == getuid());
	CHECK(mocap_control(c, MOCAP_CMD_RECORD_START, "/tmp/take1", msg, sizeof(msg)) == MOCAP_E_FAILED);
	CHECK(strcmp(msg, "cannot record: disk full") == 0 && strcmp(mocap_errmsg(), "cannot record: disk full") == 0);
	CHECK(strcmp(d.last.argument, "/tmp/take1") == 0);
	CHECK(d.handled == 2);
	/* Refused by the server before the daemon sees them, as ERROR
	 * invalid: an argument to a command that takes none, and an unknown
	 * command (docs/PROTOCOL.md, CONTROL). */
	const mocap_command none[] = {MOCAP_CMD_RELOAD, MOCAP_CMD_RECORD_STOP, MOCAP_CMD_RECORD_STATUS,
				      MOCAP_CMD_RECORD_LIST};
	for (size_t i = 0; i < sizeof(none) / sizeof(none[0]); i++) {
		int rc = mocap_control(c, none[i], "extra", msg, sizeof(msg));
		CHECK_MSG(rc == MOCAP_E_REFUSED && strstr(mocap_errmsg(), "takes no argument"), "command %d: %d %s",
			  (int)none[i], rc, mocap_errmsg());
	}
	CHECK(mocap_control(c, (mocap_command)99, NULL, msg, sizeof(msg)) == MOCAP_E_REFUSED);
	CHECK_MSG(d.handled == 2, "the daemon saw %d commands, 2 were valid", d.handled);
	/* A daemon that never answers: the client times out. */
	atomic_store(&d.stop, true);
	pthread_join(dt, NULL);
	mocap_set_timeout(c, 200);
	CHECK(mocap_control(c, MOCAP_CMD_RELOAD, NULL, NULL, 0) == MOCAP_E_TIMEOUT);
	mocap_close(c);
	srv_destroy(srv);
}

/* Run as another user (re-executed by test_permissions). */
static int unprivileged_client(const char *sock)
{
	mocap_client *c = mocap_connect(sock, "nobody");
	if (!c) {
		fprintf(stderr, "unprivileged: %s\n", mocap_errmsg());
		return 10;
	}
	int fails = 0;
	if (mocap_is_privileged(c))
		fails |= 1;
	if (mocap_control(c, MOCAP_CMD_RELOAD, NULL, NULL, 0) != MOCAP_E_PERMISSION ||
	    !strstr(mocap_errmsg(), "only to mocapd's user and group"))
		fails |= 2;
	mocap_ring rings[4];
	if (mocap_get_rings(c, rings, 4) != MOCAP_E_PERMISSION)
		fails |= 4;
	mocap_daemon_status st;
	if (mocap_get_status(c, &st) != 0) /* reading is allowed to anyone who can connect */
		fails |= 8;
	mocap_keypoint kp = {0, 1, 1, 1};
	mocap_send_keypoints(c, 1, 0, &kp, 1);
	mocap_ping(c, NULL);
	if (mocap_send_keypoints(c, 1, 0, &kp, 1) != MOCAP_E_PERMISSION)
		fails |= 16;
	mocap_close(c);
	return fails;
}

static void test_permissions(const char *self)
{
	if (geteuid() != 0) {
		printf("permission test not run: needs root to run a client as another user\n");
		return;
	}
	srv_server *srv = make_server(8, 256);
	chmod(dir, 0755);
	pid_t pid = fork();
	if (pid == 0) {
		if (setgroups(0, NULL) || setgid(65534) || setuid(65534))
			_exit(20);
		execl(self, self, "--unprivileged-client", path, (char *)NULL);
		_exit(21);
	}
	int status = 0;
	waitpid(pid, &status, 0);
	CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 0, "unprivileged client: exit %d",
		  WIFEXITED(status) ? WEXITSTATUS(status) : -1);
	srv_destroy(srv);
}

static void test_inputs_and_world(void)
{
	srv_server *srv = make_server(8, 256);
	mc_err err;
	CHECK(srv_set_rig(srv, "{}", 2, &err) == 0);
	mocap_client *c = mocap_connect(path, "vr-runtime");
	/* Keypoints reach the daemon. */
	mocap_keypoint kp[3] = {{0, 10, 20, 0.9f}, {5, 30, 40, 0.5f}, {17, 50, 60, 1.0f}};
	CHECK(mocap_send_keypoints(c, 12345, 1, kp, 3) == 0);
	CHECK(mocap_ping(c, NULL) == 0); /* the server has handled it by now */
	srv_keypoints got;
	CHECK(srv_poll_keypoints(srv, &got) == 1);
	CHECK(got.capture_ns == 12345 && got.cam == 1 && got.nkeypoints == 3 && got.pid == getpid());
	CHECK(got.keypoints[1].joint == 5 && got.keypoints[1].u == 30 && got.keypoints[1].v == 40 &&
	      fabs(got.keypoints[1].conf - 0.5) < 1e-7 && got.keypoints[2].cam == 1);
	CHECK(srv_poll_keypoints(srv, &got) == 0);
	/* A bad camera is refused; the next send says so. */
	CHECK(mocap_send_keypoints(c, 1, 2, kp, 1) == 0);
	mocap_ping(c, NULL);
	CHECK(mocap_send_keypoints(c, 1, 0, kp, 1) == MOCAP_E_REFUSED && strstr(mocap_errmsg(), "the rig has 2 cameras"));
	kp[0].joint = NJ;
	CHECK(mocap_send_keypoints(c, 1, 0, kp, 1) == 0);
	mocap_ping(c, NULL);
	CHECK(mocap_send_keypoints(c, 1, 0, kp, 0) == MOCAP_E_REFUSED && strstr(mocap_errmsg(), "joint 18"));
	kp[0].confidence = 2;
	CHECK(mocap_send_keypoints(c, 1, 0, kp, 1) == MOCAP_E_ARG);

	/* World frame: head poses at t0 and t0 + 10 ms, a frame in between. */
	mocap_client *w = mocap_connect(path, "world");
	CHECK(mocap_subscribe(w, MOCAP_ALL, MOCAP_SPACE_WORLD, 0) == 0);
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	mc_skeleton sk;
	make_skeleton(&sk, 1);
	sk.timestamp_ns = 1000000000;
	/* No head pose yet: sent in rig space, and marked so. */
	srv_publish(srv, &sk, 1, &err);
	CHECK(mocap_read_frame(w, f, 2000) == 1 && f->space == MOCAP_SPACE_RIG && f->joints[2].position[0] == 1.0);
	double q90[4] = {cos(M_PI / 4), 0, 0, sin(M_PI / 4)}; /* 90 degrees about z */
	double pa[3] = {1, 2, 3}, pb[3] = {1.2, 2, 3};
	CHECK(mocap_send_head_pose(w, 995000000, pa, q90) == 0);
	CHECK(mocap_send_head_pose(w, 1005000000, pb, q90) == 0);
	double bad_q[4] = {1, 1, 0, 0};
	CHECK(mocap_send_head_pose(w, 1005000000, pb, bad_q) == MOCAP_E_ARG);
	/* 1e308 m is finite but no play area: the server refuses it (issue
	 * 20, defect 8), and the pose it keeps is the last sane one */
	double far[3] = {1e308, 0, 0};
	mocap_send_head_pose(w, 1006000000, far, q90);
	mocap_ping(w, NULL);
	srv_head_pose hp;
	CHECK(srv_latest_head_pose(srv, &hp) == 1 && hp.timestamp_ns == 1005000000);
	int refused = mocap_send_head_pose(w, 1005000000, pb, q90);
	CHECK_MSG(refused != 0 && strstr(mocap_errmsg(), "at most 10000 m"), "after a far head pose: %d %s", refused,
		  mocap_errmsg());
	make_skeleton(&sk, 2);
	sk.timestamp_ns = 1000000000;
	srv_publish(srv, &sk, 2, &err);
	CHECK(mocap_read_frame(w, f, 2000) == 1 && f->seq == 2 && f->space == MOCAP_SPACE_WORLD);
	/* Joint 2 in rig space: (2, 0.2, -1); rotated 90 deg about z:
	 * (-0.2, 2, -1); plus the interpolated translation (1.1, 2, 3). */
	CHECK_NEAR(f->joints[2].position[0], 0.9, 1e-9);
	CHECK_NEAR(f->joints[2].position[1], 4.0, 1e-9);
	CHECK_NEAR(f->joints[2].position[2], 2.0, 1e-9);
	mc_quat qj = mc_quat_mul(mc_quat_from_rotvec(mc_v3(0, 0, M_PI / 2)), mc_quat_from_rotvec(mc_v3(0, 0.02, 0)));
	CHECK_NEAR(f->joints[2].orientation[0], qj.w, 1e-9);
	CHECK_NEAR(f->joints[2].orientation[2], qj.y, 1e-9);
	CHECK_NEAR(f->joints[2].orientation[3], qj.z, 1e-9);
	/* A frame long after the last head pose: not in world space. */
	sk.timestamp_ns = 2000000000;
	srv_publish(srv, &sk, 3, &err);
	CHECK(mocap_read_frame(w, f, 2000) == 1 && f->space == MOCAP_SPACE_RIG);
	free(f);
	mocap_close(w);
	mocap_close(c);
	srv_destroy(srv);
}

/* The keypoint inbox the tracking thread reads: oldest first, bounded (a
 * full inbox drops its oldest batch and counts it), and the event fd
 * readable exactly while a batch waits. */
static void test_keypoint_inbox(void)
{
	srv_server *srv = make_server(8, 256);
	mc_err err;
	CHECK(srv_set_rig(srv, "{}", 2, &err) == 0);
	srv_keypoint_inbox *inbox = srv_keypoints_inbox(srv);
	CHECK(inbox != NULL && srv_keypoints_inbox(srv) == inbox);
	mocap_client *c = mocap_connect(path, "detector");
	mocap_keypoint kp = {3, 10, 20, 0.5f};
	const int sent = 65; /* one more than the inbox holds */
	for (int i = 0; i < sent; i++)
		CHECK(mocap_send_keypoints(c, 1000 + (uint64_t)i, i % 2, &kp, 1) == 0);
	CHECK(mocap_ping(c, NULL) == 0); /* every batch is in by now */
	/* Waiting keypoints do not wake the main loop (only control requests do). */
	struct pollfd pf = {.fd = srv_event_fd(srv), .events = POLLIN};
	CHECK(poll(&pf, 1, 0) == 0);
	srv_stats st;
	srv_get_stats(srv, &st);
	CHECK(st.keypoint_drops == 1);
	srv_keypoints got;
	int n = 0;
	bool in_order = true;
	while (srv_inbox_pop_keypoints(inbox, &got) == 1) {
		in_order &= got.capture_ns == 1001 + (uint64_t)n && got.cam == (int)((1 + n) % 2) && got.nkeypoints == 1 &&
			    got.keypoints[0].joint == 3;
		n++;
	}
	CHECK_MSG(n == sent - 1 && in_order, "%d batches popped (in order: %d)", n, in_order);
	CHECK(poll(&pf, 1, 0) == 0);
	/* The old call reads the same inbox. */
	CHECK(mocap_send_keypoints(c, 5, 1, &kp, 1) == 0);
	CHECK(mocap_ping(c, NULL) == 0);
	CHECK(srv_poll_keypoints(srv, &got) == 1 && got.capture_ns == 5);
	CHECK(srv_inbox_pop_keypoints(inbox, &got) == 0);
	mocap_close(c);
	srv_destroy(srv);
}

static void test_rings(void)
{
	srv_server *srv = make_server(8, 256);
	mc_err err;
	mc_ring *ring = mc_ring_create("left", 4, 4096, &err);
	CHECK_MSG(ring != NULL, "%s", err.msg);
	if (!ring) {
		srv_destroy(srv);
		return;
	}
	size_t cap;
	uint8_t *slot = mc_ring_slot_begin(ring, &cap);
	memset(slot, 0xab, 100);
	mc_ring_meta meta = {.timestamp_ns = 77, .bytesused = 100, .width = 10, .height = 10, .pixfmt = MC_PIXFMT_GRAY8,
			     .stride = 10};
	CHECK(mc_ring_slot_commit(ring, &meta, &err) == 0);
	struct stat stt;
	fstat(mc_ring_fd(ring), &stt);
	CHECK(srv_add_ring(srv, "left", mc_ring_fd(ring), (uint64_t)stt.st_size, &err) == 0);

	mocap_client *c = mocap_connect(path, "preview");
	mocap_ring rings[4];
	int n = mocap_get_rings(c, rings, 4);
	CHECK(n == 1 && strcmp(rings[0].camera, "left") == 0 && rings[0].size == (uint64_t)stt.st_size);
	if (n == 1) {
		/* Read-only: a writable shared mapping is refused. */
		void *wmap = mmap(NULL, rings[0].size, PROT_READ | PROT_WRITE, MAP_SHARED, rings[0].fd, 0);
		CHECK(wmap == MAP_FAILED && errno == EACCES);
		mc_ring *rd = mc_ring_map(rings[0].fd, &err);
		CHECK_MSG(rd != NULL, "%s", err.msg);
		if (rd) {
			uint8_t buf[4096];
			mc_ring_cursor cur = mc_ring_cursor_oldest(rd);
			mc_ring_meta m2;
			CHECK(mc_ring_read_next(rd, &cur, buf, sizeof(buf), &m2, &err) == MC_RING_FRAME);
			CHECK(m2.timestamp_ns == 77 && m2.bytesused == 100 && buf[99] == 0xab);
			mc_ring_close(rd);
		}
		close(rings[0].fd);
	}
	/* Clearing withdraws them. */
	srv_clear_rings(srv);
	CHECK(mocap_get_rings(c, rings, 4) == 0);
	mocap_close(c);
	mc_ring_close(ring);
	srv_destroy(srv);
}

static void test_errors(void)
{
	/* No daemon: the message says so and names the path. */
	CHECK(mocap_connect(path, "x") == NULL && mocap_errcode() == MOCAP_E_NOT_RUNNING);
	CHECK(strstr(mocap_errmsg(), "daemon not running at ") && strstr(mocap_errmsg(), path));
	/* MOCAP_SOCKET is used when no path is given. */
	setenv("MOCAP_SOCKET", path, 1);
	CHECK(strcmp(mocap_default_socket(), path) == 0);
	srv_server *srv = make_server(8, 256);
	mocap_client *c = mocap_connect(NULL, "env");
	CHECK(c != NULL);
	unsetenv("MOCAP_SOCKET");
	CHECK(strcmp(mocap_default_socket(), MOCAP_DEFAULT_SOCKET) == 0);
	CHECK(strcmp(MOCAP_DEFAULT_SOCKET, SRV_DEFAULT_PATH) == 0);
	/* The daemon stops: calls fail with "disconnected", nothing hangs. */
	CHECK(mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
	srv_destroy(srv);
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	CHECK(mocap_read_frame(c, f, 2000) == MOCAP_E_DISCONNECTED && strstr(mocap_errmsg(), "stopping"));
	mocap_daemon_status st;
	CHECK(mocap_get_status(c, &st) == MOCAP_E_DISCONNECTED);
	free(f);
	mocap_close(c);
	/* Not a mocapd socket at all. */
	FILE *file = fopen(path, "w");
	fclose(file);
	CHECK(mocap_connect(path, "x") == NULL && mocap_errcode() == MOCAP_E_NOT_RUNNING);
	unlink(path);
}

int main(int argc, char **argv)
{
	if (argc == 3 && strcmp(argv[1], "--unprivileged-client") == 0)
		return unprivileged_client(argv[2]);
	snprintf(dir, sizeof(dir), "/tmp/mocap-ipc-XXXXXX");
	if (!mkdtemp(dir))
		TEST_SKIP("cannot create a temporary directory: %s", strerror(errno));
	snprintf(path, sizeof(path), "%s/mocapd.sock", dir);
	test_receive();
	test_64_clients();
	test_slow_client();
	test_latest();
	test_threads();
	test_control();
	test_permissions(argv[0]);
	test_inputs_and_world();
	test_keypoint_inbox();
	test_rings();
	test_errors();
	rmdir(dir);
	return mc_test_finish("test_ipc_client");
}
