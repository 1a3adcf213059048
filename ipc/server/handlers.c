/* Request handlers: one function per client message type, each answering
 * from the server's own state or passing the request to an inbox the
 * daemon reads (inbox.c).  Requests that change the daemon or feed it
 * (control, rings, keypoints, head poses) need a privileged peer. */
#include "server/internal.h"

#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <unistd.h>

/* Tells the daemon who connected; the name is the client's own words,
 * so anything but printable ASCII becomes '?' (no forged log lines). */
static void report_client(srv_server *srv, const client *c)
{
	if (!srv->cfg.on_client)
		return;
	char name[sizeof(c->name)];
	size_t n = 0;
	for (; c->name[n] && n + 1 < sizeof(name); n++)
		name[n] = c->name[n] >= 0x20 && c->name[n] < 0x7f ? c->name[n] : '?';
	name[n] = 0;
	char line[256];
	if (c->tcp)
		snprintf(line, sizeof(line), "client '%s' connected over TCP from %s%s, protocol %u", n ? name : "?",
			 c->peer, c->privileged ? " (may control)" : "", c->version);
	else
		snprintf(line, sizeof(line), "client '%s' connected (pid %d, uid %u%s), protocol %u", n ? name : "?",
			 (int)c->pid, (unsigned)c->uid, c->privileged ? ", may control" : "", c->version);
	srv->cfg.on_client(srv->cfg.on_client_ctx, line);
}

static void handle_hello(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_hello *h = &m->u.hello;
	srv_str_copy(c->name, sizeof(c->name), h->client_name);
	if (h->min_version > PROTO_VERSION || h->max_version < PROTO_MIN_VERSION) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_VERSION, true,
				"protocol version mismatch: the client speaks versions %u..%u, this mocapd speaks %d..%d; "
				"update the client library or the daemon",
				h->min_version, h->max_version, PROTO_MIN_VERSION, PROTO_VERSION);
		pthread_mutex_lock(&srv->lock);
		srv->stats.refused++;
		pthread_mutex_unlock(&srv->lock);
		return;
	}
	c->hello = true;
	c->version = h->max_version < PROTO_VERSION ? h->max_version : PROTO_VERSION; /* the highest both speak */
	report_client(srv, c);
	proto_msg *o = &srv->out;
	memset(o, 0, sizeof(o->h) + sizeof(o->u.welcome));
	o->h.type = MC_MSG_WELCOME;
	o->h.request_id = m->h.request_id;
	o->u.welcome.magic = PROTO_MAGIC;
	o->u.welcome.version = c->version;
	o->u.welcome.flags = c->privileged ? MC_WELCOME_PRIVILEGED : 0;
	o->u.welcome.max_message = PROTO_MAX_MESSAGE;
	o->u.welcome.server_pid = (uint32_t)getpid();
	o->u.welcome.server_time_ns = mc_now_ns();
	srv_str_copy(o->u.welcome.daemon_version, sizeof(o->u.welcome.daemon_version), srv->cfg.daemon_version);
	srv_reply(srv, c, o);
}

/* Ends the client's stream: no frames queued, none in the latest slot, no
 * gap still to report (a new subscription starts a new stream). */
static void reset_stream(client *c)
{
	srv_blob_unref(c->latest);
	c->latest = NULL;
	c->gap_count = c->gap_first = 0;
}

static void handle_subscribe(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_subscribe *s = &m->u.subscribe;
	uint32_t len = 1;
	if (s->mode == MC_SUB_ALL) {
		len = s->queue_len ? s->queue_len : (uint32_t)srv->cfg.queue_len;
		if (len > (uint32_t)srv->cfg.max_queue_len)
			len = (uint32_t)srv->cfg.max_queue_len;
	}
	if (!srv_q_reshape(c, s->mode == MC_SUB_ALL ? (int)len : 0, true)) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_BUSY, false, "out of memory");
		return;
	}
	reset_stream(c);
	c->mode = s->mode;
	c->space = s->space;
	c->queue_len = len;
	srv_reply_ok(srv, c, m->h.request_id, m->h.type, len);
	srv_send_definition(srv, c);
}

static void handle_unsubscribe(srv_server *srv, client *c, const proto_msg *m)
{
	srv_q_reshape(c, 0, true);
	reset_stream(c);
	c->mode = 0;
	srv_reply_ok(srv, c, m->h.request_id, m->h.type, 0);
}

static void latency_to_wire(const srv_latency_status *l, mc_wire_latency_status *w)
{
	w->window = l->window;
	for (int s = 0; s < PROTO_LATENCY_STAGES; s++) {
		w->stage[s].p50 = l->stage[s].p50;
		w->stage[s].p99 = l->stage[s].p99;
		w->stage[s].max = l->stage[s].max;
	}
	w->skipped_behind = l->skipped_behind;
	w->skipped_stale = l->skipped_stale;
	w->incomplete = l->incomplete;
}

static void handle_get_status(srv_server *srv, client *c, const proto_msg *m)
{
	proto_msg *o = &srv->out;
	memset(o, 0, sizeof(o->h) + sizeof(o->u.status));
	o->h.type = MC_MSG_STATUS;
	o->h.request_id = m->h.request_id;
	mc_msg_status *s = &o->u.status;
	pthread_mutex_lock(&srv->lock);
	const srv_status *st = &srv->status;
	s->start_ns = st->start_ns;
	s->frames_published = st->frames_published;
	s->frames_dropped = st->frames_dropped;
	s->client_drops = srv->stats.client_drops;
	s->publish_fps = st->publish_fps;
	s->track_ms_mean = st->track_ms_mean;
	s->track_ms_max = st->track_ms_max;
	s->tracker_state = (uint8_t)st->tracker_state;
	s->recording = st->recording;
	s->nclients = (uint32_t)srv->stats.clients;
	srv_str_copy(s->device, sizeof(s->device), st->device);
	int ncams = st->ncams < 0 ? 0 : st->ncams > MC_MAX_CAMERAS ? MC_MAX_CAMERAS : st->ncams;
	s->ncams = (uint16_t)ncams;
	for (int i = 0; i < ncams; i++) {
		const srv_cam_status *cs = &st->cams[i];
		s->cams[i].fps = cs->fps;
		s->cams[i].frames = cs->frames;
		s->cams[i].drops = cs->drops;
		/* "failed" came with version 3: older clients know only error */
		s->cams[i].state = (uint32_t)(cs->state == MC_CAM_STATE_FAILED && c->version < 3 ? MC_CAM_STATE_ERROR
													: cs->state);
		s->cams[i].width = (uint32_t)(cs->width > 0 ? cs->width : 0);
		s->cams[i].height = (uint32_t)(cs->height > 0 ? cs->height : 0);
		srv_str_copy(s->cams[i].name, sizeof(s->cams[i].name), cs->name);
	}
	s->has_detector = c->version >= 2;
	if (s->has_detector) {
		const srv_detector_status *ds = &st->detector;
		mc_wire_detector_status *d = &s->detector;
		d->state = (uint32_t)ds->state;
		d->rate = ds->rate;
		d->used_rate = ds->used_rate;
		d->ms_mean = ds->ms_mean;
		d->ms_last = ds->ms_last;
		d->ms_max = ds->ms_max;
		d->views = ds->views;
		d->skipped = ds->skipped;
		d->used = ds->used;
		srv_str_copy(d->model, sizeof(d->model), ds->model);
		srv_str_copy(d->message, sizeof(d->message), ds->message);
	}
	s->has_latency = c->version >= 3;
	if (s->has_latency)
		latency_to_wire(&st->latency, &s->latency);
	pthread_mutex_unlock(&srv->lock);
	s->server_time_ns = mc_now_ns();
	srv_reply(srv, c, o);
}

static void handle_get_skeleton(srv_server *srv, client *c, const proto_msg *m)
{
	if (!srv->def_blob) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_UNAVAILABLE, false,
				"no skeleton yet: the daemon has not loaded a body model");
		return;
	}
	/* The shared definition blob has request_id 0; a reply echoes the id. */
	blob *b = srv_blob_new(srv->def_blob->data, srv->def_blob->len, false);
	if (!b)
		return;
	uint32_t id = m->h.request_id;
	for (int i = 0; i < 4; i++)
		b->data[8 + i] = (uint8_t)(id >> (8 * i));
	srv_client_send(srv, c, b);
	srv_blob_unref(b);
}

static void handle_get_rig(srv_server *srv, client *c, const proto_msg *m)
{
	proto_msg *o = srv_out_msg(srv, MC_MSG_RIG, m->h.request_id);
	blob *b = NULL;
	pthread_mutex_lock(&srv->lock);
	if (srv->rig_json) {
		o->u.rig.ncams = (uint32_t)srv->rig_ncams;
		o->u.rig.length = (uint32_t)strlen(srv->rig_json);
		o->u.rig.json = srv->rig_json;
		b = srv_encode_blob(srv, o, false);
	}
	pthread_mutex_unlock(&srv->lock);
	if (!b) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_UNAVAILABLE, false,
				"no rig yet: the daemon has not loaded one");
		return;
	}
	srv_client_send(srv, c, b);
	srv_blob_unref(b);
}

static bool require_privilege(srv_server *srv, client *c, const proto_msg *m, const char *what)
{
	if (c->privileged)
		return true;
	if (c->tcp) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_PERMISSION, false,
				"%s is not allowed over TCP by this mocapd ([network] privileged = false)", what);
		return false;
	}
	srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_PERMISSION, false,
			"%s is allowed only to mocapd's user and group (you are uid %u gid %u); "
			"add your user to the daemon's group",
			what, (unsigned)c->uid, (unsigned)c->gid);
	return false;
}

static bool control_takes_argument(uint32_t command)
{
	return command == MC_CONTROL_RECORD_START || command == MC_CONTROL_ACTOR_SAVE || command == MC_CONTROL_STEER;
}

static void handle_control(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_control *ctl = &m->u.control;
	if (!require_privilege(srv, c, m, "control"))
		return;
	if (ctl->command < MC_CONTROL_RELOAD || ctl->command > MC_CONTROL_STEER) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				"unknown control command %u (1 reload, 2 record start, 3 record stop, 4 actor save, "
				"5 record status, 6 record list, 7 steer)",
				ctl->command);
		return;
	}
	/* Checked here, like the command, so that every refusal of a
	 * request's form is an ERROR and CONTROL_RESULT means "it ran". */
	if (ctl->argument[0] && !control_takes_argument(ctl->command)) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				"control command %u takes no argument (got '%.64s')", ctl->command, ctl->argument);
		return;
	}
	if (!srv_controls_push(srv, c, m->h.request_id, ctl))
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_BUSY, false,
				"%d control requests are already waiting for the daemon; try again", CONTROL_QUEUE_LEN);
}

static void handle_get_rings(srv_server *srv, client *c, const proto_msg *m)
{
	/* TCP first: rings are refused over TCP whatever the client's
	 * privilege, with one answer (docs/PROTOCOL.md, TCP). */
	if (c->tcp) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_UNAVAILABLE, false,
				"camera rings are shared memory on the daemon's machine: not available over TCP");
		return;
	}
	if (!require_privilege(srv, c, m, "mapping camera rings"))
		return;
	proto_msg *o = srv_out_msg(srv, MC_MSG_RINGS, m->h.request_id);
	int fds[PROTO_MAX_RINGS], n = 0;
	pthread_mutex_lock(&srv->lock);
	for (int i = 0; i < srv->nrings; i++) {
		/* The blob owns duplicates, so that clearing the rings while a
		 * reply waits in a queue cannot send a closed descriptor. */
		int d = fcntl(srv->rings[i].fd, F_DUPFD_CLOEXEC, 0);
		if (d < 0)
			continue;
		fds[n] = d;
		o->u.rings.rings[n].size = srv->rings[i].size;
		srv_str_copy(o->u.rings.rings[n].name, sizeof(o->u.rings.rings[n].name), srv->rings[i].name);
		n++;
	}
	pthread_mutex_unlock(&srv->lock);
	o->u.rings.count = (uint16_t)n;
	blob *b = srv_encode_blob(srv, o, false);
	if (!b) {
		for (int i = 0; i < n; i++)
			close(fds[i]);
		return;
	}
	memcpy(b->fds, fds, sizeof(int) * (size_t)n);
	b->nfds = n;
	srv_client_send(srv, c, b);
	srv_blob_unref(b);
}

static void handle_keypoints(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_keypoints *k = &m->u.keypoints;
	if (!require_privilege(srv, c, m, "sending keypoints"))
		return;
	if (k->count > SRV_MAX_KEYPOINTS) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				"%u keypoints in one batch, at most %d", k->count, SRV_MAX_KEYPOINTS);
		return;
	}
	pthread_mutex_lock(&srv->lock);
	int ncams = srv->rig_json ? srv->rig_ncams : MC_MAX_CAMERAS;
	int njoints = srv->def_set ? srv->def.njoints : MC_MAX_JOINTS;
	pthread_mutex_unlock(&srv->lock);
	if (k->camera >= ncams) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				"camera %u: the rig has %d cameras", k->camera, ncams);
		return;
	}
	for (int i = 0; i < k->count; i++) {
		const mc_wire_keypoint *p = &k->kp[i];
		if (!isfinite(p->u) || !isfinite(p->v) || !(p->confidence >= 0.0f && p->confidence <= 1.0f)) {
			srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
					"keypoint %d: u, v must be finite and confidence in 0..1 (got %g, %g, %g)", i,
					(double)p->u, (double)p->v, (double)p->confidence);
			return;
		}
		if (k->kp[i].joint >= njoints) {
			srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
					"keypoint %d: joint %u, the skeleton has %d joints", i, k->kp[i].joint, njoints);
			return;
		}
	}
	srv_keypoints_push(&srv->keypoints, k, c->pid);
}

static void handle_head_pose(srv_server *srv, client *c, const proto_msg *m)
{
	const mc_msg_head_pose *h = &m->u.head_pose;
	if (!require_privilege(srv, c, m, "sending head poses"))
		return;
	double n2 = 0;
	bool finite = true;
	for (int i = 0; i < 4; i++) {
		n2 += h->orientation[i] * h->orientation[i];
		finite &= isfinite(h->orientation[i]) && (i == 3 || isfinite(h->position[i]));
	}
	/* A quaternion far from unit length is a client bug (x, y, z, w
	 * order, degrees, a matrix): refuse it rather than normalise it. */
	if (!finite || fabs(sqrt(n2) - 1.0) > 1e-3) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				"head pose: position must be finite and orientation a unit quaternion (w, x, y, z); "
				"its length is %g", sqrt(n2));
		return;
	}
	/* Metres in a VR runtime's tracking space: a play area, not 1e308. */
	for (int i = 0; i < 3; i++)
		if (fabs(h->position[i]) > SRV_HEAD_POSE_MAX_M) {
			srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
					"head pose: position[%d] is %g m; at most %g m from the origin", i,
					(double)h->position[i], SRV_HEAD_POSE_MAX_M);
			return;
		}
	srv_head_pose hp;
	hp.timestamp_ns = h->timestamp_ns;
	hp.position = mc_v3(h->position[0], h->position[1], h->position[2]);
	mc_quat q = {h->orientation[0], h->orientation[1], h->orientation[2], h->orientation[3]};
	hp.orientation = mc_quat_normalize(q);
	srv_head_pose_store(srv, &hp);
}

/* The latest-pose block's read-only descriptor; any client may read
 * skeletons, so no privilege is needed. */
static void handle_get_pose_block(srv_server *srv, client *c, const proto_msg *m)
{
	if (c->tcp || srv->pose_fd < 0) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_UNAVAILABLE, false,
				"the latest-pose block is shared memory on the daemon's machine: not available%s",
				c->tcp ? " over TCP" : "");
		return;
	}
	int fd = fcntl(srv->pose_fd, F_DUPFD_CLOEXEC, 0);
	proto_msg *o = srv_out_msg(srv, MC_MSG_POSE_BLOCK, m->h.request_id);
	o->u.pose_block.version = POSE_BLOCK_VERSION;
	o->u.pose_block.size = POSE_BLOCK_SIZE;
	blob *b = fd >= 0 ? srv_encode_blob(srv, o, false) : NULL;
	if (!b) {
		if (fd >= 0)
			close(fd);
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_BUSY, false, "out of descriptors or memory");
		return;
	}
	b->fds[0] = fd;
	b->nfds = 1;
	srv_client_send(srv, c, b);
	srv_blob_unref(b);
}

/* TCP only, and first: the token (tcp.c compares it). */
static void handle_auth(srv_server *srv, client *c, const proto_msg *m)
{
	if (!c->tcp) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_INVALID, false,
				"AUTH is for TCP connections; the Unix socket needs none");
		return;
	}
	if (c->authed) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_HANDSHAKE, true, "second AUTH");
		return;
	}
	if (!srv_tcp_token_ok(srv, m->u.auth.token)) {
		if (srv->cfg.on_client) {
			char line[128];
			snprintf(line, sizeof(line), "TCP client %s refused: wrong token", c->peer);
			srv->cfg.on_client(srv->cfg.on_client_ctx, line);
		}
		pthread_mutex_lock(&srv->lock);
		srv->stats.refused++;
		pthread_mutex_unlock(&srv->lock);
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_AUTH, true,
				"wrong token for mocapd's TCP port (see [network] token_file in its config)");
		return;
	}
	/* Waiting connections do not count against max_clients (listen.c):
	 * an authenticated one does, so the limit is checked again here. */
	if (srv_counted_clients(srv) >= srv->cfg.max_clients) {
		char why[96];
		snprintf(why, sizeof(why), "too many clients: mocapd accepts at most %d at once", srv->cfg.max_clients);
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_TOO_MANY_CLIENTS, true, why);
		return;
	}
	c->authed = true;
	c->privileged = srv->cfg.tcp_privileged;
	srv_reply_ok(srv, c, m->h.request_id, m->h.type, 0);
}

static void handle_ping(srv_server *srv, client *c, const proto_msg *m)
{
	proto_msg *o = srv_out_msg(srv, MC_MSG_PONG, m->h.request_id);
	o->u.ping.value = m->u.ping.value;
	o->u.ping.server_time_ns = mc_now_ns();
	srv_reply(srv, c, o);
}

void srv_protocol_error(srv_server *srv, client *c, uint16_t type, uint32_t request_id, const char *why)
{
	pthread_mutex_lock(&srv->lock);
	srv->stats.protocol_errors++;
	pthread_mutex_unlock(&srv->lock);
	srv_reply_error(srv, c, request_id, type, PROTO_E_MALFORMED, true, "malformed message: %s", why);
}

void srv_protocol_error_raw(srv_server *srv, client *c, size_t len, const char *why)
{
	uint16_t type = len >= 2 ? (uint16_t)(srv->rxbuf[0] | srv->rxbuf[1] << 8) : 0;
	uint32_t rid = 0;
	if (len >= 12)
		for (int i = 0; i < 4; i++)
			rid |= (uint32_t)srv->rxbuf[8 + i] << (8 * i);
	srv_protocol_error(srv, c, type, rid, why);
}

void srv_handle_message(srv_server *srv, client *c, size_t len)
{
	proto_msg *m = &srv->in;
	char why[256];
	if (proto_decode(srv->rxbuf, len, PROTO_FROM_CLIENT, m, why, sizeof(why)) != 0) {
		srv_protocol_error_raw(srv, c, len, why);
		return;
	}
	if (c->tcp && !c->authed && m->h.type != MC_MSG_AUTH) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_AUTH, true,
				"%s before AUTH: a TCP connection must start with AUTH and the daemon's token",
				proto_type_name(m->h.type));
		return;
	}
	if (!c->hello && m->h.type != MC_MSG_HELLO && m->h.type != MC_MSG_AUTH) {
		srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_HANDSHAKE, true,
				"%s before HELLO: a client must start with HELLO", proto_type_name(m->h.type));
		return;
	}
	switch (m->h.type) {
	case MC_MSG_HELLO:
		if (c->hello)
			srv_reply_error(srv, c, m->h.request_id, m->h.type, PROTO_E_HANDSHAKE, true, "second HELLO");
		else
			handle_hello(srv, c, m);
		break;
	case MC_MSG_SUBSCRIBE: handle_subscribe(srv, c, m); break;
	case MC_MSG_UNSUBSCRIBE: handle_unsubscribe(srv, c, m); break;
	case MC_MSG_GET_STATUS: handle_get_status(srv, c, m); break;
	case MC_MSG_GET_SKELETON: handle_get_skeleton(srv, c, m); break;
	case MC_MSG_GET_RIG: handle_get_rig(srv, c, m); break;
	case MC_MSG_CONTROL: handle_control(srv, c, m); break;
	case MC_MSG_GET_RINGS: handle_get_rings(srv, c, m); break;
	case MC_MSG_KEYPOINTS: handle_keypoints(srv, c, m); break;
	case MC_MSG_HEAD_POSE: handle_head_pose(srv, c, m); break;
	case MC_MSG_PING: handle_ping(srv, c, m); break;
	case MC_MSG_AUTH: handle_auth(srv, c, m); break;
	case MC_MSG_GET_POSE_BLOCK: handle_get_pose_block(srv, c, m); break;
	}
}

void srv_deliver_control_results(srv_server *srv)
{
	control_answer ans[CONTROL_QUEUE_LEN];
	int n = srv_controls_take_answers(srv, ans);
	for (int i = 0; i < n; i++) {
		client *c = srv_find_client(srv, ans[i].client_serial);
		if (!c)
			continue;
		proto_msg *o = srv_out_msg(srv, MC_MSG_CONTROL_RESULT, ans[i].request_id);
		o->u.control_result.command = ans[i].command;
		o->u.control_result.result = ans[i].result;
		srv_str_copy(o->u.control_result.message, sizeof(o->u.control_result.message), ans[i].message);
		srv_reply(srv, c, o);
	}
}
