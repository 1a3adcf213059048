/* The latest-pose block and prediction: a client maps the block
 * (libmocap), reads nothing before the first pose and the newest after,
 * waits for the next pose on the futex, never sees a torn pose while the
 * server writes at 1 kHz, and cannot write the block (a raw client that
 * gets the descriptor can map it read-only only).  mocap_predict is exact
 * on constant linear and angular velocity, clamps at its limit, holds
 * frames it cannot pair, and predicts from the block's two newest poses. */
#include "base/mc_time.h"
#include "mocap.h"
#include "pose_block.h"
#include "proto.h"
#include "server.h"
#include "ipc_fixture.h"
#include "test_util.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>

#define NJ 18

static char dir[48], path[96];

static void set_def(srv_server *srv) { ipc_set_chain_def(srv, NJ); }

/* Every joint of frame `seq` at (seq, j, -seq): a torn read mixes them. */
static mc_vec3 seq_position(uint64_t seq, int j) { return mc_v3((double)seq, j, -(double)seq); }

static int publish(srv_server *srv, uint64_t seq) { return ipc_publish(srv, seq, NJ, 1000000, seq_position); }

static bool consistent(const mocap_skeleton_frame *f)
{
	bool ok = f->njoints == NJ && f->capture_ns == f->seq * 1000000;
	for (int j = 0; ok && j < NJ; j++)
		ok = f->joints[j].position[0] == (double)f->seq && f->joints[j].position[1] == j &&
		     f->joints[j].position[2] == -(double)f->seq;
	return ok;
}

/* --- reading and waiting --- */

typedef struct {
	const mocap_pose_block *b;
	atomic_bool stop;
	long reads, torn, backwards;
} reader_arg;

static void *reader(void *arg)
{
	reader_arg *r = arg;
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	uint64_t last = 0;
	while (!atomic_load(&r->stop)) {
		if (mocap_pose_block_read(r->b, f) != 1)
			continue;
		r->reads++;
		r->torn += !consistent(f);
		r->backwards += f->seq < last;
		last = f->seq;
	}
	free(f);
	return NULL;
}

typedef struct {
	const mocap_pose_block *b;
	uint64_t after, seq, woke_ns;
	int rc;
} waiter_arg;

static void *waiter(void *arg)
{
	waiter_arg *w = arg;
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	w->rc = mocap_pose_block_wait(w->b, w->after, f, 5000);
	w->woke_ns = mc_now_ns();
	w->seq = f->seq;
	free(f);
	return NULL;
}

static void test_block(srv_server *srv)
{
	mocap_client *c = mocap_connect(path, "pose");
	CHECK_MSG(c, "%s", mocap_errmsg());
	mocap_pose_block *b = c ? mocap_pose_block_map(c) : NULL;
	CHECK_MSG(b, "%s", mocap_errmsg());
	if (!b) {
		mocap_close(c);
		return;
	}
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	CHECK(mocap_pose_block_read(b, f) == 0);
	CHECK(mocap_pose_block_predict(b, 0, f) == MOCAP_E_UNAVAILABLE);
	CHECK(mocap_pose_block_wait(b, 0, f, 50) == 0); /* times out */
	CHECK(publish(srv, 1) == 0 && publish(srv, 2) == 0);
	CHECK(mocap_pose_block_read(b, f) == 1 && f->seq == 2 && consistent(f) && f->skeleton_id > 0);
	CHECK(mocap_pose_block_wait(b, 1, f, 0) == 1 && f->seq == 2);

	/* A waiter blocked on the futex wakes for the next pose, long before
	 * its timeout. */
	pthread_t th;
	waiter_arg w = {.b = b, .after = 2};
	pthread_create(&th, NULL, waiter, &w);
	struct timespec pause = {0, 50000000};
	nanosleep(&pause, NULL);
	uint64_t t0 = mc_now_ns();
	CHECK(publish(srv, 3) == 0);
	pthread_join(th, NULL);
	CHECK_MSG(w.rc == 1 && w.seq == 3 && w.woke_ns >= t0 && w.woke_ns - t0 < 500000000ull,
		  "waiter: rc %d, seq %llu, %.3f ms after the publish", w.rc, (unsigned long long)w.seq,
		  (double)(w.woke_ns - t0) / 1e6);
	reader_arg r = {.b = b};

	/* Never torn: one reader spinning while the server writes at 1 kHz. */
	pthread_create(&th, NULL, reader, &r);
	for (uint64_t s = 4; s < 2004; s++) {
		publish(srv, s);
		struct timespec ts = {0, 1000000};
		nanosleep(&ts, NULL);
	}
	atomic_store(&r.stop, true);
	pthread_join(th, NULL);
	printf("pose block: %ld reads under a 1 kHz writer, %ld torn, %ld out of order\n", r.reads, r.torn,
	       r.backwards);
	CHECK(r.reads > 1000 && r.torn == 0 && r.backwards == 0);

	/* Prediction from the block: the joints move 1 m per ms along x. */
	uint64_t newest = 2003 * 1000000ull;
	CHECK(mocap_pose_block_predict(b, newest + 2000000, f) == 0);
	CHECK(fabs(f->joints[5].position[0] - 2005.0) < 1e-9 && f->capture_ns == newest + 2000000);
	free(f);
	mocap_pose_block_unmap(b);
	mocap_close(c);
}

/* A raw client asks for the block and tries to write through what it got. */
static void test_read_only(void)
{
	int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	snprintf(a.sun_path, sizeof(a.sun_path), "%s", path);
	CHECK(connect(fd, (struct sockaddr *)&a, sizeof(a)) == 0);
	static proto_msg m;
	uint8_t buf[PROTO_MAX_MESSAGE];
	memset(&m, 0, sizeof(m));
	m.h.type = MC_MSG_HELLO;
	m.h.request_id = 1;
	m.u.hello.magic = PROTO_MAGIC;
	m.u.hello.min_version = m.u.hello.max_version = PROTO_VERSION;
	size_t n = proto_encode(&m, buf, sizeof(buf));
	CHECK(send(fd, buf, n, 0) == (ssize_t)n && recv(fd, buf, sizeof(buf), 0) > 0);
	memset(&m, 0, sizeof(m));
	m.h.type = MC_MSG_GET_POSE_BLOCK;
	m.h.request_id = 2;
	n = proto_encode(&m, buf, sizeof(buf));
	CHECK(send(fd, buf, n, 0) == (ssize_t)n);
	union {
		char b[CMSG_SPACE(sizeof(int))];
		struct cmsghdr align;
	} ctl;
	struct iovec iov = {buf, sizeof(buf)};
	struct msghdr mh = {.msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl.b, .msg_controllen = sizeof(ctl.b)};
	ssize_t got = recvmsg(fd, &mh, 0);
	struct cmsghdr *cm = got > 0 ? CMSG_FIRSTHDR(&mh) : NULL;
	CHECK(cm && cm->cmsg_type == SCM_RIGHTS);
	if (cm) {
		int bfd;
		memcpy(&bfd, CMSG_DATA(cm), sizeof(int));
		CHECK(proto_decode(buf, (size_t)got, PROTO_FROM_SERVER, &m, NULL, 0) == 0 &&
		      m.h.type == MC_MSG_POSE_BLOCK && m.u.pose_block.size == POSE_BLOCK_SIZE);
		CHECK(mmap(NULL, POSE_BLOCK_SIZE, PROT_READ | PROT_WRITE, MAP_SHARED, bfd, 0) == MAP_FAILED);
		void *p = mmap(NULL, POSE_BLOCK_SIZE, PROT_READ, MAP_SHARED, bfd, 0);
		CHECK(p != MAP_FAILED && mprotect(p, POSE_BLOCK_SIZE, PROT_READ | PROT_WRITE) != 0);
		CHECK(pwrite(bfd, "x", 1, 0) < 0);
		CHECK(p != MAP_FAILED && ((const pose_block *)p)->magic == POSE_BLOCK_MAGIC);
		if (p != MAP_FAILED)
			munmap(p, POSE_BLOCK_SIZE);
		close(bfd);
	}
	close(fd);
}

/* --- prediction --- */

static void frame_at(mocap_skeleton_frame *f, uint64_t t_ns, double x, double angle_z)
{
	memset(f, 0, sizeof(*f));
	f->capture_ns = t_ns;
	f->skeleton_id = 1;
	f->njoints = 2;
	for (int j = 0; j < 2; j++) {
		f->joints[j].position[0] = x + j;
		f->joints[j].position[1] = 2 * x;
		f->joints[j].orientation[0] = cos(angle_z / 2);
		f->joints[j].orientation[3] = sin(angle_z / 2);
	}
}

static void test_predict(void)
{
	static mocap_skeleton_frame a, b, out;
	/* 1 m/s along x, 2 along y, 1 rad/s about z, 20 ms apart. */
	frame_at(&a, 1000000000ull, 1.00, 0.30);
	frame_at(&b, 1020000000ull, 1.02, 0.32);
	CHECK(mocap_predict(&a, &b, 1060000000ull, &out) == 0); /* +40 ms */
	CHECK_NEAR(out.joints[1].position[0], 1.06 + 1, 1e-12);
	CHECK_NEAR(out.joints[1].position[1], 2.12, 1e-12);
	CHECK_NEAR(2 * atan2(out.joints[0].orientation[3], out.joints[0].orientation[0]), 0.36, 1e-12);
	CHECK(out.capture_ns == 1060000000ull);
	CHECK(mocap_predict(&a, &b, 1010000000ull, &out) == 0); /* backwards, between the two */
	CHECK_NEAR(out.joints[0].position[0], 1.01, 1e-12);
	CHECK(mocap_predict(&a, &b, 1500000000ull, &out) == 1); /* clamped at +100 ms */
	CHECK_NEAR(out.joints[0].position[0], 1.12, 1e-12);
	CHECK(out.capture_ns == 1020000000ull + MOCAP_PREDICT_MAX_NS);
	/* Held: another skeleton, or the frames the wrong way round. */
	a.skeleton_id = 2;
	CHECK(mocap_predict(&a, &b, 1060000000ull, &out) == 2 && out.joints[0].position[0] == 1.02);
	a.skeleton_id = 1;
	CHECK(mocap_predict(&b, &a, 1060000000ull, &out) == 2);
	CHECK(mocap_predict(NULL, &b, 1060000000ull, &out) == 2);
	CHECK(mocap_predict(&a, NULL, 0, &out) == MOCAP_E_ARG);
	/* In place, and through a half turn (the shorter way is kept). */
	frame_at(&a, 0, 0, 3.0);
	frame_at(&b, 10000000, 0, 3.1);
	CHECK(mocap_predict(&a, &b, 20000000, &b) == 0);
	double angle = 2 * atan2(b.joints[0].orientation[3], b.joints[0].orientation[0]);
	CHECK_NEAR(angle, 3.2, 1e-9); /* on by +0.1 rad, not back the long way */
}

int main(void)
{
	snprintf(dir, sizeof(dir), "/tmp/mc_pose_XXXXXX");
	if (!mkdtemp(dir))
		TEST_SKIP("no temporary directory");
	snprintf(path, sizeof(path), "%s/s.sock", dir);
	test_predict();
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	mc_err err = {{0}};
	srv_server *srv = srv_create(&cfg, &err);
	CHECK_MSG(srv, "%s", err.msg);
	if (srv) {
		set_def(srv);
		test_block(srv);
		test_read_only();
		srv_destroy(srv);
	}
	rmdir(dir);
	return mc_test_failures ? 1 : 0;
}
