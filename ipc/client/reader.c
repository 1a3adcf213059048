/* The reader: whichever thread needs something from the socket receives
 * what is there (without the lock), converts frames (that allocates), then
 * files each message under the lock: frames and gaps into the frame queue,
 * replies to the thread waiting for their request id, unsolicited errors as
 * the refusal the next one-way send reports, fatal ones as the
 * connection's end.  Skeleton definitions pushed to subscribers are not
 * kept: a frame names its definition (skeleton_id), and
 * mocap_get_skeleton asks for the newest. */
#include "client/internal.h"

#include <errno.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

void mcl_set_dead(mocap_client *c, int code, const char *fmt, ...)
{
	if (c->dead)
		return;
	c->dead = code;
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(c->dead_msg, sizeof(c->dead_msg), fmt, ap);
	va_end(ap);
}

void mcl_close_fds(const int *fds, int n)
{
	for (int i = 0; i < n; i++)
		close(fds[i]);
}

static waiter *find_waiter(mocap_client *c, uint32_t id)
{
	for (int i = 0; i < MAX_WAITERS; i++)
		if (c->waiters[i].used && c->waiters[i].id == id && !c->waiters[i].done)
			return &c->waiters[i];
	return NULL;
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

/* Keeps a non-fatal ERROR nobody waits for: the next one-way send reports it. */
static void keep_async_error(mocap_client *c, const mc_msg_error *e)
{
	c->async_code = mcl_code_of_server_error(e->code);
	snprintf(c->async_msg, sizeof(c->async_msg), "%s", e->message);
}

/* Files one decoded message (lock held).  Takes ownership of fds. */
static void dispatch(mocap_client *c, const proto_msg *m, size_t len, mocap_skeleton_frame *frame, int *fds,
		     int nfds)
{
	uint16_t t = m->h.type;
	if (t == MC_MSG_FRAME) {
		if (frame && c->mode)
			mcl_fq_push(c, frame);
		else
			free(frame);
	} else if (t == MC_MSG_GAP) {
		c->pending_missed += m->u.gap.count;
	}
	if (t == MC_MSG_ERROR && m->u.error.fatal)
		mcl_set_dead(c, mcl_code_of_server_error(m->u.error.code), "mocapd closed the connection: %s",
			     m->u.error.message);
	if (t == MC_MSG_FRAME || t == MC_MSG_GAP || m->h.request_id == 0) {
		if (t == MC_MSG_ERROR && !m->u.error.fatal)
			keep_async_error(c, &m->u.error);
		mcl_close_fds(fds, nfds);
		return;
	}
	waiter *w = find_waiter(c, m->h.request_id);
	uint8_t *copy = w ? malloc(len) : NULL;
	if (!copy) {
		if (t == MC_MSG_ERROR && !m->u.error.fatal && !w)
			keep_async_error(c, &m->u.error);
		mcl_close_fds(fds, nfds);
		return;
	}
	memcpy(copy, c->rx, len);
	w->data = copy;
	w->len = len;
	w->nfds = nfds;
	memcpy(w->fds, fds, sizeof(int) * (size_t)nfds);
	w->done = true;
}

/* Takes the descriptors of a received datagram (at most MAX_RX_FDS; the
 * rest are closed).  Returns how many. */
static int take_fds(struct msghdr *mh, int *fds)
{
	int nfds = 0;
	for (struct cmsghdr *cm = CMSG_FIRSTHDR(mh); cm; cm = CMSG_NXTHDR(mh, cm)) {
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
	return nfds;
}

/* Decodes the message of n bytes in c->rx and files it (lock not held).
 * Takes the descriptors.  false when the connection is now dead. */
static bool file_message(mocap_client *c, size_t n, bool truncated, int *fds, int nfds, uint64_t t)
{
	char why[256];
	if (truncated || proto_decode(c->rx, n, PROTO_FROM_SERVER, &c->dec, why, sizeof(why)) != 0) {
		if (truncated)
			snprintf(why, sizeof(why), "message longer than %d bytes", PROTO_MAX_MESSAGE);
		mcl_close_fds(fds, nfds);
		pthread_mutex_lock(&c->lock);
		mcl_set_dead(c, MOCAP_E_PROTOCOL, "mocapd sent a malformed message: %s", why);
		pthread_mutex_unlock(&c->lock);
		return false;
	}
	/* The conversion allocates; do it outside the lock. */
	mocap_skeleton_frame *frame = c->dec.h.type == MC_MSG_FRAME ? convert_frame(&c->dec.u.frame, t) : NULL;
	pthread_mutex_lock(&c->lock);
	dispatch(c, &c->dec, n, frame, fds, nfds);
	pthread_mutex_unlock(&c->lock);
	return true;
}

static void set_dead_locked(mocap_client *c, ssize_t n, int err)
{
	pthread_mutex_lock(&c->lock);
	if (n == 0)
		mcl_set_dead(c, MOCAP_E_DISCONNECTED, "mocapd closed the connection (%s)", c->path);
	else
		mcl_set_dead(c, MOCAP_E_DISCONNECTED, "connection to mocapd lost: %s", strerror(err));
	pthread_mutex_unlock(&c->lock);
}

/* What a receive call's result n means: 1 data, 0 try again (EINTR), -1
 * stop: nothing more for now, or the connection ended (now marked dead). */
static int received(mocap_client *c, ssize_t n)
{
	if (n > 0)
		return 1;
	if (n < 0 && errno == EINTR)
		return 0;
	if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
		return -1;
	set_dead_locked(c, n, errno);
	return -1;
}

/* TCP: reads what is there and files every whole message (lock not held). */
static void read_stream_burst(mocap_client *c)
{
	for (int i = 0; i < RX_BURST; i++) {
		int r = received(c, mcl_tcp_recv(c));
		if (r == 0)
			continue;
		if (r < 0)
			return;
		uint64_t t = mc_now_ns();
		size_t len;
		int rc, no_fds[1]; /* nothing comes with a message on TCP */
		while ((rc = mcl_tcp_take(c, &len)) == 1)
			if (!file_message(c, len, false, no_fds, 0, t))
				return;
		if (rc < 0) {
			pthread_mutex_lock(&c->lock);
			mcl_set_dead(c, MOCAP_E_PROTOCOL, "mocapd sent a bad TCP length prefix");
			pthread_mutex_unlock(&c->lock);
			return;
		}
	}
}

/* Receives what is there (lock not held).  Returns after EAGAIN, an error
 * or RX_BURST messages. */
static void read_burst(mocap_client *c)
{
	if (c->stream) {
		read_stream_burst(c);
		return;
	}
	for (int i = 0; i < RX_BURST; i++) {
		struct iovec iov = {.iov_base = c->rx, .iov_len = sizeof(c->rx)};
		union {
			char buf[CMSG_SPACE(sizeof(int) * MAX_RX_FDS)];
			struct cmsghdr align;
		} ctl;
		struct msghdr mh = {.msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl.buf,
				    .msg_controllen = sizeof(ctl.buf)};
		ssize_t n = recvmsg(c->fd, &mh, MSG_DONTWAIT | MSG_CMSG_CLOEXEC);
		int r = received(c, n);
		if (r == 0)
			continue;
		if (r < 0)
			return;
		uint64_t t = mc_now_ns();
		int fds[MAX_RX_FDS];
		int nfds = take_fds(&mh, fds);
		if (!file_message(c, (size_t)n, (mh.msg_flags & MSG_TRUNC) != 0, fds, nfds, t))
			return;
	}
}

void mcl_wait_step(mocap_client *c, uint64_t deadline)
{
	if (c->reading) {
		if (deadline == FOREVER) {
			pthread_cond_wait(&c->cond, &c->lock);
		} else {
			struct timespec ts = mc_ns_timespec(deadline);
			pthread_cond_timedwait(&c->cond, &c->lock, &ts);
		}
		return;
	}
	c->reading = true;
	pthread_mutex_unlock(&c->lock);
	/* deadline 0 only takes what is there: no need to poll first. */
	struct pollfd p = {.fd = c->fd, .events = POLLIN};
	if (deadline == 0 || poll(&p, 1, mcl_ms_until(deadline)) > 0)
		read_burst(c);
	pthread_mutex_lock(&c->lock);
	c->reading = false;
	pthread_cond_broadcast(&c->cond);
}
