/* Connection: the socket path (or a tcp:// address, tcp.c), connecting (with a message for each way it
 * can fail that tells the user what to do), the HELLO/WELCOME handshake,
 * and closing. */
#include "client/internal.h"

#include "base/mc_thread.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

/* mocap.h is installed and cannot include proto.h: its limits are literal,
 * and tied to the wire's here. */
_Static_assert(MOCAP_PROTOCOL_VERSION == PROTO_VERSION, "the library speaks the protocol's version");
_Static_assert(MOCAP_MAX_JOINTS == PROTO_MAX_JOINTS, "a frame carries at most the wire's joints");
_Static_assert(MOCAP_MAX_CAMERAS == PROTO_MAX_CAMS, "a status carries at most the wire's cameras");
_Static_assert(MOCAP_MAX_RINGS == PROTO_MAX_RINGS, "a RINGS reply carries at most the wire's rings");
_Static_assert(MOCAP_MAX_KEYPOINTS == PROTO_MAX_KEYPOINTS, "a batch carries at most the wire's keypoints");
_Static_assert(MOCAP_NAME_MAX == PROTO_NAME_MAX + 1, "names are the wire's, with the NUL");
_Static_assert(MAX_RX_FDS >= PROTO_MAX_RINGS, "every ring's descriptor is received");
_Static_assert((int)MOCAP_LATEST == MC_SUB_LATEST && (int)MOCAP_ALL == MC_SUB_ALL, "modes are the wire's");
_Static_assert((int)MOCAP_SPACE_RIG == MC_SPACE_RIG && (int)MOCAP_SPACE_WORLD == MC_SPACE_WORLD,
	       "spaces are the wire's");

/* CLOCK_MONOTONIC now, in nanoseconds: the core's clock, exported. */
uint64_t mocap_now_ns(void) { return mc_now_ns(); }

const char *mocap_default_socket(void)
{
	const char *p = getenv(MOCAP_SOCKET_ENV);
	return p && p[0] ? p : MOCAP_DEFAULT_SOCKET;
}

static int connect_socket(const char *path)
{
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	if (strlen(path) >= sizeof(a.sun_path))
		return mcl_set_err(MOCAP_E_ARG, "socket path too long (at most %zu bytes): %s", sizeof(a.sun_path) - 1,
				   path);
	memcpy(a.sun_path, path, strlen(path) + 1);
	int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
	if (fd < 0)
		return mcl_set_err(MOCAP_E_SYSTEM, "socket: %s", strerror(errno));
	if (connect(fd, (struct sockaddr *)&a, sizeof(a)) != 0) {
		int e = errno;
		close(fd);
		switch (e) {
		case ENOENT:
			return mcl_set_err(MOCAP_E_NOT_RUNNING,
					   "daemon not running at %s (no socket there; is mocapd started?)", path);
		case ECONNREFUSED:
			return mcl_set_err(MOCAP_E_NOT_RUNNING,
					   "daemon not running at %s (the socket is left over, nobody listens)", path);
		case EACCES:
		case EPERM:
			return mcl_access_error(path);
		case EPROTOTYPE:
			return mcl_set_err(MOCAP_E_PROTOCOL, "%s is not a mocapd socket (wrong socket type)", path);
		case ENOTDIR:
			return mcl_set_err(MOCAP_E_NOT_RUNNING, "daemon not running at %s (%s)", path, strerror(e));
		}
		return mcl_set_err(MOCAP_E_SYSTEM, "cannot connect to %s: %s", path, strerror(e));
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
	pthread_mutex_init(&c->send_lock, NULL);
	mc_cond_init_monotonic(&c->cond);
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

/* HELLO and WELCOME. */
static int handshake(mocap_client *c, const char *client_name)
{
	proto_msg *m = mcl_new_msg(MC_MSG_HELLO);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.hello.magic = PROTO_MAGIC;
	m->u.hello.min_version = PROTO_MIN_VERSION;
	m->u.hello.max_version = PROTO_VERSION;
	snprintf(m->u.hello.client_name, sizeof(m->u.hello.client_name), "%s", client_name ? client_name : "");
	int rc = mcl_request(c, m, MC_MSG_WELCOME, m, NULL, NULL, NULL);
	if (rc == 0) {
		c->privileged = (m->u.welcome.flags & MC_WELCOME_PRIVILEGED) != 0;
		c->version = m->u.welcome.version;
		snprintf(c->daemon_version, sizeof(c->daemon_version), "%s", m->u.welcome.daemon_version);
	}
	free(m);
	return rc;
}

mocap_client *mocap_connect_token(const char *address, const char *client_name, const char *token)
{
	if (!address)
		address = mocap_default_socket();
	bool tcp = mcl_is_tcp_address(address);
	char tok[PROTO_TOKEN_MAX + 1];
	if (strlen(address) >= sizeof(((mocap_client *)0)->path)) {
		mcl_set_err(MOCAP_E_ARG, "address too long: %s", address);
		return NULL;
	}
	if (tcp && mcl_tcp_token(token, tok, sizeof(tok)) < 0)
		return NULL;
	int fd = tcp ? mcl_tcp_connect(address) : connect_socket(address);
	if (fd < 0)
		return NULL;
	mocap_client *c = client_new(fd, address);
	if (!c) {
		close(fd);
		mcl_set_err(MOCAP_E_SYSTEM, "out of memory");
		return NULL;
	}
	c->stream = tcp;
	int rc = tcp ? mcl_tcp_auth(c, tok) : 0;
	if (rc == 0)
		rc = handshake(c, client_name);
	if (rc != 0) {
		/* Keep the message of the failed handshake across mocap_close. */
		int code = mocap_errcode();
		char msg[MCL_ERRMSG_MAX];
		snprintf(msg, sizeof(msg), "%s", mocap_errmsg());
		mocap_close(c);
		mcl_set_err(code, "%s: %s", address, msg);
		return NULL;
	}
	return c;
}

mocap_client *mocap_connect(const char *path, const char *client_name)
{
	return mocap_connect_token(path, client_name, NULL);
}

void mocap_close(mocap_client *c)
{
	if (!c)
		return;
	if (c->fq) {
		mcl_fq_clear(c);
		free(c->fq);
	}
	for (int i = 0; i < MAX_WAITERS; i++) {
		free(c->waiters[i].data);
		if (c->waiters[i].done)
			mcl_close_fds(c->waiters[i].fds, c->waiters[i].nfds);
	}
	if (c->epfd >= 0)
		close(c->epfd);
	if (c->evfd >= 0)
		close(c->evfd);
	close(c->fd);
	free(c->srx);
	pthread_cond_destroy(&c->cond);
	pthread_mutex_destroy(&c->send_lock);
	pthread_mutex_destroy(&c->lock);
	free(c);
}

int mocap_is_privileged(const mocap_client *c) { return c->privileged; }
const char *mocap_daemon_version(const mocap_client *c) { return c->daemon_version; }
int mocap_protocol_version(const mocap_client *c) { return (int)c->version; }
void mocap_set_timeout(mocap_client *c, int timeout_ms) { c->timeout_ms = timeout_ms < 0 ? -1 : timeout_ms; }
int mocap_fd(mocap_client *c) { return c->epfd; }
