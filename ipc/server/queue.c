/* Client queues: reference-counted blobs, each client's FIFO and "latest"
 * slot, non-blocking sends, gap reports and replies.  A client that stops
 * reading loses frames (reported as gaps), never the server's time; one
 * that does not read its replies is disconnected. */
#include "server/internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

/* --- Blobs --- */

blob *srv_blob_new(const uint8_t *data, size_t len, bool is_frame)
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

blob *srv_blob_ref(blob *b)
{
	b->refs++;
	return b;
}

void srv_blob_unref(blob *b)
{
	if (!b || --b->refs > 0)
		return;
	for (int i = 0; i < b->nfds; i++)
		close(b->fds[i]);
	free(b);
}

blob *srv_encode_blob(srv_server *srv, const proto_msg *m, bool is_frame)
{
	size_t n = proto_encode(m, srv->txbuf, sizeof(srv->txbuf));
	return n ? srv_blob_new(srv->txbuf, n, is_frame) : NULL;
}

/* --- The FIFO --- */

/* Requests are read until the client is closing; EPOLLOUT while
 * something waits for room in its socket. */
static void epoll_update(srv_server *srv, client *c, bool want_out, bool force)
{
	if ((c->epollout == want_out && !force) || c->dead)
		return;
	struct epoll_event ev = {.events = (c->closing ? 0 : EPOLLIN) | (want_out ? EPOLLOUT : 0), .data.ptr = c};
	epoll_ctl(srv->epfd, EPOLL_CTL_MOD, c->fd, &ev);
	c->epollout = want_out;
}

static blob *q_front(client *c) { return c->q[c->qhead]; }

void srv_q_pop(client *c)
{
	blob *b = c->q[c->qhead];
	if (b->is_frame)
		c->qframes--;
	srv_blob_unref(b);
	c->qhead = (c->qhead + 1) % c->qcap;
	c->qn--;
}

bool srv_q_push(client *c, blob *b)
{
	if (!b->is_frame && c->qn - c->qframes >= NONFRAME_MAX)
		return false;
	if (c->qn >= c->qcap)
		return false;
	c->q[(c->qhead + c->qn) % c->qcap] = srv_blob_ref(b);
	c->qn++;
	if (b->is_frame)
		c->qframes++;
	return true;
}

bool srv_q_reshape(client *c, int frames, bool drop_frames)
{
	int cap = frames + NONFRAME_MAX + 1;
	blob **nq = calloc((size_t)cap, sizeof(*nq));
	if (!nq)
		return false;
	int n = 0, nframes = 0;
	for (int i = 0; i < c->qn; i++) {
		blob *b = c->q[(c->qhead + i) % c->qcap];
		if (b->is_frame && (drop_frames || nframes >= frames)) {
			srv_blob_unref(b);
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

/* --- Sending --- */

int srv_send_blob(client *c, const blob *b)
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

void srv_queue_gap(srv_server *srv, client *c)
{
	if (!c->gap_count || c->mode != MC_SUB_ALL || c->qframes >= (int)c->queue_len)
		return;
	proto_msg *m = srv_out_msg(srv, MC_MSG_GAP, 0);
	m->u.gap.first_seq = c->gap_first;
	m->u.gap.count = c->gap_count;
	blob *b = srv_encode_blob(srv, m, false);
	if (b && srv_q_push(c, b)) {
		c->gap_count = 0;
		c->gap_first = 0;
	}
	srv_blob_unref(b);
}

/* Sends one blob: 1 all of it, 0 none (the socket is full), -1 the client
 * is gone; or, on TCP, 0 with *sent > 0 when only part of it went. */
static int send_one(client *c, const blob *b, size_t *sent)
{
	return c->tcp ? srv_tcp_send(c, b, sent) : srv_send_blob(c, b);
}

/* Takes the front blob off the FIFO, or out of the latest slot. */
static void take_front(client *c)
{
	if (c->qn) {
		srv_q_pop(c);
	} else {
		srv_blob_unref(c->latest);
		c->latest = NULL;
	}
}

/* A blob stays where it is (FIFO or latest slot) until it starts to go, so
 * that a newer frame can still replace one in the latest slot; a TCP blob
 * that went in part is held in c->sending and finished first. */
void srv_client_flush(srv_server *srv, client *c)
{
	for (;;) {
		if (c->dead)
			return;
		int rc;
		if (c->sending) {
			rc = srv_tcp_send(c, c->sending, &c->sent);
			if (rc == 1) {
				srv_blob_unref(c->sending);
				c->sending = NULL;
			}
		} else {
			srv_queue_gap(srv, c);
			blob *b = c->qn ? q_front(c) : c->latest;
			if (!b)
				break;
			size_t sent = 0;
			rc = send_one(c, b, &sent);
			if (rc == 0 && sent > 0) {
				c->sending = srv_blob_ref(b);
				c->sent = sent;
			}
			if (rc == 1 || sent > 0)
				take_front(c);
		}
		if (rc < 0) {
			srv_client_close(srv, c);
			return;
		}
		if (rc == 0) {
			epoll_update(srv, c, true, false);
			return;
		}
	}
	if (c->closing) { /* its last words are out */
		srv_client_close(srv, c);
		return;
	}
	epoll_update(srv, c, false, false);
}

/* --- Replies --- */

void srv_client_send(srv_server *srv, client *c, blob *b)
{
	if (!b || c->dead || c->closing) /* nothing goes after the last words */
		return;
	if (!srv_q_push(c, b)) {
		srv_reply_error(srv, c, 0, 0, PROTO_E_OVERLOAD, true,
				"more than %d replies unread: the client does not read its socket", NONFRAME_MAX);
		return;
	}
	srv_client_flush(srv, c);
}

void srv_reply(srv_server *srv, client *c, const proto_msg *m)
{
	blob *b = srv_encode_blob(srv, m, false);
	srv_client_send(srv, c, b);
	srv_blob_unref(b);
}

void srv_reply_error(srv_server *srv, client *c, uint32_t request_id, uint16_t request_type, uint32_t code,
		     bool fatal, const char *fmt, ...)
{
	if (c->dead)
		return;
	proto_msg *m = srv_out_msg(srv, MC_MSG_ERROR, request_id);
	m->u.error.code = code;
	m->u.error.request_type = request_type;
	m->u.error.fatal = fatal;
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(m->u.error.message, sizeof(m->u.error.message), fmt, ap);
	va_end(ap);
	if (!fatal) {
		srv_reply(srv, c, m);
		return;
	}
	blob *b = srv_encode_blob(srv, m, false);
	if (b)
		srv_last_words(srv, c, b);
	else
		srv_client_close(srv, c);
	srv_blob_unref(b);
}

void srv_last_words(srv_server *srv, client *c, blob *b)
{
	if (c->dead || c->closing)
		return;
	/* Whatever was queued goes (a TCP message already under way is
	 * finished first, or the peer would read the error as its rest); the
	 * error is sent as soon as the socket has room, then the connection
	 * closes.  No more requests are read meanwhile. */
	while (c->qn)
		srv_q_pop(c);
	srv_blob_unref(c->latest);
	c->latest = NULL;
	c->mode = 0;
	c->gap_count = 0;
	c->closing = true;
	c->closing_by_ns = mc_now_ns() + LAST_WORDS_NS;
	srv_q_push(c, b);
	epoll_update(srv, c, c->epollout, true);
	srv_client_flush(srv, c);
}

void srv_reply_ok(srv_server *srv, client *c, uint32_t request_id, uint16_t request_type, uint32_t value)
{
	proto_msg *m = srv_out_msg(srv, MC_MSG_OK, request_id);
	m->u.ok.request_type = request_type;
	m->u.ok.value = value;
	srv_reply(srv, c, m);
}
