/* What the files of ipc/server/ share: the server's state and the functions
 * one file offers the others.  Not installed, not for the daemon: the
 * daemon's API is ../server.h.
 *
 * Threads.  The daemon's threads only touch what is marked "shared" below
 * (under `lock`): the publish mailbox, the skeleton definition, status,
 * rig, rings and the inboxes the daemon reads.  Everything about clients
 * belongs to the server thread alone, so sockets are never shared between
 * threads and the daemon's calls never wait for a socket.
 *
 * Queues.  An outgoing message is encoded once into a reference-counted
 * `blob` and shared by every client that gets it.  Each client has a FIFO of
 * blobs: at most queue_len frames ("all" mode) plus a few replies.  A
 * "latest" client has no frames in its FIFO, only a one-frame slot that each
 * new frame replaces.  Sockets are non-blocking; whatever the kernel does not
 * take stays queued until EPOLLOUT.
 *
 * The files, in the order a message meets them:
 *   listen.c    the listening socket: creating or adopting it, accepting
 *   pose.c      the latest-pose shared-memory block (../pose_block.h)
 *   tcp.c       the TCP listener for other machines: length-prefixed
 *               framing over a byte stream, the token (AUTH)
 *   peercred.c  who the peer is (SO_PEERCRED) and whether it is privileged
 *   client.c    a connection's life: reading datagrams, closing, reaping
 *   handlers.c  one function per request type
 *   inbox.c     what clients send the daemon: keypoints, control requests,
 *               head poses, and the event fd that says they wait
 *   fanout.c    skeletons from the daemon (srv_publish) to subscribers
 *   queue.c     blobs, per-client FIFOs, sending and replies
 *   server.c    create, destroy, the server thread, the daemon's setters */
#ifndef SRV_INTERNAL_H
#define SRV_INTERNAL_H

#include "base/mc_time.h"
#include "pose_block.h"
#include "proto.h"
#include "server.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>
#include <sys/types.h>

#define MAILBOX_LEN 128           /* frames the server thread may lag behind (2 s at 60 Hz) */
#define NONFRAME_MAX 64           /* replies, gaps, definitions queued per client */
#define KEYPOINT_QUEUE_LEN 64
#define CONTROL_QUEUE_LEN 16
#define HEAD_POSE_HISTORY 64
#define HANDSHAKE_TIMEOUT_NS 5000000000ull
/* TCP connections that have not presented the token yet have their own
 * small limits, in all and from one address, and do not count against
 * max_clients: connections that never authenticate cannot take the
 * local clients' slots (issue 34 item 1). */
#define SRV_MAX_PENDING_TCP 16
#define SRV_MAX_PENDING_TCP_PER_HOST 4
#define LAST_WORDS_NS 5000000000ull /* how long a fatal ERROR waits for the client to read it */
#define READ_BURST 32             /* messages read from one client per wake-up, for fairness */

/* Copies a C string into a fixed buffer, truncating. */
static inline void srv_str_copy(char *dst, size_t size, const char *src)
{
	size_t n = strnlen(src, size - 1);
	memmove(dst, src, n);
	dst[n] = 0;
}

/* --- Blobs: encoded messages shared between client queues (queue.c) --- */

typedef struct {
	int refs;
	bool is_frame;
	size_t len;
	int nfds;                       /* descriptors sent with it (RINGS) */
	int fds[PROTO_MAX_RINGS];
	uint8_t data[];
} blob;

/* --- State --- */

/* A published skeleton waiting in the mailbox for the server thread. */
typedef struct {
	uint64_t seq, capture_ns, publish_ns;
	uint32_t skeleton_id;
	uint8_t state;
	int njoints;
	struct {
		double pos[3], quat[4];
		float conf;
	} j[MC_MAX_JOINTS];
} pending_frame;

typedef struct client {
	int fd;
	bool tcp;               /* a TCP connection (tcp.c), else the Unix socket */
	bool authed;            /* TCP: presented the token */
	char peer[64];          /* TCP: the peer's address, for the log */
	char host[48];          /* TCP: the peer's address without the port */
	uint8_t *srx;           /* TCP: bytes received that are not a whole message yet */
	size_t srx_len;
	blob *sending;          /* TCP: a blob partly sent, finished before any other */
	size_t sent;            /* bytes of it sent, length prefix included */
	uint64_t serial;        /* unique per connection, for control tokens */
	uint64_t accepted_ns;
	bool hello, privileged, dead;
	/* A fatal ERROR is queued as the last thing to send: nothing is read
	 * from the client any more, and it is closed once the error is out
	 * (or at closing_by_ns, if it never reads). */
	bool closing;
	uint64_t closing_by_ns;
	uint16_t version;       /* the protocol version chosen in HELLO */
	pid_t pid;
	uid_t uid;
	gid_t gid;
	char name[PROTO_NAME_MAX + 1];
	uint8_t mode;           /* 0 = not subscribed, else mc_sub_mode */
	uint8_t space;
	uint32_t queue_len;
	blob **q;               /* FIFO ring */
	int qcap, qhead, qn, qframes;
	blob *latest;           /* "latest" mode slot */
	uint64_t gap_first, gap_count; /* frames dropped, not yet reported */
	bool epollout;
} client;

typedef struct {
	uint64_t token;
	bool polled;
	uint64_t client_serial;
	uint32_t request_id;
	srv_control req;
} control_entry;

typedef struct {
	uint64_t token;
	int result;
	char message[PROTO_TEXT_MAX + 1];
} control_result;

/* A control request the daemon has answered, with what the reply needs. */
typedef struct {
	uint64_t client_serial;
	uint32_t request_id;
	uint32_t command;
	int result;
	char message[PROTO_TEXT_MAX + 1];
} control_answer;

typedef struct {
	int fd; /* our own O_RDONLY descriptor */
	uint64_t size;
	char name[PROTO_NAME_MAX + 1];
} ring_entry;

/* The keypoint batches clients sent, for the daemon's tracking thread: a
 * ring of KEYPOINT_QUEUE_LEN under the server's lock (which it shares with
 * the control queue, so that the event fd says the truth about both). */
struct srv_keypoint_inbox {
	srv_server *srv;
	srv_keypoints *ring;
	int head, count;
};

struct srv_server {
	srv_config cfg;
	int listen_fd, tcp_fd, epfd, wake_fd, event_fd;
	pose_block *pose; /* the latest-pose block, written under `lock` */
	int pose_fd;      /* its read-only descriptor, duplicated for clients */
	int tcp_port;
	bool created_path;
	dev_t path_dev;
	ino_t path_ino;
	pthread_t thread;
	bool thread_started;
	atomic_bool stop;

	/* Shared with the daemon's threads, under lock. */
	pthread_mutex_t lock;
	pending_frame mailbox[MAILBOX_LEN];
	int mb_head, mb_count;
	bool def_set, def_changed;
	int def_at;             /* mailbox frames published before the change */
	uint32_t def_id;
	srv_skeleton_def def;
	srv_status status;
	char *rig_json;
	int rig_ncams;
	ring_entry rings[SRV_MAX_RINGS];
	int nrings;
	control_entry controls[CONTROL_QUEUE_LEN];
	int ncontrols;
	uint64_t next_token;
	control_result results[CONTROL_QUEUE_LEN];
	int nresults;
	srv_keypoint_inbox keypoints;
	bool have_head_pose;
	srv_head_pose latest_head_pose;
	srv_stats stats;

	/* Server thread only. */
	client **clients;       /* live ones and, until srv_reap_clients(), dead ones */
	int nclients, clients_cap;
	uint64_t next_serial;
	uint64_t expected_seq; /* 0 = none yet */
	blob *def_blob;
	bool def_rig_is_world;
	srv_head_pose head_hist[HEAD_POSE_HISTORY];
	/* srv_set_head_pose_tap; under tap_lock, held while it is called */
	pthread_mutex_t tap_lock;
	void (*head_pose_tap)(void *ctx, const srv_head_pose *hp);
	void *head_pose_tap_ctx;
	int head_n, head_next;
	pending_frame drained[MAILBOX_LEN];
	srv_skeleton_def def_copy;
	proto_msg in, out;
	uint8_t rxbuf[PROTO_MAX_MESSAGE + 1];
	uint8_t txbuf[PROTO_MAX_MESSAGE];
};

/* --- listen.c --- */

/* Creates the socket file, or adopts cfg.listen_fd.  0 or -1 (err set). */
int srv_listen_open(srv_server *srv, mc_err *err);
/* Closes the listening socket and removes the file if it is still ours. */
void srv_listen_close(srv_server *srv);
/* Accepts every waiting connection on listen_fd (the Unix socket or,
 * with tcp, the TCP listener) (server thread). */
void srv_accept_clients(srv_server *srv, int listen_fd, bool tcp);

/* --- pose.c --- */

/* Creates the latest-pose block.  0 or -1 (err set). */
int srv_pose_open(srv_server *srv, mc_err *err);
void srv_pose_close(srv_server *srv);
/* Writes a published frame into the block (lock held: one writer). */
void srv_pose_write(srv_server *srv, const pending_frame *p);
/* Wakes readers waiting on the block (lock not needed). */
void srv_pose_wake(srv_server *srv);

/* --- tcp.c --- */

/* Opens the TCP listener of cfg.tcp_listen, if any.  0 or -1 (err set). */
int srv_tcp_open(srv_server *srv, mc_err *err);
void srv_tcp_close(srv_server *srv);
/* Sets up an accepted TCP connection (no delay, keep-alive, the peer's
 * address).  false when it cannot be used. */
bool srv_tcp_setup_client(client *c, int fd);
/* Reads from a TCP client and handles every whole message received. */
void srv_tcp_readable(srv_server *srv, client *c);
/* Sends the rest of a blob with its length prefix; *sent counts the bytes
 * gone so far.  1 all sent, 0 the socket is full, -1 the client is gone. */
int srv_tcp_send(client *c, const blob *b, size_t *sent);
/* Whether token is the configured one (in time independent of where they
 * differ). */
bool srv_tcp_token_ok(const srv_server *srv, const char *token);

/* --- peercred.c --- */

/* Fills c->pid, uid, gid and privileged from the peer of socket fd.
 * false when the kernel does not say who it is. */
bool srv_peer_identify(const srv_server *srv, int fd, client *c);

/* --- client.c (server thread) --- */

/* Marks the client dead and closes its socket; the struct lives on until
 * srv_reap_clients(), because callers up the stack may hold the pointer. */
void srv_client_close(srv_server *srv, client *c);
void srv_client_free(client *c);
void srv_reap_clients(srv_server *srv);
int srv_live_clients(const srv_server *srv);
/* Live clients that count against max_clients: every Unix-socket client
 * and every TCP client that presented the token. */
int srv_counted_clients(const srv_server *srv);
client *srv_find_client(srv_server *srv, uint64_t serial);
/* Reads and handles up to READ_BURST datagrams. */
void srv_client_readable(srv_server *srv, client *c);
/* Closes connections that sent no HELLO in time, and closing ones that
 * did not read their last words in LAST_WORDS_NS. */
void srv_expire_clients(srv_server *srv);

/* --- handlers.c (server thread) --- */

/* Handles the datagram of `len` bytes in srv->rxbuf. */
void srv_handle_message(srv_server *srv, client *c, size_t len);
/* Counts a malformed message and disconnects its sender. */
void srv_protocol_error(srv_server *srv, client *c, uint16_t type, uint32_t request_id, const char *why);
/* The same for the len bytes in srv->rxbuf, refused undecoded: the ERROR
 * echoes their type and request id, as far as they came. */
void srv_protocol_error_raw(srv_server *srv, client *c, size_t len, const char *why);
/* Replies to the control requests the daemon has answered. */
void srv_deliver_control_results(srv_server *srv);

/* --- inbox.c --- */

/* The server thread's side of the inboxes.  A checked batch from process
 * pid into the keypoint inbox; 1 when the oldest batch made room for it. */
int srv_keypoints_push(srv_keypoint_inbox *in, const mc_msg_keypoints *k, pid_t pid);
/* Queues a control request from c; false when CONTROL_QUEUE_LEN wait. */
bool srv_controls_push(srv_server *srv, const client *c, uint32_t request_id, const mc_msg_control *ctl);
/* Takes up to CONTROL_QUEUE_LEN answered requests off the queue. */
int srv_controls_take_answers(srv_server *srv, control_answer *out);
/* Records a head pose: in the history the fan-out reads, and as the latest. */
void srv_head_pose_store(srv_server *srv, const srv_head_pose *hp);

/* --- fanout.c (server thread) --- */

/* Takes the mailbox and definition changes from the daemon's threads and
 * passes them on to subscribers, in the order they were made. */
void srv_drain_mailbox(srv_server *srv);
/* Queues the current skeleton definition to c, if there is one. */
void srv_send_definition(srv_server *srv, client *c);

/* --- queue.c (server thread, except the blob functions) --- */

blob *srv_blob_new(const uint8_t *data, size_t len, bool is_frame);
blob *srv_blob_ref(blob *b);
void srv_blob_unref(blob *b);
/* Encodes m into a new blob; NULL when it does not encode or no memory. */
blob *srv_encode_blob(srv_server *srv, const proto_msg *m, bool is_frame);

/* The server thread's outgoing message, its header cleared and set to
 * type and request_id (0: unsolicited); the body is the caller's to fill. */
static inline proto_msg *srv_out_msg(srv_server *srv, uint16_t type, uint32_t request_id)
{
	proto_msg *m = &srv->out;
	memset(&m->h, 0, sizeof(m->h));
	m->h.type = type;
	m->h.request_id = request_id;
	return m;
}

/* Appends a blob (taking a reference).  false when the client's reply
 * budget is exhausted: it does not read what it asked for. */
bool srv_q_push(client *c, blob *b);
void srv_q_pop(client *c);
/* Rebuilds the FIFO with room for `frames` frames, dropping queued frames
 * when `drop_frames` (a new subscription starts a new stream). */
bool srv_q_reshape(client *c, int frames, bool drop_frames);
/* Sends one blob.  1 sent, 0 the socket is full, -1 the client is gone. */
int srv_send_blob(client *c, const blob *b);
/* Reports dropped frames once the queue has room again. */
void srv_queue_gap(srv_server *srv, client *c);
/* Sends what the socket takes: the FIFO first, then the latest frame. */
void srv_client_flush(srv_server *srv, client *c);
/* Queues a reply; a client that does not read its replies is dropped. */
void srv_client_send(srv_server *srv, client *c, blob *b);
/* Encodes and queues a reply; a NULL or unencodable message is skipped. */
void srv_reply(srv_server *srv, client *c, const proto_msg *m);
/* A fatal error is the client's last words (srv_last_words). */
void srv_reply_error(srv_server *srv, client *c, uint32_t request_id, uint16_t request_type, uint32_t code,
		     bool fatal, const char *fmt, ...) __attribute__((format(printf, 7, 8)));
/* Queues b as the last message to c: the rest of its queue is dropped, its
 * requests are no longer read, and it is closed once b is sent (or after
 * LAST_WORDS_NS). */
void srv_last_words(srv_server *srv, client *c, blob *b);
void srv_reply_ok(srv_server *srv, client *c, uint32_t request_id, uint16_t request_type, uint32_t value);

/* --- server.c --- */

/* Wakes the server thread (after the daemon changed something). */
void srv_wake(srv_server *srv);

#endif
