/* proto_encode: protocol messages from the C structs of proto.h into bytes
 * (versions 1 to 3; docs/PROTOCOL.md gives every offset used here).  The
 * decoder, its mirror, is proto_decode.c. */
#include "proto.h"

#include "base/mc_le.h"

#include <string.h>

/* --- Writer: appends fields, remembers whether anything did not fit. --- */

typedef struct {
	uint8_t *buf;
	size_t cap, len;
	bool bad;
} writer;

static uint8_t *w_room(writer *w, size_t n)
{
	if (w->bad || n > w->cap - w->len) {
		w->bad = true;
		return NULL;
	}
	uint8_t *p = w->buf + w->len;
	w->len += n;
	return p;
}
static void w_u8(writer *w, uint8_t v)
{
	uint8_t *p = w_room(w, 1);
	if (p)
		*p = v;
}
static void w_u16(writer *w, uint16_t v)
{
	uint8_t *p = w_room(w, 2);
	if (p)
		mc_le_put_u16(p, v);
}
static void w_u32(writer *w, uint32_t v)
{
	uint8_t *p = w_room(w, 4);
	if (p)
		mc_le_put_u32(p, v);
}
static void w_u64(writer *w, uint64_t v)
{
	uint8_t *p = w_room(w, 8);
	if (p)
		mc_le_put_u64(p, v);
}
static void w_f32(writer *w, float v)
{
	uint32_t u;
	memcpy(&u, &v, 4);
	w_u32(w, u);
}
static void w_f64(writer *w, double v)
{
	uint64_t u;
	memcpy(&u, &v, 8);
	w_u64(w, u);
}
/* str16: u16 length + bytes; strings longer than max are refused. */
static void w_str(writer *w, const char *s, size_t max)
{
	size_t n = strnlen(s, max + 1);
	if (n > max) {
		w->bad = true;
		return;
	}
	w_u16(w, (uint16_t)n);
	uint8_t *p = w_room(w, n);
	if (p)
		memcpy(p, s, n);
}

/* --- Bodies, one function per message type.  The offsets in the comments
 * are from the start of the message (the header is 16 bytes). --- */

static void enc_hello(writer *w, const mc_msg_hello *m)
{
	w_u32(w, m->magic);           /* 16 */
	w_u16(w, m->min_version);     /* 20 */
	w_u16(w, m->max_version);     /* 22 */
	w_str(w, m->client_name, PROTO_NAME_MAX); /* 24 */
}

static void enc_welcome(writer *w, const mc_msg_welcome *m)
{
	w_u32(w, m->magic);
	w_u16(w, m->version);
	w_u16(w, m->flags);
	w_u32(w, m->max_message);
	w_u32(w, m->server_pid);
	w_u64(w, m->server_time_ns);
	w_str(w, m->daemon_version, PROTO_NAME_MAX);
}

static void enc_error(writer *w, const mc_msg_error *m)
{
	w_u32(w, m->code);
	w_u16(w, m->request_type);
	w_u16(w, m->fatal);
	w_str(w, m->message, PROTO_TEXT_MAX);
}

static void enc_ok(writer *w, const mc_msg_ok *m)
{
	w_u16(w, m->request_type);
	w_u16(w, 0);
	w_u32(w, m->value);
}

static void enc_subscribe(writer *w, const mc_msg_subscribe *m)
{
	w_u8(w, m->mode);
	w_u8(w, m->space);
	w_u16(w, 0);
	w_u32(w, m->queue_len);
}

static void enc_control(writer *w, const mc_msg_control *m)
{
	w_u32(w, m->command);
	w_str(w, m->argument, PROTO_ARG_MAX);
}

static void enc_auth(writer *w, const mc_msg_auth *m) { w_str(w, m->token, PROTO_TOKEN_MAX); }

static void enc_pose_block(writer *w, const mc_msg_pose_block *m)
{
	w_u32(w, m->version);
	w_u32(w, 0);
	w_u64(w, m->size);
}

static void enc_keypoints(writer *w, const mc_msg_keypoints *m)
{
	if (m->count > PROTO_MAX_KEYPOINTS) {
		w->bad = true;
		return;
	}
	w_u64(w, m->capture_ns);
	w_u16(w, m->camera);
	w_u16(w, m->count);
	w_u32(w, 0);
	for (int i = 0; i < m->count; i++) {
		w_u16(w, m->kp[i].joint);
		w_u16(w, 0);
		w_f32(w, m->kp[i].u);
		w_f32(w, m->kp[i].v);
		w_f32(w, m->kp[i].confidence);
	}
}

static void enc_head_pose(writer *w, const mc_msg_head_pose *m)
{
	w_u64(w, m->timestamp_ns);
	for (int i = 0; i < 3; i++)
		w_f64(w, m->position[i]);
	for (int i = 0; i < 4; i++)
		w_f64(w, m->orientation[i]);
}

static void enc_ping(writer *w, const mc_msg_ping *m, bool pong)
{
	w_u64(w, m->value);
	if (pong)
		w_u64(w, m->server_time_ns);
}

static void enc_skeleton(writer *w, const mc_msg_skeleton *m)
{
	if (m->njoints > PROTO_MAX_JOINTS) {
		w->bad = true;
		return;
	}
	w_u32(w, m->skeleton_id);
	w_u16(w, m->njoints);
	w_u8(w, m->rig_is_world);
	w_u8(w, 0);
	for (int j = 0; j < m->njoints; j++) {
		w_u32(w, (uint32_t)m->joints[j].parent);
		w_u32(w, 0);
		for (int i = 0; i < 3; i++)
			w_f64(w, m->joints[j].offset[i]);
	}
	for (int j = 0; j < m->njoints; j++)
		w_str(w, m->joints[j].name, PROTO_NAME_MAX);
}

static void enc_frame(writer *w, const mc_msg_frame *m)
{
	if (m->njoints > PROTO_MAX_JOINTS) {
		w->bad = true;
		return;
	}
	w_u64(w, m->seq);          /* 16 */
	w_u64(w, m->capture_ns);   /* 24 */
	w_u64(w, m->publish_ns);   /* 32 */
	w_u32(w, m->skeleton_id);  /* 40 */
	w_u16(w, m->njoints);      /* 44 */
	w_u8(w, m->state);         /* 46 */
	w_u8(w, m->space);         /* 47 */
	for (int j = 0; j < m->njoints; j++) { /* 48 + 64 j */
		const mc_wire_joint *jt = &m->joints[j];
		for (int i = 0; i < 3; i++)
			w_f64(w, jt->position[i]);
		for (int i = 0; i < 4; i++)
			w_f64(w, jt->orientation[i]);
		w_f32(w, jt->confidence);
		w_u32(w, 0);
	}
}

static void enc_gap(writer *w, const mc_msg_gap *m)
{
	w_u64(w, m->first_seq);
	w_u64(w, m->count);
}

static void enc_status(writer *w, const mc_msg_status *m)
{
	if (m->ncams > PROTO_MAX_CAMS) {
		w->bad = true;
		return;
	}
	w_u64(w, m->server_time_ns);   /* 16 */
	w_u64(w, m->start_ns);         /* 24 */
	w_u64(w, m->frames_published); /* 32 */
	w_u64(w, m->frames_dropped);   /* 40 */
	w_u64(w, m->client_drops);     /* 48 */
	w_f64(w, m->publish_fps);      /* 56 */
	w_f64(w, m->track_ms_mean);    /* 64 */
	w_f64(w, m->track_ms_max);     /* 72 */
	w_u8(w, m->tracker_state);     /* 80 */
	w_u8(w, m->recording);         /* 81 */
	w_u16(w, m->ncams);            /* 82 */
	w_u32(w, m->nclients);         /* 84 */
	for (int c = 0; c < m->ncams; c++) { /* 88 + 40 c */
		const mc_wire_cam_status *cs = &m->cams[c];
		w_f64(w, cs->fps);
		w_u64(w, cs->frames);
		w_u64(w, cs->drops);
		w_u32(w, cs->state);
		w_u32(w, cs->width);
		w_u32(w, cs->height);
		w_u32(w, 0);
	}
	w_str(w, m->device, PROTO_NAME_MAX);
	for (int c = 0; c < m->ncams; c++)
		w_str(w, m->cams[c].name, PROTO_NAME_MAX);
	if (!m->has_detector)
		return;
	const mc_wire_detector_status *d = &m->detector; /* version 2 */
	w_u32(w, d->state);
	w_u32(w, 0);
	for (int i = 0; i < 5; i++)
		w_f64(w, d->figures[i]);
	for (int i = 0; i < 3; i++)
		w_u64(w, d->counts[i]);
	w_str(w, d->model, PROTO_TEXT_MAX);
	w_str(w, d->message, PROTO_TEXT_MAX);
	if (!m->has_latency)
		return;
	const mc_wire_latency_status *l = &m->latency; /* version 3 */
	w_u32(w, l->window);
	w_u32(w, 0);
	for (int s = 0; s < PROTO_LATENCY_STAGES; s++) {
		w_f64(w, l->stage[s].p50);
		w_f64(w, l->stage[s].p99);
		w_f64(w, l->stage[s].max);
	}
	w_u64(w, l->skipped_behind);
	w_u64(w, l->skipped_stale);
	w_u64(w, l->incomplete);
}

static void enc_rig(writer *w, const mc_msg_rig *m)
{
	if (m->length > PROTO_RIG_MAX) {
		w->bad = true;
		return;
	}
	w_u32(w, m->ncams);
	w_u32(w, m->length);
	uint8_t *p = w_room(w, m->length);
	if (p && m->length)
		memcpy(p, m->json, m->length);
}

static void enc_control_result(writer *w, const mc_msg_control_result *m)
{
	w_u32(w, m->command);
	w_u32(w, (uint32_t)m->result);
	w_str(w, m->message, PROTO_TEXT_MAX);
}

static void enc_rings(writer *w, const mc_msg_rings *m)
{
	if (m->count > PROTO_MAX_RINGS) {
		w->bad = true;
		return;
	}
	w_u16(w, m->count);
	w_u16(w, 0);
	w_u32(w, 0);
	for (int i = 0; i < m->count; i++) {
		w_u64(w, m->rings[i].size);
		w_u64(w, 0);
	}
	for (int i = 0; i < m->count; i++)
		w_str(w, m->rings[i].name, PROTO_NAME_MAX);
}

/* --- Dispatch --- */

size_t proto_encode(const proto_msg *msg, void *buf, size_t cap)
{
	if (cap > PROTO_MAX_MESSAGE)
		cap = PROTO_MAX_MESSAGE;
	writer w = {buf, cap, 0, false};
	w_u16(&w, msg->h.type);
	w_u16(&w, 0);
	w_u32(&w, 0); /* size, patched below */
	w_u32(&w, msg->h.request_id);
	w_u32(&w, 0);
	switch (msg->h.type) {
	case MC_MSG_HELLO: enc_hello(&w, &msg->u.hello); break;
	case MC_MSG_SUBSCRIBE: enc_subscribe(&w, &msg->u.subscribe); break;
	case MC_MSG_UNSUBSCRIBE:
	case MC_MSG_GET_STATUS:
	case MC_MSG_GET_SKELETON:
	case MC_MSG_GET_RIG:
	case MC_MSG_GET_RINGS: break;
	case MC_MSG_CONTROL: enc_control(&w, &msg->u.control); break;
	case MC_MSG_KEYPOINTS: enc_keypoints(&w, &msg->u.keypoints); break;
	case MC_MSG_HEAD_POSE: enc_head_pose(&w, &msg->u.head_pose); break;
	case MC_MSG_PING: enc_ping(&w, &msg->u.ping, false); break;
	case MC_MSG_AUTH: enc_auth(&w, &msg->u.auth); break;
	case MC_MSG_GET_POSE_BLOCK: break;
	case MC_MSG_POSE_BLOCK: enc_pose_block(&w, &msg->u.pose_block); break;
	case MC_MSG_WELCOME: enc_welcome(&w, &msg->u.welcome); break;
	case MC_MSG_ERROR: enc_error(&w, &msg->u.error); break;
	case MC_MSG_OK: enc_ok(&w, &msg->u.ok); break;
	case MC_MSG_SKELETON: enc_skeleton(&w, &msg->u.skeleton); break;
	case MC_MSG_FRAME: enc_frame(&w, &msg->u.frame); break;
	case MC_MSG_GAP: enc_gap(&w, &msg->u.gap); break;
	case MC_MSG_STATUS: enc_status(&w, &msg->u.status); break;
	case MC_MSG_RIG: enc_rig(&w, &msg->u.rig); break;
	case MC_MSG_CONTROL_RESULT: enc_control_result(&w, &msg->u.control_result); break;
	case MC_MSG_RINGS: enc_rings(&w, &msg->u.rings); break;
	case MC_MSG_PONG: enc_ping(&w, &msg->u.ping, true); break;
	default: return 0;
	}
	if (w.bad)
		return 0;
	mc_le_put_u32(w.buf + 4, (uint32_t)w.len);
	return w.len;
}
