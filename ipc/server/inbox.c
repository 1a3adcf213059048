/* The inboxes the daemon reads: keypoint batches (for the tracking
 * thread), control requests (for the main loop) and head poses.  The
 * server thread fills them from handlers.c; the daemon's threads take from
 * them at any time.  All of it is under the server's lock, and the event fd
 * is readable exactly while a keypoint batch or an unpolled control
 * request waits: with one lock for both there is no moment at which one
 * side resets the fd while the other has just filled its queue. */
#include "server/internal.h"

#include <unistd.h>

/* Called with the lock held, after something was queued. */
static void signal_event(srv_server *srv)
{
	uint64_t one = 1;
	if (write(srv->event_fd, &one, sizeof(one)) < 0) {
		/* the counter is saturated: it is readable anyway */
	}
}

/* Called with the lock held: resets the event fd once nothing waits. */
/* Only control requests: the main loop waits on the fd for them, while the
 * tracking thread takes keypoints on its own schedule (once per frame set),
 * so a keypoint batch waiting for it must not keep the fd readable and the
 * main loop spinning. */
static void reset_event_fd_if_idle(srv_server *srv)
{
	bool waiting = false;
	for (int i = 0; i < srv->ncontrols; i++)
		waiting |= !srv->controls[i].polled;
	if (!waiting) {
		uint64_t v;
		if (read(srv->event_fd, &v, sizeof(v)) < 0) {
			/* EAGAIN: already reset */
		}
	}
}

int srv_event_fd(srv_server *srv) { return srv->event_fd; }

/* --- Keypoints --- */

srv_keypoint_inbox *srv_keypoints_inbox(srv_server *srv) { return &srv->keypoints; }

int srv_keypoints_push(srv_keypoint_inbox *in, const mc_msg_keypoints *k, pid_t pid)
{
	srv_server *srv = in->srv;
	int dropped = 0;
	pthread_mutex_lock(&srv->lock);
	if (in->count == KEYPOINT_QUEUE_LEN) {
		in->head = (in->head + 1) % KEYPOINT_QUEUE_LEN;
		in->count--;
		srv->stats.keypoint_drops++;
		dropped = 1;
	}
	srv_keypoints *o = &in->ring[(in->head + in->count) % KEYPOINT_QUEUE_LEN];
	in->count++;
	o->capture_ns = k->capture_ns;
	o->cam = k->camera;
	o->nkeypoints = k->count;
	o->pid = pid;
	for (int i = 0; i < k->count; i++) {
		o->keypoints[i].cam = k->camera;
		o->keypoints[i].joint = k->kp[i].joint;
		o->keypoints[i].u = k->kp[i].u;
		o->keypoints[i].v = k->kp[i].v;
		o->keypoints[i].conf = k->kp[i].confidence;
	}
	pthread_mutex_unlock(&srv->lock);
	return dropped;
}

int srv_inbox_pop_keypoints(srv_keypoint_inbox *in, srv_keypoints *out)
{
	srv_server *srv = in->srv;
	int got = 0;
	pthread_mutex_lock(&srv->lock);
	if (in->count > 0) {
		*out = in->ring[in->head];
		in->head = (in->head + 1) % KEYPOINT_QUEUE_LEN;
		in->count--;
		got = 1;
	}
	pthread_mutex_unlock(&srv->lock);
	return got;
}

int srv_poll_keypoints(srv_server *srv, srv_keypoints *out)
{
	return srv_inbox_pop_keypoints(&srv->keypoints, out);
}

/* --- Control requests --- */

bool srv_controls_push(srv_server *srv, const client *c, uint32_t request_id, const mc_msg_control *ctl)
{
	pthread_mutex_lock(&srv->lock);
	bool full = srv->ncontrols >= CONTROL_QUEUE_LEN;
	if (!full) {
		control_entry *e = &srv->controls[srv->ncontrols++];
		memset(e, 0, sizeof(*e));
		e->token = ++srv->next_token;
		e->client_serial = c->serial;
		e->request_id = request_id;
		e->req.token = e->token;
		e->req.command = (mc_control_command)ctl->command;
		srv_str_copy(e->req.argument, sizeof(e->req.argument), ctl->argument);
		e->req.pid = c->pid;
		e->req.uid = c->uid;
		e->req.gid = c->gid;
		signal_event(srv);
	}
	pthread_mutex_unlock(&srv->lock);
	return !full;
}

int srv_poll_control(srv_server *srv, srv_control *out)
{
	int got = 0;
	pthread_mutex_lock(&srv->lock);
	for (int i = 0; i < srv->ncontrols && !got; i++) {
		if (srv->controls[i].polled)
			continue;
		srv->controls[i].polled = true;
		*out = srv->controls[i].req;
		got = 1;
	}
	reset_event_fd_if_idle(srv);
	pthread_mutex_unlock(&srv->lock);
	return got;
}

void srv_control_done(srv_server *srv, uint64_t token, int result, const char *message)
{
	pthread_mutex_lock(&srv->lock);
	if (srv->nresults < CONTROL_QUEUE_LEN) {
		control_result *r = &srv->results[srv->nresults++];
		r->token = token;
		r->result = result;
		srv_str_copy(r->message, sizeof(r->message), message ? message : "");
	}
	pthread_mutex_unlock(&srv->lock);
	srv_wake(srv);
}

int srv_controls_take_answers(srv_server *srv, control_answer *out)
{
	int n = 0;
	pthread_mutex_lock(&srv->lock);
	for (int i = 0; i < srv->nresults; i++) {
		/* Find and remove the request the result belongs to. */
		for (int k = 0; k < srv->ncontrols; k++) {
			control_entry *e = &srv->controls[k];
			if (e->token != srv->results[i].token)
				continue;
			control_answer *a = &out[n++];
			a->client_serial = e->client_serial;
			a->request_id = e->request_id;
			a->command = (uint32_t)e->req.command;
			a->result = srv->results[i].result;
			memcpy(a->message, srv->results[i].message, sizeof(a->message));
			srv->controls[k] = srv->controls[--srv->ncontrols];
			break;
		}
	}
	srv->nresults = 0;
	pthread_mutex_unlock(&srv->lock);
	return n;
}

/* --- Head poses --- */

void srv_head_pose_store(srv_server *srv, const srv_head_pose *hp)
{
	/* The history is the server thread's alone (fanout.c reads it). */
	srv->head_hist[srv->head_next] = *hp;
	srv->head_next = (srv->head_next + 1) % HEAD_POSE_HISTORY;
	if (srv->head_n < HEAD_POSE_HISTORY)
		srv->head_n++;
	pthread_mutex_lock(&srv->lock);
	if (!srv->have_head_pose || hp->timestamp_ns >= srv->latest_head_pose.timestamp_ns)
		srv->latest_head_pose = *hp;
	srv->have_head_pose = true;
	pthread_mutex_unlock(&srv->lock);
	pthread_mutex_lock(&srv->tap_lock);
	if (srv->head_pose_tap)
		srv->head_pose_tap(srv->head_pose_tap_ctx, hp);
	pthread_mutex_unlock(&srv->tap_lock);
}

void srv_set_head_pose_tap(srv_server *srv, void (*fn)(void *ctx, const srv_head_pose *hp), void *ctx)
{
	pthread_mutex_lock(&srv->tap_lock);
	srv->head_pose_tap = fn;
	srv->head_pose_tap_ctx = ctx;
	pthread_mutex_unlock(&srv->tap_lock);
}

int srv_latest_head_pose(srv_server *srv, srv_head_pose *out)
{
	pthread_mutex_lock(&srv->lock);
	int got = srv->have_head_pose;
	if (got)
		*out = srv->latest_head_pose;
	pthread_mutex_unlock(&srv->lock);
	return got;
}
