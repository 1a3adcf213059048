/* libmocap: the client library (see mocap.h and docs/PROTOCOL.md).
 *
 * Threads.  Any thread that needs something from the socket (a frame, a
 * reply) becomes the "reader" if nobody else is: it polls and receives
 * without holding the lock, then files each message under the lock (frames
 * into the frame queue, replies into the slot of the thread waiting for
 * that request id) and wakes the others.  Threads that find a reader busy
 * wait on the condition variable.  So replies always reach the thread that
 * asked, whichever thread happened to read them, and frames read by a
 * request are kept for mocap_read_frame. */
#include "mocap.h"
#include "proto.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define FRAME_QUEUE_MAX 1024 /* frames kept in the library ("all" mode) */
#define MAX_WAITERS 32       /* requests in flight at once */
#define RX_BURST 64
#define MAX_RX_FDS 16
#define FOREVER UINT64_MAX

/* A frame as queued: the mocap_skeleton_frame header and njoints joints. */
#define FRAME_BYTES(n) (offsetof(mocap_skeleton_frame, joints) + (size_t)(n) * sizeof(mocap_joint))

typedef struct {
	bool used, done;
	uint32_t id;
	uint8_t *data; /* the reply datagram */
	size_t len;
	int fds[MAX_RX_FDS];
	int nfds;
} waiter;

struct mocap_client {
	int fd, epfd, evfd;
	char path[sizeof(((struct sockaddr_un *)0)->sun_path)];
	bool privileged;
	int timeout_ms;
	atomic_uint next_id;

	pthread_mutex_t lock; /* everything below */
	pthread_cond_t cond;
	bool reading;         /* a thread is receiving */
	int dead;             /* 0, or the error every call now returns */
	char dead_msg[PROTO_TEXT_MAX + 128];
	int mode;
	mocap_skeleton_frame **fq;     /* ring of FRAME_QUEUE_MAX partial frames */
	int fq_head, fq_n;
	uint64_t pending_missed;
	bool ev_set;
	mocap_skeleton_def *skel; /* newest definition pushed by the daemon */
	waiter waiters[MAX_WAITERS];
	int async_code;       /* refusal of a keypoint batch or head pose */
	char async_msg[PROTO_TEXT_MAX + 1];

	/* The reader's own scratch. */
	uint8_t rx[PROTO_MAX_MESSAGE + 1];
	proto_msg dec;
};

/* --- Errors: per thread, like errno. --- */

static _Thread_local int tl_code;
static _Thread_local char tl_msg[PROTO_TEXT_MAX + 256];

static int set_err(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int set_err(int code, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(tl_msg, sizeof(tl_msg), fmt, ap);
	va_end(ap);
	tl_code = code;
	return code;
}

int mocap_errcode(void) { return tl_code; }
const char *mocap_errmsg(void) { return tl_msg[0] ? tl_msg : mocap_strerror(tl_code); }

const char *mocap_strerror(int code)
{
	switch (code) {
	case 0: return "no error";
	case MOCAP_E_NOT_RUNNING: return "daemon not running";
	case MOCAP_E_ACCESS: return "permission denied on the socket";
	case MOCAP_E_VERSION: return "protocol version mismatch";
	case MOCAP_E_PROTOCOL: return "protocol error";
	case MOCAP_E_DISCONNECTED: return "disconnected";
	case MOCAP_E_TIMEOUT: return "timed out";
	case MOCAP_E_PERMISSION: return "not allowed";
	case MOCAP_E_REFUSED: return "refused by the daemon";
	case MOCAP_E_UNAVAILABLE: return "not available";
	case MOCAP_E_FAILED: return "command failed";
	case MOCAP_E_ARG: return "invalid argument";
	case MOCAP_E_SYSTEM: return "system error";
	}
	return "unknown error";
}

const char *mocap_track_state_name(mocap_track_state s)
{
	switch (s) {
	case MOCAP_TRACK_OK: return "ok";
	case MOCAP_TRACK_UNCERTAIN: return "uncertain";
	case MOCAP_TRACK_LOST: return "lost";
	case MOCAP_TRACK_IDLE: return "idle";
	}
	return "unknown";
}

static int code_of_server_error(uint32_t code)
{
	switch (code) {
	case PROTO_E_VERSION: return MOCAP_E_VERSION;
	case PROTO_E_MALFORMED:
	case PROTO_E_HANDSHAKE: return MOCAP_E_PROTOCOL;
	case PROTO_E_PERMISSION: return MOCAP_E_PERMISSION;
	case PROTO_E_UNAVAILABLE: return MOCAP_E_UNAVAILABLE;
	case PROTO_E_SHUTDOWN: return MOCAP_E_DISCONNECTED;
	}
	return MOCAP_E_REFUSED;
}

/* --- Time --- */

uint64_t mocap_now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static uint64_t deadline_after(int timeout_ms)
{
	return timeout_ms < 0 ? FOREVER : mocap_now_ns() + (uint64_t)timeout_ms * 1000000ull;
}

/* Milliseconds until a deadline for poll(), rounded up; -1 for forever. */
static int ms_until(uint64_t deadline)
{
	if (deadline == FOREVER)
		return -1;
	uint64_t t = mocap_now_ns();
	if (t >= deadline)
		return 0;
	uint64_t ms = (deadline - t + 999999) / 1000000;
	return ms > 1000000000 ? 1000000000 : (int)ms;
}

const char *mocap_default_socket(void)
{
	const char *p = getenv(MOCAP_SOCKET_ENV);
	return p && p[0] ? p : MOCAP_DEFAULT_SOCKET;
}

/* --- The frame queue and the pollable event --- */

/* Makes the eventfd readable exactly while a frame or an error waits.
 * Called (lock held) when a public function returns to the application,
 * not on every queue change: a frame that is received and handed out in
 * the same call then costs no eventfd system calls. */
static void update_event(mocap_client *c)
{
	bool want = c->fq_n > 0 || c->dead;
	if (want == c->ev_set)
		return;
	uint64_t v = 1;
	ssize_t r = want ? write(c->evfd, &v, sizeof(v)) : read(c->evfd, &v, sizeof(v));
	(void)r;
	c->ev_set = want;
}

static void fq_clear(mocap_client *c)
{
	while (c->fq_n) {
		free(c->fq[c->fq_head]);
		c->fq_head = (c->fq_head + 1) % FRAME_QUEUE_MAX;
		c->fq_n--;
	}
}

static void fq_push(mocap_client *c, mocap_skeleton_frame *f)
{
	if (c->mode == MOCAP_LATEST)
		fq_clear(c); /* only the newest counts */
	if (c->fq_n == FRAME_QUEUE_MAX) {
		/* The application does not read its frames: drop, and say so. */
		c->pending_missed += 1 + f->missed;
		free(f);
		return;
	}
	f->missed += c->pending_missed;
	c->pending_missed = 0;
	c->fq[(c->fq_head + c->fq_n) % FRAME_QUEUE_MAX] = f;
	c->fq_n++;
}

static void set_dead(mocap_client *c, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void set_dead(mocap_client *c, int code, const char *fmt, ...)
{
	if (c->dead)
		return;
	c->dead = code;
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(c->dead_msg, sizeof(c->dead_msg), fmt, ap);
	va_end(ap);
}

/* --- Receiving --- */

static waiter *find_waiter(mocap_client *c, uint32_t id)
{
	for (int i = 0; i < MAX_WAITERS; i++)
		if (c->waiters[i].used && c->waiters[i].id == id && !c->waiters[i].done)
			return &c->waiters[i];
	return NULL;
}

static void close_fds(const int *fds, int n)
{
	for (int i = 0; i < n; i++)
		close(fds[i]);
}

static mocap_skeleton_frame *convert_frame(const mc_msg_frame *m, uint64_t receive_ns)
{
	mocap_skeleton_frame *f = malloc(FRAME_BYTES(m->njoints));
	if (!f)
		return NULL;
	f->seq = m->seq;
	f->capture_ns = m->capture_ns;
	f->publish_ns = m->publish_ns;
	f->receive_ns = receive_ns;
	f->missed = 0;
	f->skeleton_id = m->skeleton_id;
	f->state = (mocap_track_state)m->state;
	f->space = (mocap_space)m->space;
	f->njoints = m->njoints;
	for (int j = 0; j < m->njoints; j++) {
		memcpy(f->joints[j].position, m->joints[j].position, sizeof(f->joints[j].position));
		memcpy(f->joints[j].orientation, m->joints[j].orientation, sizeof(f->joints[j].orientation));
		f->joints[j].confidence = m->joints[j].confidence;
	}
	return f;
}

static mocap_skeleton_def *convert_skeleton(const mc_msg_skeleton *m)
{
	mocap_skeleton_def *s = calloc(1, sizeof(*s));
	if (!s)
		return NULL;
	s->id = m->skeleton_id;
	s->rig_is_world = m->rig_is_world;
	s->njoints = m->njoints;
	for (int j = 0; j < m->njoints; j++) {
		snprintf(s->joints[j].name, sizeof(s->joints[j].name), "%s", m->joints[j].name);
		s->joints[j].parent = m->joints[j].parent;
		memcpy(s->joints[j].rest_offset, m->joints[j].offset, sizeof(s->joints[j].rest_offset));
	}
	return s;
}

/* Files one decoded message (lock held).  Takes ownership of fds. */
static void dispatch(mocap_client *c, const proto_msg *m, size_t len, mocap_skeleton_frame *frame, mocap_skeleton_def *skel,
		     int *fds, int nfds)
{
	uint16_t t = m->h.type;
	if (t == MC_MSG_FRAME) {
		if (frame && c->mode)
			fq_push(c, frame);
		else
			free(frame);
	} else if (t == MC_MSG_GAP) {
		c->pending_missed += m->u.gap.count;
	} else if (t == MC_MSG_SKELETON && skel) {
		free(c->skel);
		c->skel = skel;
		skel = NULL;
	}
	free(skel);
	if (t == MC_MSG_ERROR && m->u.error.fatal)
		set_dead(c, code_of_server_error(m->u.error.code), "mocapd closed the connection: %s",
			 m->u.error.message);
	if (t == MC_MSG_FRAME || t == MC_MSG_GAP || m->h.request_id == 0) {
		if (t == MC_MSG_ERROR && !m->u.error.fatal) {
			c->async_code = code_of_server_error(m->u.error.code);
			snprintf(c->async_msg, sizeof(c->async_msg), "%s", m->u.error.message);
		}
		close_fds(fds, nfds);
		return;
	}
	waiter *w = find_waiter(c, m->h.request_id);
	uint8_t *copy = w ? malloc(len) : NULL;
	if (!copy) {
		if (t == MC_MSG_ERROR && !m->u.error.fatal && !w) {
			c->async_code = code_of_server_error(m->u.error.code);
			snprintf(c->async_msg, sizeof(c->async_msg), "%s", m->u.error.message);
		}
		close_fds(fds, nfds);
		return;
	}
	memcpy(copy, c->rx, len);
	w->data = copy;
	w->len = len;
	w->nfds = nfds;
	memcpy(w->fds, fds, sizeof(int) * (size_t)nfds);
	w->done = true;
}

/* Receives what is there (lock not held).  Returns after EAGAIN, an error
 * or RX_BURST messages. */
static void read_burst(mocap_client *c)
{
	for (int i = 0; i < RX_BURST; i++) {
		struct iovec iov = {.iov_base = c->rx, .iov_len = sizeof(c->rx)};
		union {
			char buf[CMSG_SPACE(sizeof(int) * MAX_RX_FDS)];
			struct cmsghdr align;
		} ctl;
		struct msghdr mh = {.msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl.buf,
				    .msg_controllen = sizeof(ctl.buf)};
		ssize_t n = recvmsg(c->fd, &mh, MSG_DONTWAIT | MSG_CMSG_CLOEXEC);
		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
			return;
		uint64_t t = mocap_now_ns();
		int fds[MAX_RX_FDS], nfds = 0;
		for (struct cmsghdr *cm = n > 0 ? CMSG_FIRSTHDR(&mh) : NULL; cm; cm = CMSG_NXTHDR(&mh, cm)) {
			if (cm->cmsg_level != SOL_SOCKET || cm->cmsg_type != SCM_RIGHTS)
				continue;
			int k = (int)((cm->cmsg_len - CMSG_LEN(0)) / sizeof(int));
			for (int j = 0; j < k; j++) {
				int fd;
				memcpy(&fd, CMSG_DATA(cm) + (size_t)j * sizeof(int), sizeof(int));
				if (nfds < MAX_RX_FDS)
					fds[nfds++] = fd;
				else
					close(fd);
			}
		}
		pthread_mutex_lock(&c->lock);
		if (n <= 0) {
			if (n == 0)
				set_dead(c, MOCAP_E_DISCONNECTED, "mocapd closed the connection (%s)", c->path);
			else
				set_dead(c, MOCAP_E_DISCONNECTED, "connection to mocapd lost: %s", strerror(errno));
			pthread_mutex_unlock(&c->lock);
			return;
		}
		pthread_mutex_unlock(&c->lock);
		char why[256];
		if ((mh.msg_flags & MSG_TRUNC) ||
		    proto_decode(c->rx, (size_t)n, PROTO_FROM_SERVER, &c->dec, why, sizeof(why)) != 0) {
			if (mh.msg_flags & MSG_TRUNC)
				snprintf(why, sizeof(why), "message longer than %d bytes", PROTO_MAX_MESSAGE);
			close_fds(fds, nfds);
			pthread_mutex_lock(&c->lock);
			set_dead(c, MOCAP_E_PROTOCOL, "mocapd sent a malformed message: %s", why);
			pthread_mutex_unlock(&c->lock);
			return;
		}
		/* Conversions allocate; do them outside the lock. */
		mocap_skeleton_frame *frame = c->dec.h.type == MC_MSG_FRAME ? convert_frame(&c->dec.u.frame, t) : NULL;
		mocap_skeleton_def *skel = c->dec.h.type == MC_MSG_SKELETON ? convert_skeleton(&c->dec.u.skeleton) : NULL;
		pthread_mutex_lock(&c->lock);
		dispatch(c, &c->dec, (size_t)n, frame, skel, fds, nfds);
		pthread_mutex_unlock(&c->lock);
	}
}

/* One step of waiting for something from the socket (lock held on entry
 * and exit): read if nobody else does, else wait for the reader. */
static void wait_step(mocap_client *c, uint64_t deadline)
{
	if (c->reading) {
		if (deadline == FOREVER) {
			pthread_cond_wait(&c->cond, &c->lock);
		} else {
			struct timespec ts = {.tv_sec = (time_t)(deadline / 1000000000ull),
					      .tv_nsec = (long)(deadline % 1000000000ull)};
			pthread_cond_timedwait(&c->cond, &c->lock, &ts);
		}
		return;
	}
	c->reading = true;
	pthread_mutex_unlock(&c->lock);
	/* deadline 0 only takes what is there: no need to poll first. */
	struct pollfd p = {.fd = c->fd, .events = POLLIN};
	if (deadline == 0 || poll(&p, 1, ms_until(deadline)) > 0)
		read_burst(c);
	pthread_mutex_lock(&c->lock);
	c->reading = false;
	pthread_cond_broadcast(&c->cond);
}

/* --- Sending and requests --- */

static int send_msg(mocap_client *c, const proto_msg *m, uint64_t deadline)
{
	uint8_t buf[8192];
	size_t n = proto_encode(m, buf, sizeof(buf));
	if (!n)
		return set_err(MOCAP_E_ARG, "%s: a field is out of the protocol's range", proto_type_name(m->h.type));
	for (;;) {
		ssize_t r = send(c->fd, buf, n, MSG_DONTWAIT | MSG_NOSIGNAL);
		if (r >= 0)
			return 0;
		if (errno == EINTR)
			continue;
		if (errno != EAGAIN && errno != EWOULDBLOCK && errno != ENOBUFS)
			return set_err(MOCAP_E_DISCONNECTED, "sending to mocapd: %s", strerror(errno));
		/* The daemon reads slower than we write: wait for room. */
		struct pollfd p = {.fd = c->fd, .events = POLLOUT};
		int pr = poll(&p, 1, ms_until(deadline));
		if (pr == 0)
			return set_err(MOCAP_E_TIMEOUT, "mocapd does not read our messages");
	}
}

static int dead_error(mocap_client *c) { return set_err(c->dead, "%s", c->dead_msg); }

/* Sends `req` and waits for the reply with the same id.  On success the
 * decoded reply is in *reply (and its descriptors in fds); an ERROR reply
 * becomes its error code. */
static int request_raw(mocap_client *c, proto_msg *req, uint16_t want, proto_msg *reply, int *fds, int *nfds,
		       uint8_t **raw)
{
	uint64_t deadline = deadline_after(c->timeout_ms);
	uint32_t id;
	do
		id = atomic_fetch_add(&c->next_id, 1);
	while (id == 0);
	req->h.request_id = id;

	pthread_mutex_lock(&c->lock);
	if (c->dead) {
		int rc = dead_error(c);
		pthread_mutex_unlock(&c->lock);
		return rc;
	}
	waiter *w = NULL;
	for (int i = 0; i < MAX_WAITERS && !w; i++)
		if (!c->waiters[i].used)
			w = &c->waiters[i];
	if (!w) {
		pthread_mutex_unlock(&c->lock);
		return set_err(MOCAP_E_SYSTEM, "more than %d requests in flight on one connection", MAX_WAITERS);
	}
	memset(w, 0, sizeof(*w));
	w->used = true;
	w->id = id;
	pthread_mutex_unlock(&c->lock);

	int rc = send_msg(c, req, deadline);
	pthread_mutex_lock(&c->lock);
	while (rc == 0 && !w->done && !c->dead) {
		if (mocap_now_ns() >= deadline) {
			rc = set_err(MOCAP_E_TIMEOUT, "no reply from mocapd to %s within %d ms", proto_type_name(req->h.type),
				     c->timeout_ms);
			break;
		}
		wait_step(c, deadline);
	}
	if (rc == 0 && !w->done)
		rc = dead_error(c);
	uint8_t *data = w->data;
	size_t len = w->len;
	int got_fds[MAX_RX_FDS], ngot = w->done ? w->nfds : 0;
	memcpy(got_fds, w->fds, sizeof(int) * (size_t)ngot);
	w->used = false;
	w->data = NULL;
	update_event(c);
	pthread_mutex_unlock(&c->lock);

	if (rc == 0) {
		char why[256];
		if (proto_decode(data, len, PROTO_FROM_SERVER, reply, why, sizeof(why)) != 0)
			rc = set_err(MOCAP_E_PROTOCOL, "mocapd sent a malformed reply: %s", why);
		else if (reply->h.type == MC_MSG_ERROR)
			rc = set_err(code_of_server_error(reply->u.error.code), "%s", reply->u.error.message);
		else if (reply->h.type != want)
			rc = set_err(MOCAP_E_PROTOCOL, "mocapd answered %s with %s, expected %s",
				     proto_type_name(req->h.type), proto_type_name(reply->h.type),
				     proto_type_name(want));
	}
	if (rc == 0 && raw)
		*raw = data; /* the reply points into it (RIG's json) */
	else
		free(data);
	if (rc == 0 && fds && nfds) {
		memcpy(fds, got_fds, sizeof(int) * (size_t)ngot);
		*nfds = ngot;
	} else {
		close_fds(got_fds, ngot);
	}
	return rc;
}

static int request(mocap_client *c, proto_msg *req, uint16_t want, proto_msg *reply, int *fds, int *nfds)
{
	return request_raw(c, req, want, reply, fds, nfds, NULL);
}

/* A request on a heap message (the union is large for small thread stacks). */
static proto_msg *new_msg(uint16_t type)
{
	proto_msg *m = calloc(1, sizeof(*m));
	if (m)
		m->h.type = type;
	else
		set_err(MOCAP_E_SYSTEM, "out of memory");
	return m;
}

/* --- Connection --- */

static int connect_socket(const char *path)
{
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	if (strlen(path) >= sizeof(a.sun_path))
		return set_err(MOCAP_E_ARG, "socket path too long (at most %zu bytes): %s", sizeof(a.sun_path) - 1, path);
	memcpy(a.sun_path, path, strlen(path) + 1);
	int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
	if (fd < 0)
		return set_err(MOCAP_E_SYSTEM, "socket: %s", strerror(errno));
	if (connect(fd, (struct sockaddr *)&a, sizeof(a)) != 0) {
		int e = errno;
		close(fd);
		switch (e) {
		case ENOENT:
			return set_err(MOCAP_E_NOT_RUNNING, "daemon not running at %s (no socket there; is mocapd started?)",
				       path);
		case ECONNREFUSED:
			return set_err(MOCAP_E_NOT_RUNNING, "daemon not running at %s (the socket is left over, nobody listens)",
				       path);
		case EACCES:
		case EPERM:
			return set_err(MOCAP_E_ACCESS,
				       "permission denied connecting to %s: your user needs to be in the daemon's group", path);
		case EPROTOTYPE:
			return set_err(MOCAP_E_PROTOCOL, "%s is not a mocapd socket (wrong socket type)", path);
		case ENOTDIR:
			return set_err(MOCAP_E_NOT_RUNNING, "daemon not running at %s (%s)", path, strerror(e));
		}
		return set_err(MOCAP_E_SYSTEM, "cannot connect to %s: %s", path, strerror(e));
	}
	fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
	return fd;
}

static mocap_client *client_new(int fd, const char *path)
{
	mocap_client *c = calloc(1, sizeof(*c));
	if (!c)
		return NULL;
	c->fd = fd;
	c->epfd = c->evfd = -1;
	snprintf(c->path, sizeof(c->path), "%s", path);
	c->timeout_ms = 10000;
	atomic_init(&c->next_id, 1);
	pthread_mutex_init(&c->lock, NULL);
	pthread_condattr_t ca;
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&c->cond, &ca);
	pthread_condattr_destroy(&ca);
	c->fq = calloc(FRAME_QUEUE_MAX, sizeof(*c->fq));
	c->evfd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	c->epfd = epoll_create1(EPOLL_CLOEXEC);
	if (!c->fq || c->evfd < 0 || c->epfd < 0) {
		mocap_close(c);
		return NULL;
	}
	struct epoll_event ev = {.events = EPOLLIN, .data.fd = c->fd};
	epoll_ctl(c->epfd, EPOLL_CTL_ADD, c->fd, &ev);
	ev.data.fd = c->evfd;
	epoll_ctl(c->epfd, EPOLL_CTL_ADD, c->evfd, &ev);
	return c;
}

mocap_client *mocap_connect(const char *path, const char *client_name)
{
	if (!path)
		path = mocap_default_socket();
	int fd = connect_socket(path);
	if (fd < 0)
		return NULL;
	mocap_client *c = client_new(fd, path);
	if (!c) {
		close(fd);
		set_err(MOCAP_E_SYSTEM, "out of memory");
		return NULL;
	}
	proto_msg *m = new_msg(MC_MSG_HELLO);
	if (!m) {
		mocap_close(c);
		return NULL;
	}
	m->u.hello.magic = PROTO_MAGIC;
	m->u.hello.min_version = PROTO_VERSION;
	m->u.hello.max_version = PROTO_VERSION;
	snprintf(m->u.hello.client_name, sizeof(m->u.hello.client_name), "%s", client_name ? client_name : "");
	int rc = request(c, m, MC_MSG_WELCOME, m, NULL, NULL);
	if (rc == 0)
		c->privileged = (m->u.welcome.flags & MC_WELCOME_PRIVILEGED) != 0;
	free(m);
	if (rc != 0) {
		/* Keep the message of the failed handshake across mocap_close. */
		int code = tl_code;
		char msg[sizeof(tl_msg)];
		snprintf(msg, sizeof(msg), "%s", tl_msg);
		mocap_close(c);
		set_err(code, "%s: %s", path, msg);
		return NULL;
	}
	return c;
}

void mocap_close(mocap_client *c)
{
	if (!c)
		return;
	if (c->fq) {
		fq_clear(c);
		free(c->fq);
	}
	for (int i = 0; i < MAX_WAITERS; i++) {
		free(c->waiters[i].data);
		if (c->waiters[i].done)
			close_fds(c->waiters[i].fds, c->waiters[i].nfds);
	}
	free(c->skel);
	if (c->epfd >= 0)
		close(c->epfd);
	if (c->evfd >= 0)
		close(c->evfd);
	close(c->fd);
	pthread_cond_destroy(&c->cond);
	pthread_mutex_destroy(&c->lock);
	free(c);
}

int mocap_is_privileged(const mocap_client *c) { return c->privileged; }
void mocap_set_timeout(mocap_client *c, int timeout_ms) { c->timeout_ms = timeout_ms < 0 ? -1 : timeout_ms; }
int mocap_fd(mocap_client *c) { return c->epfd; }

/* --- Requests --- */

int mocap_subscribe(mocap_client *c, mocap_mode mode, mocap_space space, unsigned queue_len)
{
	if (mode != MOCAP_LATEST && mode != MOCAP_ALL)
		return set_err(MOCAP_E_ARG, "subscribe: mode must be MOCAP_LATEST or MOCAP_ALL");
	if (space != MOCAP_SPACE_RIG && space != MOCAP_SPACE_WORLD)
		return set_err(MOCAP_E_ARG, "subscribe: space must be MOCAP_SPACE_RIG or MOCAP_SPACE_WORLD");
	proto_msg *m = new_msg(MC_MSG_SUBSCRIBE);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.subscribe.mode = (uint8_t)mode;
	m->u.subscribe.space = (uint8_t)space;
	m->u.subscribe.queue_len = queue_len;
	/* Frames of an older subscription still in flight are dropped
	 * from here on until the reply (they may be of another mode). */
	pthread_mutex_lock(&c->lock);
	c->mode = 0;
	fq_clear(c);
	c->pending_missed = 0;
	update_event(c);
	pthread_mutex_unlock(&c->lock);
	int rc = request(c, m, MC_MSG_OK, m, NULL, NULL);
	free(m);
	if (rc == 0) {
		pthread_mutex_lock(&c->lock);
		c->mode = mode;
		pthread_mutex_unlock(&c->lock);
	}
	return rc;
}

int mocap_unsubscribe(mocap_client *c)
{
	proto_msg *m = new_msg(MC_MSG_UNSUBSCRIBE);
	if (!m)
		return MOCAP_E_SYSTEM;
	pthread_mutex_lock(&c->lock);
	c->mode = 0;
	fq_clear(c);
	update_event(c);
	pthread_mutex_unlock(&c->lock);
	int rc = request(c, m, MC_MSG_OK, m, NULL, NULL);
	free(m);
	return rc;
}

int mocap_read_frame(mocap_client *c, mocap_skeleton_frame *f, int timeout_ms)
{
	uint64_t deadline = deadline_after(timeout_ms < 0 ? -1 : timeout_ms);
	int rc = 0;
	bool looked = false;
	pthread_mutex_lock(&c->lock);
	if (!c->mode && !c->fq_n && !c->dead) {
		pthread_mutex_unlock(&c->lock);
		return set_err(MOCAP_E_ARG, "read_frame: not subscribed (call mocap_subscribe first)");
	}
	/* LATEST: take in everything already there first, to return the newest. */
	if (c->mode == MOCAP_LATEST && !c->reading) {
		wait_step(c, 0);
		looked = true;
	}
	for (;;) {
		if (c->fq_n) {
			mocap_skeleton_frame *q = c->fq[c->fq_head];
			c->fq_head = (c->fq_head + 1) % FRAME_QUEUE_MAX;
			c->fq_n--;
			memcpy(f, q, FRAME_BYTES(q->njoints));
			free(q);
			rc = 1;
			break;
		}
		if (c->dead) {
			rc = dead_error(c);
			break;
		}
		/* Even with a zero timeout, look at the socket once. */
		if (looked && deadline != FOREVER && mocap_now_ns() >= deadline)
			break;
		wait_step(c, deadline);
		looked = true;
	}
	update_event(c);
	pthread_mutex_unlock(&c->lock);
	return rc;
}

int mocap_get_skeleton(mocap_client *c, mocap_skeleton_def *s)
{
	proto_msg *m = new_msg(MC_MSG_GET_SKELETON);
	if (!m)
		return MOCAP_E_SYSTEM;
	int rc = request(c, m, MC_MSG_SKELETON, m, NULL, NULL);
	if (rc == 0) {
		mocap_skeleton_def *k = convert_skeleton(&m->u.skeleton);
		if (k) {
			*s = *k;
			free(k);
		} else {
			rc = set_err(MOCAP_E_SYSTEM, "out of memory");
		}
	}
	free(m);
	return rc;
}

int mocap_get_status(mocap_client *c, mocap_daemon_status *st)
{
	proto_msg *m = new_msg(MC_MSG_GET_STATUS);
	if (!m)
		return MOCAP_E_SYSTEM;
	int rc = request(c, m, MC_MSG_STATUS, m, NULL, NULL);
	if (rc == 0) {
		const mc_msg_status *s = &m->u.status;
		memset(st, 0, sizeof(*st));
		st->tracker_state = (mocap_track_state)s->tracker_state;
		st->recording = s->recording;
		st->publish_fps = s->publish_fps;
		st->track_ms_mean = s->track_ms_mean;
		st->track_ms_max = s->track_ms_max;
		st->frames_published = s->frames_published;
		st->frames_dropped = s->frames_dropped;
		st->client_drops = s->client_drops;
		st->server_time_ns = s->server_time_ns;
		st->uptime_ns = s->server_time_ns > s->start_ns ? s->server_time_ns - s->start_ns : 0;
		st->clients = (int)s->nclients;
		snprintf(st->device, sizeof(st->device), "%s", s->device);
		st->ncams = s->ncams;
		for (int i = 0; i < s->ncams; i++) {
			mocap_camera_status *cs = &st->cams[i];
			snprintf(cs->name, sizeof(cs->name), "%s", s->cams[i].name);
			cs->state = (int)s->cams[i].state;
			cs->width = (int)s->cams[i].width;
			cs->height = (int)s->cams[i].height;
			cs->fps = s->cams[i].fps;
			cs->frames = s->cams[i].frames;
			cs->drops = s->cams[i].drops;
		}
	}
	free(m);
	return rc;
}

int mocap_get_rig(mocap_client *c, char **json, int *ncams)
{
	*json = NULL;
	proto_msg *m = new_msg(MC_MSG_GET_RIG);
	if (!m)
		return MOCAP_E_SYSTEM;
	uint8_t *raw = NULL;
	int rc = request_raw(c, m, MC_MSG_RIG, m, NULL, NULL, &raw);
	if (rc == 0) {
		*json = malloc((size_t)m->u.rig.length + 1);
		if (*json) {
			memcpy(*json, m->u.rig.json, m->u.rig.length);
			(*json)[m->u.rig.length] = 0;
			if (ncams)
				*ncams = (int)m->u.rig.ncams;
		} else {
			rc = set_err(MOCAP_E_SYSTEM, "out of memory");
		}
	}
	free(raw);
	free(m);
	return rc;
}

int mocap_control(mocap_client *c, mocap_command cmd, const char *argument, char *msg, size_t msglen)
{
	if (msg && msglen)
		msg[0] = 0;
	if (argument && strlen(argument) > PROTO_ARG_MAX)
		return set_err(MOCAP_E_ARG, "control: argument longer than %d bytes", PROTO_ARG_MAX);
	proto_msg *m = new_msg(MC_MSG_CONTROL);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.control.command = (uint32_t)cmd;
	snprintf(m->u.control.argument, sizeof(m->u.control.argument), "%s", argument ? argument : "");
	int rc = request(c, m, MC_MSG_CONTROL_RESULT, m, NULL, NULL);
	if (rc == 0) {
		if (msg && msglen)
			snprintf(msg, msglen, "%s", m->u.control_result.message);
		if (m->u.control_result.result != 0)
			rc = set_err(MOCAP_E_FAILED, "%s", m->u.control_result.message);
	} else if (msg && msglen) {
		snprintf(msg, msglen, "%s", tl_msg);
	}
	free(m);
	return rc;
}

int mocap_get_rings(mocap_client *c, mocap_ring *rings, int max)
{
	proto_msg *m = new_msg(MC_MSG_GET_RINGS);
	if (!m)
		return MOCAP_E_SYSTEM;
	int fds[MAX_RX_FDS], nfds = 0;
	int rc = request(c, m, MC_MSG_RINGS, m, fds, &nfds);
	if (rc == 0) {
		if (nfds != m->u.rings.count) {
			close_fds(fds, nfds);
			rc = set_err(MOCAP_E_PROTOCOL, "RINGS lists %u rings but came with %d descriptors",
				     m->u.rings.count, nfds);
		} else {
			int n = 0;
			for (int i = 0; i < nfds; i++) {
				if (n >= max) {
					close(fds[i]);
					continue;
				}
				snprintf(rings[n].camera, sizeof(rings[n].camera), "%s", m->u.rings.rings[i].name);
				rings[n].fd = fds[i];
				rings[n].size = m->u.rings.rings[i].size;
				n++;
			}
			rc = n;
		}
	}
	free(m);
	return rc;
}

/* The refusal of an earlier unacknowledged message, if any (lock held). */
static int take_async_error(mocap_client *c)
{
	if (c->dead)
		return dead_error(c);
	if (!c->async_code)
		return 0;
	int code = set_err(c->async_code, "%s", c->async_msg);
	c->async_code = 0;
	return code;
}

/* Sends an unacknowledged message; reports an earlier refusal first. */
static int send_oneway(mocap_client *c, proto_msg *m)
{
	/* Read what has arrived, so that a refusal is seen promptly. */
	pthread_mutex_lock(&c->lock);
	if (!c->reading)
		wait_step(c, 0);
	int rc = take_async_error(c);
	update_event(c);
	pthread_mutex_unlock(&c->lock);
	if (rc)
		return rc;
	uint32_t id;
	do
		id = atomic_fetch_add(&c->next_id, 1);
	while (id == 0);
	m->h.request_id = id;
	return send_msg(c, m, deadline_after(c->timeout_ms));
}

int mocap_send_keypoints(mocap_client *c, uint64_t capture_ns, int camera, const mocap_keypoint *kp, int n)
{
	if (n < 0 || n > MOCAP_MAX_KEYPOINTS)
		return set_err(MOCAP_E_ARG, "keypoints: %d in one batch, at most %d", n, MOCAP_MAX_KEYPOINTS);
	if (camera < 0 || camera > 65535)
		return set_err(MOCAP_E_ARG, "keypoints: camera %d out of range", camera);
	proto_msg *m = new_msg(MC_MSG_KEYPOINTS);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.keypoints.capture_ns = capture_ns;
	m->u.keypoints.camera = (uint16_t)camera;
	m->u.keypoints.count = (uint16_t)n;
	int rc = 0;
	for (int i = 0; i < n && rc == 0; i++) {
		if (kp[i].joint < 0 || kp[i].joint > 65535)
			rc = set_err(MOCAP_E_ARG, "keypoints: keypoint %d: joint %d out of range", i, kp[i].joint);
		else if (!isfinite(kp[i].u) || !isfinite(kp[i].v) || !(kp[i].confidence >= 0 && kp[i].confidence <= 1))
			rc = set_err(MOCAP_E_ARG, "keypoints: keypoint %d: u, v must be finite and confidence in 0..1", i);
		m->u.keypoints.kp[i].joint = (uint16_t)kp[i].joint;
		m->u.keypoints.kp[i].u = kp[i].u;
		m->u.keypoints.kp[i].v = kp[i].v;
		m->u.keypoints.kp[i].confidence = kp[i].confidence;
	}
	if (rc == 0)
		rc = send_oneway(c, m);
	free(m);
	return rc;
}

int mocap_send_head_pose(mocap_client *c, uint64_t timestamp_ns, const double position[3],
			 const double orientation_wxyz[4])
{
	double n2 = 0;
	for (int i = 0; i < 4; i++) {
		n2 += orientation_wxyz[i] * orientation_wxyz[i];
		if (!isfinite(orientation_wxyz[i]) || (i < 3 && !isfinite(position[i])))
			return set_err(MOCAP_E_ARG, "head pose: not a finite number");
	}
	if (fabs(sqrt(n2) - 1.0) > 1e-3)
		return set_err(MOCAP_E_ARG, "head pose: orientation is not a unit quaternion (w, x, y, z): length %g",
			       sqrt(n2));
	proto_msg *m = new_msg(MC_MSG_HEAD_POSE);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.head_pose.timestamp_ns = timestamp_ns;
	memcpy(m->u.head_pose.position, position, sizeof(m->u.head_pose.position));
	memcpy(m->u.head_pose.orientation, orientation_wxyz, sizeof(m->u.head_pose.orientation));
	int rc = send_oneway(c, m);
	free(m);
	return rc;
}

int mocap_ping(mocap_client *c, uint64_t *server_time_ns)
{
	proto_msg *m = new_msg(MC_MSG_PING);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.ping.value = mocap_now_ns();
	int rc = request(c, m, MC_MSG_PONG, m, NULL, NULL);
	if (rc == 0 && server_time_ns)
		*server_time_ns = m->u.ping.server_time_ns;
	free(m);
	return rc;
}
