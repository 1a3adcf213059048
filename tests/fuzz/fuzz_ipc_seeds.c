/* Writes one valid message of every type into DIR, as the fuzzer's seed
 * corpus (generated at build time, so no binary files live in git). */
#include "proto.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static proto_msg m;
static unsigned char buf[PROTO_MAX_MESSAGE];

static int write_seed(const char *dir, const char *name)
{
	size_t n = proto_encode(&m, buf, sizeof(buf));
	if (!n) {
		fprintf(stderr, "fuzz_ipc_seeds: cannot encode %s\n", name);
		return 1;
	}
	char path[4096];
	snprintf(path, sizeof(path), "%s/%s", dir, name);
	FILE *f = fopen(path, "wb");
	if (!f || fwrite(buf, 1, n, f) != n || fclose(f) != 0) {
		fprintf(stderr, "fuzz_ipc_seeds: %s: cannot write\n", path);
		return 1;
	}
	return 0;
}

static void start(uint16_t type)
{
	memset(&m, 0, sizeof(m));
	m.h.type = type;
	m.h.request_id = 7;
}

int main(int argc, char **argv)
{
	if (argc != 2) {
		fprintf(stderr, "usage: fuzz_ipc_seeds DIR\n");
		return 2;
	}
	const char *d = argv[1];
	int bad = 0;
	start(MC_MSG_HELLO);
	m.u.hello.magic = PROTO_MAGIC;
	m.u.hello.min_version = m.u.hello.max_version = 1;
	strcpy(m.u.hello.client_name, "seed");
	bad |= write_seed(d, "hello");
	start(MC_MSG_SUBSCRIBE);
	m.u.subscribe.mode = MC_SUB_ALL;
	m.u.subscribe.queue_len = 16;
	bad |= write_seed(d, "subscribe");
	static const uint16_t empty[] = {MC_MSG_UNSUBSCRIBE, MC_MSG_GET_STATUS, MC_MSG_GET_SKELETON, MC_MSG_GET_RIG,
					 MC_MSG_GET_RINGS};
	for (size_t i = 0; i < sizeof(empty) / sizeof(empty[0]); i++) {
		start(empty[i]);
		bad |= write_seed(d, proto_type_name(empty[i]));
	}
	start(MC_MSG_CONTROL);
	m.u.control.command = 2;
	strcpy(m.u.control.argument, "/tmp/take1");
	bad |= write_seed(d, "control");
	start(MC_MSG_KEYPOINTS);
	m.u.keypoints.capture_ns = 123456789;
	m.u.keypoints.camera = 1;
	m.u.keypoints.count = 3;
	for (int i = 0; i < 3; i++)
		m.u.keypoints.kp[i] = (mc_wire_keypoint){(uint16_t)i, 100.0f + i, 200.0f, 0.5f};
	bad |= write_seed(d, "keypoints");
	start(MC_MSG_HEAD_POSE);
	m.u.head_pose.timestamp_ns = 42;
	m.u.head_pose.orientation[0] = 1;
	bad |= write_seed(d, "head_pose");
	start(MC_MSG_PING);
	m.u.ping.value = 99;
	bad |= write_seed(d, "ping");
	start(MC_MSG_GET_POSE_BLOCK);
	bad |= write_seed(d, "get_pose_block");
	start(MC_MSG_POSE_BLOCK);
	m.u.pose_block.version = 1;
	m.u.pose_block.size = 33088;
	bad |= write_seed(d, "pose_block");
	start(MC_MSG_AUTH);
	strcpy(m.u.auth.token, "0123456789abcdef0123456789abcdef");
	bad |= write_seed(d, "auth");
	/* Server messages: libmocap decodes them with the same code. */
	start(MC_MSG_FRAME);
	m.u.frame.seq = 5;
	m.u.frame.njoints = 2;
	m.u.frame.joints[0].orientation[0] = m.u.frame.joints[1].orientation[0] = 1;
	bad |= write_seed(d, "frame");
	start(MC_MSG_SKELETON);
	m.u.skeleton.njoints = 2;
	m.u.skeleton.joints[0].parent = -1;
	strcpy(m.u.skeleton.joints[0].name, "pelvis");
	strcpy(m.u.skeleton.joints[1].name, "spine");
	bad |= write_seed(d, "skeleton");
	start(MC_MSG_STATUS);
	m.u.status.ncams = 1;
	strcpy(m.u.status.cams[0].name, "left");
	strcpy(m.u.status.device, "cpu");
	bad |= write_seed(d, "status");
	start(MC_MSG_ERROR);
	m.u.error.code = PROTO_E_VERSION;
	strcpy(m.u.error.message, "version mismatch");
	bad |= write_seed(d, "error");
	start(MC_MSG_RIG);
	m.u.rig.json = "{\"cameras\": []}";
	m.u.rig.length = (uint32_t)strlen(m.u.rig.json);
	bad |= write_seed(d, "rig");
	start(MC_MSG_RINGS);
	m.u.rings.count = 1;
	m.u.rings.rings[0].size = 4096;
	strcpy(m.u.rings.rings[0].name, "left");
	bad |= write_seed(d, "rings");
	start(MC_MSG_GAP);
	m.u.gap.first_seq = 10;
	m.u.gap.count = 3;
	bad |= write_seed(d, "gap");
	return bad;
}
