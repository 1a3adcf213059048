/* proto_decode: protocol messages from bytes into the C structs of proto.h
 * (versions 1 to 3; docs/PROTOCOL.md gives every offset used here, and so
 * do the comments of the encoder, proto_encode.c).  Every length and count
 * is checked against the datagram and the protocol limits before it is
 * read: the server runs this on every datagram, and the fuzzer drives it. */
#include "proto.h"

#include "base/mc_le.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

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

/* --- Bodies, one function per message type (offsets in docs/PROTOCOL.md
 * and in the comments of proto_encode.c). --- */

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

static void dec_error(reader *r, mc_msg_error *m)
{
	m->code = r_u32(r, "code");
	m->request_type = r_u16(r, "request_type");
	m->fatal = r_u16(r, "fatal");
	r_str(r, m->message, PROTO_TEXT_MAX, "message");
}

static void dec_ok(reader *r, mc_msg_ok *m)
{
	m->request_type = r_u16(r, "request_type");
	r_u16(r, "reserved");
	m->value = r_u32(r, "value");
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

static void dec_control(reader *r, mc_msg_control *m)
{
	m->command = r_u32(r, "command");
	r_str(r, m->argument, PROTO_ARG_MAX, "argument");
}

static void dec_auth(reader *r, mc_msg_auth *m) { r_str(r, m->token, PROTO_TOKEN_MAX, "token"); }

static void dec_pose_block(reader *r, mc_msg_pose_block *m)
{
	m->version = r_u32(r, "version");
	r_u32(r, "reserved");
	m->size = r_u64(r, "size");
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

static void dec_head_pose(reader *r, mc_msg_head_pose *m)
{
	m->timestamp_ns = r_u64(r, "timestamp_ns");
	for (int i = 0; i < 3; i++)
		m->position[i] = r_f64(r, "position");
	for (int i = 0; i < 4; i++)
		m->orientation[i] = r_f64(r, "orientation");
}

static void dec_ping(reader *r, mc_msg_ping *m, bool pong)
{
	m->value = r_u64(r, "value");
	m->server_time_ns = pong ? r_u64(r, "server_time_ns") : 0;
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

static void dec_gap(reader *r, mc_msg_gap *m)
{
	m->first_seq = r_u64(r, "first_seq");
	m->count = r_u64(r, "count");
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

static void dec_rig(reader *r, mc_msg_rig *m)
{
	m->ncams = r_u32(r, "ncams");
	m->length = r_u32(r, "length");
	m->json = (const char *)r_take(r, m->length, "json");
}

static void dec_control_result(reader *r, mc_msg_control_result *m)
{
	m->command = r_u32(r, "command");
	m->result = (int32_t)r_u32(r, "result");
	r_str(r, m->message, PROTO_TEXT_MAX, "message");
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

/* --- Dispatch --- */

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
