/* The server at the protocol level, with raw SOCK_SEQPACKET clients:
 * handshake and version refusal, malformed messages (error reply and
 * disconnect, the server goes on), a client that leaves in the middle of a
 * message or of a stream, the client limit, the socket file (stale socket
 * removal, refusal to replace a live one or a regular file), socket
 * activation, the status, rig and skeleton requests, and the status through
 * libmocap (both symbol versions of mocap_get_status in libmocap.so). */
#include "mocap.h"
#include "proto.h"
#include "server.h"
#include "ipc_fixture.h"
#include "test_util.h"

#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <stddef.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

static char dir[48], path[96];
static proto_msg rx;

static int raw_connect(const char *p)
{
	int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	snprintf(a.sun_path, sizeof(a.sun_path), "%s", p);
	if (connect(fd, (struct sockaddr *)&a, sizeof(a)) != 0) {
		close(fd);
		return -1;
	}
	return fd;
}

static int raw_send(int fd, const proto_msg *m)
{
	uint8_t buf[8192];
	size_t n = proto_encode(m, buf, sizeof(buf));
	return n && send(fd, buf, n, MSG_NOSIGNAL) == (ssize_t)n ? 0 : -1;
}

/* 1 and rx filled, 0 timeout, -1 end of stream. */
static int raw_recv(int fd, int timeout_ms)
{
	static uint8_t buf[PROTO_MAX_MESSAGE];
	struct pollfd p = {.fd = fd, .events = POLLIN};
	if (poll(&p, 1, timeout_ms) <= 0)
		return 0;
	ssize_t n = recv(fd, buf, sizeof(buf), 0);
	if (n <= 0)
		return -1;
	char why[256];
	int rc = proto_decode(buf, (size_t)n, PROTO_FROM_SERVER, &rx, why, sizeof(why));
	CHECK_MSG(rc == 0, "server sent a malformed message: %s", why);
	return rc == 0 ? 1 : -1;
}

/* Receives until a message of `type` (skipping frames and definitions). */
static bool raw_expect(int fd, uint16_t type)
{
	for (int i = 0; i < 1000; i++) {
		int r = raw_recv(fd, 2000);
		if (r <= 0)
			return false;
		if (rx.h.type == type)
			return true;
		if (rx.h.type != MC_MSG_FRAME && rx.h.type != MC_MSG_SKELETON && rx.h.type != MC_MSG_GAP)
			return false;
	}
	return false;
}

static proto_msg tx;

static void sleep_ms_local(int ms)
{
	struct timespec ts = {0, ms * 1000000L};
	nanosleep(&ts, NULL);
}

static void send_hello(int fd, uint16_t lo, uint16_t hi)
{
	memset(&tx, 0, sizeof(tx));
	tx.h.type = MC_MSG_HELLO;
	tx.h.request_id = 1;
	tx.u.hello.magic = PROTO_MAGIC;
	tx.u.hello.min_version = lo;
	tx.u.hello.max_version = hi;
	strcpy(tx.u.hello.client_name, "raw");
	CHECK(raw_send(fd, &tx) == 0);
}

static int hello_client(void)
{
	int fd = raw_connect(path);
	CHECK(fd >= 0);
	if (fd < 0)
		return -1;
	send_hello(fd, 1, 1);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_WELCOME && rx.u.welcome.version == 1 &&
	      rx.h.request_id == 1);
	return fd;
}

static void simple_request(int fd, uint16_t type, uint32_t id)
{
	memset(&tx, 0, sizeof(tx));
	tx.h.type = type;
	tx.h.request_id = id;
	CHECK(raw_send(fd, &tx) == 0);
}

/* Subscribes fd to every frame ("all" mode; queue_len 0: the default). */
static void subscribe_all(int fd, uint32_t id, uint32_t queue_len)
{
	memset(&tx, 0, sizeof(tx));
	tx.h.type = MC_MSG_SUBSCRIBE;
	tx.h.request_id = id;
	tx.u.subscribe.mode = MC_SUB_ALL;
	tx.u.subscribe.queue_len = queue_len;
	CHECK(raw_send(fd, &tx) == 0);
}

/* The connection is closed by the server (after an optional last message). */
static bool closed_by_server(int fd)
{
	for (int i = 0; i < 100; i++) {
		int r = raw_recv(fd, 2000);
		if (r < 0)
			return true;
		if (r == 0)
			return false;
	}
	return false;
}

static srv_server *make_server(int max_clients, int listen_fd)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	cfg.max_clients = max_clients;
	cfg.listen_fd = listen_fd;
	mc_err err = {{0}};
	srv_server *srv = srv_create(&cfg, &err);
	CHECK_MSG(srv != NULL, "%s", err.msg);
	return srv;
}

static void set_def(srv_server *srv, int njoints) { ipc_set_chain_def(srv, njoints); }

static mc_vec3 seq_position(uint64_t seq, int j) { return mc_v3((double)seq, j, 0); }

static void publish(srv_server *srv, uint64_t seq, int njoints)
{
	CHECK(ipc_publish(srv, seq, njoints, 1000, seq_position) == 0);
}

static void test_handshake(void)
{
	srv_server *srv = make_server(8, -1);
	/* A client speaking only newer versions is refused with a message
	 * saying which versions each side speaks, then disconnected. */
	int fd = raw_connect(path);
	send_hello(fd, 4, 5);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_ERROR);
	CHECK(rx.u.error.code == PROTO_E_VERSION && rx.u.error.fatal == 1);
	CHECK_MSG(strstr(rx.u.error.message, "client speaks versions 4..5") &&
			  strstr(rx.u.error.message, "this mocapd speaks 1..3"),
		  "%s", rx.u.error.message);
	CHECK(closed_by_server(fd));
	close(fd);
	/* Only version 2: accepted with 2. */
	fd = raw_connect(path);
	send_hello(fd, 2, 2);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_WELCOME && rx.u.welcome.version == 2);
	close(fd);
	/* A range that includes them all is accepted with the highest, 3. */
	fd = raw_connect(path);
	send_hello(fd, 1, 9);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_WELCOME && rx.u.welcome.version == 3);
	CHECK(rx.u.welcome.flags & MC_WELCOME_PRIVILEGED); /* same user as the server */
	/* A second HELLO is a protocol error. */
	send_hello(fd, 1, 1);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_ERROR && rx.u.error.code == PROTO_E_HANDSHAKE);
	CHECK(closed_by_server(fd));
	close(fd);
	/* A request before HELLO. */
	fd = raw_connect(path);
	simple_request(fd, MC_MSG_GET_STATUS, 5);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_ERROR && rx.u.error.code == PROTO_E_HANDSHAKE &&
	      rx.h.request_id == 5);
	CHECK(closed_by_server(fd));
	close(fd);
	/* Still serving. */
	fd = hello_client();
	simple_request(fd, MC_MSG_PING, 9);
	CHECK(raw_expect(fd, MC_MSG_PONG) && rx.h.request_id == 9);
	close(fd);
	srv_stats st;
	srv_get_stats(srv, &st);
	CHECK(st.refused == 1);
	srv_destroy(srv);
}

static void test_malformed(void)
{
	srv_server *srv = make_server(8, -1);
	set_def(srv, 3);
	int good = hello_client();
	subscribe_all(good, 2, 0);
	CHECK(raw_expect(good, MC_MSG_OK));

	struct {
		const char *what;
		uint8_t bytes[64];
		size_t len;
		const char *reason;
	} cases[] = {
		{"short", {1, 2, 3}, 3, "shorter than the 16-byte header"},
		{"unknown type", {0x55, 0x00, 0, 0, 16, 0, 0, 0, 7, 0, 0, 0}, 16, "unknown message type 0x0055"},
		{"size mismatch", {0x04, 0x00, 0, 0, 99, 0, 0, 0, 7, 0, 0, 0}, 16, "size field says 99"},
		{"server type", {0x05, 0x80, 0, 0, 16, 0, 0, 0, 7, 0, 0, 0}, 16, "cannot come from the client"},
		{"bad mode", {0x02, 0x00, 0, 0, 24, 0, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0, 9, 0}, 24, "mode: 9"},
		{"trailing", {0x04, 0x00, 0, 0, 17, 0, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0, 1}, 17, "trailing"},
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		int fd = hello_client();
		CHECK(send(fd, cases[i].bytes, cases[i].len, MSG_NOSIGNAL) == (ssize_t)cases[i].len);
		int r = raw_recv(fd, 2000);
		CHECK_MSG(r == 1 && rx.h.type == MC_MSG_ERROR && rx.u.error.code == PROTO_E_MALFORMED &&
				  rx.u.error.fatal,
			  "case %s: no fatal MALFORMED error", cases[i].what);
		CHECK_MSG(strstr(rx.u.error.message, cases[i].reason), "case %s: '%s'", cases[i].what,
			  rx.u.error.message);
		CHECK_MSG(closed_by_server(fd), "case %s: not disconnected", cases[i].what);
		close(fd);
	}
	/* An oversized datagram. */
	int fd = hello_client();
	static uint8_t big[PROTO_MAX_MESSAGE + 100];
	memset(big, 0, sizeof(big));
	big[0] = 0x0b; /* a PING, id 7, far too long: the ERROR names both */
	big[8] = 7;
	CHECK(send(fd, big, sizeof(big), MSG_NOSIGNAL) == (ssize_t)sizeof(big));
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_ERROR && strstr(rx.u.error.message, "longer than"));
	CHECK_MSG(rx.u.error.request_type == MC_MSG_PING && rx.h.request_id == 7, "oversize: request_type %u, id %u",
		  rx.u.error.request_type, rx.h.request_id);
	CHECK(closed_by_server(fd));
	close(fd);
	/* Descriptors from a client are closed and refused. */
	fd = hello_client();
	int sent_fd = open("/dev/null", O_RDONLY | O_CLOEXEC);
	uint8_t ping[24] = {0x0b, 0, 0, 0, 24, 0, 0, 0, 3};
	struct iovec iov = {ping, sizeof(ping)};
	union {
		char buf[CMSG_SPACE(sizeof(int))];
		struct cmsghdr align;
	} ctl;
	struct msghdr mh = {.msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl.buf, .msg_controllen = sizeof(ctl.buf)};
	struct cmsghdr *cm = CMSG_FIRSTHDR(&mh);
	cm->cmsg_level = SOL_SOCKET;
	cm->cmsg_type = SCM_RIGHTS;
	cm->cmsg_len = CMSG_LEN(sizeof(int));
	memcpy(CMSG_DATA(cm), &sent_fd, sizeof(int));
	CHECK(sendmsg(fd, &mh, MSG_NOSIGNAL) == (ssize_t)sizeof(ping));
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_ERROR && strstr(rx.u.error.message, "descriptors"));
	CHECK_MSG(rx.u.error.request_type == MC_MSG_PING && rx.h.request_id == 3, "with fds: request_type %u, id %u",
		  rx.u.error.request_type, rx.h.request_id);
	CHECK(closed_by_server(fd));
	close(fd);
	close(sent_fd);

	/* The well-behaved client was never disturbed and still gets frames. */
	publish(srv, 1, 3);
	CHECK(raw_expect(good, MC_MSG_FRAME) && rx.u.frame.seq == 1 && rx.u.frame.njoints == 3);
	srv_stats st;
	srv_get_stats(srv, &st);
	CHECK(st.protocol_errors == 8);
	close(good);
	srv_destroy(srv);
}

/* Clients that leave at awkward moments: after half a handshake, with a
 * request in flight, with a backlog of frames queued for them. */
static void test_disconnects(void)
{
	srv_server *srv = make_server(16, -1);
	set_def(srv, 20);
	int watcher = hello_client();
	subscribe_all(watcher, 2, 4000);
	CHECK(raw_expect(watcher, MC_MSG_OK));
	for (int round = 0; round < 20; round++) {
		/* Connected, nothing sent. */
		int a = raw_connect(path);
		/* Half a message: a header announcing 24 bytes, 10 sent. */
		int b = raw_connect(path);
		uint8_t half[10] = {0x01, 0, 0, 0, 24, 0, 0, 0, 1, 0};
		send(b, half, sizeof(half), MSG_NOSIGNAL);
		/* A request, then gone before the reply. */
		int c = hello_client();
		simple_request(c, MC_MSG_GET_STATUS, 3);
		/* Subscribed to everything, never reads, leaves mid-stream. */
		int d = hello_client();
		subscribe_all(d, 4, 0);
		for (int k = 0; k < 10; k++)
			publish(srv, (uint64_t)round * 10 + k + 1, 20);
		close(a);
		close(b);
		close(c);
		shutdown(d, SHUT_RD); /* stop reading first: the server's sends fail */
		close(d);
	}
	/* The watcher got all 200 frames in order: nobody's leaving hurt it. */
	uint64_t expect = 1;
	while (expect <= 200 && raw_expect(watcher, MC_MSG_FRAME)) {
		CHECK(rx.u.frame.seq == expect);
		expect = rx.u.frame.seq + 1;
	}
	CHECK(expect == 201);
	struct timespec ts = {0, 50000000};
	nanosleep(&ts, NULL);
	srv_stats st;
	srv_get_stats(srv, &st);
	CHECK_MSG(st.clients == 1, "%d clients left", st.clients);
	close(watcher);
	srv_destroy(srv);
}

/* A client that asks and asks but never reads its replies is cut off once
 * its socket buffer and its reply budget are full; nobody else notices. */
static void test_flood(void)
{
	srv_server *srv = make_server(8, -1);
	int other = hello_client();
	int fd = hello_client();
	int flags = fcntl(fd, F_GETFL);
	fcntl(fd, F_SETFL, flags | O_NONBLOCK);
	int sent = 0, full = 0;
	for (int i = 0; i < 20000 && full < 200; i++) {
		uint8_t req[16] = {0x04, 0, 0, 0, 16, 0, 0, 0, (uint8_t)i, (uint8_t)(i >> 8), 1};
		ssize_t n = send(fd, req, sizeof(req), MSG_NOSIGNAL);
		if (n < 0 && errno == EAGAIN) { /* the server stopped reading us */
			full++;
			sleep_ms_local(1);
			continue;
		}
		if (n < 0)
			break;
		full = 0;
		sent++;
	}
	fcntl(fd, F_SETFL, flags);
	/* The replies the socket held, then the overload error, then the end:
	 * the error waits for room and the connection closes after it. */
	int replies = 0;
	bool eof = false, overload = false;
	for (;;) {
		int r = raw_recv(fd, 3000);
		if (r < 0) {
			eof = true;
			break;
		}
		if (r == 0)
			break;
		replies++;
		overload = rx.h.type == MC_MSG_ERROR && rx.u.error.code == PROTO_E_OVERLOAD && rx.u.error.fatal;
	}
	CHECK_MSG(eof, "the flooding client was not disconnected (%d sent, %d replies)", sent, replies);
	CHECK_MSG(overload, "the last message before the end was not the overload error");
	CHECK(replies < sent);
	printf("flood: %d requests sent, %d replies read, the last the overload error, before the server closed the "
	       "connection\n", sent, replies);
	simple_request(other, MC_MSG_PING, 77);
	CHECK(raw_expect(other, MC_MSG_PONG) && rx.h.request_id == 77);
	close(fd);
	close(other);
	srv_destroy(srv);
}

static void test_client_limit(void)
{
	srv_server *srv = make_server(4, -1);
	int fds[4];
	for (int i = 0; i < 4; i++)
		fds[i] = hello_client();
	int extra = raw_connect(path);
	CHECK(extra >= 0);
	CHECK(raw_recv(extra, 2000) == 1 && rx.h.type == MC_MSG_ERROR &&
	      rx.u.error.code == PROTO_E_TOO_MANY_CLIENTS && strstr(rx.u.error.message, "at most 4"));
	CHECK(closed_by_server(extra));
	close(extra);
	close(fds[0]);
	/* A place is free again once the server has noticed. */
	int again = -1;
	for (int tries = 0; tries < 50 && again < 0; tries++) {
		struct timespec ts = {0, 20000000};
		nanosleep(&ts, NULL);
		int fd = raw_connect(path);
		send_hello(fd, 1, 1);
		if (raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_WELCOME)
			again = fd;
		else
			close(fd);
	}
	CHECK(again >= 0);
	close(again);
	for (int i = 1; i < 4; i++)
		close(fds[i]);
	srv_destroy(srv);
}

static void test_socket_file(void)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	mc_err err = {{0}};

	/* A stale socket (bound, nobody listening: a SIGKILLed daemon). */
	int s = socket(AF_UNIX, SOCK_SEQPACKET, 0);
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	snprintf(a.sun_path, sizeof(a.sun_path), "%s", path);
	CHECK(bind(s, (struct sockaddr *)&a, sizeof(a)) == 0);
	close(s);
	srv_server *srv = srv_create(&cfg, &err);
	CHECK_MSG(srv != NULL, "stale socket not replaced: %s", err.msg);
	struct stat st;
	CHECK(stat(path, &st) == 0 && S_ISSOCK(st.st_mode) && (st.st_mode & 0777) == 0660);

	/* A live daemon at the path is left alone. */
	srv_server *second = srv_create(&cfg, &err);
	CHECK(second == NULL && strstr(err.msg, "another mocapd is listening"));
	int fd = hello_client();
	CHECK(fd >= 0);
	close(fd);
	srv_destroy(srv);
	CHECK(stat(path, &st) != 0 && errno == ENOENT); /* removed on exit */

	/* A regular file is never removed. */
	FILE *f = fopen(path, "w");
	fputs("precious", f);
	fclose(f);
	srv = srv_create(&cfg, &err);
	CHECK(srv == NULL && strstr(err.msg, "not a socket"));
	CHECK(stat(path, &st) == 0 && S_ISREG(st.st_mode));
	unlink(path);

	/* A path that cannot fit in sockaddr_un. */
	memset(cfg.path, 'x', 200);
	cfg.path[200] = 0;
	srv = srv_create(&cfg, &err);
	CHECK(srv == NULL && strstr(err.msg, "too long"));
}

static void test_socket_activation(void)
{
	int ls = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	snprintf(a.sun_path, sizeof(a.sun_path), "%s", path);
	CHECK(bind(ls, (struct sockaddr *)&a, sizeof(a)) == 0 && listen(ls, 8) == 0);
	/* A client may connect before the daemon is up: it waits in the backlog. */
	int early = raw_connect(path);
	CHECK(early >= 0);
	send_hello(early, 1, 1);
	srv_server *srv = make_server(8, ls);
	CHECK(raw_recv(early, 2000) == 1 && rx.h.type == MC_MSG_WELCOME);
	close(early);
	srv_destroy(srv);
	struct stat st;
	CHECK(stat(path, &st) == 0); /* systemd's socket file stays */
	unlink(path);

	/* A stream socket is not what the protocol needs. */
	int stream = socket(AF_UNIX, SOCK_STREAM, 0);
	CHECK(bind(stream, (struct sockaddr *)&a, sizeof(a)) == 0 && listen(stream, 8) == 0);
	srv_config cfg;
	srv_config_default(&cfg);
	cfg.listen_fd = stream;
	mc_err err;
	CHECK(srv_create(&cfg, &err) == NULL && strstr(err.msg, "SOCK_SEQPACKET"));
	close(stream);
	unlink(path);
}

static void test_requests(void)
{
	srv_server *srv = make_server(8, -1);
	int fd = hello_client();
	/* Nothing loaded yet. */
	simple_request(fd, MC_MSG_GET_SKELETON, 10);
	CHECK(raw_expect(fd, MC_MSG_ERROR) && rx.u.error.code == PROTO_E_UNAVAILABLE && !rx.u.error.fatal &&
	      rx.h.request_id == 10);
	simple_request(fd, MC_MSG_GET_RIG, 11);
	CHECK(raw_expect(fd, MC_MSG_ERROR) && rx.u.error.code == PROTO_E_UNAVAILABLE);

	set_def(srv, 5);
	mc_err err;
	CHECK(srv_set_rig(srv, "{\"cameras\": [1, 2]}", 2, &err) == 0);
	srv_status st = {0};
	st.tracker_state = SRV_TRACKER_UNCERTAIN;
	st.publish_fps = 29.97;
	st.track_ms_mean = 12.5;
	st.frames_published = 1234;
	st.ncams = 2;
	snprintf(st.cams[1].name, sizeof(st.cams[1].name), "right");
	st.cams[1].drops = 17;
	st.cams[1].state = MC_CAM_STATE_STALLED;
	snprintf(st.device, sizeof(st.device), "pocl: cpu");
	srv_set_status(srv, &st);

	simple_request(fd, MC_MSG_GET_SKELETON, 12);
	CHECK(raw_expect(fd, MC_MSG_SKELETON) && rx.h.request_id == 12 && rx.u.skeleton.njoints == 5);
	CHECK(strcmp(rx.u.skeleton.joints[4].name, "j4") == 0 && rx.u.skeleton.joints[4].parent == 3);
	CHECK(fabs(rx.u.skeleton.joints[4].offset[1] - 0.4) < 1e-12);
	simple_request(fd, MC_MSG_GET_RIG, 13);
	CHECK(raw_expect(fd, MC_MSG_RIG) && rx.u.rig.ncams == 2 && rx.u.rig.length == 19 &&
	      memcmp(rx.u.rig.json, "{\"cameras\": [1, 2]}", 19) == 0);
	simple_request(fd, MC_MSG_GET_STATUS, 14);
	CHECK(raw_expect(fd, MC_MSG_STATUS) && rx.h.request_id == 14);
	CHECK(rx.u.status.tracker_state == 1 && rx.u.status.publish_fps == 29.97 && rx.u.status.frames_published == 1234);
	CHECK(rx.u.status.ncams == 2 && strcmp(rx.u.status.cams[1].name, "right") == 0 && rx.u.status.cams[1].drops == 17);
	CHECK(rx.u.status.cams[1].state == MC_CAM_STATE_STALLED && rx.u.status.nclients == 1);
	CHECK(strcmp(rx.u.status.device, "pocl: cpu") == 0);
	CHECK(!rx.u.status.has_detector); /* a version 1 client: no detector block */
	/* A version 2 client gets the detector too. */
	st.detector.state = SRV_DETECTOR_FAILED;
	st.detector.ms_max = 3.5;
	st.detector.views = 42;
	snprintf(st.detector.message, sizeof(st.detector.message), "m.onnx: not an ONNX model");
	srv_set_status(srv, &st);
	int fd2 = raw_connect(path);
	send_hello(fd2, 1, 2);
	CHECK(raw_recv(fd2, 2000) == 1 && rx.h.type == MC_MSG_WELCOME && rx.u.welcome.version == 2);
	simple_request(fd2, MC_MSG_GET_STATUS, 15);
	CHECK(raw_expect(fd2, MC_MSG_STATUS) && rx.h.request_id == 15 && rx.u.status.has_detector);
	CHECK(rx.u.status.detector.state == 2 && rx.u.status.detector.ms_max == 3.5 && rx.u.status.detector.views == 42);
	CHECK(strcmp(rx.u.status.detector.message, "m.onnx: not an ONNX model") == 0);
	close(fd2);
	/* A camera failed for good is "failed" (4) from version 3, as the
	 * daemon's log says; older clients know only "error" (2). */
	st.cams[0].state = MC_CAM_STATE_FAILED;
	srv_set_status(srv, &st);
	for (uint16_t v = 2; v <= 3; v++) {
		fd2 = raw_connect(path);
		send_hello(fd2, 1, v);
		CHECK(raw_recv(fd2, 2000) == 1 && rx.h.type == MC_MSG_WELCOME && rx.u.welcome.version == v);
		simple_request(fd2, MC_MSG_GET_STATUS, 16);
		CHECK(raw_expect(fd2, MC_MSG_STATUS));
		CHECK_MSG(rx.u.status.cams[0].state == (v < 3 ? MC_CAM_STATE_ERROR : MC_CAM_STATE_FAILED),
			  "version %d: camera state %u", v, rx.u.status.cams[0].state);
		close(fd2);
	}

	/* Publishing checks the definition. */
	mc_skeleton sk;
	memset(&sk, 0, sizeof(sk));
	sk.njoints = 4;
	CHECK(srv_publish(srv, &sk, 1, &err) == -1 && strstr(err.msg, "4 joints, the definition 5"));
	srv_skeleton_def bad = {0};
	bad.njoints = 2;
	strcpy(bad.name[0], "a");
	strcpy(bad.name[1], "b");
	bad.parent[0] = -1;
	bad.parent[1] = 1;
	CHECK(srv_set_skeleton_def(srv, &bad, &err) == -1 && strstr(err.msg, "parent 1"));

	/* A subscriber gets the definition first, then frames; a new
	 * definition reaches it before the frames that follow it. */
	subscribe_all(fd, 15, 0);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_OK && rx.u.ok.value == 256);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_SKELETON && rx.h.request_id == 0);
	uint32_t id1 = rx.u.skeleton.skeleton_id;
	publish(srv, 1, 5);
	set_def(srv, 6);
	publish(srv, 2, 6);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_FRAME && rx.u.frame.skeleton_id == id1);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_SKELETON && rx.u.skeleton.njoints == 6);
	uint32_t id2 = rx.u.skeleton.skeleton_id;
	CHECK(id2 != id1);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_FRAME && rx.u.frame.skeleton_id == id2 &&
	      rx.u.frame.njoints == 6 && rx.u.frame.joints[5].position[1] == 5.0);
	/* A jump in the daemon's seq is a gap for "all" subscribers. */
	publish(srv, 10, 6);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_GAP && rx.u.gap.first_seq == 3 && rx.u.gap.count == 7);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_FRAME && rx.u.frame.seq == 10);
	/* Unsubscribed: no more frames. */
	simple_request(fd, MC_MSG_UNSUBSCRIBE, 16);
	CHECK(raw_expect(fd, MC_MSG_OK) && rx.h.request_id == 16);
	publish(srv, 11, 6);
	simple_request(fd, MC_MSG_PING, 17);
	CHECK(raw_recv(fd, 2000) == 1 && rx.h.type == MC_MSG_PONG);
	close(fd);
	srv_destroy(srv);
}

/* mocap_daemon_status and its two symbol versions: the status with the
 * detector and the latency (MOCAP_3, what mocap.h declares), for programs
 * built against libmocap 1.1 (MOCAP_2) and 1.0 (MOCAP_1) their layouts,
 * nothing written past them.
 * Through the shared library built beside this test (<build>/lib). */
static void test_status_versions(void)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	mc_err err = {{0}};
	srv_server *srv = srv_create(&cfg, &err);
	CHECK_MSG(srv, "%s", err.msg);
	if (!srv)
		return;
	srv_status st = {0};
	st.ncams = 1;
	snprintf(st.cams[0].name, sizeof(st.cams[0].name), "left");
	st.detector.state = SRV_DETECTOR_RUNNING;
	st.detector.ms_mean = 1.5;
	st.detector.used = 9;
	snprintf(st.detector.model, sizeof(st.detector.model), "m.onnx");
	st.latency.window = 300;
	st.latency.stage[SRV_LAT_TOTAL].p99 = 21.5;
	st.latency.stage[SRV_LAT_WAIT].max = 4.25;
	st.latency.skipped_stale = 3;
	srv_set_status(srv, &st);
	mocap_client *c = mocap_connect(path, "status");
	mocap_daemon_status *ds = calloc(1, sizeof(*ds));
	CHECK(c && ds && mocap_get_status(c, ds) == 0);
	CHECK(ds && ds->detector.state == MOCAP_DETECTOR_RUNNING && ds->detector.ms_mean == 1.5 && ds->detector.used == 9);
	CHECK(ds && strcmp(ds->detector.model, "m.onnx") == 0 && strcmp(ds->cams[0].name, "left") == 0);
	CHECK(ds && ds->latency.known && ds->latency.window == 300 && ds->latency.stage[MOCAP_LAT_TOTAL].p99 == 21.5 &&
	      ds->latency.stage[MOCAP_LAT_WAIT].max == 4.25 && ds->latency.skipped_stale == 3);
	mocap_close(c);

	char so[PATH_MAX];
	ssize_t n = readlink("/proc/self/exe", so, sizeof(so) - 32);
	so[n > 0 ? n : 0] = 0;
	char *slash = strrchr(so, '/');
	if (slash)
		*slash = 0; /* <build>/tests */
	slash = strrchr(so, '/');
	snprintf(slash ? slash : so, sizeof(so) - (size_t)(slash ? slash - so : 0), "/lib/libmocap.so.1");
	void *h = dlopen(so, RTLD_NOW | RTLD_LOCAL);
	if (!h)
		printf("%s: %s; the symbol versions are not checked\n", so, dlerror());
	else {
		typedef mocap_client *(*connect_fn)(const char *, const char *);
		typedef int (*status_fn)(mocap_client *, void *);
		connect_fn con = (connect_fn)dlsym(h, "mocap_connect");
		void (*cls)(mocap_client *) = (void (*)(mocap_client *))dlsym(h, "mocap_close");
		status_fn v1 = (status_fn)dlvsym(h, "mocap_get_status", "MOCAP_1");
		status_fn v2 = (status_fn)dlvsym(h, "mocap_get_status", "MOCAP_2");
		status_fn v3 = (status_fn)dlvsym(h, "mocap_get_status", "MOCAP_3");
		CHECK(con && cls && v1 && v2 && v3 && (void *)v1 != (void *)v2 && (void *)v2 != (void *)v3);
		CHECK((void *)dlsym(h, "mocap_get_status") == (void *)v3); /* the default */
		mocap_client *sc = con ? con(path, "status-so") : NULL;
		size_t old = offsetof(mocap_daemon_status, detector), old2 = offsetof(mocap_daemon_status, latency);
		unsigned char *buf = malloc(sizeof(*ds) + 64);
		if (sc && buf && v1 && v2 && v3) {
			memset(buf, 0xa5, old + 64);
			CHECK(v1(sc, buf) == 0);
			bool untouched = true;
			for (size_t i = old; i < old + 64; i++)
				untouched &= buf[i] == 0xa5;
			CHECK_MSG(untouched, "mocap_get_status@MOCAP_1 wrote past the 1.0 layout");
			int ncams;
			memcpy(&ncams, buf + offsetof(mocap_daemon_status, ncams), sizeof(ncams));
			CHECK(ncams == 1);
			memset(buf, 0xa5, old2 + 64);
			CHECK(v2(sc, buf) == 0);
			untouched = true;
			for (size_t i = old2; i < old2 + 64; i++)
				untouched &= buf[i] == 0xa5;
			CHECK_MSG(untouched, "mocap_get_status@MOCAP_2 wrote past the 1.1 layout");
			memcpy(ds, buf, old2);
			CHECK(ds->detector.used == 9);
			memset(ds, 0, sizeof(*ds));
			CHECK(v3(sc, ds) == 0 && ds->detector.used == 9 && ds->latency.window == 300);
		}
		free(buf);
		if (sc)
			cls(sc);
		dlclose(h);
	}
	free(ds);
	srv_destroy(srv);
}

int main(void)
{
	snprintf(dir, sizeof(dir), "/tmp/mocap-ipc-XXXXXX");
	if (!mkdtemp(dir))
		TEST_SKIP("cannot create a temporary directory: %s", strerror(errno));
	snprintf(path, sizeof(path), "%s/mocapd.sock", dir);
	test_handshake();
	test_malformed();
	test_disconnects();
	test_flood();
	test_client_limit();
	test_socket_file();
	test_socket_activation();
	test_requests();
	unlink(path);
	test_status_versions();
	rmdir(dir);
	return mc_test_finish("test_ipc_server");
}
