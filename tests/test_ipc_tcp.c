/* Clients on other machines: the server's TCP listener on loopback.
 *
 * At the protocol level (raw TCP sockets, length-prefixed messages): a
 * connection must start with AUTH and the right token or it is closed
 * (no token, a wrong one, a request before AUTH), a bad length prefix
 * closes it, a message trickled in one byte at a time is read whole.
 * Through libmocap (tcp://): a client on TCP receives exactly the frames a
 * client on the Unix socket receives, a large reply (the rig) arrives
 * whole, a client that stops reading loses frames as counted gaps while
 * its stream stays framed, and the privileges: none by default, control
 * and inputs with tcp_privileged, never rings. */
#include "mocap.h"
#include "proto.h"
#include "server.h"
#include "base/mc_time.h"
#include "ipc_fixture.h"
#include "test_util.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdint.h>
#include <sys/socket.h>
#include <time.h>

#define TOKEN "test-token-0123456789abcdef"
#define NJ 24

static char dir[48], path[96], addr[64];
static int port;
static proto_msg rx, tx;

static void sleep_ms(int ms)
{
	struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
	nanosleep(&ts, NULL);
}

static srv_server *make_server(bool privileged, const char *listen, const char *token, mc_err *err)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	snprintf(cfg.tcp_listen, sizeof(cfg.tcp_listen), "%s", listen);
	snprintf(cfg.tcp_token, sizeof(cfg.tcp_token), "%s", token);
	cfg.tcp_privileged = privileged;
	cfg.queue_len = 16;
	return srv_create(&cfg, err);
}

static void set_def(srv_server *srv) { ipc_set_chain_def(srv, NJ); }

static mc_vec3 odd_position(uint64_t seq, int j) { return mc_v3((double)seq, j * 0.25, -1.0 / (1 + (double)seq)); }

static void publish(srv_server *srv, uint64_t seq)
{
	/* A full mailbox (the server thread 128 frames behind) refuses the
	 * frame: give the server thread time now and then, and when it is
	 * behind all the same (ASan on a loaded machine: make check failed
	 * here), wait for it and publish the frame again. */
	if (seq % 64 == 0)
		sleep_ms(2);
	int tries = 0;
	while (ipc_publish(srv, seq, NJ, 1000, odd_position) != 0 && ++tries < 2000)
		sleep_ms(1);
	CHECK_MSG(tries < 2000, "frame %llu: the server thread took nothing for 2 s", (unsigned long long)seq);
}

/* --- Raw TCP --- */

static int tcp_connect(void)
{
	int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (connect(fd, (struct sockaddr *)&a, sizeof(a)) != 0) {
		close(fd);
		return -1;
	}
	return fd;
}

/* Sends tx with its length prefix, `chunk` bytes per write (0: at once). */
static int tcp_send(int fd, size_t chunk)
{
	uint8_t buf[8192];
	size_t n = proto_encode(&tx, buf + 4, sizeof(buf) - 4);
	if (!n)
		return -1;
	for (int i = 0; i < 4; i++)
		buf[i] = (uint8_t)(n >> (8 * i));
	n += 4;
	for (size_t at = 0; at < n;) {
		size_t k = chunk && chunk < n - at ? chunk : n - at;
		if (send(fd, buf + at, k, MSG_NOSIGNAL) != (ssize_t)k)
			return -1;
		at += k;
		if (chunk)
			sleep_ms(2);
	}
	return 0;
}

static bool read_exact(int fd, uint8_t *p, size_t n)
{
	for (size_t at = 0; at < n;) {
		struct pollfd pf = {.fd = fd, .events = POLLIN};
		if (poll(&pf, 1, 3000) <= 0)
			return false;
		ssize_t r = recv(fd, p + at, n - at, 0);
		if (r <= 0)
			return false;
		at += (size_t)r;
	}
	return true;
}

/* 1 and rx filled, -1 end of stream or timeout. */
static int tcp_recv(int fd)
{
	static uint8_t buf[PROTO_MAX_MESSAGE];
	uint8_t pre[4];
	if (!read_exact(fd, pre, 4))
		return -1;
	uint32_t n = (uint32_t)pre[0] | (uint32_t)pre[1] << 8 | (uint32_t)pre[2] << 16 | (uint32_t)pre[3] << 24;
	CHECK_MSG(n >= PROTO_HEADER_SIZE && n <= PROTO_MAX_MESSAGE, "length prefix %u", n);
	if (n < PROTO_HEADER_SIZE || n > PROTO_MAX_MESSAGE || !read_exact(fd, buf, n))
		return -1;
	char why[256];
	int rc = proto_decode(buf, n, PROTO_FROM_SERVER, &rx, why, sizeof(why));
	CHECK_MSG(rc == 0, "server sent a malformed message: %s", why);
	return rc == 0 ? 1 : -1;
}

static void make_auth(const char *token)
{
	memset(&tx, 0, sizeof(tx));
	tx.h.type = MC_MSG_AUTH;
	tx.h.request_id = 7;
	snprintf(tx.u.auth.token, sizeof(tx.u.auth.token), "%s", token);
}

static void make_hello(void)
{
	memset(&tx, 0, sizeof(tx));
	tx.h.type = MC_MSG_HELLO;
	tx.h.request_id = 8;
	tx.u.hello.magic = PROTO_MAGIC;
	tx.u.hello.min_version = 1;
	tx.u.hello.max_version = PROTO_VERSION;
	strcpy(tx.u.hello.client_name, "raw-tcp");
}

/* A fatal ERROR with `code`, then the end of the stream. */
static bool refused_with(int fd, uint32_t code)
{
	bool got = tcp_recv(fd) == 1 && rx.h.type == MC_MSG_ERROR && rx.u.error.code == code && rx.u.error.fatal;
	return got && tcp_recv(fd) == -1;
}

static void test_raw_auth(srv_server *srv)
{
	srv_stats before, after;
	srv_get_stats(srv, &before);
	int fd = tcp_connect(); /* HELLO without AUTH */
	make_hello();
	CHECK(fd >= 0 && tcp_send(fd, 0) == 0);
	CHECK(refused_with(fd, PROTO_E_AUTH));
	close(fd);

	fd = tcp_connect(); /* a wrong token */
	make_auth("test-token-0123456789abcdeX");
	CHECK(tcp_send(fd, 0) == 0);
	CHECK(refused_with(fd, PROTO_E_AUTH));
	close(fd);
	fd = tcp_connect(); /* a prefix of the right one */
	make_auth("test-token-0123456789abcde");
	CHECK(tcp_send(fd, 0) == 0);
	CHECK(refused_with(fd, PROTO_E_AUTH));
	close(fd);
	srv_get_stats(srv, &after);
	CHECK(after.refused == before.refused + 2);

	fd = tcp_connect(); /* a length prefix out of range */
	uint8_t bad[8] = {5, 0, 0, 0, 1, 2, 3, 4};
	CHECK(send(fd, bad, sizeof(bad), MSG_NOSIGNAL) == (ssize_t)sizeof(bad));
	CHECK(refused_with(fd, PROTO_E_MALFORMED));
	close(fd);

	/* The right token, AUTH and HELLO trickled in 3-byte pieces. */
	fd = tcp_connect();
	make_auth(TOKEN);
	CHECK(tcp_send(fd, 3) == 0);
	CHECK(tcp_recv(fd) == 1 && rx.h.type == MC_MSG_OK && rx.u.ok.request_type == MC_MSG_AUTH &&
	      rx.h.request_id == 7);
	make_hello();
	CHECK(tcp_send(fd, 3) == 0);
	CHECK(tcp_recv(fd) == 1 && rx.h.type == MC_MSG_WELCOME && rx.u.welcome.version == PROTO_VERSION &&
	      !(rx.u.welcome.flags & MC_WELCOME_PRIVILEGED));
	make_auth(TOKEN); /* a second AUTH */
	CHECK(tcp_send(fd, 0) == 0);
	CHECK(refused_with(fd, PROTO_E_HANDSHAKE));
	close(fd);
}

/* TCP connections that never authenticate do not take local clients'
 * slots (issue 34 item 1: 64 of them locked every Unix-socket client out
 * until the handshake deadline dropped them, and were re-opened): at most
 * SRV_MAX_PENDING_TCP_PER_HOST wait from one address, the others are
 * refused at once, and a local client is served within 1 s. */
static void test_pending_flood(void)
{
	enum { FLOOD = 70 };
	int fds[FLOOD], refused = 0;
	for (int i = 0; i < FLOOD; i++)
		fds[i] = tcp_connect();
	sleep_ms(300); /* the server thread accepts them */
	for (int i = 0; i < FLOOD; i++) {
		struct pollfd p = {.fd = fds[i], .events = POLLIN};
		if (fds[i] >= 0 && poll(&p, 1, 0) == 1 && refused_with(fds[i], PROTO_E_TOO_MANY_CLIENTS))
			refused++;
	}
	uint64_t start = mc_now_ns();
	mocap_client *c = mocap_connect(path, "local-during-flood");
	double ms = (double)(mc_now_ns() - start) * 1e-6;
	printf("TCP flood: %d of %d unauthenticated connections refused; a Unix client %s in %.1f ms\n", refused,
	       FLOOD, c ? "connected" : "was refused", ms);
	CHECK_MSG(c != NULL && ms < 1000, "a Unix client during the flood: %s", c ? "slow" : mocap_errmsg());
	CHECK_MSG(refused >= FLOOD - 8, "only %d of %d waiting TCP connections refused", refused, FLOOD);
	if (c) {
		uint64_t t = 0;
		CHECK(mocap_ping(c, &t) == 0);
		mocap_close(c);
	}
	for (int i = 0; i < FLOOD; i++)
		if (fds[i] >= 0)
			close(fds[i]);
	sleep_ms(100); /* the server sees them go */
}

/* --- libmocap --- */

static void test_client_errors(void)
{
	unsetenv("MOCAP_TOKEN");
	unsetenv("MOCAP_TOKEN_FILE");
	CHECK(mocap_connect(addr, "t") == NULL && mocap_errcode() == MOCAP_E_ACCESS &&
	      strstr(mocap_errmsg(), "MOCAP_TOKEN"));
	CHECK(mocap_connect_token(addr, "t", "wrong-token-but-long-enough") == NULL &&
	      mocap_errcode() == MOCAP_E_ACCESS && strstr(mocap_errmsg(), "wrong token"));
	CHECK(mocap_connect_token("tcp://127.0.0.1", "t", TOKEN) == NULL && mocap_errcode() == MOCAP_E_ARG);
	/* A port nobody listens on (the listener's, once it is closed, is
	 * unlikely to be taken again at once; the error is what matters). */
	mocap_client *c = mocap_connect_token("tcp://127.0.0.1:1", "t", TOKEN);
	CHECK(c == NULL && mocap_errcode() == MOCAP_E_NOT_RUNNING);

	char file[128];
	snprintf(file, sizeof(file), "%s/token", dir);
	FILE *f = fopen(file, "w");
	fprintf(f, "%s\n", TOKEN);
	fclose(f);
	setenv("MOCAP_TOKEN_FILE", file, 1);
	c = mocap_connect(addr, "from-file");
	CHECK_MSG(c != NULL, "%s", mocap_errmsg());
	if (c) {
		uint64_t t = 0;
		CHECK(mocap_ping(c, &t) == 0 && t > 0);
		mocap_close(c);
	}
	unsetenv("MOCAP_TOKEN_FILE");
}

/* Every frame, in order, the same on both transports. */
static void test_same_frames(srv_server *srv)
{
	mocap_client *u = mocap_connect(path, "unix");
	mocap_client *t = mocap_connect_token(addr, "tcp", TOKEN);
	CHECK_MSG(u && t, "%s", mocap_errmsg());
	if (!u || !t)
		return;
	CHECK(mocap_subscribe(u, MOCAP_ALL, MOCAP_SPACE_RIG, 512) == 0);
	CHECK(mocap_subscribe(t, MOCAP_ALL, MOCAP_SPACE_RIG, 512) == 0);
	enum { N = 300 };
	for (uint64_t s = 1; s <= N; s++) {
		publish(srv, s);
		if (s % 50 == 0)
			sleep_ms(5);
	}
	static mocap_skeleton_frame fu, ft;
	int same = 0;
	for (int i = 0; i < N; i++) {
		if (mocap_read_frame(u, &fu, 3000) != 1 || mocap_read_frame(t, &ft, 3000) != 1)
			break;
		bool eq = fu.seq == ft.seq && fu.capture_ns == ft.capture_ns && fu.publish_ns == ft.publish_ns &&
			  fu.njoints == NJ && ft.njoints == NJ && fu.missed == 0 && ft.missed == 0;
		for (int j = 0; eq && j < NJ; j++)
			eq = !memcmp(fu.joints[j].position, ft.joints[j].position, sizeof(fu.joints[j].position)) &&
			     !memcmp(fu.joints[j].orientation, ft.joints[j].orientation,
				     sizeof(fu.joints[j].orientation)) &&
			     fu.joints[j].confidence == ft.joints[j].confidence;
		same += eq && ft.seq == (uint64_t)i + 1;
	}
	CHECK_MSG(same == N, "%d of %d frames the same on TCP and on the Unix socket", same, N);
	mocap_daemon_status st;
	CHECK(mocap_get_status(t, &st) == 0 && st.clients >= 2);
	mocap_close(u);
	mocap_close(t);
}

/* A 60 KB reply goes out in many pieces and arrives whole. */
static void test_large_reply(srv_server *srv)
{
	static char json[60000];
	memset(json, ' ', sizeof(json) - 1);
	json[0] = '{';
	json[sizeof(json) - 2] = '}';
	json[1000] = 'x';
	mc_err err;
	CHECK(srv_set_rig(srv, json, 2, &err) == 0);
	mocap_client *t = mocap_connect_token(addr, "rig", TOKEN);
	char *got = NULL;
	int ncams = 0;
	CHECK(t && mocap_get_rig(t, &got, &ncams) == 0 && got && ncams == 2 && strcmp(got, json) == 0);
	free(got);
	mocap_close(t);
}

/* Counts what a raw subscriber gets: frames in order, gaps adding up. */
static void test_slow_reader(srv_server *srv)
{
	int fd = tcp_connect();
	make_auth(TOKEN);
	CHECK(tcp_send(fd, 0) == 0 && tcp_recv(fd) == 1 && rx.h.type == MC_MSG_OK);
	make_hello();
	CHECK(tcp_send(fd, 0) == 0 && tcp_recv(fd) == 1 && rx.h.type == MC_MSG_WELCOME);
	/* A small buffer, so that frames pile up at the server quickly (not
	 * tiny: a window of a few segments makes loopback TCP crawl). */
	int small = 32768;
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof(small));
	memset(&tx, 0, sizeof(tx));
	tx.h.type = MC_MSG_SUBSCRIBE;
	tx.h.request_id = 9;
	tx.u.subscribe.mode = MC_SUB_ALL;
	tx.u.subscribe.queue_len = 8;
	CHECK(tcp_send(fd, 0) == 0 && tcp_recv(fd) == 1 && rx.h.type == MC_MSG_OK);
	enum { N = 6000 }; /* 9.5 MB of frames: more than the socket buffers take */
	uint64_t base = 300; /* test_same_frames published 1..300 */
	for (uint64_t s = 1; s <= N; s++)
		publish(srv, base + s);
	sleep_ms(100);
	uint64_t last = base, frames = 0, lost = 0;
	bool ordered = true;
	while (frames + lost < N && tcp_recv(fd) == 1) {
		if (rx.h.type == MC_MSG_GAP) {
			lost += rx.u.gap.count;
		} else if (rx.h.type == MC_MSG_FRAME && rx.u.frame.seq > base) {
			ordered &= rx.u.frame.seq > last;
			frames++;
			last = rx.u.frame.seq;
		}
	}
	CHECK_MSG(ordered && frames + lost == N && lost > 0 && frames > 8,
		  "last %llu, %llu frames + %llu lost, of %d", (unsigned long long)(last - base),
		  (unsigned long long)frames, (unsigned long long)lost, N);
	close(fd);
}

static void test_privileges(srv_server *unpriv)
{
	mocap_client *t = mocap_connect_token(addr, "weak", TOKEN);
	char msg[256] = "";
	CHECK(t && !mocap_is_privileged(t));
	CHECK(t && mocap_control(t, MOCAP_CMD_RELOAD, NULL, msg, sizeof(msg)) == MOCAP_E_PERMISSION &&
	      strstr(mocap_errmsg(), "TCP"));
	/* Rings are refused over TCP "either way" (docs/PROTOCOL.md): the
	 * same `unavailable` for an unprivileged client (it got `permission`). */
	mocap_ring weak_rings[4];
	CHECK_MSG(t && mocap_get_rings(t, weak_rings, 4) == MOCAP_E_UNAVAILABLE && strstr(mocap_errmsg(), "TCP"),
		  "unprivileged GET_RINGS over TCP: %s", mocap_errmsg());
	mocap_close(t);
	srv_destroy(unpriv);

	mc_err err;
	srv_server *srv = make_server(true, "127.0.0.1:0", TOKEN, &err);
	CHECK_MSG(srv, "%s", err.msg);
	if (!srv)
		return;
	snprintf(addr, sizeof(addr), "tcp://127.0.0.1:%d", srv_tcp_port(srv));
	set_def(srv);
	t = mocap_connect_token(addr, "strong", TOKEN);
	CHECK(t && mocap_is_privileged(t));
	mocap_ring rings[4];
	CHECK(t && mocap_get_rings(t, rings, 4) == MOCAP_E_UNAVAILABLE && strstr(mocap_errmsg(), "TCP"));
	CHECK(t && mocap_pose_block_map(t) == NULL && mocap_errcode() == MOCAP_E_UNAVAILABLE &&
	      strstr(mocap_errmsg(), "TCP"));
	mocap_keypoint kp = {.joint = 3, .u = 10, .v = 20, .confidence = 0.9f};
	CHECK(t && mocap_send_keypoints(t, 12345, 0, &kp, 1) == 0);
	mc_err e2;
	CHECK(srv_set_rig(srv, "{}", 2, &e2) == 0);
	srv_keypoints got;
	int n = 0;
	for (int i = 0; i < 200 && !n; i++) {
		n = srv_poll_keypoints(srv, &got);
		if (!n)
			sleep_ms(5);
	}
	CHECK(n == 1 && got.capture_ns == 12345 && got.nkeypoints == 1 && got.keypoints[0].joint == 3);
	mocap_close(t);
	srv_destroy(srv);
}

static void test_config_errors(void)
{
	mc_err err = {{0}};
	CHECK(make_server(false, "127.0.0.1:0", "short", &err) == NULL && strstr(err.msg, "at least 16"));
	CHECK(make_server(false, "localhost", TOKEN, &err) == NULL && strstr(err.msg, "HOST:PORT"));
	CHECK(make_server(false, "::1:7000", TOKEN, &err) == NULL && strstr(err.msg, "HOST:PORT"));
	CHECK(make_server(false, "no.such.host.invalid:7000", TOKEN, &err) == NULL &&
	      strstr(err.msg, "no.such.host.invalid"));
}

int main(void)
{
	snprintf(dir, sizeof(dir), "/tmp/mc_tcp_XXXXXX");
	if (!mkdtemp(dir))
		TEST_SKIP("no temporary directory");
	snprintf(path, sizeof(path), "%s/s.sock", dir);
	test_config_errors();
	mc_err err = {{0}};
	srv_server *srv = make_server(false, "127.0.0.1:0", TOKEN, &err);
	if (!srv && strstr(err.msg, "TCP"))
		TEST_SKIP("no TCP on loopback here: %s", err.msg);
	CHECK_MSG(srv, "%s", err.msg);
	if (!srv)
		return 1;
	port = srv_tcp_port(srv);
	CHECK(port > 0);
	snprintf(addr, sizeof(addr), "tcp://127.0.0.1:%d", port);
	set_def(srv);
	test_raw_auth(srv);
	test_pending_flood();
	test_client_errors();
	test_same_frames(srv);
	test_large_reply(srv);
	test_slow_reader(srv);
	test_privileges(srv); /* destroys srv */
	char cmd[128];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	if (system(cmd) != 0)
		fprintf(stderr, "cannot remove %s\n", dir);
	return mc_test_failures ? 1 : 0;
}
