/* proto: encoding and decoding of protocol versions 1 and 2 (see proto.h and
 * docs/PROTOCOL.md, which gives every offset used here). */
#include "proto.h"

#include "base/mc_le.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
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

/* --- Reader: takes fields, fails once with a reason. --- */

typedef struct {
	const uint8_t *buf;
	size_t len, pos;
	const char *msg;  /* message type name for reasons */
	char *why;
	size_t whylen;
	bool bad;
} reader;

static void r_fail(reader *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void r_fail(reader *r, const char *fmt, ...)
{
	if (r->bad)
		return;
	r->bad = true;
	if (!r->why || !r->whylen)
		return;
	int n = snprintf(r->why, r->whylen, "%s: ", r->msg);
	if (n < 0 || (size_t)n >= r->whylen)
		return;
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(r->why + n, r->whylen - (size_t)n, fmt, ap);
	va_end(ap);
}
static const uint8_t *r_take(reader *r, size_t n, const char *field)
{
	if (r->bad)
		return NULL;
	if (n > r->len - r->pos) {
		r_fail(r, "%s: message ends at byte %zu, field needs %zu more", field, r->len, n - (r->len - r->pos));
		return NULL;
	}
	const uint8_t *p = r->buf + r->pos;
	r->pos += n;
	return p;
}
static uint8_t r_u8(reader *r, const char *f)
{
	const uint8_t *p = r_take(r, 1, f);
	return p ? *p : 0;
}
static uint16_t r_u16(reader *r, const char *f)
{
	const uint8_t *p = r_take(r, 2, f);
	return p ? mc_le_u16(p) : 0;
}
static uint32_t r_u32(reader *r, const char *f)
{
	const uint8_t *p = r_take(r, 4, f);
	return p ? mc_le_u32(p) : 0;
}
static uint64_t r_u64(reader *r, const char *f)
{
	const uint8_t *p = r_take(r, 8, f);
	return p ? mc_le_u64(p) : 0;
}
static float r_f32(reader *r, const char *f)
{
	uint32_t u = r_u32(r, f);
	float v;
	memcpy(&v, &u, 4);
	return v;
}
static double r_f64(reader *r, const char *f)
{
	uint64_t u = r_u64(r, f);
	double v;
	memcpy(&v, &u, 8);
	return v;
}
/* A finite double, else the message is malformed. */
static double r_finite(reader *r, const char *f)
{
	double v = r_f64(r, f);
	if (!r->bad && !isfinite(v))
		r_fail(r, "%s: not a finite number", f);
	return v;
}
static void r_str(reader *r, char *out, size_t max, const char *f)
{
	out[0] = 0;
	uint16_t n = r_u16(r, f);
	if (r->bad)
		return;
	if (n > max) {
		r_fail(r, "%s: string of %u bytes, at most %zu allowed", f, n, max);
		return;
	}
	const uint8_t *p = r_take(r, n, f);
	if (!p)
		return;
	if (memchr(p, 0, n)) {
		r_fail(r, "%s: string contains a NUL byte", f);
		return;
	}
	memcpy(out, p, n);
	out[n] = 0;
}
static void r_end(reader *r)
{
	if (!r->bad && r->pos != r->len)
		r_fail(r, "%zu trailing bytes after the last field (message is %zu bytes)", r->len - r->pos, r->len);
}

/* --- Names --- */

const char *proto_type_name(uint16_t type)
{
	switch (type) {
	case MC_MSG_HELLO: return "HELLO";
	case MC_MSG_SUBSCRIBE: return "SUBSCRIBE";
	case MC_MSG_UNSUBSCRIBE: return "UNSUBSCRIBE";
	case MC_MSG_GET_STATUS: return "GET_STATUS";
	case MC_MSG_GET_SKELETON: return "GET_SKELETON";
	case MC_MSG_GET_RIG: return "GET_RIG";
	case MC_MSG_CONTROL: return "CONTROL";
	case MC_MSG_GET_RINGS: return "GET_RINGS";
	case MC_MSG_KEYPOINTS: return "KEYPOINTS";
	case MC_MSG_HEAD_POSE: return "HEAD_POSE";
	case MC_MSG_PING: return "PING";
	case MC_MSG_AUTH: return "AUTH";
	case MC_MSG_GET_POSE_BLOCK: return "GET_POSE_BLOCK";
	case MC_MSG_POSE_BLOCK: return "POSE_BLOCK";
	case MC_MSG_WELCOME: return "WELCOME";
	case MC_MSG_ERROR: return "ERROR";
	case MC_MSG_OK: return "OK";
	case MC_MSG_SKELETON: return "SKELETON";
	case MC_MSG_FRAME: return "FRAME";
	case MC_MSG_GAP: return "GAP";
	case MC_MSG_STATUS: return "STATUS";
	case MC_MSG_RIG: return "RIG";
	case MC_MSG_CONTROL_RESULT: return "CONTROL_RESULT";
	case MC_MSG_RINGS: return "RINGS";
	case MC_MSG_PONG: return "PONG";
	}
	return "unknown";
}

/* --- Bodies, one pair of functions per message type.  The offsets in the
 * comments are from the start of the message (the header is 16 bytes). --- */

static void enc_hello(writer *w, const mc_msg_hello *m)
{
	w_u32(w, m->magic);           /* 16 */
	w_u16(w, m->min_version);     /* 20 */
	w_u16(w, m->max_version);     /* 22 */
	w_str(w, m->client_name, PROTO_NAME_MAX); /* 24 */
}
static void dec_hello(reader *r, mc_msg_hello *m)
{
	m->magic = r_u32(r, "magic");
	if (!r->bad && m->magic != PROTO_MAGIC)
		r_fail(r, "magic: 0x%08x, expected 0x%08x (\"MOCP\"): not a mocapd client", m->magic, PROTO_MAGIC);
	m->min_version = r_u16(r, "min_version");
	m->max_version = r_u16(r, "max_version");
	if (!r->bad && m->min_version > m->max_version)
		r_fail(r, "min_version %u > max_version %u", m->min_version, m->max_version);
	r_str(r, m->client_name, PROTO_NAME_MAX, "client_name");
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
static void dec_welcome(reader *r, mc_msg_welcome *m)
{
	m->magic = r_u32(r, "magic");
	if (!r->bad && m->magic != PROTO_MAGIC)
		r_fail(r, "magic: 0x%08x, expected 0x%08x: not a mocapd server", m->magic, PROTO_MAGIC);
	m->version = r_u16(r, "version");
	m->flags = r_u16(r, "flags");
	m->max_message = r_u32(r, "max_message");
	m->server_pid = r_u32(r, "server_pid");
	m->server_time_ns = r_u64(r, "server_time_ns");
	r_str(r, m->daemon_version, PROTO_NAME_MAX, "daemon_version");
}

static void enc_error(writer *w, const mc_msg_error *m)
{
	w_u32(w, m->code);
	w_u16(w, m->request_type);
	w_u16(w, m->fatal);
	w_str(w, m->message, PROTO_TEXT_MAX);
}
static void dec_error(reader *r, mc_msg_error *m)
{
	m->code = r_u32(r, "code");
	m->request_type = r_u16(r, "request_type");
	m->fatal = r_u16(r, "fatal");
	r_str(r, m->message, PROTO_TEXT_MAX, "message");
}

static void enc_ok(writer *w, const mc_msg_ok *m)
{
	w_u16(w, m->request_type);
	w_u16(w, 0);
	w_u32(w, m->value);
}
static void dec_ok(reader *r, mc_msg_ok *m)
{
	m->request_type = r_u16(r, "request_type");
	r_u16(r, "reserved");
	m->value = r_u32(r, "value");
}

static void enc_subscribe(writer *w, const mc_msg_subscribe *m)
{
	w_u8(w, m->mode);
	w_u8(w, m->space);
	w_u16(w, 0);
	w_u32(w, m->queue_len);
}
static void dec_subscribe(reader *r, mc_msg_subscribe *m)
{
	m->mode = r_u8(r, "mode");
	m->space = r_u8(r, "space");
	r_u16(r, "reserved");
	m->queue_len = r_u32(r, "queue_len");
	if (!r->bad && m->mode != MC_SUB_LATEST && m->mode != MC_SUB_ALL)
		r_fail(r, "mode: %u, expected 1 (latest) or 2 (all)", m->mode);
	if (!r->bad && m->space != MC_SPACE_RIG && m->space != MC_SPACE_WORLD)
		r_fail(r, "space: %u, expected 0 (rig) or 1 (world)", m->space);
}

static void enc_control(writer *w, const mc_msg_control *m)
{
	w_u32(w, m->command);
	w_str(w, m->argument, PROTO_ARG_MAX);
}
static void dec_control(reader *r, mc_msg_control *m)
{
	m->command = r_u32(r, "command");
	r_str(r, m->argument, PROTO_ARG_MAX, "argument");
}

static void enc_auth(writer *w, const mc_msg_auth *m) { w_str(w, m->token, PROTO_TOKEN_MAX); }

static void dec_auth(reader *r, mc_msg_auth *m) { r_str(r, m->token, PROTO_TOKEN_MAX, "token"); }

static void enc_pose_block(writer *w, const mc_msg_pose_block *m)
{
	w_u32(w, m->version);
	w_u32(w, 0);
	w_u64(w, m->size);
}
static void dec_pose_block(reader *r, mc_msg_pose_block *m)
{
	m->version = r_u32(r, "version");
	r_u32(r, "reserved");
	m->size = r_u64(r, "size");
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
static void dec_keypoints(reader *r, mc_msg_keypoints *m)
{
	m->capture_ns = r_u64(r, "capture_ns");
	m->camera = r_u16(r, "camera");
	m->count = r_u16(r, "count");
	r_u32(r, "reserved");
	if (r->bad)
		return;
	if (m->count > PROTO_MAX_KEYPOINTS) {
		r_fail(r, "count: %u keypoints, at most %d allowed", m->count, PROTO_MAX_KEYPOINTS);
		return;
	}
	if (r->len - r->pos != (size_t)m->count * 16) {
		r_fail(r, "count %u needs %zu bytes of keypoints, message has %zu", m->count,
			      (size_t)m->count * 16, r->len - r->pos);
		return;
	}
	/* Values (finite, confidence in 0..1, indices) are checked by the
	 * server, which answers a bad one without closing the connection. */
	for (int i = 0; i < m->count; i++) {
		mc_wire_keypoint *k = &m->kp[i];
		k->joint = r_u16(r, "joint");
		r_u16(r, "reserved");
		k->u = r_f32(r, "u");
		k->v = r_f32(r, "v");
		k->confidence = r_f32(r, "confidence");
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
static void dec_head_pose(reader *r, mc_msg_head_pose *m)
{
	m->timestamp_ns = r_u64(r, "timestamp_ns");
	for (int i = 0; i < 3; i++)
		m->position[i] = r_f64(r, "position");
	for (int i = 0; i < 4; i++)
		m->orientation[i] = r_f64(r, "orientation");
}

static void enc_ping(writer *w, const mc_msg_ping *m, bool pong)
{
	w_u64(w, m->value);
	if (pong)
		w_u64(w, m->server_time_ns);
}
static void dec_ping(reader *r, mc_msg_ping *m, bool pong)
{
	m->value = r_u64(r, "value");
	m->server_time_ns = pong ? r_u64(r, "server_time_ns") : 0;
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
static void dec_skeleton(reader *r, mc_msg_skeleton *m)
{
	m->skeleton_id = r_u32(r, "skeleton_id");
	m->njoints = r_u16(r, "njoints");
	m->rig_is_world = r_u8(r, "rig_is_world");
	r_u8(r, "reserved");
	if (r->bad)
		return;
	if (m->njoints > PROTO_MAX_JOINTS) {
		r_fail(r, "njoints: %u, at most %d allowed", m->njoints, PROTO_MAX_JOINTS);
		return;
	}
	for (int j = 0; j < m->njoints && !r->bad; j++) {
		int32_t p = (int32_t)r_u32(r, "parent");
		r_u32(r, "reserved");
		/* Parents come before their children: that makes the joints a
		 * tree and lets a client compute world positions in one pass. */
		if (!r->bad && (p < -1 || p >= j))
			r_fail(r, "joint %d: parent %d, expected -1 or a joint before it", j, (int)p);
		m->joints[j].parent = p;
		for (int i = 0; i < 3; i++)
			m->joints[j].offset[i] = r_finite(r, "offset");
	}
	for (int j = 0; j < m->njoints && !r->bad; j++)
		r_str(r, m->joints[j].name, PROTO_NAME_MAX, "name");
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
static void dec_frame(reader *r, mc_msg_frame *m)
{
	m->seq = r_u64(r, "seq");
	m->capture_ns = r_u64(r, "capture_ns");
	m->publish_ns = r_u64(r, "publish_ns");
	m->skeleton_id = r_u32(r, "skeleton_id");
	m->njoints = r_u16(r, "njoints");
	m->state = r_u8(r, "state");
	m->space = r_u8(r, "space");
	if (r->bad)
		return;
	if (m->njoints > PROTO_MAX_JOINTS) {
		r_fail(r, "njoints: %u, at most %d allowed", m->njoints, PROTO_MAX_JOINTS);
		return;
	}
	if (r->len - r->pos != (size_t)m->njoints * 64) {
		r_fail(r, "njoints %u needs %zu bytes of joints, message has %zu", m->njoints,
			      (size_t)m->njoints * 64, r->len - r->pos);
		return;
	}
	for (int j = 0; j < m->njoints; j++) {
		mc_wire_joint *jt = &m->joints[j];
		for (int i = 0; i < 3; i++)
			jt->position[i] = r_f64(r, "position");
		for (int i = 0; i < 4; i++)
			jt->orientation[i] = r_f64(r, "orientation");
		jt->confidence = r_f32(r, "confidence");
		r_u32(r, "reserved");
	}
}

static void enc_gap(writer *w, const mc_msg_gap *m)
{
	w_u64(w, m->first_seq);
	w_u64(w, m->count);
}
static void dec_gap(reader *r, mc_msg_gap *m)
{
	m->first_seq = r_u64(r, "first_seq");
	m->count = r_u64(r, "count");
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

/* Version 2's detector block, when the message goes on after the names. */
static void dec_status_detector(reader *r, mc_msg_status *m)
{
	m->has_detector = false;
	if (r->bad || r->pos == r->len)
		return;
	mc_wire_detector_status *d = &m->detector;
	m->has_detector = true;
	d->state = r_u32(r, "detector.state");
	r_u32(r, "detector.reserved");
	if (!r->bad && d->state > 2) {
		r_fail(r, "detector.state: %u, expected 0..2", d->state);
		return;
	}
	for (int i = 0; i < 5; i++)
		d->figures[i] = r_f64(r, "detector figures");
	for (int i = 0; i < 3; i++)
		d->counts[i] = r_u64(r, "detector counts");
	r_str(r, d->model, PROTO_TEXT_MAX, "detector.model");
	r_str(r, d->message, PROTO_TEXT_MAX, "detector.message");
}

/* Version 3's latency block, when the message goes on after the detector. */
static void dec_status_latency(reader *r, mc_msg_status *m)
{
	m->has_latency = false;
	if (r->bad || !m->has_detector || r->pos == r->len)
		return;
	mc_wire_latency_status *l = &m->latency;
	m->has_latency = true;
	l->window = r_u32(r, "latency.window");
	r_u32(r, "latency.reserved");
	for (int s = 0; s < PROTO_LATENCY_STAGES; s++) {
		l->stage[s].p50 = r_f64(r, "latency.p50");
		l->stage[s].p99 = r_f64(r, "latency.p99");
		l->stage[s].max = r_f64(r, "latency.max");
	}
	l->skipped_behind = r_u64(r, "latency.skipped_behind");
	l->skipped_stale = r_u64(r, "latency.skipped_stale");
	l->incomplete = r_u64(r, "latency.incomplete");
}
static void dec_status(reader *r, mc_msg_status *m)
{
	m->server_time_ns = r_u64(r, "server_time_ns");
	m->start_ns = r_u64(r, "start_ns");
	m->frames_published = r_u64(r, "frames_published");
	m->frames_dropped = r_u64(r, "frames_dropped");
	m->client_drops = r_u64(r, "client_drops");
	m->publish_fps = r_f64(r, "publish_fps");
	m->track_ms_mean = r_f64(r, "track_ms_mean");
	m->track_ms_max = r_f64(r, "track_ms_max");
	m->tracker_state = r_u8(r, "tracker_state");
	m->recording = r_u8(r, "recording");
	m->ncams = r_u16(r, "ncams");
	m->nclients = r_u32(r, "nclients");
	if (r->bad)
		return;
	if (m->ncams > PROTO_MAX_CAMS) {
		r_fail(r, "ncams: %u, at most %d allowed", m->ncams, PROTO_MAX_CAMS);
		return;
	}
	for (int c = 0; c < m->ncams && !r->bad; c++) {
		mc_wire_cam_status *cs = &m->cams[c];
		cs->fps = r_f64(r, "cams.fps");
		cs->frames = r_u64(r, "cams.frames");
		cs->drops = r_u64(r, "cams.drops");
		cs->state = r_u32(r, "cams.state");
		cs->width = r_u32(r, "cams.width");
		cs->height = r_u32(r, "cams.height");
		r_u32(r, "cams.reserved");
	}
	r_str(r, m->device, PROTO_NAME_MAX, "device");
	for (int c = 0; c < m->ncams && !r->bad; c++)
		r_str(r, m->cams[c].name, PROTO_NAME_MAX, "cams.name");
	dec_status_detector(r, m);
	dec_status_latency(r, m);
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
static void dec_rig(reader *r, mc_msg_rig *m)
{
	m->ncams = r_u32(r, "ncams");
	m->length = r_u32(r, "length");
	m->json = (const char *)r_take(r, m->length, "json");
}

static void enc_control_result(writer *w, const mc_msg_control_result *m)
{
	w_u32(w, m->command);
	w_u32(w, (uint32_t)m->result);
	w_str(w, m->message, PROTO_TEXT_MAX);
}
static void dec_control_result(reader *r, mc_msg_control_result *m)
{
	m->command = r_u32(r, "command");
	m->result = (int32_t)r_u32(r, "result");
	r_str(r, m->message, PROTO_TEXT_MAX, "message");
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
static void dec_rings(reader *r, mc_msg_rings *m)
{
	m->count = r_u16(r, "count");
	r_u16(r, "reserved");
	r_u32(r, "reserved");
	if (r->bad)
		return;
	if (m->count > PROTO_MAX_RINGS) {
		r_fail(r, "count: %u rings, at most %d allowed", m->count, PROTO_MAX_RINGS);
		return;
	}
	for (int i = 0; i < m->count && !r->bad; i++) {
		m->rings[i].size = r_u64(r, "size");
		r_u64(r, "reserved");
	}
	for (int i = 0; i < m->count && !r->bad; i++)
		r_str(r, m->rings[i].name, PROTO_NAME_MAX, "name");
}

/* --- TCP framing --- */

void proto_tcp_prefix(uint8_t out[PROTO_TCP_PREFIX], size_t message_len)
{
	mc_le_put_u32(out, (uint32_t)message_len);
}

int proto_tcp_next(const uint8_t *p, size_t have, uint32_t *len)
{
	if (have < PROTO_TCP_PREFIX)
		return 0;
	*len = mc_le_u32(p);
	if (*len < PROTO_HEADER_SIZE || *len > PROTO_MAX_MESSAGE)
		return -1;
	return have - PROTO_TCP_PREFIX >= *len;
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

int proto_decode(const void *buf, size_t len, proto_direction from, proto_msg *msg, char *why,
		    size_t whylen)
{
	reader r = {buf, len, 0, "message", why, whylen, false};
	if (why && whylen)
		why[0] = 0;
	if (len < PROTO_HEADER_SIZE) {
		r_fail(&r, "%zu bytes, shorter than the %d-byte header", len, PROTO_HEADER_SIZE);
		return -1;
	}
	if (len > PROTO_MAX_MESSAGE) {
		r_fail(&r, "%zu bytes, longer than the %d-byte limit", len, PROTO_MAX_MESSAGE);
		return -1;
	}
	msg->h.type = r_u16(&r, "type");
	msg->h.flags = r_u16(&r, "flags");
	msg->h.size = r_u32(&r, "size");
	msg->h.request_id = r_u32(&r, "request_id");
	msg->h.reserved = r_u32(&r, "reserved");
	uint16_t t = msg->h.type;
	const char *name = proto_type_name(t);
	if (strcmp(name, "unknown") == 0) {
		r_fail(&r, "unknown message type 0x%04x", t);
		return -1;
	}
	r.msg = name;
	bool from_server = (t & MC_MSG_FROM_SERVER) != 0;
	if (from_server != (from == PROTO_FROM_SERVER)) {
		r_fail(&r, "a %s message cannot come from the %s", from_server ? "server" : "client",
		       from == PROTO_FROM_SERVER ? "server" : "client");
		return -1;
	}
	if (msg->h.size != len) {
		r_fail(&r, "size field says %u bytes, datagram has %zu", msg->h.size, len);
		return -1;
	}
	switch (t) {
	case MC_MSG_HELLO: dec_hello(&r, &msg->u.hello); break;
	case MC_MSG_SUBSCRIBE: dec_subscribe(&r, &msg->u.subscribe); break;
	case MC_MSG_UNSUBSCRIBE:
	case MC_MSG_GET_STATUS:
	case MC_MSG_GET_SKELETON:
	case MC_MSG_GET_RIG:
	case MC_MSG_GET_RINGS: break;
	case MC_MSG_CONTROL: dec_control(&r, &msg->u.control); break;
	case MC_MSG_KEYPOINTS: dec_keypoints(&r, &msg->u.keypoints); break;
	case MC_MSG_HEAD_POSE: dec_head_pose(&r, &msg->u.head_pose); break;
	case MC_MSG_PING: dec_ping(&r, &msg->u.ping, false); break;
	case MC_MSG_AUTH: dec_auth(&r, &msg->u.auth); break;
	case MC_MSG_GET_POSE_BLOCK: break;
	case MC_MSG_POSE_BLOCK: dec_pose_block(&r, &msg->u.pose_block); break;
	case MC_MSG_WELCOME: dec_welcome(&r, &msg->u.welcome); break;
	case MC_MSG_ERROR: dec_error(&r, &msg->u.error); break;
	case MC_MSG_OK: dec_ok(&r, &msg->u.ok); break;
	case MC_MSG_SKELETON: dec_skeleton(&r, &msg->u.skeleton); break;
	case MC_MSG_FRAME: dec_frame(&r, &msg->u.frame); break;
	case MC_MSG_GAP: dec_gap(&r, &msg->u.gap); break;
	case MC_MSG_STATUS: dec_status(&r, &msg->u.status); break;
	case MC_MSG_RIG: dec_rig(&r, &msg->u.rig); break;
	case MC_MSG_CONTROL_RESULT: dec_control_result(&r, &msg->u.control_result); break;
	case MC_MSG_RINGS: dec_rings(&r, &msg->u.rings); break;
	case MC_MSG_PONG: dec_ping(&r, &msg->u.ping, true); break;
	}
	r_end(&r);
	return r.bad ? -1 : 0;
}
