/* preview_guard: header deadlines and stream limits (preview_guard.h). */
#include "preview_guard.h"

#include "base/mc_time.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

#define GUARD_GRACE_NS 500000000ull

typedef struct guard_conn {
	int fd;
	uint64_t since_ns; /* the connection, or the end of its last request */
	bool headers;      /* the current request's headers are whole */
	bool cut;          /* shut down by the guard */
	struct guard_conn *prev, *next;
} guard_conn;

struct preview_guard {
	pthread_mutex_t lock;
	guard_conn *conns;
	int pending; /* connections waiting for headers, not cut */
	atomic_int streams;
	atomic_bool stop;
	pthread_t watchdog;
};

/* Shuts a connection down: libmicrohttpd's thread for it sees the end of
 * the stream and closes it (the fd stays its to close).  Under the lock. */
static void cut(preview_guard *g, guard_conn *c)
{
	if (c->cut)
		return;
	c->cut = true;
	if (!c->headers)
		g->pending--;
	shutdown(c->fd, SHUT_RDWR);
}

static void *watchdog(void *arg)
{
	preview_guard *g = arg;
	while (!atomic_load(&g->stop)) {
		uint64_t now = mc_now_ns();
		pthread_mutex_lock(&g->lock);
		for (guard_conn *c = g->conns; c; c = c->next)
			if (!c->headers && !c->cut && now - c->since_ns > GUARD_HEADER_S * 1000000000ull)
				cut(g, c);
		pthread_mutex_unlock(&g->lock);
		usleep(200000);
	}
	return NULL;
}

preview_guard *guard_new(void)
{
	preview_guard *g = calloc(1, sizeof(*g));
	if (!g)
		return NULL;
	pthread_mutex_init(&g->lock, NULL);
	if (pthread_create(&g->watchdog, NULL, watchdog, g) != 0) {
		pthread_mutex_destroy(&g->lock);
		free(g);
		return NULL;
	}
	return g;
}

void guard_free(preview_guard *g)
{
	if (!g)
		return;
	atomic_store(&g->stop, true);
	pthread_join(g->watchdog, NULL);
	while (g->conns) {
		guard_conn *c = g->conns;
		g->conns = c->next;
		free(c);
	}
	pthread_mutex_destroy(&g->lock);
	free(g);
}

/* Which connection gives way when too many wait for their headers: the
 * one that has waited longest, if it has had half a second (a browser sends
 * its headers at once, a flood's connections wait), else the new one c.
 * Under the lock. */
static guard_conn *oldest_waiting(preview_guard *g, guard_conn *c)
{
	guard_conn *oldest = NULL;
	for (guard_conn *o = g->conns; o; o = o->next)
		if (!o->headers && !o->cut && (!oldest || o->since_ns < oldest->since_ns))
			oldest = o;
	return oldest && c->since_ns - oldest->since_ns > GUARD_GRACE_NS ? oldest : c;
}

static void conn_started(preview_guard *g, struct MHD_Connection *conn, void **socket_context)
{
	const union MHD_ConnectionInfo *info = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CONNECTION_FD);
	guard_conn *c = calloc(1, sizeof(*c));
	if (!c || !info) {
		free(c);
		return; /* not guarded: the idle timeout still holds */
	}
	c->fd = info->connect_fd;
	c->since_ns = mc_now_ns();
	pthread_mutex_lock(&g->lock);
	c->next = g->conns;
	if (g->conns)
		g->conns->prev = c;
	g->conns = c;
	g->pending++;
	if (g->pending > GUARD_MAX_PENDING) /* keep the other slots for pages */
		cut(g, oldest_waiting(g, c));
	pthread_mutex_unlock(&g->lock);
	*socket_context = c;
}

static void conn_closed(preview_guard *g, guard_conn *c)
{
	pthread_mutex_lock(&g->lock);
	if (!c->cut && !c->headers)
		g->pending--;
	if (c->prev)
		c->prev->next = c->next;
	else
		g->conns = c->next;
	if (c->next)
		c->next->prev = c->prev;
	pthread_mutex_unlock(&g->lock);
	free(c);
}

void guard_notify_connection(void *cls, struct MHD_Connection *conn, void **socket_context,
			     enum MHD_ConnectionNotificationCode toe)
{
	preview_guard *g = cls;
	if (toe == MHD_CONNECTION_NOTIFY_STARTED)
		conn_started(g, conn, socket_context);
	else if (toe == MHD_CONNECTION_NOTIFY_CLOSED && *socket_context)
		conn_closed(g, *socket_context);
}

static guard_conn *conn_of(struct MHD_Connection *conn)
{
	const union MHD_ConnectionInfo *info = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
	return info ? info->socket_context : NULL;
}

void guard_headers_done(preview_guard *g, struct MHD_Connection *conn)
{
	guard_conn *c = conn_of(conn);
	if (!c)
		return;
	pthread_mutex_lock(&g->lock);
	if (!c->headers && !c->cut)
		g->pending--;
	c->headers = true;
	pthread_mutex_unlock(&g->lock);
}

/* A kept-alive connection waits for its next request's headers: the
 * deadline starts again. */
void guard_request_completed(void *cls, struct MHD_Connection *conn, void **con_cls,
			     enum MHD_RequestTerminationCode toe)
{
	(void)con_cls, (void)toe;
	preview_guard *g = cls;
	guard_conn *c = conn_of(conn);
	if (!c)
		return;
	pthread_mutex_lock(&g->lock);
	if (c->headers && !c->cut)
		g->pending++;
	c->headers = false;
	c->since_ns = mc_now_ns();
	pthread_mutex_unlock(&g->lock);
}

bool guard_stream_begin(preview_guard *g, struct MHD_Connection *conn)
{
	if (atomic_fetch_add(&g->streams, 1) >= GUARD_MAX_STREAMS) {
		atomic_fetch_sub(&g->streams, 1);
		return false;
	}
	/* A stream that does not read makes no progress: closed after this
	 * long, where the server's default is 60 s. */
	MHD_set_connection_option(conn, MHD_CONNECTION_OPTION_TIMEOUT, (unsigned)GUARD_STREAM_IDLE_S);
	return true;
}

void guard_stream_end(preview_guard *g)
{
	atomic_fetch_sub(&g->streams, 1);
}
