/* The listening socket: created at the configured path (replacing only a
 * stale socket file) or adopted from systemd, connections accepted up to
 * the client limit, and the socket file removed at the end if it is still
 * the one this server made. */
#include "server/internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <stdlib.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

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
	srv_str_copy(a.sun_path, sizeof(a.sun_path), path);
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
	/* The mode comes from the umask at bind (a socket file is created
	 * 0777 & ~umask), and the group is set with lchown: nothing follows a
	 * symbolic link that someone may have put at the path meanwhile (a
	 * chmod or chown by path would change its target).  Nobody can
	 * connect before listen(), so there is no window with the wrong
	 * permissions. */
	mode_t old_umask = umask(0777 & ~(mode_t)(srv->cfg.socket_mode & 0777));
	int bound = bind(fd, (struct sockaddr *)&a, sizeof(a));
	umask(old_umask);
	if (bound != 0) {
		mc_err_set(err, "%s: cannot create the socket: %s", path, strerror(errno));
		close(fd);
		return -1;
	}
	srv->created_path = true;
	struct stat st;
	if (lstat(path, &st) == 0) {
		srv->path_dev = st.st_dev;
		srv->path_ino = st.st_ino;
	}
	srv->listen_fd = fd;
	if (srv->cfg.control_gid != (gid_t)-1 && lchown(path, (uid_t)-1, srv->cfg.control_gid) != 0)
		return mc_err_set(err, "%s: cannot give the socket to group %u: %s", path,
				  (unsigned)srv->cfg.control_gid, strerror(errno));
	if (listen(fd, 64) != 0)
		return mc_err_set(err, "%s: listen: %s", path, strerror(errno));
	return 0;
}

int srv_listen_open(srv_server *srv, mc_err *err)
{
	return srv->cfg.listen_fd >= 0 ? adopt_listen_fd(srv, err) : create_listen_socket(srv, err);
}

void srv_listen_close(srv_server *srv)
{
	if (srv->listen_fd >= 0)
		close(srv->listen_fd);
	srv->listen_fd = -1;
	/* Remove the socket file only if it still is the one we made: a new
	 * daemon may already have replaced it. */
	struct stat st;
	if (srv->created_path && stat(srv->cfg.path, &st) == 0 && st.st_dev == srv->path_dev &&
	    st.st_ino == srv->path_ino)
		unlink(srv->cfg.path);
}

/* --- Accepting (both listeners) --- */

static void refuse_connection(srv_server *srv, int fd, bool tcp, const char *why)
{
	proto_msg *m = &srv->out;
	memset(m, 0, sizeof(*m));
	m->h.type = MC_MSG_ERROR;
	m->u.error.code = PROTO_E_TOO_MANY_CLIENTS;
	m->u.error.fatal = 1;
	srv_str_copy(m->u.error.message, sizeof(m->u.error.message), why);
	size_t n = proto_encode(m, srv->txbuf, sizeof(srv->txbuf));
	blob *b = n ? srv_blob_new(srv->txbuf, n, false) : NULL;
	if (b) {
		client once = {.fd = fd};
		size_t sent = 0;
		if (tcp)
			srv_tcp_send(&once, b, &sent);
		else
			srv_send_blob(&once, b);
	}
	srv_blob_unref(b);
	close(fd);
	pthread_mutex_lock(&srv->lock);
	srv->stats.refused++;
	pthread_mutex_unlock(&srv->lock);
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

/* Who the peer is: SO_PEERCRED on the Unix socket, the address on TCP. */
static bool identify(const srv_server *srv, int fd, bool tcp, client *c)
{
	return tcp ? srv_tcp_setup_client(c, fd) : srv_peer_identify(srv, fd, c);
}

/* Why a new connection (c identified) is refused, or NULL: max_clients
 * for the clients that count (srv_counted_clients), the pending limits
 * for a TCP connection, which counts once it has authenticated. */
static const char *over_limit(const srv_server *srv, const client *c, char *why, size_t cap)
{
	if (srv_counted_clients(srv) >= srv->cfg.max_clients) {
		snprintf(why, cap, "too many clients: mocapd accepts at most %d at once", srv->cfg.max_clients);
		return why;
	}
	if (!c->tcp)
		return NULL;
	int pending = 0, from_host = 0;
	for (int i = 0; i < srv->nclients; i++) {
		const client *o = srv->clients[i];
		if (!o->dead && o->tcp && !o->authed) {
			pending++;
			from_host += strcmp(o->host, c->host) == 0;
		}
	}
	if (pending >= SRV_MAX_PENDING_TCP)
		snprintf(why, cap, "too many TCP connections waiting to authenticate (at most %d)", SRV_MAX_PENDING_TCP);
	else if (from_host >= SRV_MAX_PENDING_TCP_PER_HOST)
		snprintf(why, cap, "too many TCP connections from %.48s waiting to authenticate (at most %d)", c->host,
			 SRV_MAX_PENDING_TCP_PER_HOST);
	else
		return NULL;
	return why;
}

void srv_accept_clients(srv_server *srv, int listen_fd, bool tcp)
{
	for (;;) {
		int fd = accept4(listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
		if (fd < 0)
			return; /* EAGAIN, or a transient error: epoll tells us again */
		client *c = calloc(1, sizeof(*c));
		if (!c || !identify(srv, fd, tcp, c)) {
			free(c);
			close(fd);
			continue;
		}
		char why[160];
		if (over_limit(srv, c, why, sizeof(why))) {
			free(c);
			refuse_connection(srv, fd, tcp, why);
			continue;
		}
		if (!srv_q_reshape(c, 0, true)) {
			free(c->q);
			free(c);
			close(fd);
			continue;
		}
		c->fd = fd;
		c->serial = ++srv->next_serial;
		c->accepted_ns = mc_now_ns();
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
		srv->stats.clients = srv_live_clients(srv);
		pthread_mutex_unlock(&srv->lock);
	}
}
