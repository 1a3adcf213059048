/* tcp:// addresses: mocapd's optional TCP listener for clients on other
 * machines (docs/PROTOCOL.md, "TCP").  The messages are those of the Unix
 * socket, each preceded by its length as a u32 (little-endian); the first
 * one is AUTH with the daemon's token. */
#include "client/internal.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

#define TOKEN_ENV MOCAP_TOKEN_ENV
#define TOKEN_FILE_ENV MOCAP_TOKEN_FILE_ENV
#define SRX_CAP (PROTO_TCP_PREFIX + PROTO_MAX_MESSAGE)

/* "tcp://HOST:PORT" or "tcp://[V6]:PORT" into host and port. */
static int split_address(const char *address, char *host, size_t hcap, char *port, size_t pcap)
{
	const char *a = address + strlen(MCL_TCP_SCHEME);
	const char *colon = strrchr(a, ':');
	size_t hn = colon ? (size_t)(colon - a) : 0;
	if (hn >= 2 && a[0] == '[' && a[hn - 1] == ']') {
		a++;
		hn -= 2;
	}
	if (!colon || hn == 0 || hn >= hcap || !colon[1] || strlen(colon + 1) >= pcap)
		return mcl_set_err(MOCAP_E_ARG, "%s: expected tcp://HOST:PORT", address);
	memcpy(host, a, hn);
	host[hn] = 0;
	snprintf(port, pcap, "%s", colon + 1);
	return 0;
}

static int connect_error(const char *address, int e)
{
	if (e == ECONNREFUSED)
		return mcl_set_err(MOCAP_E_NOT_RUNNING,
				   "daemon not running at %s (nobody listens there; is [network] listen set?)", address);
	return mcl_set_err(MOCAP_E_NOT_RUNNING, "cannot connect to %s: %s", address, strerror(e));
}

int mcl_tcp_connect(const char *address)
{
	char host[256], port[16];
	int bad = split_address(address, host, sizeof(host), port, sizeof(port));
	if (bad < 0)
		return bad;
	struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM};
	struct addrinfo *ai = NULL;
	int rc = getaddrinfo(host, port, &hints, &ai);
	if (rc != 0)
		return mcl_set_err(MOCAP_E_NOT_RUNNING, "%s: %s", address, gai_strerror(rc));
	int e = 0, fd = -1;
	for (struct addrinfo *p = ai; p && fd < 0; p = p->ai_next) {
		fd = socket(p->ai_family, p->ai_socktype | SOCK_CLOEXEC, p->ai_protocol);
		if (fd >= 0 && connect(fd, p->ai_addr, p->ai_addrlen) != 0) {
			e = errno;
			close(fd);
			fd = -1;
		}
	}
	freeaddrinfo(ai);
	if (fd < 0)
		return connect_error(address, e);
	int one = 1;
	setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
	setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &one, sizeof(one));
	fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
	return fd;
}

static int token_from_file(const char *path, char *out, size_t cap)
{
	FILE *f = fopen(path, "r");
	if (!f)
		return mcl_set_err(MOCAP_E_ARG, "%s=%s: %s", TOKEN_FILE_ENV, path, strerror(errno));
	bool got = fgets(out, (int)cap, f) != NULL;
	fclose(f);
	out[got ? strcspn(out, "\r\n") : 0] = 0;
	if (!out[0])
		return mcl_set_err(MOCAP_E_ARG, "%s=%s: the file is empty", TOKEN_FILE_ENV, path);
	return 0;
}

int mcl_tcp_token(const char *given, char *out, size_t cap)
{
	const char *env = getenv(TOKEN_ENV), *file = getenv(TOKEN_FILE_ENV);
	const char *t = given && given[0] ? given : env && env[0] ? env : NULL;
	if (t) {
		if (strlen(t) >= cap)
			return mcl_set_err(MOCAP_E_ARG, "the token is longer than %zu bytes", cap - 1);
		snprintf(out, cap, "%s", t);
		return 0;
	}
	if (file && file[0])
		return token_from_file(file, out, cap);
	return mcl_set_err(MOCAP_E_ACCESS, "a TCP connection needs the daemon's token: set %s or %s", TOKEN_ENV,
			   TOKEN_FILE_ENV);
}

int mcl_tcp_auth(mocap_client *c, const char *token)
{
	proto_msg *m = mcl_new_msg(MC_MSG_AUTH);
	if (!m)
		return MOCAP_E_SYSTEM;
	snprintf(m->u.auth.token, sizeof(m->u.auth.token), "%s", token);
	int rc = mcl_request(c, m, MC_MSG_OK, m, NULL, NULL, NULL);
	free(m);
	return rc;
}

/* Writes all of buf, waiting for room until deadline.  The bytes written
 * so far in *done. */
static int write_all(int fd, const uint8_t *buf, size_t n, size_t *done, uint64_t deadline)
{
	while (*done < n) {
		ssize_t r = send(fd, buf + *done, n - *done, MSG_DONTWAIT | MSG_NOSIGNAL);
		if (r >= 0) {
			*done += (size_t)r;
			continue;
		}
		if (errno == EINTR)
			continue;
		if (errno != EAGAIN && errno != EWOULDBLOCK)
			return mcl_set_err(MOCAP_E_DISCONNECTED, "sending to mocapd: %s", strerror(errno));
		struct pollfd p = {.fd = fd, .events = POLLOUT};
		if (poll(&p, 1, mcl_ms_until(deadline)) == 0)
			return mcl_set_err(MOCAP_E_TIMEOUT, "mocapd does not read our messages");
	}
	return 0;
}

int mcl_tcp_send(mocap_client *c, const uint8_t *msg, size_t n, uint64_t deadline)
{
	uint8_t buf[PROTO_TCP_PREFIX + 8192];
	if (n > sizeof(buf) - PROTO_TCP_PREFIX)
		return mcl_set_err(MOCAP_E_ARG, "message of %zu bytes is too long", n);
	proto_tcp_prefix(buf, n);
	memcpy(buf + PROTO_TCP_PREFIX, msg, n);
	size_t done = 0;
	pthread_mutex_lock(&c->send_lock);
	int rc = write_all(c->fd, buf, n + PROTO_TCP_PREFIX, &done, deadline);
	pthread_mutex_unlock(&c->send_lock);
	if (rc != 0 && done > 0) {
		/* Half a message is on the wire: nothing after it can be framed. */
		pthread_mutex_lock(&c->lock);
		mcl_set_dead(c, rc, "%s", mocap_errmsg());
		pthread_mutex_unlock(&c->lock);
	}
	return rc;
}

ssize_t mcl_tcp_recv(mocap_client *c)
{
	if (!c->srx && !(c->srx = malloc(SRX_CAP))) {
		errno = ENOMEM;
		return -1;
	}
	if (c->srx_at) { /* what was filed goes; the rest moves to the front */
		memmove(c->srx, c->srx + c->srx_at, c->srx_len - c->srx_at);
		c->srx_len -= c->srx_at;
		c->srx_at = 0;
	}
	ssize_t n = recv(c->fd, c->srx + c->srx_len, SRX_CAP - c->srx_len, MSG_DONTWAIT);
	if (n > 0)
		c->srx_len += (size_t)n;
	return n;
}

int mcl_tcp_take(mocap_client *c, size_t *len)
{
	const uint8_t *p = c->srx + c->srx_at;
	uint32_t n;
	int whole = proto_tcp_next(p, c->srx_len - c->srx_at, &n);
	if (whole <= 0)
		return whole;
	memcpy(c->rx, p + PROTO_TCP_PREFIX, n);
	c->srx_at += PROTO_TCP_PREFIX + n;
	*len = n;
	return 1;
}
