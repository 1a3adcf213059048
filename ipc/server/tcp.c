/* Clients on other machines: an optional TCP listener that carries the
 * same messages as the Unix socket, each preceded by its length (a u32,
 * little-endian), because a byte stream keeps no message boundaries.
 *
 * There is no SO_PEERCRED over TCP, so the first message of a connection
 * must be AUTH with the daemon's token (handlers.c checks it here); a
 * connection that sends anything else, or a wrong token, is closed.  The
 * token travels in clear: docs/PROTOCOL.md says to keep the port on a
 * trusted network or behind a tunnel. */
#include "server/internal.h"

#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#define TCP_RX_CAP (PROTO_TCP_PREFIX + PROTO_MAX_MESSAGE)

_Static_assert(SRV_TOKEN_MAX == PROTO_TOKEN_MAX + 1, "the token is AUTH's");

/* Splits "HOST:PORT" or "[V6]:PORT"; false when it is neither. */
static bool split_host_port(const char *spec, char *host, size_t hcap, char *port, size_t pcap)
{
	const char *colon = strrchr(spec, ':');
	if (!colon || !colon[1] || strlen(colon + 1) >= pcap)
		return false;
	const char *h = spec;
	size_t hn = (size_t)(colon - spec);
	if (hn >= 2 && h[0] == '[' && h[hn - 1] == ']') {
		h++;
		hn -= 2;
	} else if (memchr(h, ':', hn)) {
		return false; /* a bare IPv6 address needs brackets */
	}
	if (hn == 0 || hn >= hcap)
		return false;
	memcpy(host, h, hn);
	host[hn] = 0;
	snprintf(port, pcap, "%s", colon + 1);
	for (const char *p = port; *p; p++)
		if (*p < '0' || *p > '9')
			return false;
	return atoi(port) <= 65535;
}

static int bound_port(int fd)
{
	struct sockaddr_storage ss;
	socklen_t l = sizeof(ss);
	if (getsockname(fd, (struct sockaddr *)&ss, &l) != 0)
		return 0;
	if (ss.ss_family == AF_INET)
		return ntohs(((struct sockaddr_in *)&ss)->sin_port);
	if (ss.ss_family == AF_INET6)
		return ntohs(((struct sockaddr_in6 *)&ss)->sin6_port);
	return 0;
}

/* A listening socket on the first address of `ai` that binds. */
static int listen_first(const struct addrinfo *ai, int *last_errno)
{
	for (; ai; ai = ai->ai_next) {
		int fd = socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol);
		if (fd < 0) {
			*last_errno = errno;
			continue;
		}
		int one = 1;
		setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
		if (bind(fd, ai->ai_addr, ai->ai_addrlen) == 0 && listen(fd, 64) == 0)
			return fd;
		*last_errno = errno;
		close(fd);
	}
	return -1;
}

int srv_tcp_open(srv_server *srv, mc_err *err)
{
	const char *spec = srv->cfg.tcp_listen;
	if (!spec[0])
		return 0;
	if (strlen(srv->cfg.tcp_token) < SRV_TOKEN_MIN)
		return mc_err_set(err, "TCP listener %s: the access token must have at least %d characters", spec,
				  SRV_TOKEN_MIN);
	char host[256], port[16];
	if (!split_host_port(spec, host, sizeof(host), port, sizeof(port)))
		return mc_err_set(err, "TCP listener '%s': expected HOST:PORT, e.g. 0.0.0.0:7878 or [::1]:7878", spec);
	struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM,
				 .ai_flags = AI_PASSIVE | AI_NUMERICSERV};
	struct addrinfo *ai = NULL;
	int rc = getaddrinfo(host, port, &hints, &ai);
	if (rc != 0)
		return mc_err_set(err, "TCP listener %s: %s", spec, gai_strerror(rc));
	int last_errno = 0;
	srv->tcp_fd = listen_first(ai, &last_errno);
	freeaddrinfo(ai);
	if (srv->tcp_fd < 0)
		return mc_err_set(err, "TCP listener %s: %s", spec, strerror(last_errno));
	srv->tcp_port = bound_port(srv->tcp_fd);
	return 0;
}

void srv_tcp_close(srv_server *srv)
{
	if (srv->tcp_fd >= 0)
		close(srv->tcp_fd);
	srv->tcp_fd = -1;
}

int srv_tcp_port(srv_server *srv) { return srv->tcp_fd >= 0 ? srv->tcp_port : 0; }

bool srv_tcp_setup_client(client *c, int fd)
{
	int one = 1;
	/* Frames are small and wanted at once: no Nagle delay. */
	if (setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one)) != 0)
		return false;
	setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &one, sizeof(one));
	struct sockaddr_storage ss;
	socklen_t l = sizeof(ss);
	char host[NI_MAXHOST], serv[NI_MAXSERV];
	if (getpeername(fd, (struct sockaddr *)&ss, &l) != 0 ||
	    getnameinfo((struct sockaddr *)&ss, l, host, sizeof(host), serv, sizeof(serv),
			NI_NUMERICHOST | NI_NUMERICSERV) != 0)
		return false;
	snprintf(c->peer, sizeof(c->peer), ss.ss_family == AF_INET6 ? "[%s]:%s" : "%s:%s", host, serv);
	snprintf(c->host, sizeof(c->host), "%.47s", host); /* numeric: at most 45 */
	c->tcp = true;
	c->pid = 0;
	c->uid = (uid_t)-1;
	c->gid = (gid_t)-1;
	c->privileged = false; /* until AUTH, and then as configured */
	return true;
}

/* Handles every whole message at the start of c->srx; keeps the rest. */
static void handle_received(srv_server *srv, client *c)
{
	size_t at = 0;
	while (!c->dead && !c->closing) {
		uint32_t len;
		int whole = proto_tcp_next(c->srx + at, c->srx_len - at, &len);
		if (whole < 0) {
			char why[128];
			snprintf(why, sizeof(why), "TCP length prefix of %u bytes; a message has %d to %d", len,
				 PROTO_HEADER_SIZE, PROTO_MAX_MESSAGE);
			srv_protocol_error(srv, c, 0, 0, why);
			return;
		}
		if (!whole)
			break;
		memcpy(srv->rxbuf, c->srx + at + PROTO_TCP_PREFIX, len);
		at += PROTO_TCP_PREFIX + len;
		srv_drain_mailbox(srv); /* as for the Unix socket (client.c) */
		if (!c->dead && !c->closing)
			srv_handle_message(srv, c, len);
	}
	if (!c->dead && at) {
		memmove(c->srx, c->srx + at, c->srx_len - at);
		c->srx_len -= at;
	}
}

/* One read per wake-up (epoll is level-triggered: it says again when more
 * waits), then every whole message in the buffer. */
void srv_tcp_readable(srv_server *srv, client *c)
{
	if (!c->srx && !(c->srx = malloc(TCP_RX_CAP))) {
		srv_client_close(srv, c);
		return;
	}
	ssize_t n;
	do
		n = recv(c->fd, c->srx + c->srx_len, TCP_RX_CAP - c->srx_len, MSG_DONTWAIT);
	while (n < 0 && errno == EINTR);
	if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
		return;
	if (n <= 0) {
		srv_client_close(srv, c);
		return;
	}
	c->srx_len += (size_t)n;
	handle_received(srv, c);
}

int srv_tcp_send(client *c, const blob *b, size_t *sent)
{
	uint8_t prefix[PROTO_TCP_PREFIX];
	proto_tcp_prefix(prefix, b->len);
	size_t total = PROTO_TCP_PREFIX + b->len;
	while (*sent < total) {
		struct iovec iov[2];
		int n = 0;
		if (*sent < PROTO_TCP_PREFIX) {
			iov[n++] = (struct iovec){prefix + *sent, PROTO_TCP_PREFIX - *sent};
			iov[n++] = (struct iovec){(void *)b->data, b->len};
		} else {
			size_t off = *sent - PROTO_TCP_PREFIX;
			iov[n++] = (struct iovec){(void *)(b->data + off), b->len - off};
		}
		struct msghdr mh = {.msg_iov = iov, .msg_iovlen = (size_t)n};
		ssize_t r = sendmsg(c->fd, &mh, MSG_DONTWAIT | MSG_NOSIGNAL);
		if (r < 0) {
			if (errno == EINTR)
				continue;
			return errno == EAGAIN || errno == EWOULDBLOCK ? 0 : -1;
		}
		*sent += (size_t)r;
	}
	return 1;
}

bool srv_tcp_token_ok(const srv_server *srv, const char *token)
{
	const char *want = srv->cfg.tcp_token;
	size_t n = strlen(want), m = strnlen(token, SRV_TOKEN_MAX);
	/* Every byte of the configured token is compared, whatever the
	 * guess: the time does not tell how much of it was right. */
	unsigned diff = (unsigned)(n != m) | (unsigned)(n == 0);
	for (size_t i = 0; i < n; i++)
		diff |= (unsigned)(uint8_t)want[i] ^ (unsigned)(uint8_t)(i < m ? token[i] : 0);
	return diff == 0;
}
