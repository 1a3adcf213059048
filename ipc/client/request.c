/* Requests and replies: sending a message, waiting for the reply with the
 * same request id (as the reader or behind it), and the requests whose
 * reply is a plain answer: skeleton definition, status, rig, control and
 * ping. */
#include "client/internal.h"

#include <errno.h>
#include <stddef.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

proto_msg *mcl_new_msg(uint16_t type)
{
	proto_msg *m = calloc(1, sizeof(*m));
	if (m)
		m->h.type = type;
	else
		mcl_set_err(MOCAP_E_SYSTEM, "out of memory");
	return m;
}

uint32_t mcl_next_id(mocap_client *c)
{
	uint32_t id;
	do
		id = atomic_fetch_add(&c->next_id, 1);
	while (id == 0);
	return id;
}

int mcl_send_msg(mocap_client *c, const proto_msg *m, uint64_t deadline)
{
	uint8_t buf[8192];
	size_t n = proto_encode(m, buf, sizeof(buf));
	if (!n)
		return mcl_set_err(MOCAP_E_ARG, "%s: a field is out of the protocol's range", proto_type_name(m->h.type));
	if (c->stream)
		return mcl_tcp_send(c, buf, n, deadline);
	for (;;) {
		ssize_t r = send(c->fd, buf, n, MSG_DONTWAIT | MSG_NOSIGNAL);
		if (r >= 0)
			return 0;
		if (errno == EINTR)
			continue;
		if (errno != EAGAIN && errno != EWOULDBLOCK && errno != ENOBUFS)
			return mcl_set_err(MOCAP_E_DISCONNECTED, "sending to mocapd: %s", strerror(errno));
		/* The daemon reads slower than we write: wait for room. */
		struct pollfd p = {.fd = c->fd, .events = POLLOUT};
		int pr = poll(&p, 1, mcl_ms_until(deadline));
		if (pr == 0)
			return mcl_set_err(MOCAP_E_TIMEOUT, "mocapd does not read our messages");
	}
}

/* A free waiter slot for request id, or NULL (lock held). */
static waiter *take_waiter(mocap_client *c, uint32_t id)
{
	waiter *w = NULL;
	for (int i = 0; i < MAX_WAITERS && !w; i++)
		if (!c->waiters[i].used)
			w = &c->waiters[i];
	if (w) {
		memset(w, 0, sizeof(*w));
		w->used = true;
		w->id = id;
	}
	return w;
}

int mcl_request(mocap_client *c, proto_msg *req, uint16_t want, proto_msg *reply, int *fds, int *nfds,
		uint8_t **raw)
{
	uint64_t deadline = mcl_deadline_after(c->timeout_ms);
	req->h.request_id = mcl_next_id(c);

	pthread_mutex_lock(&c->lock);
	if (c->dead) {
		int rc = mcl_dead_error(c);
		pthread_mutex_unlock(&c->lock);
		return rc;
	}
	waiter *w = take_waiter(c, req->h.request_id);
	if (!w) {
		pthread_mutex_unlock(&c->lock);
		return mcl_set_err(MOCAP_E_SYSTEM, "more than %d requests in flight on one connection", MAX_WAITERS);
	}
	pthread_mutex_unlock(&c->lock);

	int rc = mcl_send_msg(c, req, deadline);
	pthread_mutex_lock(&c->lock);
	while (rc == 0 && !w->done && !c->dead) {
		if (mc_now_ns() >= deadline) {
			rc = mcl_set_err(MOCAP_E_TIMEOUT, "no reply from mocapd to %s within %d ms",
					 proto_type_name(req->h.type), c->timeout_ms);
			break;
		}
		mcl_wait_step(c, deadline);
	}
	if (rc == 0 && !w->done)
		rc = mcl_dead_error(c);
	uint8_t *data = w->data;
	size_t len = w->len;
	int got_fds[MAX_RX_FDS], ngot = w->done ? w->nfds : 0;
	memcpy(got_fds, w->fds, sizeof(int) * (size_t)ngot);
	w->used = false;
	w->data = NULL;
	mcl_update_event(c);
	pthread_mutex_unlock(&c->lock);

	if (rc == 0) {
		char why[256];
		uint16_t req_type = req->h.type; /* reply may be req */
		if (proto_decode(data, len, PROTO_FROM_SERVER, reply, why, sizeof(why)) != 0)
			rc = mcl_set_err(MOCAP_E_PROTOCOL, "mocapd sent a malformed reply: %s", why);
		else if (reply->h.type == MC_MSG_ERROR)
			rc = mcl_set_err(mcl_code_of_server_error(reply->u.error.code), "%s", reply->u.error.message);
		else if (reply->h.type != want)
			rc = mcl_set_err(MOCAP_E_PROTOCOL, "mocapd answered %s with %s, expected %s",
					 proto_type_name(req_type), proto_type_name(reply->h.type), proto_type_name(want));
	}
	if (rc == 0 && raw)
		*raw = data; /* the reply points into it (RIG's json) */
	else
		free(data);
	if (rc == 0 && fds && nfds) {
		memcpy(fds, got_fds, sizeof(int) * (size_t)ngot);
		*nfds = ngot;
	} else {
		mcl_close_fds(got_fds, ngot);
	}
	return rc;
}

/* --- Requests with a plain answer --- */

static mocap_skeleton_def *convert_skeleton(const mc_msg_skeleton *m)
{
	mocap_skeleton_def *s = calloc(1, sizeof(*s));
	if (!s)
		return NULL;
	s->id = m->skeleton_id;
	s->rig_is_world = m->rig_is_world;
	s->njoints = m->njoints;
	for (int j = 0; j < m->njoints; j++) {
		snprintf(s->joints[j].name, sizeof(s->joints[j].name), "%s", m->joints[j].name);
		s->joints[j].parent = m->joints[j].parent;
		memcpy(s->joints[j].rest_offset, m->joints[j].offset, sizeof(s->joints[j].rest_offset));
	}
	return s;
}

int mocap_get_skeleton(mocap_client *c, mocap_skeleton_def *s)
{
	proto_msg *m = mcl_new_msg(MC_MSG_GET_SKELETON);
	if (!m)
		return MOCAP_E_SYSTEM;
	int rc = mcl_request(c, m, MC_MSG_SKELETON, m, NULL, NULL, NULL);
	if (rc == 0) {
		mocap_skeleton_def *k = convert_skeleton(&m->u.skeleton);
		if (k) {
			*s = *k;
			free(k);
		} else {
			rc = mcl_set_err(MOCAP_E_SYSTEM, "out of memory");
		}
	}
	free(m);
	return rc;
}

static void convert_status(const mc_msg_status *s, mocap_daemon_status *st)
{
	memset(st, 0, sizeof(*st));
	st->tracker_state = (mocap_track_state)s->tracker_state;
	st->recording = s->recording;
	st->publish_fps = s->publish_fps;
	st->track_ms_mean = s->track_ms_mean;
	st->track_ms_max = s->track_ms_max;
	st->frames_published = s->frames_published;
	st->frames_dropped = s->frames_dropped;
	st->client_drops = s->client_drops;
	st->server_time_ns = s->server_time_ns;
	st->uptime_ns = s->server_time_ns > s->start_ns ? s->server_time_ns - s->start_ns : 0;
	st->clients = (int)s->nclients;
	snprintf(st->device, sizeof(st->device), "%s", s->device);
	st->ncams = s->ncams;
	for (int i = 0; i < s->ncams; i++) {
		mocap_camera_status *cs = &st->cams[i];
		snprintf(cs->name, sizeof(cs->name), "%s", s->cams[i].name);
		cs->state = (int)s->cams[i].state;
		cs->width = (int)s->cams[i].width;
		cs->height = (int)s->cams[i].height;
		cs->fps = s->cams[i].fps;
		cs->frames = s->cams[i].frames;
		cs->drops = s->cams[i].drops;
	}
	mocap_detector_status *d = &st->detector;
	if (!s->has_detector) {
		d->state = MOCAP_DETECTOR_UNKNOWN; /* a version 1 daemon */
		return;
	}
	const mc_wire_detector_status *w = &s->detector;
	d->state = (mocap_detector_state)w->state;
	d->rate = w->rate;
	d->used_rate = w->used_rate;
	d->ms_mean = w->ms_mean;
	d->ms_last = w->ms_last;
	d->ms_max = w->ms_max;
	d->views = w->views;
	d->skipped = w->skipped;
	d->used = w->used;
	snprintf(d->model, sizeof(d->model), "%s", w->model);
	snprintf(d->message, sizeof(d->message), "%s", w->message);
}

static void convert_latency(const mc_msg_status *s, mocap_latency_status *l)
{
	l->known = s->has_latency;
	if (!s->has_latency)
		return;
	const mc_wire_latency_status *w = &s->latency;
	l->window = w->window;
	for (int i = 0; i < MOCAP_LAT_NSTAGES; i++) {
		l->stage[i].p50 = w->stage[i].p50;
		l->stage[i].p99 = w->stage[i].p99;
		l->stage[i].max = w->stage[i].max;
	}
	l->skipped_behind = w->skipped_behind;
	l->skipped_stale = w->skipped_stale;
	l->incomplete = w->incomplete;
}

/* mocap_get_status@@MOCAP_3: the status with the detector and the latency. */
int mcl_get_status_v3(mocap_client *c, mocap_daemon_status *st)
{
	proto_msg *m = mcl_new_msg(MC_MSG_GET_STATUS);
	if (!m)
		return MOCAP_E_SYSTEM;
	int rc = mcl_request(c, m, MC_MSG_STATUS, m, NULL, NULL, NULL);
	if (rc == 0) {
		convert_status(&m->u.status, st);
		convert_latency(&m->u.status, &st->latency);
	}
	free(m);
	return rc;
}

/* The status in the layout of an older libmocap: the first `bytes` of it. */
static int get_status_prefix(mocap_client *c, void *st, size_t bytes)
{
	mocap_daemon_status *full = malloc(sizeof(*full));
	if (!full) {
		mcl_set_err(MOCAP_E_SYSTEM, "out of memory");
		return MOCAP_E_SYSTEM;
	}
	int rc = mcl_get_status_v3(c, full);
	if (rc == 0)
		memcpy(st, full, bytes);
	free(full);
	return rc;
}

/* mocap_get_status@MOCAP_2, for programs built against libmocap 1.1:
 * their mocap_daemon_status ends where `latency` begins. */
int mcl_get_status_v2(mocap_client *c, void *st)
{
	return get_status_prefix(c, st, offsetof(mocap_daemon_status, latency));
}

/* mocap_get_status@MOCAP_1, for programs built against libmocap 1.0:
 * their mocap_daemon_status ends where `detector` begins. */
int mcl_get_status_v1(mocap_client *c, void *st)
{
	return get_status_prefix(c, st, offsetof(mocap_daemon_status, detector));
}

/* In a static link the default version (@@) is plain mocap_get_status. */
__asm__(".symver mcl_get_status_v1,mocap_get_status@MOCAP_1");
__asm__(".symver mcl_get_status_v2,mocap_get_status@MOCAP_2");
__asm__(".symver mcl_get_status_v3,mocap_get_status@@MOCAP_3");

int mocap_get_rig(mocap_client *c, char **json, int *ncams)
{
	*json = NULL;
	proto_msg *m = mcl_new_msg(MC_MSG_GET_RIG);
	if (!m)
		return MOCAP_E_SYSTEM;
	uint8_t *raw = NULL;
	int rc = mcl_request(c, m, MC_MSG_RIG, m, NULL, NULL, &raw);
	if (rc == 0) {
		*json = malloc((size_t)m->u.rig.length + 1);
		if (*json) {
			memcpy(*json, m->u.rig.json, m->u.rig.length);
			(*json)[m->u.rig.length] = 0;
			if (ncams)
				*ncams = (int)m->u.rig.ncams;
		} else {
			rc = mcl_set_err(MOCAP_E_SYSTEM, "out of memory");
		}
	}
	free(raw);
	free(m);
	return rc;
}

int mocap_control(mocap_client *c, mocap_command cmd, const char *argument, char *msg, size_t msglen)
{
	if (msg && msglen)
		msg[0] = 0;
	if (argument && strlen(argument) > PROTO_ARG_MAX)
		return mcl_set_err(MOCAP_E_ARG, "control: argument longer than %d bytes", PROTO_ARG_MAX);
	proto_msg *m = mcl_new_msg(MC_MSG_CONTROL);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.control.command = (uint32_t)cmd;
	snprintf(m->u.control.argument, sizeof(m->u.control.argument), "%s", argument ? argument : "");
	int rc = mcl_request(c, m, MC_MSG_CONTROL_RESULT, m, NULL, NULL, NULL);
	if (rc == 0) {
		if (msg && msglen)
			snprintf(msg, msglen, "%s", m->u.control_result.message);
		if (m->u.control_result.result != 0)
			rc = mcl_set_err(MOCAP_E_FAILED, "%s", m->u.control_result.message);
	} else if (msg && msglen) {
		snprintf(msg, msglen, "%s", mocap_errmsg());
	}
	free(m);
	return rc;
}

int mocap_ping(mocap_client *c, uint64_t *server_time_ns)
{
	proto_msg *m = mcl_new_msg(MC_MSG_PING);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.ping.value = mc_now_ns();
	int rc = mcl_request(c, m, MC_MSG_PONG, m, NULL, NULL, NULL);
	if (rc == 0 && server_time_ns)
		*server_time_ns = m->u.ping.server_time_ns;
	free(m);
	return rc;
}
