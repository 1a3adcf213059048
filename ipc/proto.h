/* proto: the mocapd wire protocol, versions 1 and 2 (docs/PROTOCOL.md).
 *
 * One message per SOCK_SEQPACKET datagram.  Every message starts with a
 * 16-byte header; all integers and floats are little-endian; strings are a
 * u16 byte length followed by that many bytes (UTF-8, no NUL, no padding).
 * A message's size must equal its datagram's size and the sum of its
 * fields exactly: trailing or missing bytes make it malformed.
 *
 * This module only converts between bytes and the C structs below; it does
 * no I/O and keeps no state, so both the server and libmocap use it and the
 * fuzzer drives proto_decode() directly.  Decoding never trusts a length
 * or count field: everything is checked against the datagram size and the
 * protocol limits before it is read. */
#ifndef PROTO_H
#define PROTO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define PROTO_VERSION 3        /* the highest version this code speaks */
#define PROTO_MIN_VERSION 1    /* the lowest; 2 adds STATUS's detector block, 3 its latency block */
#define PROTO_LATENCY_STAGES 6 /* ready, wait, decode, track, publish, total */
#define PROTO_MAGIC 0x50434f4du /* "MOCP" as bytes 4d 4f 43 50 */
#define PROTO_HEADER_SIZE 16
#define PROTO_MAX_MESSAGE 65536

/* Limits of version 1 (bytes exclude the length prefix). */
#define PROTO_MAX_JOINTS 128
#define PROTO_MAX_CAMS 16
#define PROTO_MAX_KEYPOINTS 256
#define PROTO_MAX_RINGS 16
#define PROTO_NAME_MAX 63      /* joint, camera, client, device names, versions */
#define PROTO_ARG_MAX 255      /* control argument */
#define PROTO_TEXT_MAX 1023    /* error and control result messages */
#define PROTO_TOKEN_MAX 255    /* AUTH's token */
#define PROTO_TCP_PREFIX 4     /* TCP: a u32 length before every message */
#define PROTO_RIG_MAX (PROTO_MAX_MESSAGE - 24)

typedef enum {
	/* client -> server */
	MC_MSG_HELLO = 0x0001,
	MC_MSG_SUBSCRIBE = 0x0002,
	MC_MSG_UNSUBSCRIBE = 0x0003,
	MC_MSG_GET_STATUS = 0x0004,
	MC_MSG_GET_SKELETON = 0x0005,
	MC_MSG_GET_RIG = 0x0006,
	MC_MSG_CONTROL = 0x0007,
	MC_MSG_GET_RINGS = 0x0008,
	MC_MSG_KEYPOINTS = 0x0009,
	MC_MSG_HEAD_POSE = 0x000a,
	MC_MSG_PING = 0x000b,
	MC_MSG_AUTH = 0x000c, /* TCP connections only: the token, before HELLO */
	MC_MSG_GET_POSE_BLOCK = 0x000d, /* version 3: the latest-pose block (pose_block.h) */
	/* server -> client */
	MC_MSG_WELCOME = 0x8001,
	MC_MSG_ERROR = 0x8002,
	MC_MSG_OK = 0x8003,
	MC_MSG_SKELETON = 0x8004,
	MC_MSG_FRAME = 0x8005,
	MC_MSG_GAP = 0x8006,
	MC_MSG_STATUS = 0x8007,
	MC_MSG_RIG = 0x8008,
	MC_MSG_CONTROL_RESULT = 0x8009,
	MC_MSG_RINGS = 0x800a,
	MC_MSG_PONG = 0x800b,
	MC_MSG_POSE_BLOCK = 0x800c, /* its descriptor comes with it (SCM_RIGHTS) */
} mc_msg_type;

#define MC_MSG_FROM_SERVER 0x8000

typedef enum {
	PROTO_E_VERSION = 1,      /* no common protocol version (fatal) */
	PROTO_E_MALFORMED = 2,    /* bad size, field or unknown type (fatal) */
	PROTO_E_HANDSHAKE = 3,    /* a request before HELLO, or a second HELLO (fatal) */
	PROTO_E_PERMISSION = 4,   /* needs the daemon's user or group */
	PROTO_E_INVALID = 5,      /* well formed, but a value is out of range */
	PROTO_E_UNAVAILABLE = 6,  /* nothing to answer yet (no skeleton, no rig) */
	PROTO_E_BUSY = 7,         /* too many requests waiting; try again */
	PROTO_E_TOO_MANY_CLIENTS = 8, /* (fatal) */
	PROTO_E_OVERLOAD = 9,     /* the client does not read its replies (fatal) */
	PROTO_E_SHUTDOWN = 10,    /* the daemon is stopping (fatal) */
	PROTO_E_AUTH = 11,        /* TCP: no AUTH first, or a wrong token (fatal) */
} proto_error_code;

typedef enum { MC_SUB_LATEST = 1, MC_SUB_ALL = 2 } mc_sub_mode;
typedef enum { MC_SPACE_RIG = 0, MC_SPACE_WORLD = 1 } mc_space;

#define MC_WELCOME_PRIVILEGED 0x0001u /* flags: control, rings and inputs allowed */

typedef struct {
	uint16_t type;
	uint16_t flags;      /* 0 in version 1; receivers ignore it */
	uint32_t size;       /* whole message, header included */
	uint32_t request_id; /* chosen by the client, echoed in the reply; 0 when unsolicited */
	uint32_t reserved;   /* 0; receivers ignore it */
} proto_header;

typedef struct {
	uint32_t magic;
	uint16_t min_version, max_version;
	char client_name[PROTO_NAME_MAX + 1];
} mc_msg_hello;

typedef struct {
	uint32_t magic;
	uint16_t version;
	uint16_t flags;       /* MC_WELCOME_PRIVILEGED */
	uint32_t max_message;
	uint32_t server_pid;
	uint64_t server_time_ns;
	char daemon_version[PROTO_NAME_MAX + 1];
} mc_msg_welcome;

typedef struct {
	uint32_t code;         /* proto_error_code */
	uint16_t request_type; /* type of the message refused, 0 if none */
	uint16_t fatal;        /* 1: the server closes the connection after this */
	char message[PROTO_TEXT_MAX + 1];
} mc_msg_error;

typedef struct {
	uint16_t request_type;
	uint32_t value; /* SUBSCRIBE: queue length in effect; else 0 */
} mc_msg_ok;

typedef struct {
	uint8_t mode;       /* mc_sub_mode */
	uint8_t space;      /* mc_space */
	uint32_t queue_len; /* "all" only; 0 = the server's default */
} mc_msg_subscribe;

typedef struct {
	uint32_t command;   /* mc_control_command values: 1 reload, 2 record start, 3 record stop, 4 actor save */
	char argument[PROTO_ARG_MAX + 1];
} mc_msg_control;

typedef struct {
	uint16_t joint;
	float u, v;         /* native pixels of the camera image */
	float confidence;   /* 0..1 */
} mc_wire_keypoint;

typedef struct {
	uint64_t capture_ns;
	uint16_t camera;
	uint16_t count;
	mc_wire_keypoint kp[PROTO_MAX_KEYPOINTS];
} mc_msg_keypoints;

typedef struct {
	uint64_t timestamp_ns;
	double position[3];
	double orientation[4]; /* w, x, y, z */
} mc_msg_head_pose;

/* The latest-pose block: its layout version and size; the read-only
 * descriptor comes with the datagram. */
typedef struct {
	uint32_t version;
	uint64_t size;
} mc_msg_pose_block;

/* The access token of a TCP connection (docs/PROTOCOL.md, "TCP"). */
typedef struct {
	char token[PROTO_TOKEN_MAX + 1];
} mc_msg_auth;

typedef struct {
	uint64_t value;          /* echoed */
	uint64_t server_time_ns; /* PONG only */
} mc_msg_ping;

typedef struct {
	int32_t parent;
	double offset[3];
	char name[PROTO_NAME_MAX + 1];
} mc_wire_joint_def;

typedef struct {
	uint32_t skeleton_id;
	uint16_t njoints;
	uint8_t rig_is_world;
	mc_wire_joint_def joints[PROTO_MAX_JOINTS];
} mc_msg_skeleton;

typedef struct {
	double position[3];
	double orientation[4]; /* w, x, y, z */
	float confidence;
} mc_wire_joint;

typedef struct {
	uint64_t seq;
	uint64_t capture_ns;
	uint64_t publish_ns;
	uint32_t skeleton_id;
	uint16_t njoints;
	uint8_t state;   /* 0 ok, 1 uncertain, 2 lost, 4 initialising */
	uint8_t space;   /* mc_space */
	mc_wire_joint joints[PROTO_MAX_JOINTS];
} mc_msg_frame;

typedef struct {
	uint64_t first_seq;
	uint64_t count;
} mc_msg_gap;

typedef struct {
	double fps;
	uint64_t frames, drops;
	uint32_t state, width, height;
	char name[PROTO_NAME_MAX + 1];
} mc_wire_cam_status;

/* Version 2: the in-process detector, after the camera names. */
typedef struct {
	uint32_t state; /* 0 off, 1 running, 2 failed */
	union {         /* in wire order */
		struct {
			double rate, used_rate;          /* views detected / tracked with its keypoints per second */
			double ms_mean, ms_last, ms_max; /* per view */
		};
		double figures[5];
	};
	union {
		struct {
			uint64_t views, skipped, used;
		};
		uint64_t counts[3];
	};
	char model[PROTO_TEXT_MAX + 1];
	char message[PROTO_TEXT_MAX + 1];
} mc_wire_detector_status;

/* Version 3: where a frame set's time goes, after the detector block. */
typedef struct {
	uint32_t window; /* frame sets the figures are over */
	struct {
		double p50, p99, max; /* ms */
	} stage[PROTO_LATENCY_STAGES];
	uint64_t skipped_behind, skipped_stale, incomplete;
} mc_wire_latency_status;

typedef struct {
	uint64_t server_time_ns, start_ns;
	uint64_t frames_published, frames_dropped, client_drops;
	double publish_fps, track_ms_mean, track_ms_max;
	uint8_t tracker_state; /* 0 ok, 1 uncertain, 2 lost, 3 idle, 4 initialising */
	uint8_t recording;
	uint16_t ncams;
	uint32_t nclients;
	char device[PROTO_NAME_MAX + 1];
	mc_wire_cam_status cams[PROTO_MAX_CAMS];
	/* Not a field: whether the detector block is there (encoding: for a
	 * version 2 connection; decoding: the message had it). */
	bool has_detector;
	mc_wire_detector_status detector;
	bool has_latency; /* the same for version 3's latency block (needs the detector block) */
	mc_wire_latency_status latency;
} mc_msg_status;

typedef struct {
	uint32_t ncams;
	uint32_t length;
	const char *json; /* decode: points into the datagram (not terminated) */
} mc_msg_rig;

typedef struct {
	uint32_t command;
	int32_t result; /* 0 done, else failed */
	char message[PROTO_TEXT_MAX + 1];
} mc_msg_control_result;

typedef struct {
	uint16_t count; /* as many descriptors come with the datagram (SCM_RIGHTS) */
	struct {
		uint64_t size;
		char name[PROTO_NAME_MAX + 1];
	} rings[PROTO_MAX_RINGS];
} mc_msg_rings;

/* A decoded message: the header and the body of its type. */
typedef struct {
	proto_header h;
	union {
		mc_msg_hello hello;
		mc_msg_welcome welcome;
		mc_msg_error error;
		mc_msg_ok ok;
		mc_msg_subscribe subscribe;
		mc_msg_control control;
		mc_msg_keypoints keypoints;
		mc_msg_head_pose head_pose;
		mc_msg_ping ping;
		mc_msg_auth auth;
		mc_msg_pose_block pose_block;
		mc_msg_skeleton skeleton;
		mc_msg_frame frame;
		mc_msg_gap gap;
		mc_msg_status status;
		mc_msg_rig rig;
		mc_msg_control_result control_result;
		mc_msg_rings rings;
	} u;
} proto_msg;

/* Which side a decoder accepts messages from. */
typedef enum { PROTO_FROM_CLIENT = 0, PROTO_FROM_SERVER = 1 } proto_direction;

/* Decodes one datagram.  Returns 0, or -1 with a reason in why (e.g.
 * "SUBSCRIBE: mode: 7, expected 1 (latest) or 2 (all)").  Messages from the
 * other direction are malformed.  Checks that make a message malformed are
 * done here (sizes, counts, strings, enumerations, parents, finite skeleton
 * offsets); values that are merely invalid (a keypoint's confidence, a head
 * pose's quaternion) are left to the receiver, which refuses them without
 * closing the connection. */
int proto_decode(const void *buf, size_t len, proto_direction from, proto_msg *msg, char *why,
		    size_t whylen);

/* Encodes msg (msg->h.type, msg->h.request_id and the body; size, flags and
 * reserved are filled in).  Returns the message size, or 0 when it does not
 * fit in cap or a field exceeds the protocol limits. */
size_t proto_encode(const proto_msg *msg, void *buf, size_t cap);

/* TCP framing (docs/PROTOCOL.md, "TCP"): a message's length prefix. */
void proto_tcp_prefix(uint8_t out[PROTO_TCP_PREFIX], size_t message_len);
/* What the `have` bytes at p hold: 1 when a whole message follows its
 * prefix (*len its size), 0 when more bytes are needed, -1 when the prefix
 * is out of the protocol's range (*len the value read). */
int proto_tcp_next(const uint8_t *p, size_t have, uint32_t *len);

/* Size of a FRAME message with n joints. */
static inline size_t proto_frame_size(int njoints) { return 48 + 64 * (size_t)njoints; }

/* "SUBSCRIBE", "FRAME", ... or "unknown". */
const char *proto_type_name(uint16_t type);

#endif
