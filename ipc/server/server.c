/* srv_server: creating and destroying the server, its thread's epoll loop,
 * and what the daemon hands it besides skeletons (rig, status, rings).
 * See ../server.h for the contract, internal.h for how the files of this
 * folder divide the work, and docs/PROTOCOL.md for the messages. */
#include "server/internal.h"
#include "base/mc_thread.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <unistd.h>

/* The server's limits are the core's and the protocol's: a value the
 * daemon may hand over must fit on the wire. */
_Static_assert(PROTO_MAX_CAMS >= MC_MAX_CAMERAS, "a status report must carry every camera");
_Static_assert(PROTO_MAX_JOINTS >= MC_MAX_JOINTS, "a frame must carry every joint");
_Static_assert(MC_JOINT_NAME_MAX <= PROTO_NAME_MAX + 1, "joint names must fit on the wire");
_Static_assert(SRV_NAME_MAX == PROTO_NAME_MAX + 1, "camera and device names are the wire's");
_Static_assert(SRV_ARG_MAX == PROTO_ARG_MAX + 1, "the control argument is the wire's");
_Static_assert(SRV_MAX_KEYPOINTS == PROTO_MAX_KEYPOINTS, "a keypoint batch is the wire's");
_Static_assert(SRV_MAX_RINGS == PROTO_MAX_RINGS, "a RINGS reply carries every ring");
_Static_assert(SRV_LAT_NSTAGES == PROTO_LATENCY_STAGES, "STATUS carries every latency stage");
_Static_assert(SRV_TRACKER_IDLE == 3, "mc_msg_status.tracker_state: 3 is idle on the wire");
_Static_assert(SRV_TRACKER_INITIALISING == 4 && MC_TRACK_INITIALISING == 4,
	       "tracker_state and FRAME state: 4 is initialising on the wire");

void srv_config_default(srv_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	srv_str_copy(cfg->path, sizeof(cfg->path), SRV_DEFAULT_PATH);
	cfg->listen_fd = -1;
	cfg->max_clients = 64;
	cfg->queue_len = 256;
	cfg->max_queue_len = 4096;
	cfg->socket_mode = 0660;
	cfg->control_gid = (gid_t)-1;
	cfg->head_pose_max_age_ns = 50000000ull;
	snprintf(cfg->daemon_version, sizeof(cfg->daemon_version), "mocapd");
}

/* --- The server thread --- */

void srv_wake(srv_server *srv)
{
	uint64_t one = 1;
	if (write(srv->wake_fd, &one, sizeof(one)) < 0) {
		/* the counter is saturated: the thread is awake anyway */
	}
}

static void *server_thread(void *arg)
{
	srv_server *srv = arg;
	mc_thread_set_name("mocap-server");
	struct epoll_event evs[64];
	uint64_t last_expiry = mc_now_ns();
	while (!atomic_load(&srv->stop)) {
		int n = epoll_wait(srv->epfd, evs, 64, 1000);
		/* Daemon-side changes first, so a request sees everything the
		 * daemon did before the request arrived. */
		srv_drain_mailbox(srv);
		srv_deliver_control_results(srv);
		for (int i = 0; i < n; i++) {
			void *p = evs[i].data.ptr;
			if (p == &srv->listen_fd) {
				srv_accept_clients(srv, srv->listen_fd, false);
			} else if (p == &srv->tcp_fd) {
				srv_accept_clients(srv, srv->tcp_fd, true);
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
					srv_client_readable(srv, c);
				if (!c->dead && (evs[i].events & EPOLLOUT))
					srv_client_flush(srv, c);
				if (!c->dead && (evs[i].events & (EPOLLHUP | EPOLLERR)) && !(evs[i].events & EPOLLIN))
					srv_client_close(srv, c);
			}
		}
		uint64_t t = mc_now_ns();
		if (t - last_expiry > 500000000ull) {
			srv_expire_clients(srv);
			last_expiry = t;
		}
		srv_reap_clients(srv);
	}
	return NULL;
}

/* --- Life --- */

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
	srv->listen_fd = srv->tcp_fd = srv->epfd = srv->wake_fd = srv->event_fd = srv->pose_fd = -1;
	pthread_mutex_init(&srv->lock, NULL);
	pthread_mutex_init(&srv->tap_lock, NULL);
	srv->keypoints.srv = srv;
	srv->keypoints.ring = calloc(KEYPOINT_QUEUE_LEN, sizeof(*srv->keypoints.ring));
	if (!srv->keypoints.ring) {
		mc_err_set(err, "out of memory");
		goto fail;
	}
	if (srv_listen_open(srv, err) || srv_tcp_open(srv, err) || srv_pose_open(srv, err))
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
	if (srv->tcp_fd >= 0) {
		ev.data.ptr = &srv->tcp_fd;
		epoll_ctl(srv->epfd, EPOLL_CTL_ADD, srv->tcp_fd, &ev);
	}
	srv->status.tracker_state = SRV_TRACKER_IDLE;
	srv->status.start_ns = mc_now_ns();
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
		srv_wake(srv);
		pthread_join(srv->thread, NULL);
		for (int i = 0; i < srv->nclients; i++) {
			/* One try: the server thread is gone, nobody waits for room. */
			if (!srv->clients[i]->dead)
				srv_reply_error(srv, srv->clients[i], 0, 0, PROTO_E_SHUTDOWN, true, "mocapd is stopping");
			srv_client_close(srv, srv->clients[i]);
		}
		srv_reap_clients(srv);
	}
	srv_listen_close(srv);
	srv_tcp_close(srv);
	srv_pose_close(srv);
	if (srv->epfd >= 0)
		close(srv->epfd);
	if (srv->wake_fd >= 0)
		close(srv->wake_fd);
	if (srv->event_fd >= 0)
		close(srv->event_fd);
	for (int i = 0; i < srv->nrings; i++)
		close(srv->rings[i].fd);
	srv_blob_unref(srv->def_blob);
	free(srv->rig_json);
	free(srv->clients);
	free(srv->keypoints.ring);
	pthread_mutex_destroy(&srv->lock);
	pthread_mutex_destroy(&srv->tap_lock);
	free(srv);
}

/* --- What the daemon hands over --- */

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

void srv_set_status(srv_server *srv, const srv_status *st)
{
	pthread_mutex_lock(&srv->lock);
	srv->status = *st;
	pthread_mutex_unlock(&srv->lock);
}

void srv_set_recording(srv_server *srv, bool recording)
{
	pthread_mutex_lock(&srv->lock);
	srv->status.recording = recording;
	pthread_mutex_unlock(&srv->lock);
}

void srv_get_stats(srv_server *srv, srv_stats *st)
{
	pthread_mutex_lock(&srv->lock);
	*st = srv->stats;
	pthread_mutex_unlock(&srv->lock);
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
		srv_str_copy(r->name, sizeof(r->name), camera_name);
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
