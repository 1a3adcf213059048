/* A connection's life on the server thread: reading its datagrams (at most
 * READ_BURST per wake-up, so one busy client cannot starve the others),
 * the handshake deadline, closing, and freeing once nobody up the stack
 * holds the pointer any more. */
#include "server/internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

/* Reads and drops what the client sent and the server did not read: a
 * socket closed with unread data resets the connection (AF_UNIX sets
 * ECONNRESET on the peer, TCP sends RST), and the peer would lose what it
 * has not read yet, the server's last words among it. */
static void drop_unread(srv_server *srv, int fd)
{
	for (int i = 0; i < 4096; i++)
		if (recv(fd, srv->rxbuf, sizeof(srv->rxbuf), MSG_DONTWAIT) <= 0)
			return;
}

void srv_client_close(srv_server *srv, client *c)
{
	if (c->dead)
		return;
	c->dead = true;
	epoll_ctl(srv->epfd, EPOLL_CTL_DEL, c->fd, NULL);
	drop_unread(srv, c->fd);
	close(c->fd);
	c->fd = -1;
}

void srv_client_free(client *c)
{
	while (c->qn)
		srv_q_pop(c);
	srv_blob_unref(c->latest);
	srv_blob_unref(c->sending);
	free(c->srx);
	free(c->q);
	free(c);
}

void srv_reap_clients(srv_server *srv)
{
	int n = 0;
	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (!c->dead)
			srv->clients[n++] = c;
		else
			srv_client_free(c);
	}
	if (n != srv->nclients) {
		srv->nclients = n;
		pthread_mutex_lock(&srv->lock);
		srv->stats.clients = n;
		pthread_mutex_unlock(&srv->lock);
	}
}

int srv_live_clients(const srv_server *srv)
{
	int n = 0;
	for (int i = 0; i < srv->nclients; i++)
		n += !srv->clients[i]->dead;
	return n;
}

int srv_counted_clients(const srv_server *srv)
{
	int n = 0;
	for (int i = 0; i < srv->nclients; i++) {
		const client *c = srv->clients[i];
		n += !c->dead && (!c->tcp || c->authed);
	}
	return n;
}

client *srv_find_client(srv_server *srv, uint64_t serial)
{
	for (int i = 0; i < srv->nclients; i++)
		if (srv->clients[i]->serial == serial && !srv->clients[i]->dead)
			return srv->clients[i];
	return NULL;
}

/* Closes every descriptor that came with a datagram; true if there was any. */
static bool close_received_fds(struct msghdr *mh)
{
	bool had_fds = false;
	for (struct cmsghdr *cm = CMSG_FIRSTHDR(mh); cm; cm = CMSG_NXTHDR(mh, cm)) {
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
	return had_fds;
}

/* Descriptors sent by a client are closed at once: the protocol has no
 * client message that carries any. */
void srv_client_readable(srv_server *srv, client *c)
{
	if (c->tcp) {
		srv_tcp_readable(srv, c);
		return;
	}
	for (int i = 0; i < READ_BURST && !c->dead && !c->closing; i++) {
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
				srv_client_close(srv, c);
			return;
		}
		if (n == 0) { /* orderly shutdown: the client left */
			srv_client_close(srv, c);
			return;
		}
		if (close_received_fds(&mh) || (mh.msg_flags & MSG_CTRUNC)) {
			srv_protocol_error_raw(srv, c, (size_t)n, "clients must not send file descriptors");
			return;
		}
		if ((size_t)n > PROTO_MAX_MESSAGE || (mh.msg_flags & MSG_TRUNC)) {
			char why[96];
			snprintf(why, sizeof(why), "longer than the %d-byte limit", PROTO_MAX_MESSAGE);
			srv_protocol_error_raw(srv, c, sizeof(srv->rxbuf) < (size_t)n ? sizeof(srv->rxbuf) : (size_t)n, why);
			return;
		}
		/* What the daemon did before this message was sent must be
		 * visible to it (e.g. a definition set just before). */
		srv_drain_mailbox(srv);
		if (!c->dead && !c->closing)
			srv_handle_message(srv, c, (size_t)n);
	}
}

void srv_expire_clients(srv_server *srv)
{
	uint64_t t = mc_now_ns();
	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (c->closing && t > c->closing_by_ns) /* it never read its last words */
			srv_client_close(srv, c);
		else if (!c->dead && !c->closing && !c->hello && t - c->accepted_ns > HANDSHAKE_TIMEOUT_NS)
			srv_reply_error(srv, c, 0, 0, PROTO_E_HANDSHAKE, true, "no HELLO within %llu s",
					HANDSHAKE_TIMEOUT_NS / MC_NS_PER_S);
	}
}
