/* srv_server: the daemon's end of the client socket.  See server.h for the
 * contract and docs/PROTOCOL.md for the messages.
 *
 * Threads.  The daemon's threads only touch `shared` (under `lock`): the
 * publish mailbox, the skeleton definition, status, rig, rings and the
 * queues the daemon polls.  Everything about clients belongs to the server
 * thread alone, so sockets are never shared between threads and the
 * daemon's calls never wait for a socket.
 *
 * Queues.  An outgoing message is encoded once into a reference-counted
 * `blob` and shared by every client that gets it.  Each client has a FIFO of
 * blobs: at most queue_len frames ("all" mode) plus a few replies.  A
 * "latest" client has no frames in its FIFO, only a one-frame slot that each
 * new frame replaces.  Sockets are non-blocking; whatever the kernel does not
 * take stays queued until EPOLLOUT. */
#include "server.h"
#include "proto.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define MAILBOX_LEN 128           /* frames the server thread may lag behind (2 s at 60 Hz) */
#define NONFRAME_MAX 64           /* replies, gaps, definitions queued per client */
#define KEYPOINT_QUEUE_LEN 64
#define CONTROL_QUEUE_LEN 16
#define HEAD_POSE_HISTORY 64
#define HANDSHAKE_TIMEOUT_NS 5000000000ull
#define READ_BURST 32             /* messages read from one client per wake-up, for fairness */
#define MAX_PEER_GROUPS 256

/* Copies a C string into a fixed buffer, truncating. */
static void str_copy(char *dst, size_t size, const char *src)
{
	size_t n = strnlen(src, size - 1);
	memmove(dst, src, n);
	dst[n] = 0;
}

static uint64_t now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* --- Blobs: encoded messages shared between client queues. --- */

typedef struct {
	int refs;
	bool is_frame;
	size_t len;
	int nfds;                       /* descriptors sent with it (RINGS) */
	int fds[PROTO_MAX_RINGS];
	uint8_t data[];
} blob;

static blob *blob_new(const uint8_t *data, size_t len, bool is_frame)
{
	blob *b = malloc(sizeof(*b) + len);
	if (!b)
		return NULL;
	b->refs = 1;
	b->is_frame = is_frame;
	b->len = len;
	b->nfds = 0;
	memcpy(b->data, data, len);
	return b;
}

static blob *blob_ref(blob *b)
{
	b->refs++;
	return b;
}

static void blob_unref(blob *b)
{
	if (!b || --b->refs > 0)
		return;
	for (int i = 0; i < b->nfds; i++)
		close(b->fds[i]);
	free(b);
}

/* --- State --- */

typedef struct {
	uint64_t seq, capture_ns, publish_ns;
	uint32_t skeleton_id;
	uint8_t state;
	int njoints;
	struct {
		double pos[3], quat[4];
		float conf;
	} j[MC_MAX_JOINTS];
} pending_frame;

typedef struct client {
	int fd;
	uint64_t serial;        /* unique per connection, for control tokens */
	uint64_t accepted_ns;
	bool hello, privileged, dead;
	pid_t pid;
	uid_t uid;
	gid_t gid;
	char name[PROTO_NAME_MAX + 1];
	uint8_t mode;           /* 0 = not subscribed, else mc_sub_mode */
	uint8_t space;
	uint32_t queue_len;
	blob **q;               /* FIFO ring */
	int qcap, qhead, qn, qframes;
	blob *latest;           /* "latest" mode slot */
	uint64_t gap_first, gap_count; /* frames dropped, not yet reported */
	bool epollout;
} client;

typedef struct {
	uint64_t token;
	bool polled;
	uint64_t client_serial;
	uint32_t request_id;
	srv_control req;
} control_entry;

typedef struct {
	uint64_t token;
	int result;
	char message[PROTO_TEXT_MAX + 1];
} control_result;

typedef struct {
	int fd; /* our own O_RDONLY descriptor */
	uint64_t size;
	char name[PROTO_NAME_MAX + 1];
} ring_entry;

struct srv_server {
	srv_config cfg;
	int listen_fd, epfd, wake_fd, event_fd;
	bool created_path;
	dev_t path_dev;
	ino_t path_ino;
	pthread_t thread;
	bool thread_started;
	atomic_bool stop;

	/* Shared with the daemon's threads, under lock. */
	pthread_mutex_t lock;
	pending_frame mailbox[MAILBOX_LEN];
	int mb_head, mb_count;
	bool def_set, def_changed;
	int def_at;             /* mailbox frames published before the change */
	uint32_t def_id;
	srv_skeleton_def def;
	srv_status status;
	char *rig_json;
	int rig_ncams;
	ring_entry rings[SRV_MAX_RINGS];
	int nrings;
	control_entry controls[CONTROL_QUEUE_LEN];
	int ncontrols;
	uint64_t next_token;
	control_result results[CONTROL_QUEUE_LEN];
	int nresults;
	srv_keypoints *kp_queue; /* ring of KEYPOINT_QUEUE_LEN */
	int kp_head, kp_count;
	bool have_head_pose;
	srv_head_pose latest_head_pose;
	srv_stats stats;

	/* Server thread only. */
	client **clients;       /* live ones and, until reap_clients(), dead ones */
	int nclients, clients_cap;
	uint64_t next_serial;
	uint64_t expected_seq; /* 0 = none yet */
	blob *def_blob;
	bool def_rig_is_world;
	int def_njoints;
	srv_head_pose head_hist[HEAD_POSE_HISTORY];
	int head_n, head_next;
	pending_frame drained[MAILBOX_LEN];
	srv_skeleton_def def_copy;
	proto_msg in, out;
	uint8_t rxbuf[PROTO_MAX_MESSAGE + 1];
	uint8_t txbuf[PROTO_MAX_MESSAGE];
};

/* --- Config --- */

void srv_config_default(srv_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	str_copy(cfg->path, sizeof(cfg->path), SRV_DEFAULT_PATH);
	cfg->listen_fd = -1;
	cfg->max_clients = 64;
	cfg->queue_len = 256;
	cfg->max_queue_len = 4096;
	cfg->socket_mode = 0660;
	cfg->control_gid = (gid_t)-1;
	cfg->head_pose_max_age_ns = 50000000ull;
	snprintf(cfg->daemon_version, sizeof(cfg->daemon_version), "mocapd");
}

/* --- Listening socket --- */

/* Removes a socket file nobody listens on (left by a killed daemon).  Any
 * other file, or a live listener, is left alone and reported. */
static int remove_stale_socket(const char *path, mc_err *err)
{
	struct stat st;
	if (lstat(path, &st) != 0) {
		if (errno == ENOENT)
			return 0;
		return mc_err_set(err, "%s: %s", path, strerror(errno));
	}
	if (!S_ISSOCK(st.st_mode))
		return mc_err_set(err, "%s: exists and is not a socket; not removing it", path);
	int probe = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
	if (probe < 0)
		return mc_err_set(err, "socket: %s", strerror(errno));
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	str_copy(a.sun_path, sizeof(a.sun_path), path);
	int rc = connect(probe, (struct sockaddr *)&a, sizeof(a));
	int e = errno;
	close(probe);
	if (rc == 0)
		return mc_err_set(err, "%s: another mocapd is listening there", path);
	if (e == EPROTOTYPE)
		return mc_err_set(err, "%s: another program is listening there (not a SOCK_SEQPACKET socket)", path);
	if (e != ECONNREFUSED)
		return mc_err_set(err, "%s: cannot tell whether the socket is in use: %s", path, strerror(e));
	if (unlink(path) != 0 && errno != ENOENT)
		return mc_err_set(err, "%s: cannot remove the stale socket: %s", path, strerror(errno));
	return 0;
}

static int adopt_listen_fd(srv_server *srv, mc_err *err)
{
	int fd = srv->cfg.listen_fd, type = 0, domain = 0, listening = 0;
	socklen_t l = sizeof(int);
	if (getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &l) != 0)
		return mc_err_set(err, "listen fd %d: %s", fd, strerror(errno));
	l = sizeof(int);
	getsockopt(fd, SOL_SOCKET, SO_DOMAIN, &domain, &l);
	l = sizeof(int);
	getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &l);
	if (domain != AF_UNIX || type != SOCK_SEQPACKET || !listening)
		return mc_err_set(err, "listen fd %d: expected a listening AF_UNIX SOCK_SEQPACKET socket "
				       "(ListenSequentialPacket= in mocapd.socket)", fd);
	int fl = fcntl(fd, F_GETFL);
	fcntl(fd, F_SETFL, fl | O_NONBLOCK);
	fcntl(fd, F_SETFD, FD_CLOEXEC);
	srv->listen_fd = fd;
	return 0;
}

static int create_listen_socket(srv_server *srv, mc_err *err)
{
	const char *path = srv->cfg.path;
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	if (!path[0])
		return mc_err_set(err, "socket path is empty");
	if (strlen(path) >= sizeof(a.sun_path))
		return mc_err_set(err, "%s: socket path too long (at most %zu bytes)", path, sizeof(a.sun_path) - 1);
	memcpy(a.sun_path, path, strlen(path) + 1);
	if (remove_stale_socket(path, err) < 0)
		return -1;
	int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (fd < 0)
		return mc_err_set(err, "socket: %s", strerror(errno));
	/* bind, then fix mode and group, then listen: nobody can connect
	 * before listen(), so there is no window with the wrong permissions. */
	if (bind(fd, (struct sockaddr *)&a, sizeof(a)) != 0) {
		mc_err_set(err, "%s: cannot create the socket: %s", path, strerror(errno));
		close(fd);
		return -1;
	}
	srv->created_path = true;
	struct stat st;
	if (stat(path, &st) == 0) {
		srv->path_dev = st.st_dev;
		srv->path_ino = st.st_ino;
	}
	srv->listen_fd = fd;
	if (chmod(path, srv->cfg.socket_mode & 07777) != 0)
		return mc_err_set(err, "%s: chmod %o: %s", path, srv->cfg.socket_mode, strerror(errno));
	if (srv->cfg.control_gid != (gid_t)-1 && chown(path, (uid_t)-1, srv->cfg.control_gid) != 0)
		return mc_err_set(err, "%s: cannot give the socket to group %u: %s", path,
				  (unsigned)srv->cfg.control_gid, strerror(errno));
	if (listen(fd, 64) != 0)
		return mc_err_set(err, "%s: listen: %s", path, strerror(errno));
	return 0;
}

/* --- Client queues --- */

static void epoll_update(srv_server *srv, client *c, bool want_out)
{
	if (c->epollout == want_out || c->dead)
		return;
	struct epoll_event ev = {.events = EPOLLIN | (want_out ? EPOLLOUT : 0), .data.ptr = c};
	epoll_ctl(srv->epfd, EPOLL_CTL_MOD, c->fd, &ev);
	c->epollout = want_out;
}

static blob *q_front(client *c) { return c->q[c->qhead]; }

static void q_pop(client *c)
{
	blob *b = c->q[c->qhead];
	if (b->is_frame)
		c->qframes--;
	blob_unref(b);
	c->qhead = (c->qhead + 1) % c->qcap;
	c->qn--;
}

/* Appends a blob (taking a reference).  false when the client's reply
 * budget is exhausted: it does not read what it asked for. */
static bool q_push(client *c, blob *b)
{
	if (!b->is_frame && c->qn - c->qframes >= NONFRAME_MAX)
		return false;
	if (c->qn >= c->qcap)
		return false;
	c->q[(c->qhead + c->qn) % c->qcap] = blob_ref(b);
	c->qn++;
	if (b->is_frame)
		c->qframes++;
	return true;
}

/* Rebuilds the FIFO with room for `frames` frames, dropping queued frames
 * when `drop_frames` (a new subscription starts a new stream). */
static bool q_reshape(client *c, int frames, bool drop_frames)
{
	int cap = frames + NONFRAME_MAX + 1;
	blob **nq = calloc((size_t)cap, sizeof(*nq));
	if (!nq)
		return false;
	int n = 0, nframes = 0;
	for (int i = 0; i < c->qn; i++) {
		blob *b = c->q[(c->qhead + i) % c->qcap];
		if (b->is_frame && (drop_frames || nframes >= frames)) {
			blob_unref(b);
			continue;
		}
		nframes += b->is_frame;
		nq[n++] = b;
	}
	free(c->q);
	c->q = nq;
	c->qcap = cap;
	c->qhead = 0;
	c->qn = n;
	c->qframes = nframes;
	return true;
}

static blob *encode_blob(srv_server *srv, const proto_msg *m, bool is_frame)
{
	size_t n = proto_encode(m, srv->txbuf, sizeof(srv->txbuf));
	return n ? blob_new(srv->txbuf, n, is_frame) : NULL;
}

static void client_close(srv_server *srv, client *c);

/* Sends one blob.  1 sent, 0 the socket is full, -1 the client is gone. */
static int send_blob(client *c, const blob *b)
{
	struct iovec iov = {.iov_base = (void *)b->data, .iov_len = b->len};
	struct msghdr mh = {.msg_iov = &iov, .msg_iovlen = 1};
	union {
		char buf[CMSG_SPACE(sizeof(int) * PROTO_MAX_RINGS)];
		struct cmsghdr align;
	} ctl;
	if (b->nfds > 0) {
		mh.msg_control = ctl.buf;
		mh.msg_controllen = CMSG_SPACE(sizeof(int) * (size_t)b->nfds);
		struct cmsghdr *cm = CMSG_FIRSTHDR(&mh);
		cm->cmsg_level = SOL_SOCKET;
		cm->cmsg_type = SCM_RIGHTS;
		cm->cmsg_len = CMSG_LEN(sizeof(int) * (size_t)b->nfds);
		memcpy(CMSG_DATA(cm), b->fds, sizeof(int) * (size_t)b->nfds);
	}
	for (;;) {
		ssize_t n = sendmsg(c->fd, &mh, MSG_DONTWAIT | MSG_NOSIGNAL);
		if (n >= 0)
			return 1;
		if (errno == EINTR)
			continue;
		if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)
			return 0;
		return -1;
	}
}

/* Reports dropped frames once the queue has room again. */
static void maybe_queue_gap(srv_server *srv, client *c)
{
	if (!c->gap_count || c->mode != MC_SUB_ALL || c->qframes >= (int)c->queue_len)
		return;
	proto_msg *m = &srv->out;
	memset(&m->h, 0, sizeof(m->h));
	m->h.type = MC_MSG_GAP;
	m->u.gap.first_seq = c->gap_first;
	m->u.gap.count = c->gap_count;
	blob *b = encode_blob(srv, m, false);
	if (b && q_push(c, b)) {
		c->gap_count = 0;
		c->gap_first = 0;
	}
	blob_unref(b);
}

/* Sends what the socket takes: the FIFO first, then the latest frame. */
static void client_flush(srv_server *srv, client *c)
{
	for (;;) {
		if (c->dead)
			return;
		maybe_queue_gap(srv, c);
		blob *b = c->qn ? q_front(c) : c->latest;
		if (!b)
			break;
		int rc = send_blob(c, b);
		if (rc < 0) {
			client_close(srv, c);
			return;
		}
		if (rc == 0) {
			epoll_update(srv, c, true);
			return;
		}
		if (c->qn)
			q_pop(c);
		else {
			blob_unref(c->latest);
			c->latest = NULL;
		}
	}
	epoll_update(srv, c, false);
}

static void reply_error(srv_server *srv, client *c, uint32_t request_id, uint16_t request_type, uint32_t code,
			bool fatal, const char *fmt, ...) __attribute__((format(printf, 7, 8)));

/* Queues a reply; a client that does not read its replies is dropped. */
static void client_send(srv_server *srv, client *c, blob *b)
{
	if (!b || c->dead)
		return;
	if (!q_push(c, b)) {
		reply_error(srv, c, 0, 0, PROTO_E_OVERLOAD, true,
			    "more than %d replies unread: the client does not read its socket", NONFRAME_MAX);
		return;
	}
	client_flush(srv, c);
}

static void reply_error(srv_server *srv, client *c, uint32_t request_id, uint16_t request_type, uint32_t code,
			bool fatal, const char *fmt, ...)
{
	if (c->dead)
		return;
	proto_msg *m = &srv->out;
	memset(&m->h, 0, sizeof(m->h));
	m->h.type = MC_MSG_ERROR;
	m->h.request_id = request_id;
	m->u.error.code = code;
	m->u.error.request_type = request_type;
	m->u.error.fatal = fatal;
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(m->u.error.message, sizeof(m->u.error.message), fmt, ap);
	va_end(ap);
	blob *b = encode_blob(srv, m, false);
	if (fatal) {
		/* Last words: drop whatever was queued, try once, close. */
		if (b)
			send_blob(c, b);
		blob_unref(b);
		client_close(srv, c);
		return;
	}
	client_send(srv, c, b);
	blob_unref(b);
}

static void reply_ok(srv_server *srv, client *c, uint32_t request_id, uint16_t request_type, uint32_t value)
{
	proto_msg *m = &srv->out;
	memset(&m->h, 0, sizeof(m->h));
	m->h.type = MC_MSG_OK;
	m->h.request_id = request_id;
	m->u.ok.request_type = request_type;
	m->u.ok.value = value;
	blob *b = encode_blob(srv, m, false);
	client_send(srv, c, b);
	blob_unref(b);
}

/* --- Connections --- */

static bool in_group_list(const gid_t *groups, int n, gid_t g)
{
	for (int i = 0; i < n; i++)
		if (groups[i] == g)
			return true;
	return false;
}

/* The daemon's user, root, or a member of the control group. */
static bool peer_is_privileged(const srv_server *srv, int fd, const struct ucred *cr)
{
	if (cr->uid == 0 || cr->uid == geteuid())
		return true;
	gid_t g = srv->cfg.control_gid == (gid_t)-1 ? getegid() : srv->cfg.control_gid;
	if (cr->gid == g)
		return true;
	gid_t groups[MAX_PEER_GROUPS];
	socklen_t len = sizeof(groups);
	if (getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, groups, &len) == 0)
		return in_group_list(groups, (int)(len / sizeof(gid_t)), g);
	return false;
}

static void refuse_connection(srv_server *srv, int fd, const char *why)
{
	proto_msg *m = &srv->out;
	memset(m, 0, sizeof(*m));
	m->h.type = MC_MSG_ERROR;
	m->u.error.code = PROTO_E_TOO_MANY_CLIENTS;
	m->u.error.fatal = 1;
	str_copy(m->u.error.message, sizeof(m->u.error.message), why);
	size_t n = proto_encode(m, srv->txbuf, sizeof(srv->txbuf));
	if (n)
		send(fd, srv->txbuf, n, MSG_DONTWAIT | MSG_NOSIGNAL);
	close(fd);
	pthread_mutex_lock(&srv->lock);
	srv->stats.refused++;
	pthread_mutex_unlock(&srv->lock);
}

static int live_clients(const srv_server *srv)
{
	int n = 0;
	for (int i = 0; i < srv->nclients; i++)
		n += !srv->clients[i]->dead;
	return n;
}

static bool grow_clients(srv_server *srv)
{
	int cap = srv->clients_cap ? 2 * srv->clients_cap : 16;
	client **nc = realloc(srv->clients, (size_t)cap * sizeof(*nc));
	if (!nc)
		return false;
	srv->clients = nc;
	srv->clients_cap = cap;
	return true;
}

static void accept_clients(srv_server *srv)
{
	for (;;) {
		int fd = accept4(srv->listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
		if (fd < 0)
			return; /* EAGAIN, or a transient error: epoll tells us again */
		if (live_clients(srv) >= srv->cfg.max_clients) {
			char why[128];
			snprintf(why, sizeof(why), "too many clients: mocapd accepts at most %d at once",
				 srv->cfg.max_clients);
			refuse_connection(srv, fd, why);
			continue;
		}
		client *c = calloc(1, sizeof(*c));
		struct ucred cr;
		socklen_t l = sizeof(cr);
		if (!c || getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cr, &l) != 0 || !q_reshape(c, 0, true)) {
			free(c);
			close(fd);
			continue;
		}
		c->fd = fd;
		c->serial = ++srv->next_serial;
		c->accepted_ns = now_ns();
		c->pid = cr.pid;
		c->uid = cr.uid;
		c->gid = cr.gid;
		c->privileged = peer_is_privileged(srv, fd, &cr);
		struct epoll_event ev = {.events = EPOLLIN, .data.ptr = c};
		if (epoll_ctl(srv->epfd, EPOLL_CTL_ADD, fd, &ev) != 0) {
			free(c->q);
			free(c);
			close(fd);
			continue;
		}
		if (srv->nclients == srv->clients_cap && !grow_clients(srv)) {
			epoll_ctl(srv->epfd, EPOLL_CTL_DEL, fd, NULL);
			free(c->q);
			free(c);
			close(fd);
			continue;
		}
		srv->clients[srv->nclients++] = c;
		pthread_mutex_lock(&srv->lock);
		srv->stats.accepted++;
		srv->stats.clients = live_clients(srv);
		pthread_mutex_unlock(&srv->lock);
	}
}

/* Marks the client dead and closes its socket; the struct is freed by
 * reap_clients() at the end of the loop iteration, because callers up the
 * stack may still hold the pointer. */
static void client_close(srv_server *srv, client *c)
{
	if (c->dead)
		return;
	c->dead = true;
	epoll_ctl(srv->epfd, EPOLL_CTL_DEL, c->fd, NULL);
	close(c->fd);
	c->fd = -1;
}

static void reap_clients(srv_server *srv)
{
	int n = 0;
	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (!c->dead) {
			srv->clients[n++] = c;
			continue;
		}
		while (c->qn)
			q_pop(c);
		blob_unref(c->latest);
		free(c->q);
		free(c);
	}
	if (n != srv->nclients) {
		srv->nclients = n;
		pthread_mutex_lock(&srv->lock);
		srv->stats.clients = n;
		pthread_mutex_unlock(&srv->lock);
	}
}

static client *find_client(srv_server *srv, uint64_t serial)
{
	for (int i = 0; i < srv->nclients; i++)
		if (srv->clients[i]->serial == serial && !srv->clients[i]->dead)
			return srv->clients[i];
	return NULL;
}

/* --- Frames --- */

static void fill_frame_msg(mc_msg_frame *f, const pending_frame *p)
{
	f->seq = p->seq;
	f->capture_ns = p->capture_ns;
	f->publish_ns = p->publish_ns;
	f->skeleton_id = p->skeleton_id;
	f->njoints = (uint16_t)p->njoints;
	f->state = p->state;
	f->space = MC_SPACE_RIG;
	for (int j = 0; j < p->njoints; j++) {
		memcpy(f->joints[j].position, p->j[j].pos, sizeof(p->j[j].pos));
		memcpy(f->joints[j].orientation, p->j[j].quat, sizeof(p->j[j].quat));
		f->joints[j].confidence = p->j[j].conf;
	}
}

/* world_from_rig at time t from the head pose history: interpolated between
 * the poses around t, else the nearest one within the configured age. */
static bool head_pose_at(const srv_server *srv, uint64_t t, srv_head_pose *out)
{
	const srv_head_pose *before = NULL, *after = NULL;
	for (int i = 0; i < srv->head_n; i++) {
		const srv_head_pose *h = &srv->head_hist[i];
		if (h->timestamp_ns <= t && (!before || h->timestamp_ns > before->timestamp_ns))
			before = h;
		if (h->timestamp_ns >= t && (!after || h->timestamp_ns < after->timestamp_ns))
			after = h;
	}
	uint64_t age = srv->cfg.head_pose_max_age_ns;
	if (before && after && after->timestamp_ns - before->timestamp_ns <= 2 * age) {
		double span = (double)(after->timestamp_ns - before->timestamp_ns);
		double s = span > 0 ? (double)(t - before->timestamp_ns) / span : 0.0;
		out->timestamp_ns = t;
		out->position = mc_v3_add(mc_v3_scale(before->position, 1 - s), mc_v3_scale(after->position, s));
		/* Normalised linear interpolation on the shorter arc: between
		 * poses a few milliseconds apart it matches slerp closely. */
		mc_quat a = before->orientation, b = after->orientation;
		double d = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
		double sb = d < 0 ? -s : s;
		mc_quat q = {a.w * (1 - s) + b.w * sb, a.x * (1 - s) + b.x * sb, a.y * (1 - s) + b.y * sb,
			     a.z * (1 - s) + b.z * sb};
		out->orientation = mc_quat_normalize(q);
		return true;
	}
	const srv_head_pose *near = NULL;
	if (before && t - before->timestamp_ns <= age)
		near = before;
	if (after && after->timestamp_ns - t <= age &&
	    (!near || after->timestamp_ns - t < t - near->timestamp_ns))
		near = after;
	if (!near)
		return false;
	*out = *near;
	return true;
}

static void frame_to_world(mc_msg_frame *f, const srv_head_pose *hp)
{
	for (int j = 0; j < f->njoints; j++) {
		mc_wire_joint *jt = &f->joints[j];
		mc_vec3 p = mc_v3(jt->position[0], jt->position[1], jt->position[2]);
		p = mc_v3_add(mc_quat_rotate(hp->orientation, p), hp->position);
		mc_quat q = {jt->orientation[0], jt->orientation[1], jt->orientation[2], jt->orientation[3]};
		q = mc_quat_mul(hp->orientation, q);
		jt->position[0] = p.x;
		jt->position[1] = p.y;
		jt->position[2] = p.z;
		jt->orientation[0] = q.w;
		jt->orientation[1] = q.x;
		jt->orientation[2] = q.y;
		jt->orientation[3] = q.z;
	}
	f->space = MC_SPACE_WORLD;
}

/* Hands one frame to every subscriber. */
static void distribute_frame(srv_server *srv, const pending_frame *p, uint64_t *drops)
{
	uint64_t missed = 0;
	if (srv->expected_seq && p->seq > srv->expected_seq)
		missed = p->seq - srv->expected_seq;
	srv->expected_seq = p->seq + 1;

	bool any_world = false, any_rig = false;
	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (c->dead || !c->mode)
			continue;
		if (c->space == MC_SPACE_WORLD)
			any_world = true;
		else
			any_rig = true;
	}
	proto_msg *m = &srv->out;
	memset(&m->h, 0, sizeof(m->h));
	m->h.type = MC_MSG_FRAME;
	fill_frame_msg(&m->u.frame, p);
	blob *rig = NULL, *world = NULL;
	if (any_rig || (any_world && !srv->def_rig_is_world))
		rig = encode_blob(srv, m, true);
	if (any_world) {
		srv_head_pose hp;
		if (srv->def_rig_is_world) {
			m->u.frame.space = MC_SPACE_WORLD;
			world = encode_blob(srv, m, true);
		} else if (head_pose_at(srv, p->capture_ns, &hp)) {
			frame_to_world(&m->u.frame, &hp);
			world = encode_blob(srv, m, true);
		} else if (rig) {
			world = blob_ref(rig); /* no head pose: sent in rig space, marked so */
		}
	}

	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (c->dead || !c->mode)
			continue;
		blob *b = c->space == MC_SPACE_WORLD ? world : rig;
		if (!b)
			continue;
		if (c->mode == MC_SUB_LATEST) {
			blob_unref(c->latest);
			c->latest = blob_ref(b);
		} else {
			if (missed && !c->gap_count)
				c->gap_first = p->seq - missed;
			c->gap_count += missed;
			maybe_queue_gap(srv, c);
			if (c->gap_count || c->qframes >= (int)c->queue_len || !q_push(c, b)) {
				if (!c->gap_count)
					c->gap_first = p->seq;
				c->gap_count++;
				(*drops)++;
			}
		}
		client_flush(srv, c);
	}
	blob_unref(rig);
	blob_unref(world);
}

static void send_definition(srv_server *srv, client *c)
{
	if (srv->def_blob)
		client_send(srv, c, srv->def_blob);
}

static void install_definition(srv_server *srv, const srv_skeleton_def *d, uint32_t id)
{
	proto_msg *m = &srv->out;
	memset(&m->h, 0, sizeof(m->h));
	m->h.type = MC_MSG_SKELETON;
	mc_msg_skeleton *s = &m->u.skeleton;
	s->skeleton_id = id;
	s->njoints = (uint16_t)d->njoints;
	s->rig_is_world = d->rig_is_world;
	for (int j = 0; j < d->njoints; j++) {
		s->joints[j].parent = d->parent[j];
		s->joints[j].offset[0] = d->rest_offset[j].x;
		s->joints[j].offset[1] = d->rest_offset[j].y;
		s->joints[j].offset[2] = d->rest_offset[j].z;
		str_copy(s->joints[j].name, sizeof(s->joints[j].name), d->name[j]);
	}
	blob *b = encode_blob(srv, m, false);
	if (!b)
		return;
	blob_unref(srv->def_blob);
	srv->def_blob = b;
	srv->def_rig_is_world = d->rig_is_world;
	srv->def_njoints = d->njoints;
	for (int i = 0; i < srv->nclients; i++)
		if (!srv->clients[i]->dead && srv->clients[i]->mode)
			send_definition(srv, srv->clients[i]);
}

/* Takes the mailbox and definition changes from the daemon's threads and
 * passes them on, in the order they were made. */
static void drain_mailbox(srv_server *srv)
{
	pthread_mutex_lock(&srv->lock);
	int n = srv->mb_count;
	for (int i = 0; i < n; i++)
		srv->drained[i] = srv->mailbox[(srv->mb_head + i) % MAILBOX_LEN];
	srv->mb_head = (srv->mb_head + n) % MAILBOX_LEN;
	srv->mb_count = 0;
	bool changed = srv->def_changed;
	uint32_t def_id = srv->def_id;
	int def_at = srv->def_at;
	if (changed)
		srv->def_copy = srv->def;
	srv->def_changed = false;
	pthread_mutex_unlock(&srv->lock);

	uint64_t drops = 0;
	for (int i = 0; i <= n; i++) {
		if (changed && i == def_at)
			install_definition(srv, &srv->def_copy, def_id);
		if (i < n)
			distribute_frame(srv, &srv->drained[i], &drops);
	}
	if (drops) {
		pthread_mutex_lock(&srv->lock);
		srv->stats.client_drops += drops;
		pthread_mutex_unlock(&srv->lock);
	}
}

/* --- Requests --- */

static void handle_hello(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_hello *h = &m->u.hello;
	str_copy(c->name, sizeof(c->name), h->client_name);
	if (h->min_version > PROTO_VERSION || h->max_version < PROTO_VERSION) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_VERSION, true,
			    "protocol version mismatch: the client speaks versions %u..%u, this mocapd speaks %d..%d; "
			    "update the client library or the daemon",
			    h->min_version, h->max_version, PROTO_VERSION, PROTO_VERSION);
		pthread_mutex_lock(&srv->lock);
		srv->stats.refused++;
		pthread_mutex_unlock(&srv->lock);
		return;
	}
	c->hello = true;
	proto_msg *o = &srv->out;
	memset(o, 0, sizeof(o->h) + sizeof(o->u.welcome));
	o->h.type = MC_MSG_WELCOME;
	o->h.request_id = m->h.request_id;
	o->u.welcome.magic = PROTO_MAGIC;
	o->u.welcome.version = PROTO_VERSION;
	o->u.welcome.flags = c->privileged ? MC_WELCOME_PRIVILEGED : 0;
	o->u.welcome.max_message = PROTO_MAX_MESSAGE;
	o->u.welcome.server_pid = (uint32_t)getpid();
	o->u.welcome.server_time_ns = now_ns();
	str_copy(o->u.welcome.daemon_version, sizeof(o->u.welcome.daemon_version), srv->cfg.daemon_version);
	blob *b = encode_blob(srv, o, false);
	client_send(srv, c, b);
	blob_unref(b);
}

static void handle_subscribe(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_subscribe *s = &m->u.subscribe;
	uint32_t len = 1;
	if (s->mode == MC_SUB_ALL) {
		len = s->queue_len ? s->queue_len : (uint32_t)srv->cfg.queue_len;
		if (len > (uint32_t)srv->cfg.max_queue_len)
			len = (uint32_t)srv->cfg.max_queue_len;
	}
	/* A new subscription starts a new stream: queued frames of the old
	 * one are dropped, and so is any gap still to be reported. */
	if (!q_reshape(c, s->mode == MC_SUB_ALL ? (int)len : 0, true)) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_BUSY, false, "out of memory");
		return;
	}
	blob_unref(c->latest);
	c->latest = NULL;
	c->gap_count = c->gap_first = 0;
	c->mode = s->mode;
	c->space = s->space;
	c->queue_len = len;
	reply_ok(srv, c, m->h.request_id, m->h.type, len);
	send_definition(srv, c);
}

static void handle_unsubscribe(srv_server *srv, client *c, const proto_msg *m)
{
	q_reshape(c, 0, true);
	blob_unref(c->latest);
	c->latest = NULL;
	c->mode = 0;
	c->gap_count = c->gap_first = 0;
	reply_ok(srv, c, m->h.request_id, m->h.type, 0);
}

static void handle_get_status(srv_server *srv, client *c, const proto_msg *m)
{
	proto_msg *o = &srv->out;
	memset(o, 0, sizeof(o->h) + sizeof(o->u.status));
	o->h.type = MC_MSG_STATUS;
	o->h.request_id = m->h.request_id;
	mc_msg_status *s = &o->u.status;
	pthread_mutex_lock(&srv->lock);
	const srv_status *st = &srv->status;
	s->start_ns = st->start_ns;
	s->frames_published = st->frames_published;
	s->frames_dropped = st->frames_dropped;
	s->client_drops = srv->stats.client_drops;
	s->publish_fps = st->publish_fps;
	s->track_ms_mean = st->track_ms_mean;
	s->track_ms_max = st->track_ms_max;
	s->tracker_state = (uint8_t)st->tracker_state;
	s->recording = st->recording;
	s->nclients = (uint32_t)srv->stats.clients;
	str_copy(s->device, sizeof(s->device), st->device);
	int ncams = st->ncams < 0 ? 0 : st->ncams > SRV_STATUS_MAX_CAMS ? SRV_STATUS_MAX_CAMS : st->ncams;
	s->ncams = (uint16_t)ncams;
	for (int i = 0; i < ncams; i++) {
		const srv_cam_status *cs = &st->cams[i];
		s->cams[i].fps = cs->fps;
		s->cams[i].frames = cs->frames;
		s->cams[i].drops = cs->drops;
		s->cams[i].state = (uint32_t)cs->state;
		s->cams[i].width = (uint32_t)(cs->width > 0 ? cs->width : 0);
		s->cams[i].height = (uint32_t)(cs->height > 0 ? cs->height : 0);
		str_copy(s->cams[i].name, sizeof(s->cams[i].name), cs->name);
	}
	pthread_mutex_unlock(&srv->lock);
	s->server_time_ns = now_ns();
	blob *b = encode_blob(srv, o, false);
	client_send(srv, c, b);
	blob_unref(b);
}

static void handle_get_skeleton(srv_server *srv, client *c, const proto_msg *m)
{
	if (!srv->def_blob) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_UNAVAILABLE, false,
			    "no skeleton yet: the daemon has not loaded a body model");
		return;
	}
	/* The shared definition blob has request_id 0; a reply echoes the id. */
	blob *b = blob_new(srv->def_blob->data, srv->def_blob->len, false);
	if (!b)
		return;
	uint32_t id = m->h.request_id;
	for (int i = 0; i < 4; i++)
		b->data[8 + i] = (uint8_t)(id >> (8 * i));
	client_send(srv, c, b);
	blob_unref(b);
}

static void handle_get_rig(srv_server *srv, client *c, const proto_msg *m)
{
	proto_msg *o = &srv->out;
	memset(&o->h, 0, sizeof(o->h));
	o->h.type = MC_MSG_RIG;
	o->h.request_id = m->h.request_id;
	blob *b = NULL;
	pthread_mutex_lock(&srv->lock);
	if (srv->rig_json) {
		o->u.rig.ncams = (uint32_t)srv->rig_ncams;
		o->u.rig.length = (uint32_t)strlen(srv->rig_json);
		o->u.rig.json = srv->rig_json;
		b = encode_blob(srv, o, false);
	}
	pthread_mutex_unlock(&srv->lock);
	if (!b) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_UNAVAILABLE, false,
			    "no rig yet: the daemon has not loaded one");
		return;
	}
	client_send(srv, c, b);
	blob_unref(b);
}

static bool require_privilege(srv_server *srv, client *c, const proto_msg *m, const char *what)
{
	if (c->privileged)
		return true;
	reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_PERMISSION, false,
		    "%s is allowed only to mocapd's user and group (you are uid %u gid %u); "
		    "add your user to the daemon's group",
		    what, (unsigned)c->uid, (unsigned)c->gid);
	return false;
}

static void handle_control(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_control *ctl = &m->u.control;
	if (!require_privilege(srv, c, m, "control"))
		return;
	if (ctl->command < MC_CONTROL_RELOAD || ctl->command > MC_CONTROL_RECORD_STOP) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
			    "unknown control command %u (1 reload, 2 record start, 3 record stop)", ctl->command);
		return;
	}
	pthread_mutex_lock(&srv->lock);
	bool full = srv->ncontrols >= CONTROL_QUEUE_LEN;
	if (!full) {
		control_entry *e = &srv->controls[srv->ncontrols++];
		memset(e, 0, sizeof(*e));
		e->token = ++srv->next_token;
		e->client_serial = c->serial;
		e->request_id = m->h.request_id;
		e->req.token = e->token;
		e->req.command = (mc_control_command)ctl->command;
		str_copy(e->req.argument, sizeof(e->req.argument), ctl->argument);
		e->req.pid = c->pid;
		e->req.uid = c->uid;
		e->req.gid = c->gid;
		uint64_t one = 1;
		if (write(srv->event_fd, &one, sizeof(one)) < 0) {
			/* the counter is saturated: it is readable anyway */
		}
	}
	pthread_mutex_unlock(&srv->lock);
	if (full)
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_BUSY, false,
			    "%d control requests are already waiting for the daemon; try again", CONTROL_QUEUE_LEN);
}

static void handle_get_rings(srv_server *srv, client *c, const proto_msg *m)
{
	if (!require_privilege(srv, c, m, "mapping camera rings"))
		return;
	proto_msg *o = &srv->out;
	memset(&o->h, 0, sizeof(o->h));
	o->h.type = MC_MSG_RINGS;
	o->h.request_id = m->h.request_id;
	int fds[PROTO_MAX_RINGS], n = 0;
	pthread_mutex_lock(&srv->lock);
	for (int i = 0; i < srv->nrings; i++) {
		/* The blob owns duplicates, so that clearing the rings while a
		 * reply waits in a queue cannot send a closed descriptor. */
		int d = fcntl(srv->rings[i].fd, F_DUPFD_CLOEXEC, 0);
		if (d < 0)
			continue;
		fds[n] = d;
		o->u.rings.rings[n].size = srv->rings[i].size;
		str_copy(o->u.rings.rings[n].name, sizeof(o->u.rings.rings[n].name), srv->rings[i].name);
		n++;
	}
	pthread_mutex_unlock(&srv->lock);
	o->u.rings.count = (uint16_t)n;
	blob *b = encode_blob(srv, o, false);
	if (!b) {
		for (int i = 0; i < n; i++)
			close(fds[i]);
		return;
	}
	memcpy(b->fds, fds, sizeof(int) * (size_t)n);
	b->nfds = n;
	client_send(srv, c, b);
	blob_unref(b);
}

static void handle_keypoints(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_keypoints *k = &m->u.keypoints;
	if (!require_privilege(srv, c, m, "sending keypoints"))
		return;
	if (k->count > SRV_MAX_KEYPOINTS) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
			    "%u keypoints in one batch, at most %d", k->count, SRV_MAX_KEYPOINTS);
		return;
	}
	pthread_mutex_lock(&srv->lock);
	int ncams = srv->rig_json ? srv->rig_ncams : MC_MAX_CAMERAS;
	int njoints = srv->def_set ? srv->def.njoints : MC_MAX_JOINTS;
	pthread_mutex_unlock(&srv->lock);
	if (k->camera >= ncams) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
			    "camera %u: the rig has %d cameras", k->camera, ncams);
		return;
	}
	for (int i = 0; i < k->count; i++) {
		const mc_wire_keypoint *p = &k->kp[i];
		if (!isfinite(p->u) || !isfinite(p->v) || !(p->confidence >= 0.0f && p->confidence <= 1.0f)) {
			reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				    "keypoint %d: u, v must be finite and confidence in 0..1 (got %g, %g, %g)", i,
				    (double)p->u, (double)p->v, (double)p->confidence);
			return;
		}
		if (k->kp[i].joint >= njoints) {
			reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				    "keypoint %d: joint %u, the skeleton has %d joints", i, k->kp[i].joint, njoints);
			return;
		}
	}
	pthread_mutex_lock(&srv->lock);
	if (srv->kp_count == KEYPOINT_QUEUE_LEN) {
		srv->kp_head = (srv->kp_head + 1) % KEYPOINT_QUEUE_LEN;
		srv->kp_count--;
		srv->stats.keypoint_drops++;
	}
	srv_keypoints *o = &srv->kp_queue[(srv->kp_head + srv->kp_count) % KEYPOINT_QUEUE_LEN];
	srv->kp_count++;
	o->capture_ns = k->capture_ns;
	o->cam = k->camera;
	o->nkeypoints = k->count;
	o->pid = c->pid;
	for (int i = 0; i < k->count; i++) {
		o->keypoints[i].cam = k->camera;
		o->keypoints[i].joint = k->kp[i].joint;
		o->keypoints[i].u = k->kp[i].u;
		o->keypoints[i].v = k->kp[i].v;
		o->keypoints[i].conf = k->kp[i].confidence;
	}
	uint64_t one = 1;
	if (write(srv->event_fd, &one, sizeof(one)) < 0) {
		/* saturated counter: still readable */
	}
	pthread_mutex_unlock(&srv->lock);
}

static void handle_head_pose(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_head_pose *h = &m->u.head_pose;
	if (!require_privilege(srv, c, m, "sending head poses"))
		return;
	double n2 = 0;
	bool finite = true;
	for (int i = 0; i < 4; i++) {
		n2 += h->orientation[i] * h->orientation[i];
		finite &= isfinite(h->orientation[i]) && (i == 3 || isfinite(h->position[i]));
	}
	/* A quaternion far from unit length is a client bug (x, y, z, w
	 * order, degrees, a matrix): refuse it rather than normalise it. */
	if (!finite || fabs(sqrt(n2) - 1.0) > 1e-3) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
			    "head pose: position must be finite and orientation a unit quaternion (w, x, y, z); "
			    "its length is %g", sqrt(n2));
		return;
	}
	srv_head_pose hp;
	hp.timestamp_ns = h->timestamp_ns;
	hp.position = mc_v3(h->position[0], h->position[1], h->position[2]);
	mc_quat q = {h->orientation[0], h->orientation[1], h->orientation[2], h->orientation[3]};
	hp.orientation = mc_quat_normalize(q);
	srv->head_hist[srv->head_next] = hp;
	srv->head_next = (srv->head_next + 1) % HEAD_POSE_HISTORY;
	if (srv->head_n < HEAD_POSE_HISTORY)
		srv->head_n++;
	pthread_mutex_lock(&srv->lock);
	if (!srv->have_head_pose || hp.timestamp_ns >= srv->latest_head_pose.timestamp_ns)
		srv->latest_head_pose = hp;
	srv->have_head_pose = true;
	pthread_mutex_unlock(&srv->lock);
}

static void handle_ping(srv_server *srv, client *c, const proto_msg *m)
{
	proto_msg *o = &srv->out;
	memset(&o->h, 0, sizeof(o->h));
	o->h.type = MC_MSG_PONG;
	o->h.request_id = m->h.request_id;
	o->u.ping.value = m->u.ping.value;
	o->u.ping.server_time_ns = now_ns();
	blob *b = encode_blob(srv, o, false);
	client_send(srv, c, b);
	blob_unref(b);
}

static void protocol_error(srv_server *srv, client *c, uint16_t type, uint32_t request_id, const char *why)
{
	pthread_mutex_lock(&srv->lock);
	srv->stats.protocol_errors++;
	pthread_mutex_unlock(&srv->lock);
	reply_error(srv, c, request_id, type, PROTO_E_MALFORMED, true, "malformed message: %s", why);
}

static void handle_message(srv_server *srv, client *c, size_t len)
{
	proto_msg *m = &srv->in;
	char why[256];
	if (proto_decode(srv->rxbuf, len, PROTO_FROM_CLIENT, m, why, sizeof(why)) != 0) {
		uint16_t type = len >= 2 ? (uint16_t)(srv->rxbuf[0] | srv->rxbuf[1] << 8) : 0;
		uint32_t rid = 0;
		if (len >= 12)
			for (int i = 0; i < 4; i++)
				rid |= (uint32_t)srv->rxbuf[8 + i] << (8 * i);
		protocol_error(srv, c, type, rid, why);
		return;
	}
	if (!c->hello && m->h.type != MC_MSG_HELLO) {
		reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_HANDSHAKE, true,
			    "%s before HELLO: a client must start with HELLO", proto_type_name(m->h.type));
		return;
	}
	switch (m->h.type) {
	case MC_MSG_HELLO:
		if (c->hello)
			reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_HANDSHAKE, true, "second HELLO");
		else
			handle_hello(srv, c, m);
		break;
	case MC_MSG_SUBSCRIBE: handle_subscribe(srv, c, m); break;
	case MC_MSG_UNSUBSCRIBE: handle_unsubscribe(srv, c, m); break;
	case MC_MSG_GET_STATUS: handle_get_status(srv, c, m); break;
	case MC_MSG_GET_SKELETON: handle_get_skeleton(srv, c, m); break;
	case MC_MSG_GET_RIG: handle_get_rig(srv, c, m); break;
	case MC_MSG_CONTROL: handle_control(srv, c, m); break;
	case MC_MSG_GET_RINGS: handle_get_rings(srv, c, m); break;
	case MC_MSG_KEYPOINTS: handle_keypoints(srv, c, m); break;
	case MC_MSG_HEAD_POSE: handle_head_pose(srv, c, m); break;
	case MC_MSG_PING: handle_ping(srv, c, m); break;
	}
}

/* Reads up to READ_BURST datagrams.  Descriptors sent by a client are
 * closed at once: the protocol has no client message that carries any. */
static void client_readable(srv_server *srv, client *c)
{
	for (int i = 0; i < READ_BURST && !c->dead; i++) {
		struct iovec iov = {.iov_base = srv->rxbuf, .iov_len = sizeof(srv->rxbuf)};
		union {
			char buf[CMSG_SPACE(sizeof(int) * 16)];
			struct cmsghdr align;
		} ctl;
		struct msghdr mh = {.msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl.buf,
				    .msg_controllen = sizeof(ctl.buf)};
		ssize_t n = recvmsg(c->fd, &mh, MSG_DONTWAIT | MSG_CMSG_CLOEXEC);
		if (n < 0) {
			if (errno == EINTR)
				continue;
			if (errno != EAGAIN && errno != EWOULDBLOCK)
				client_close(srv, c);
			return;
		}
		if (n == 0) { /* orderly shutdown: the client left */
			client_close(srv, c);
			return;
		}
		bool had_fds = false;
		for (struct cmsghdr *cm = CMSG_FIRSTHDR(&mh); cm; cm = CMSG_NXTHDR(&mh, cm)) {
			if (cm->cmsg_level == SOL_SOCKET && cm->cmsg_type == SCM_RIGHTS) {
				int nfd = (int)((cm->cmsg_len - CMSG_LEN(0)) / sizeof(int));
				for (int k = 0; k < nfd; k++) {
					int fd;
					memcpy(&fd, CMSG_DATA(cm) + k * sizeof(int), sizeof(int));
					close(fd);
				}
				had_fds = true;
			}
		}
		if (had_fds || (mh.msg_flags & MSG_CTRUNC)) {
			protocol_error(srv, c, 0, 0, "clients must not send file descriptors");
			return;
		}
		if ((size_t)n > PROTO_MAX_MESSAGE || (mh.msg_flags & MSG_TRUNC)) {
			char why[96];
			snprintf(why, sizeof(why), "longer than the %d-byte limit", PROTO_MAX_MESSAGE);
			protocol_error(srv, c, 0, 0, why);
			return;
		}
		/* What the daemon did before this message was sent must be
		 * visible to it (e.g. a definition set just before). */
		drain_mailbox(srv);
		if (!c->dead)
			handle_message(srv, c, (size_t)n);
	}
}

/* Answers of the daemon to control requests. */
static void deliver_control_results(srv_server *srv)
{
	control_result res[CONTROL_QUEUE_LEN];
	uint64_t serial[CONTROL_QUEUE_LEN];
	uint32_t rid[CONTROL_QUEUE_LEN], cmd[CONTROL_QUEUE_LEN];
	int n = 0;
	pthread_mutex_lock(&srv->lock);
	for (int i = 0; i < srv->nresults; i++) {
		/* Find and remove the request the result belongs to. */
		for (int k = 0; k < srv->ncontrols; k++) {
			control_entry *e = &srv->controls[k];
			if (e->token != srv->results[i].token)
				continue;
			res[n] = srv->results[i];
			serial[n] = e->client_serial;
			rid[n] = e->request_id;
			cmd[n] = (uint32_t)e->req.command;
			n++;
			srv->controls[k] = srv->controls[--srv->ncontrols];
			break;
		}
	}
	srv->nresults = 0;
	pthread_mutex_unlock(&srv->lock);
	for (int i = 0; i < n; i++) {
		client *c = find_client(srv, serial[i]);
		if (!c)
			continue;
		proto_msg *o = &srv->out;
		memset(&o->h, 0, sizeof(o->h));
		o->h.type = MC_MSG_CONTROL_RESULT;
		o->h.request_id = rid[i];
		o->u.control_result.command = cmd[i];
		o->u.control_result.result = res[i].result;
		str_copy(o->u.control_result.message, sizeof(o->u.control_result.message), res[i].message);
		blob *b = encode_blob(srv, o, false);
		client_send(srv, c, b);
		blob_unref(b);
	}
}

static void expire_handshakes(srv_server *srv)
{
	uint64_t t = now_ns();
	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (!c->dead && !c->hello && t - c->accepted_ns > HANDSHAKE_TIMEOUT_NS)
			reply_error(srv, c, 0, 0, PROTO_E_HANDSHAKE, true, "no HELLO within %llu s",
				    HANDSHAKE_TIMEOUT_NS / 1000000000ull);
	}
}

static void *server_thread(void *arg)
{
	srv_server *srv = arg;
	struct epoll_event evs[64];
	uint64_t last_expiry = now_ns();
	while (!atomic_load(&srv->stop)) {
		int n = epoll_wait(srv->epfd, evs, 64, 1000);
		/* Daemon-side changes first, so a request sees everything the
		 * daemon did before the request arrived. */
		drain_mailbox(srv);
		deliver_control_results(srv);
		for (int i = 0; i < n; i++) {
			void *p = evs[i].data.ptr;
			if (p == &srv->listen_fd) {
				accept_clients(srv);
			} else if (p == &srv->wake_fd) {
				uint64_t v;
				if (read(srv->wake_fd, &v, sizeof(v)) < 0) {
					/* EAGAIN: another wake-up already consumed it */
				}
			} else {
				client *c = p;
				if (c->dead)
					continue;
				if (evs[i].events & EPOLLIN)
					client_readable(srv, c);
				if (!c->dead && (evs[i].events & EPOLLOUT))
					client_flush(srv, c);
				if (!c->dead && (evs[i].events & (EPOLLHUP | EPOLLERR)) && !(evs[i].events & EPOLLIN))
					client_close(srv, c);
			}
		}
		uint64_t t = now_ns();
		if (t - last_expiry > 500000000ull) {
			expire_handshakes(srv);
			last_expiry = t;
		}
		reap_clients(srv);
	}
	return NULL;
}

/* --- Public API --- */

static void wake(srv_server *srv)
{
	uint64_t one = 1;
	if (write(srv->wake_fd, &one, sizeof(one)) < 0) {
		/* the counter is saturated: the thread is awake anyway */
	}
}

srv_server *srv_create(const srv_config *cfg, mc_err *err)
{
	if (cfg->max_clients < 1 || cfg->queue_len < 1 || cfg->max_queue_len < cfg->queue_len) {
		mc_err_set(err, "server config: need max_clients >= 1 and 1 <= queue_len <= max_queue_len "
				"(got %d, %d, %d)", cfg->max_clients, cfg->queue_len, cfg->max_queue_len);
		if (cfg->listen_fd >= 0)
			close(cfg->listen_fd);
		return NULL;
	}
	srv_server *srv = calloc(1, sizeof(*srv));
	if (!srv) {
		mc_err_set(err, "out of memory");
		if (cfg->listen_fd >= 0)
			close(cfg->listen_fd);
		return NULL;
	}
	srv->cfg = *cfg;
	srv->listen_fd = srv->epfd = srv->wake_fd = srv->event_fd = -1;
	pthread_mutex_init(&srv->lock, NULL);
	srv->kp_queue = calloc(KEYPOINT_QUEUE_LEN, sizeof(*srv->kp_queue));
	if (!srv->kp_queue) {
		mc_err_set(err, "out of memory");
		goto fail;
	}
	if (cfg->listen_fd >= 0 ? adopt_listen_fd(srv, err) : create_listen_socket(srv, err))
		goto fail;
	srv->epfd = epoll_create1(EPOLL_CLOEXEC);
	srv->wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	srv->event_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	if (srv->epfd < 0 || srv->wake_fd < 0 || srv->event_fd < 0) {
		mc_err_set(err, "epoll/eventfd: %s", strerror(errno));
		goto fail;
	}
	struct epoll_event ev = {.events = EPOLLIN, .data.ptr = &srv->listen_fd};
	epoll_ctl(srv->epfd, EPOLL_CTL_ADD, srv->listen_fd, &ev);
	ev.data.ptr = &srv->wake_fd;
	epoll_ctl(srv->epfd, EPOLL_CTL_ADD, srv->wake_fd, &ev);
	srv->status.tracker_state = SRV_TRACKER_IDLE;
	srv->status.start_ns = now_ns();
	int rc = pthread_create(&srv->thread, NULL, server_thread, srv);
	if (rc != 0) {
		mc_err_set(err, "cannot start the server thread: %s", strerror(rc));
		goto fail;
	}
	srv->thread_started = true;
	return srv;
fail:
	srv_destroy(srv);
	return NULL;
}

void srv_destroy(srv_server *srv)
{
	if (!srv)
		return;
	if (srv->thread_started) {
		atomic_store(&srv->stop, true);
		wake(srv);
		pthread_join(srv->thread, NULL);
		for (int i = 0; i < srv->nclients; i++)
			if (!srv->clients[i]->dead)
				reply_error(srv, srv->clients[i], 0, 0, PROTO_E_SHUTDOWN, true, "mocapd is stopping");
		reap_clients(srv);
	}
	if (srv->listen_fd >= 0)
		close(srv->listen_fd);
	/* Remove the socket file only if it still is the one we made: a new
	 * daemon may already have replaced it. */
	struct stat st;
	if (srv->created_path && stat(srv->cfg.path, &st) == 0 && st.st_dev == srv->path_dev &&
	    st.st_ino == srv->path_ino)
		unlink(srv->cfg.path);
	if (srv->epfd >= 0)
		close(srv->epfd);
	if (srv->wake_fd >= 0)
		close(srv->wake_fd);
	if (srv->event_fd >= 0)
		close(srv->event_fd);
	for (int i = 0; i < srv->nrings; i++)
		close(srv->rings[i].fd);
	blob_unref(srv->def_blob);
	free(srv->rig_json);
	free(srv->clients);
	free(srv->kp_queue);
	pthread_mutex_destroy(&srv->lock);
	free(srv);
}

int srv_set_skeleton_def(srv_server *srv, const srv_skeleton_def *def, mc_err *err)
{
	if (def->njoints < 1 || def->njoints > MC_MAX_JOINTS)
		return mc_err_set(err, "skeleton definition: %d joints, expected 1..%d", def->njoints, MC_MAX_JOINTS);
	for (int j = 0; j < def->njoints; j++) {
		if (def->parent[j] < -1 || def->parent[j] >= j)
			return mc_err_set(err, "skeleton definition: joint %d (%s): parent %d must be -1 or an earlier joint",
					  j, def->name[j], def->parent[j]);
		if (!memchr(def->name[j], 0, MC_JOINT_NAME_MAX) || !def->name[j][0])
			return mc_err_set(err, "skeleton definition: joint %d: empty or unterminated name", j);
		if (!mc_v3_isfinite(def->rest_offset[j]))
			return mc_err_set(err, "skeleton definition: joint %d (%s): offset is not finite", j, def->name[j]);
	}
	pthread_mutex_lock(&srv->lock);
	srv->def = *def;
	srv->def_set = true;
	srv->def_changed = true;
	srv->def_at = srv->mb_count;
	srv->def_id++;
	pthread_mutex_unlock(&srv->lock);
	wake(srv);
	return 0;
}

int srv_set_skeleton_def_from_model(srv_server *srv, const mc_model *model, mc_err *err)
{
	srv_skeleton_def *d = calloc(1, sizeof(*d));
	if (!d)
		return mc_err_set(err, "out of memory");
	d->njoints = model->njoints;
	d->rig_is_world = model->root_free;
	for (int j = 0; j < model->njoints && j < MC_MAX_JOINTS; j++) {
		str_copy(d->name[j], sizeof(d->name[j]), model->joints[j].name);
		d->parent[j] = model->joints[j].parent;
		double s = model->bone_scale[j] > 0 ? model->bone_scale[j] : 1.0;
		d->rest_offset[j] = mc_v3_scale(model->joints[j].offset, s);
	}
	int rc = srv_set_skeleton_def(srv, d, err);
	free(d);
	return rc;
}

int srv_set_rig(srv_server *srv, const char *rig_json, int ncams, mc_err *err)
{
	size_t n = strlen(rig_json);
	if (n > PROTO_RIG_MAX)
		return mc_err_set(err, "rig: %zu bytes of JSON, the protocol carries at most %d", n, PROTO_RIG_MAX);
	if (ncams < 0 || ncams > MC_MAX_CAMERAS)
		return mc_err_set(err, "rig: %d cameras, expected 0..%d", ncams, MC_MAX_CAMERAS);
	char *copy = strdup(rig_json);
	if (!copy)
		return mc_err_set(err, "out of memory");
	pthread_mutex_lock(&srv->lock);
	free(srv->rig_json);
	srv->rig_json = copy;
	srv->rig_ncams = ncams;
	pthread_mutex_unlock(&srv->lock);
	return 0;
}

int srv_publish(srv_server *srv, const mc_skeleton *sk, uint64_t seq, mc_err *err)
{
	uint64_t t = now_ns();
	int rc = 0;
	pthread_mutex_lock(&srv->lock);
	if (!srv->def_set) {
		rc = mc_err_set(err, "publish: no skeleton definition set (srv_set_skeleton_def)");
	} else if (sk->njoints != srv->def.njoints) {
		rc = mc_err_set(err, "publish: skeleton has %d joints, the definition %d", sk->njoints,
				srv->def.njoints);
	} else if (srv->mb_count == MAILBOX_LEN) {
		/* The server thread is starved; the frame is lost for every
		 * client, and "all" clients see it as a gap in seq. */
		srv->stats.mailbox_drops++;
		rc = mc_err_set(err, "publish: server thread is %d frames behind; frame %llu dropped", MAILBOX_LEN,
				(unsigned long long)seq);
	} else {
		pending_frame *p = &srv->mailbox[(srv->mb_head + srv->mb_count) % MAILBOX_LEN];
		srv->mb_count++;
		p->seq = seq;
		p->capture_ns = sk->timestamp_ns;
		p->publish_ns = t;
		p->skeleton_id = srv->def_id;
		p->state = (uint8_t)sk->state;
		p->njoints = sk->njoints;
		for (int j = 0; j < sk->njoints; j++) {
			const mc_skeleton_joint *sj = &sk->joints[j];
			p->j[j].pos[0] = sj->position.x;
			p->j[j].pos[1] = sj->position.y;
			p->j[j].pos[2] = sj->position.z;
			p->j[j].quat[0] = sj->orientation.w;
			p->j[j].quat[1] = sj->orientation.x;
			p->j[j].quat[2] = sj->orientation.y;
			p->j[j].quat[3] = sj->orientation.z;
			p->j[j].conf = sj->confidence;
		}
		srv->stats.frames_published++;
	}
	pthread_mutex_unlock(&srv->lock);
	if (rc == 0)
		wake(srv);
	return rc;
}

void srv_set_status(srv_server *srv, const srv_status *st)
{
	pthread_mutex_lock(&srv->lock);
	srv->status = *st;
	pthread_mutex_unlock(&srv->lock);
}

void srv_get_stats(srv_server *srv, srv_stats *st)
{
	pthread_mutex_lock(&srv->lock);
	*st = srv->stats;
	pthread_mutex_unlock(&srv->lock);
}

int srv_event_fd(srv_server *srv) { return srv->event_fd; }

/* Called with the lock held: resets the event fd once nothing waits. */
static void reset_event_fd_if_idle(srv_server *srv)
{
	bool waiting = srv->kp_count > 0;
	for (int i = 0; i < srv->ncontrols; i++)
		waiting |= !srv->controls[i].polled;
	if (!waiting) {
		uint64_t v;
		if (read(srv->event_fd, &v, sizeof(v)) < 0) {
			/* EAGAIN: already reset */
		}
	}
}

int srv_poll_control(srv_server *srv, srv_control *out)
{
	int got = 0;
	pthread_mutex_lock(&srv->lock);
	for (int i = 0; i < srv->ncontrols && !got; i++) {
		if (srv->controls[i].polled)
			continue;
		srv->controls[i].polled = true;
		*out = srv->controls[i].req;
		got = 1;
	}
	reset_event_fd_if_idle(srv);
	pthread_mutex_unlock(&srv->lock);
	return got;
}

void srv_control_done(srv_server *srv, uint64_t token, int result, const char *message)
{
	pthread_mutex_lock(&srv->lock);
	if (srv->nresults < CONTROL_QUEUE_LEN) {
		control_result *r = &srv->results[srv->nresults++];
		r->token = token;
		r->result = result;
		str_copy(r->message, sizeof(r->message), message ? message : "");
	}
	pthread_mutex_unlock(&srv->lock);
	wake(srv);
}

int srv_poll_keypoints(srv_server *srv, srv_keypoints *out)
{
	int got = 0;
	pthread_mutex_lock(&srv->lock);
	if (srv->kp_count > 0) {
		*out = srv->kp_queue[srv->kp_head];
		srv->kp_head = (srv->kp_head + 1) % KEYPOINT_QUEUE_LEN;
		srv->kp_count--;
		got = 1;
	}
	reset_event_fd_if_idle(srv);
	pthread_mutex_unlock(&srv->lock);
	return got;
}

int srv_latest_head_pose(srv_server *srv, srv_head_pose *out)
{
	pthread_mutex_lock(&srv->lock);
	int got = srv->have_head_pose;
	if (got)
		*out = srv->latest_head_pose;
	pthread_mutex_unlock(&srv->lock);
	return got;
}

int srv_add_ring(srv_server *srv, const char *camera_name, int fd, uint64_t size, mc_err *err)
{
	if (strlen(camera_name) > PROTO_NAME_MAX)
		return mc_err_set(err, "ring %s: camera name longer than %d bytes", camera_name, PROTO_NAME_MAX);
	/* A new open file description, read-only: a client that receives it
	 * cannot map the ring writable or write to it. */
	char proc[64];
	snprintf(proc, sizeof(proc), "/proc/self/fd/%d", fd);
	int ro = open(proc, O_RDONLY | O_CLOEXEC);
	if (ro < 0)
		return mc_err_set(err, "ring %s: cannot reopen fd %d read-only: %s", camera_name, fd, strerror(errno));
	pthread_mutex_lock(&srv->lock);
	int idx = srv->nrings;
	if (idx < SRV_MAX_RINGS) {
		ring_entry *r = &srv->rings[srv->nrings++];
		r->fd = ro;
		r->size = size;
		str_copy(r->name, sizeof(r->name), camera_name);
	}
	pthread_mutex_unlock(&srv->lock);
	if (idx >= SRV_MAX_RINGS) {
		close(ro);
		return mc_err_set(err, "ring %s: at most %d rings", camera_name, SRV_MAX_RINGS);
	}
	return idx;
}

void srv_clear_rings(srv_server *srv)
{
	pthread_mutex_lock(&srv->lock);
	for (int i = 0; i < srv->nrings; i++)
		close(srv->rings[i].fd);
	srv->nrings = 0;
	pthread_mutex_unlock(&srv->lock);
}
