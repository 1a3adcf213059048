/* Subscription and frames: the frame queue the reader fills, the pollable
 * event that says a frame (or the connection's end) waits, subscribing and
 * mocap_read_frame. */
#include "client/internal.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Called (lock held) when a public function returns to the application,
 * not on every queue change: a frame that is received and handed out in
 * the same call then costs no eventfd system calls. */
void mcl_update_event(mocap_client *c)
{
	bool want = c->fq_n > 0 || c->dead;
	if (want == c->ev_set)
		return;
	uint64_t v = 1;
	ssize_t r = want ? write(c->evfd, &v, sizeof(v)) : read(c->evfd, &v, sizeof(v));
	(void)r;
	c->ev_set = want;
}

void mcl_fq_clear(mocap_client *c)
{
	while (c->fq_n) {
		free(c->fq[c->fq_head]);
		c->fq_head = (c->fq_head + 1) % FRAME_QUEUE_MAX;
		c->fq_n--;
	}
}

void mcl_fq_push(mocap_client *c, mocap_skeleton_frame *f)
{
	if (c->mode == MOCAP_LATEST)
		mcl_fq_clear(c); /* only the newest counts */
	if (c->fq_n == FRAME_QUEUE_MAX) {
		/* The application does not read its frames: drop, and say so. */
		c->pending_missed += 1 + f->missed;
		free(f);
		return;
	}
	f->missed += c->pending_missed;
	c->pending_missed = 0;
	c->fq[(c->fq_head + c->fq_n) % FRAME_QUEUE_MAX] = f;
	c->fq_n++;
}

/* Stops taking frames until the next subscription's reply (frames of an
 * older one still in flight may be of another mode). */
static void stop_frames(mocap_client *c)
{
	pthread_mutex_lock(&c->lock);
	c->mode = 0;
	mcl_fq_clear(c);
	c->pending_missed = 0;
	mcl_update_event(c);
	pthread_mutex_unlock(&c->lock);
}

int mocap_subscribe(mocap_client *c, mocap_mode mode, mocap_space space, unsigned queue_len)
{
	if (mode != MOCAP_LATEST && mode != MOCAP_ALL)
		return mcl_set_err(MOCAP_E_ARG, "subscribe: mode must be MOCAP_LATEST or MOCAP_ALL");
	if (space != MOCAP_SPACE_RIG && space != MOCAP_SPACE_WORLD)
		return mcl_set_err(MOCAP_E_ARG, "subscribe: space must be MOCAP_SPACE_RIG or MOCAP_SPACE_WORLD");
	proto_msg *m = mcl_new_msg(MC_MSG_SUBSCRIBE);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.subscribe.mode = (uint8_t)mode;
	m->u.subscribe.space = (uint8_t)space;
	m->u.subscribe.queue_len = queue_len;
	stop_frames(c);
	int rc = mcl_request(c, m, MC_MSG_OK, m, NULL, NULL, NULL);
	free(m);
	if (rc == 0) {
		pthread_mutex_lock(&c->lock);
		c->mode = mode;
		pthread_mutex_unlock(&c->lock);
	}
	return rc;
}

int mocap_unsubscribe(mocap_client *c)
{
	proto_msg *m = mcl_new_msg(MC_MSG_UNSUBSCRIBE);
	if (!m)
		return MOCAP_E_SYSTEM;
	stop_frames(c);
	int rc = mcl_request(c, m, MC_MSG_OK, m, NULL, NULL, NULL);
	free(m);
	return rc;
}

int mocap_read_frame(mocap_client *c, mocap_skeleton_frame *f, int timeout_ms)
{
	uint64_t deadline = mcl_deadline_after(timeout_ms < 0 ? -1 : timeout_ms);
	int rc = 0;
	bool looked = false;
	pthread_mutex_lock(&c->lock);
	if (!c->mode && !c->fq_n && !c->dead) {
		pthread_mutex_unlock(&c->lock);
		return mcl_set_err(MOCAP_E_ARG, "read_frame: not subscribed (call mocap_subscribe first)");
	}
	/* LATEST: take in everything already there first, to return the newest. */
	if (c->mode == MOCAP_LATEST && !c->reading) {
		mcl_wait_step(c, 0);
		looked = true;
	}
	for (;;) {
		if (c->fq_n) {
			mocap_skeleton_frame *q = c->fq[c->fq_head];
			c->fq_head = (c->fq_head + 1) % FRAME_QUEUE_MAX;
			c->fq_n--;
			memcpy(f, q, FRAME_BYTES(q->njoints));
			free(q);
			rc = 1;
			break;
		}
		if (c->dead) {
			rc = mcl_dead_error(c);
			break;
		}
		/* Even with a zero timeout, look at the socket once. */
		if (looked && deadline != FOREVER && mc_now_ns() >= deadline)
			break;
		mcl_wait_step(c, deadline);
		looked = true;
	}
	mcl_update_event(c);
	pthread_mutex_unlock(&c->lock);
	return rc;
}
