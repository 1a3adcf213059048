/* proto: the parts of the protocol codec that encoding and decoding share:
 * message type names and the TCP framing (see proto.h and docs/PROTOCOL.md).
 * Encoding is in proto_encode.c, decoding in proto_decode.c. */
#include "proto.h"

#include "base/mc_le.h"

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
