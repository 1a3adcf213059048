/* Wire protocol: every message type round-trips; the byte layout matches
 * docs/PROTOCOL.md at the documented offsets; malformed datagrams are
 * refused with a reason that names the field. */
#include "proto.h"
#include "test_util.h"

#include <string.h>

static proto_msg a, b;
static uint8_t buf[PROTO_MAX_MESSAGE], buf2[PROTO_MAX_MESSAGE];

static uint16_t rd16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }
static uint32_t rd32(const uint8_t *p) { return (uint32_t)rd16(p) | (uint32_t)rd16(p + 2) << 16; }
static uint64_t rd64(const uint8_t *p) { return (uint64_t)rd32(p) | (uint64_t)rd32(p + 4) << 32; }
static double rdf64(const uint8_t *p)
{
	uint64_t u = rd64(p);
	double d;
	memcpy(&d, &u, 8);
	return d;
}
static void wr32(uint8_t *p, uint32_t v)
{
	for (int i = 0; i < 4; i++)
		p[i] = (uint8_t)(v >> (8 * i));
}

static void start(uint16_t type)
{
	memset(&a, 0, sizeof(a));
	a.h.type = type;
	a.h.request_id = 0x01020304;
}

/* Encodes a, decodes into b, re-encodes b: both encodings must match. */
static size_t roundtrip(proto_direction dir)
{
	size_t n = proto_encode(&a, buf, sizeof(buf));
	CHECK_MSG(n > 0, "encode %s", proto_type_name(a.h.type));
	if (!n)
		return 0;
	char why[256];
	int rc = proto_decode(buf, n, dir, &b, why, sizeof(why));
	CHECK_MSG(rc == 0, "decode %s: %s", proto_type_name(a.h.type), why);
	CHECK(b.h.type == a.h.type && b.h.request_id == a.h.request_id && b.h.size == n);
	size_t n2 = proto_encode(&b, buf2, sizeof(buf2));
	CHECK(n2 == n && memcmp(buf, buf2, n) == 0);
	return n;
}

static void expect_refused(const void *data, size_t len, proto_direction dir, const char *needle)
{
	char why[256];
	int rc = proto_decode(data, len, dir, &b, why, sizeof(why));
	CHECK_MSG(rc == -1, "accepted, expected refusal mentioning '%s'", needle);
	CHECK_MSG(strstr(why, needle) != NULL, "reason '%s' does not mention '%s'", why, needle);
}

static void test_header_and_hello(void)
{
	start(MC_MSG_HELLO);
	a.u.hello.magic = PROTO_MAGIC;
	a.u.hello.min_version = 1;
	a.u.hello.max_version = 3;
	strcpy(a.u.hello.client_name, "vr");
	size_t n = roundtrip(PROTO_FROM_CLIENT);
	/* Offsets as documented. */
	CHECK(n == 16 + 4 + 2 + 2 + 2 + 2);
	CHECK(rd16(buf) == MC_MSG_HELLO && rd16(buf + 2) == 0 && rd32(buf + 4) == n);
	CHECK(rd32(buf + 8) == 0x01020304 && rd32(buf + 12) == 0);
	CHECK(memcmp(buf + 16, "MOCP", 4) == 0);
	CHECK(rd16(buf + 20) == 1 && rd16(buf + 22) == 3 && rd16(buf + 24) == 2 && memcmp(buf + 26, "vr", 2) == 0);
	CHECK(strcmp(b.u.hello.client_name, "vr") == 0);

	/* A server message cannot come from a client, and vice versa. */
	expect_refused(buf, n, PROTO_FROM_SERVER, "cannot come from the server");
	/* Size field and datagram size must agree. */
	wr32(buf + 4, (uint32_t)n + 1);
	expect_refused(buf, n, PROTO_FROM_CLIENT, "size field says");
	wr32(buf + 4, (uint32_t)n);
	/* Truncated string, trailing bytes, bad magic. */
	expect_refused(buf, n - 1, PROTO_FROM_CLIENT, "size field says");
	wr32(buf + 4, (uint32_t)n - 1);
	expect_refused(buf, n - 1, PROTO_FROM_CLIENT, "client_name");
	buf[n] = 'x';
	wr32(buf + 4, (uint32_t)n + 1);
	expect_refused(buf, n + 1, PROTO_FROM_CLIENT, "trailing");
	wr32(buf + 4, (uint32_t)n);
	buf[16] = 'X';
	expect_refused(buf, n, PROTO_FROM_CLIENT, "magic");
	/* Short and unknown. */
	expect_refused(buf, 10, PROTO_FROM_CLIENT, "shorter than the 16-byte header");
	uint8_t unk[16] = {0x77, 0x00, 0, 0, 16, 0, 0, 0};
	expect_refused(unk, 16, PROTO_FROM_CLIENT, "unknown message type 0x0077");
	/* A NUL inside a string. */
	start(MC_MSG_HELLO);
	a.u.hello.magic = PROTO_MAGIC;
	a.u.hello.min_version = a.u.hello.max_version = 1;
	strcpy(a.u.hello.client_name, "ab");
	n = proto_encode(&a, buf, sizeof(buf));
	buf[27] = 0;
	expect_refused(buf, n, PROTO_FROM_CLIENT, "NUL");
	/* min > max. */
	a.u.hello.min_version = 2;
	n = proto_encode(&a, buf, sizeof(buf));
	expect_refused(buf, n, PROTO_FROM_CLIENT, "min_version 2 > max_version 1");
	/* Strings over the limit are not encoded. */
	start(MC_MSG_HELLO);
	memset(a.u.hello.client_name, 'a', PROTO_NAME_MAX);
	CHECK(proto_encode(&a, buf, sizeof(buf)) > 0);
	start(MC_MSG_CONTROL);
	memset(a.u.control.argument, 'a', PROTO_ARG_MAX);
	a.u.control.argument[PROTO_ARG_MAX] = 'b'; /* unterminated: 256 bytes */
	CHECK(proto_encode(&a, buf, sizeof(buf)) == 0);
}

static void test_frame_layout(void)
{
	start(MC_MSG_FRAME);
	mc_msg_frame *f = &a.u.frame;
	f->seq = 0x1122334455667788ull;
	f->capture_ns = 1000;
	f->publish_ns = 2000;
	f->skeleton_id = 9;
	f->njoints = 3;
	f->state = 1;
	f->space = 1;
	for (int j = 0; j < 3; j++) {
		f->joints[j].position[0] = j + 0.5;
		f->joints[j].position[2] = -j;
		f->joints[j].orientation[0] = 1;
		f->joints[j].confidence = 0.25f * (float)j;
	}
	size_t n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == proto_frame_size(3) && n == 48 + 3 * 64);
	CHECK(rd64(buf + 16) == 0x1122334455667788ull && rd64(buf + 24) == 1000 && rd64(buf + 32) == 2000);
	CHECK(rd32(buf + 40) == 9 && rd16(buf + 44) == 3 && buf[46] == 1 && buf[47] == 1);
	CHECK(rdf64(buf + 48 + 64 * 2) == 2.5 && rdf64(buf + 48 + 64 * 2 + 16) == -2.0);
	CHECK(rdf64(buf + 48 + 64 + 24) == 1.0); /* w of joint 1 */
	uint32_t cu = rd32(buf + 48 + 64 * 2 + 56);
	float c;
	memcpy(&c, &cu, 4);
	CHECK(c == 0.5f);
	CHECK(b.u.frame.joints[2].confidence == 0.5f && b.u.frame.joints[1].position[0] == 1.5);
	/* njoints that does not match the size. */
	buf[44] = 4;
	expect_refused(buf, n, PROTO_FROM_SERVER, "njoints 4 needs 256 bytes");
	buf[44] = 200;
	expect_refused(buf, n, PROTO_FROM_SERVER, "at most 128");
	/* The largest frame fits in one message. */
	start(MC_MSG_FRAME);
	a.u.frame.njoints = PROTO_MAX_JOINTS;
	CHECK(roundtrip(PROTO_FROM_SERVER) == proto_frame_size(PROTO_MAX_JOINTS));
}

static void test_other_messages(void)
{
	start(MC_MSG_SUBSCRIBE);
	a.u.subscribe.mode = MC_SUB_ALL;
	a.u.subscribe.space = MC_SPACE_WORLD;
	a.u.subscribe.queue_len = 500;
	size_t n = roundtrip(PROTO_FROM_CLIENT);
	CHECK(n == 24 && buf[16] == 2 && buf[17] == 1 && rd32(buf + 20) == 500);
	buf[16] = 3;
	expect_refused(buf, n, PROTO_FROM_CLIENT, "mode: 3");
	buf[16] = 1;
	buf[17] = 2;
	expect_refused(buf, n, PROTO_FROM_CLIENT, "space: 2");

	static const uint16_t empty[] = {MC_MSG_UNSUBSCRIBE, MC_MSG_GET_STATUS, MC_MSG_GET_SKELETON, MC_MSG_GET_RIG,
					 MC_MSG_GET_RINGS};
	for (size_t i = 0; i < sizeof(empty) / sizeof(empty[0]); i++) {
		start(empty[i]);
		CHECK(roundtrip(PROTO_FROM_CLIENT) == 16);
	}

	start(MC_MSG_CONTROL);
	a.u.control.command = 2;
	strcpy(a.u.control.argument, "/data/take 1.mcap");
	CHECK(roundtrip(PROTO_FROM_CLIENT) == 16 + 4 + 2 + 17);
	CHECK(strcmp(b.u.control.argument, "/data/take 1.mcap") == 0);

	start(MC_MSG_KEYPOINTS);
	a.u.keypoints.capture_ns = 77;
	a.u.keypoints.camera = 1;
	a.u.keypoints.count = 2;
	a.u.keypoints.kp[1] = (mc_wire_keypoint){5, 10.5f, 20.25f, 0.75f};
	n = roundtrip(PROTO_FROM_CLIENT);
	CHECK(n == 32 + 2 * 16 && rd16(buf + 24) == 1 && rd16(buf + 26) == 2 && rd16(buf + 48) == 5);
	CHECK(b.u.keypoints.kp[1].v == 20.25f && b.u.keypoints.kp[1].confidence == 0.75f);
	buf[26] = 3;
	expect_refused(buf, n, PROTO_FROM_CLIENT, "count 3 needs 48 bytes");

	start(MC_MSG_HEAD_POSE);
	a.u.head_pose.timestamp_ns = 5;
	a.u.head_pose.position[1] = 1.7;
	a.u.head_pose.orientation[0] = 1;
	n = roundtrip(PROTO_FROM_CLIENT);
	CHECK(n == 80 && rdf64(buf + 32) == 1.7 && rdf64(buf + 48) == 1.0);

	start(MC_MSG_PING);
	a.u.ping.value = 12345;
	CHECK(roundtrip(PROTO_FROM_CLIENT) == 24);
	start(MC_MSG_PONG);
	a.u.ping.value = 12345;
	a.u.ping.server_time_ns = 99;
	CHECK(roundtrip(PROTO_FROM_SERVER) == 32 && b.u.ping.server_time_ns == 99);

	start(MC_MSG_WELCOME);
	a.u.welcome.magic = PROTO_MAGIC;
	a.u.welcome.version = 1;
	a.u.welcome.flags = MC_WELCOME_PRIVILEGED;
	a.u.welcome.max_message = PROTO_MAX_MESSAGE;
	strcpy(a.u.welcome.daemon_version, "mocapd 0.1");
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == 40 + 2 + 10 && rd16(buf + 20) == 1 && rd16(buf + 22) == 1 && rd32(buf + 24) == 65536);

	start(MC_MSG_ERROR);
	a.u.error.code = PROTO_E_VERSION;
	a.u.error.request_type = MC_MSG_HELLO;
	a.u.error.fatal = 1;
	strcpy(a.u.error.message, "no");
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == 24 + 2 + 2 && rd32(buf + 16) == 1 && rd16(buf + 20) == 1 && rd16(buf + 22) == 1);

	start(MC_MSG_OK);
	a.u.ok.request_type = MC_MSG_SUBSCRIBE;
	a.u.ok.value = 64;
	CHECK(roundtrip(PROTO_FROM_SERVER) == 24 && rd32(buf + 20) == 64);

	start(MC_MSG_SKELETON);
	a.u.skeleton.skeleton_id = 3;
	a.u.skeleton.njoints = 2;
	a.u.skeleton.rig_is_world = 1;
	a.u.skeleton.joints[0].parent = -1;
	a.u.skeleton.joints[1].parent = 0;
	a.u.skeleton.joints[1].offset[1] = -0.3;
	strcpy(a.u.skeleton.joints[0].name, "pelvis");
	strcpy(a.u.skeleton.joints[1].name, "spine");
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == 24 + 2 * 32 + 2 + 6 + 2 + 5);
	CHECK((int32_t)rd32(buf + 24) == -1 && rdf64(buf + 56 + 16) == -0.3);
	CHECK(strcmp(b.u.skeleton.joints[1].name, "spine") == 0 && b.u.skeleton.joints[0].parent == -1);
	wr32(buf + 56, 1); /* joint 1 its own parent */
	expect_refused(buf, n, PROTO_FROM_SERVER, "joint 1: parent 1");

	start(MC_MSG_GAP);
	a.u.gap.first_seq = 100;
	a.u.gap.count = 7;
	CHECK(roundtrip(PROTO_FROM_SERVER) == 32 && rd64(buf + 24) == 7);

	start(MC_MSG_STATUS);
	mc_msg_status *s = &a.u.status;
	s->frames_published = 10;
	s->publish_fps = 29.5;
	s->tracker_state = 2;
	s->ncams = 2;
	s->nclients = 4;
	strcpy(s->device, "pocl");
	strcpy(s->cams[0].name, "left");
	strcpy(s->cams[1].name, "right");
	s->cams[1].width = 1280;
	s->cams[1].drops = 3;
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == 88 + 2 * 40 + 2 + 4 + 2 + 4 + 2 + 5);
	CHECK(rdf64(buf + 56) == 29.5 && buf[80] == 2 && rd16(buf + 82) == 2 && rd32(buf + 84) == 4);
	CHECK(rd64(buf + 88 + 40 + 16) == 3 && rd32(buf + 88 + 40 + 28) == 1280);
	CHECK(strcmp(b.u.status.cams[1].name, "right") == 0 && strcmp(b.u.status.device, "pocl") == 0);
	CHECK(!b.u.status.has_detector);
	/* Version 2: the detector block after the camera names. */
	size_t v1 = n;
	s->has_detector = true;
	s->detector.state = 2;
	s->detector.ms_mean = 1.25;
	s->detector.used = 77;
	strcpy(s->detector.model, "m.onnx");
	strcpy(s->detector.message, "m.onnx: bad");
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == v1 + 72 + 2 + 6 + 2 + 11);
	CHECK(rd32(buf + v1) == 2 && rdf64(buf + v1 + 24) == 1.25 && rd64(buf + v1 + 64) == 77);
	CHECK(b.u.status.has_detector && b.u.status.detector.state == 2 && b.u.status.detector.used == 77);
	CHECK(strcmp(b.u.status.detector.model, "m.onnx") == 0 && strcmp(b.u.status.detector.message, "m.onnx: bad") == 0);
	CHECK(!b.u.status.has_latency);
	/* Version 3: the latency block after the detector's. */
	size_t v2 = n;
	s->has_latency = true;
	s->latency.window = 900;
	s->latency.stage[5].p50 = 33.5;
	s->latency.stage[1].max = 7.0;
	s->latency.skipped_stale = 5;
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == v2 + 8 + 6 * 24 + 24);
	CHECK(rd32(buf + v2) == 900 && rdf64(buf + v2 + 8 + 5 * 24) == 33.5 && rd64(buf + v2 + 8 + 144 + 8) == 5);
	CHECK(b.u.status.has_latency && b.u.status.latency.window == 900 && b.u.status.latency.stage[1].max == 7.0 &&
	      b.u.status.latency.skipped_stale == 5);
	wr32(buf + 4, (uint32_t)(n - 1)); /* one byte short */
	expect_refused(buf, n - 1, PROTO_FROM_SERVER, "latency");
	s->has_latency = false;
	n = roundtrip(PROTO_FROM_SERVER);
	buf[v1] = 3;
	expect_refused(buf, n, PROTO_FROM_SERVER, "detector.state: 3");
	s->has_detector = false;

	start(MC_MSG_RIG);
	a.u.rig.ncams = 2;
	a.u.rig.json = "{\"a\": 1}";
	a.u.rig.length = 8;
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == 32 && b.u.rig.length == 8 && memcmp(b.u.rig.json, "{\"a\": 1}", 8) == 0);

	start(MC_MSG_CONTROL_RESULT);
	a.u.control_result.command = 1;
	a.u.control_result.result = -3;
	strcpy(a.u.control_result.message, "mocapd.conf:3: bad");
	CHECK(roundtrip(PROTO_FROM_SERVER) == 24 + 2 + 18 && b.u.control_result.result == -3);

	start(MC_MSG_RINGS);
	a.u.rings.count = 2;
	a.u.rings.rings[0].size = 1 << 20;
	strcpy(a.u.rings.rings[0].name, "left");
	strcpy(a.u.rings.rings[1].name, "right");
	n = roundtrip(PROTO_FROM_SERVER);
	CHECK(n == 24 + 2 * 16 + 6 + 7 && rd64(buf + 24) == 1 << 20);
}

/* Random bytes and random mutations of valid messages never crash the
 * decoder and are either refused with a reason or decode and re-encode to
 * the same size (the fuzzer does this at scale: make fuzz-ipc). */
static void test_random(void)
{
	unsigned long long st = 42;
	start(MC_MSG_STATUS);
	a.u.status.ncams = 2;
	size_t base = proto_encode(&a, buf2, sizeof(buf2));
	for (int it = 0; it < 20000; it++) {
		size_t n = it % 2 ? base : (size_t)(mc_test_rand(&st) * 300);
		if (it % 2)
			memcpy(buf, buf2, n);
		else
			for (size_t i = 0; i < n; i++)
				buf[i] = (uint8_t)(mc_test_rand(&st) * 256);
		int flips = 1 + (int)(mc_test_rand(&st) * 4);
		for (int k = 0; k < flips && n; k++)
			buf[(size_t)(mc_test_rand(&st) * n)] = (uint8_t)(mc_test_rand(&st) * 256);
		char why[256] = "";
		for (int dir = 0; dir < 2; dir++) {
			if (proto_decode(buf, n, (proto_direction)dir, &b, why, sizeof(why)) == 0) {
				uint8_t out[1024];
				CHECK(proto_encode(&b, out, sizeof(out)) == n);
			} else {
				CHECK(why[0] != 0);
			}
		}
	}
}

int main(void)
{
	test_header_and_hello();
	test_frame_layout();
	test_other_messages();
	test_random();
	return mc_test_finish("test_ipc_proto");
}
