/* What the files of ipc/client/ (libmocap) share.  Not installed: the
 * library's API is ../mocap.h.  Functions here are prefixed mcl_, never
 * mocap_: libmocap.so exports exactly mocap_* (../libmocap.map), and the
 * static libmocap.a should not claim short names of the application's.
 * Core headers used here are header-only (static inline), so the library
 * links nothing of the core.
 *
 * Threads.  Any thread that needs something from the socket (a frame, a
 * reply) becomes the "reader" if nobody else is: it polls and receives
 * without holding the lock, then files each message under the lock (frames
 * into the frame queue, replies into the slot of the thread waiting for
 * that request id) and wakes the others.  Threads that find a reader busy
 * wait on the condition variable.  So replies always reach the thread that
 * asked, whichever thread happened to read them, and frames read by a
 * request are kept for mocap_read_frame.
 *
 * The files:
 *   connect.c   connecting, the handshake, closing
 *   tcp.c       tcp:// addresses: connecting, the token (AUTH), and the
 *               length prefix that frames messages on the byte stream
 *   reader.c    receiving and filing messages (the reader role)
 *   request.c   sending, request/reply, and the simple requests
 *   frames.c    subscription, the frame queue, mocap_read_frame
 *   rings.c     camera ring descriptors
 *   pose.c      the latest-pose block (../pose_block.h): mapping, reading, waiting
 *   predict.c   mocap_predict: a pose extrapolated to a given time
 *   inputs.c    keypoints and head poses (one-way messages)
 *   error.c     per-thread errors, names of codes and states */
#ifndef MCL_INTERNAL_H
#define MCL_INTERNAL_H

#include "base/mc_time.h"
#include "mocap.h"
#include "proto.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <sys/types.h>
#include <sys/un.h>

#define FRAME_QUEUE_MAX 1024 /* frames kept in the library ("all" mode) */
#define MAX_WAITERS 32       /* requests in flight at once */
#define RX_BURST 64
#define MAX_RX_FDS 16
#define FOREVER UINT64_MAX
#define MCL_ERRMSG_MAX (PROTO_TEXT_MAX + 256)

/* A frame as queued: the mocap_skeleton_frame header and njoints joints. */
#define FRAME_BYTES(n) (offsetof(mocap_skeleton_frame, joints) + (size_t)(n) * sizeof(mocap_joint))

/* A thread waiting for the reply to one request. */
typedef struct {
	bool used, done;
	uint32_t id;
	uint8_t *data; /* the reply datagram */
	size_t len;
	int fds[MAX_RX_FDS];
	int nfds;
} waiter;

struct mocap_client {
	int fd, epfd, evfd;
	char path[sizeof(((struct sockaddr_un *)0)->sun_path) + 16]; /* or tcp://HOST:PORT */
	bool stream;          /* TCP: a byte stream, messages framed by tcp.c */
	pthread_mutex_t send_lock; /* TCP: one message at a time on the stream */
	bool privileged;
	unsigned version;     /* the protocol version negotiated in HELLO */
	char daemon_version[PROTO_NAME_MAX + 1]; /* WELCOME's, e.g. "mocapd 1.2.0" */
	int timeout_ms;
	atomic_uint next_id;

	pthread_mutex_t lock; /* everything below */
	pthread_cond_t cond;
	bool reading;         /* a thread is receiving */
	int dead;             /* 0, or the error every call now returns */
	char dead_msg[PROTO_TEXT_MAX + 128];
	int mode;
	mocap_skeleton_frame **fq;     /* ring of FRAME_QUEUE_MAX partial frames */
	int fq_head, fq_n;
	uint64_t pending_missed;
	bool ev_set;
	waiter waiters[MAX_WAITERS];
	int async_code;       /* refusal of a keypoint batch or head pose */
	char async_msg[PROTO_TEXT_MAX + 1];

	/* The reader's own scratch. */
	uint8_t rx[PROTO_MAX_MESSAGE + 1];
	uint8_t *srx;         /* TCP: bytes received, srx_at..srx_len not filed yet */
	size_t srx_at, srx_len;
	proto_msg dec;
};

/* --- Time --- */

static inline uint64_t mcl_deadline_after(int timeout_ms)
{
	return timeout_ms < 0 ? FOREVER : mc_now_ns() + (uint64_t)timeout_ms * MC_NS_PER_MS;
}

/* Milliseconds until a deadline for poll(), rounded up; -1 for forever. */
static inline int mcl_ms_until(uint64_t deadline)
{
	if (deadline == FOREVER)
		return -1;
	uint64_t t = mc_now_ns();
	if (t >= deadline)
		return 0;
	uint64_t ms = (deadline - t + MC_NS_PER_MS - 1) / MC_NS_PER_MS;
	return ms > 1000000000 ? 1000000000 : (int)ms;
}

/* --- error.c --- */

/* Sets the calling thread's error; returns code. */
/* mocap_get_status's three symbol versions (request.c). */
int mcl_get_status_v3(mocap_client *c, mocap_daemon_status *st);
int mcl_get_status_v2(mocap_client *c, void *st);
int mcl_get_status_v1(mocap_client *c, void *st);

int mcl_set_err(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* The MOCAP_E_* code for a PROTO_E_* code of an ERROR message. */
int mcl_code_of_server_error(uint32_t code);
/* The connection's final error as the calling thread's (lock held). */
int mcl_dead_error(mocap_client *c);

/* --- reader.c (lock held unless said otherwise) --- */

/* Marks the connection dead with the error every call returns from now. */
void mcl_set_dead(mocap_client *c, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* One step of waiting for something from the socket: read if nobody else
 * does, else wait for the reader.  deadline 0 only takes what is there. */
void mcl_wait_step(mocap_client *c, uint64_t deadline);
void mcl_close_fds(const int *fds, int n);

/* --- tcp.c --- */

#define MCL_TCP_SCHEME "tcp://"

static inline bool mcl_is_tcp_address(const char *address)
{
	return strncmp(address, MCL_TCP_SCHEME, sizeof(MCL_TCP_SCHEME) - 1) == 0;
}
/* Connects to tcp://HOST:PORT; the socket, or an error code (err set). */
int mcl_tcp_connect(const char *address);
/* The token: the argument, else $MOCAP_TOKEN, else the first line of the
 * file $MOCAP_TOKEN_FILE.  Copied into out; an error code when none. */
int mcl_tcp_token(const char *given, char *out, size_t cap);
/* Sends AUTH with the token and waits for OK. */
int mcl_tcp_auth(mocap_client *c, const char *token);
/* Sends n bytes of one message with its length prefix, whole (under
 * send_lock), waiting for room until deadline. */
int mcl_tcp_send(mocap_client *c, const uint8_t *msg, size_t n, uint64_t deadline);
/* The reader: receives into srx (recv's result, errno set). */
ssize_t mcl_tcp_recv(mocap_client *c);
/* Moves the next whole message from srx into c->rx: 1 and *len, 0 when
 * none is whole yet, -1 for a length prefix out of the protocol's range. */
int mcl_tcp_take(mocap_client *c, size_t *len);

/* --- frames.c (lock held) --- */

/* Makes the eventfd readable exactly while a frame or an error waits. */
void mcl_update_event(mocap_client *c);
void mcl_fq_clear(mocap_client *c);
/* Queues a received frame (taking it); LATEST mode keeps only the newest. */
void mcl_fq_push(mocap_client *c, mocap_skeleton_frame *f);

/* --- access.c --- */

struct stat;
/* The message for a connect() to path refused with EACCES: what (e.g.
 * "the socket") with the stat st belongs to a group and mode; says which
 * group to join and how, or that only the owner may connect. */
void mcl_access_message(char *out, size_t cap, const char *path, const char *what, const struct stat *st);
/* Sets MOCAP_E_ACCESS with that message for path (or its folder, when the
 * socket cannot be looked at); returns the code. */
int mcl_access_error(const char *path);

/* --- request.c --- */

/* A request on a heap message (the union is large for small thread stacks). */
proto_msg *mcl_new_msg(uint16_t type);
/* The next request id (never 0, which means "unsolicited"). */
uint32_t mcl_next_id(mocap_client *c);
/* Sends one message, waiting for room in the socket until deadline. */
int mcl_send_msg(mocap_client *c, const proto_msg *m, uint64_t deadline);
/* Sends `req` and waits for the reply of type `want` with the same id,
 * decoded into *reply (which may be req); its descriptors go to fds
 * (MAX_RX_FDS) when fds and nfds are given, else they are closed.  An
 * ERROR reply becomes its error code.  raw: where the reply datagram is
 * kept for the caller to free (RIG's json points into it), or NULL. */
int mcl_request(mocap_client *c, proto_msg *req, uint16_t want, proto_msg *reply, int *fds, int *nfds,
		uint8_t **raw);

#endif
