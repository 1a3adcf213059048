/* srv_server: the daemon's side of the client socket (docs/PROTOCOL.md).
 *
 * The server owns one thread that runs an epoll loop over a SOCK_SEQPACKET
 * Unix socket and its clients.  The daemon talks to it only through the
 * functions below; none of them waits for a client:
 *
 *   - srv_publish() hands a skeleton to the server thread through a
 *     briefly locked mailbox and an eventfd wake-up.  It never blocks on a
 *     socket.  A slow or stuck client never delays the tracker or any other
 *     client: each client has its own bounded queue ("all" mode) or a single
 *     newest-frame slot ("latest" mode), and its socket is non-blocking.
 *   - Requests that need the daemon (control: reload, recording) and inputs
 *     from clients (2D keypoints, VR head poses) wait in inboxes inside the
 *     server; the daemon takes them (srv_poll_control on the main loop when
 *     srv_event_fd() becomes readable; srv_inbox_pop_keypoints on the
 *     tracking thread, from the inbox srv_keypoints_inbox() returns).
 *   - Status replies are answered by the server thread from the last
 *     snapshot given with srv_set_status().
 *
 * The implementation is in ipc/server/ (ipc/server/internal.h lists its
 * files).  Every function is thread-safe unless it says otherwise.
 * Typical use:
 *
 *     srv_config cfg;
 *     srv_config_default(&cfg);          // path /run/mocapd/mocapd.sock
 *     cfg.listen_fd = sd_listen_fds(0) == 1 ? SD_LISTEN_FDS_START : -1;
 *     srv_server *srv = srv_create(&cfg, &err);
 *     srv_set_skeleton_def_from_model(srv, model, &err);
 *     srv_set_rig(srv, rig_json_text, rig->ncams, &err);
 *     ... per frame, on the publish thread:
 *     srv_publish(srv, &skeleton, seq, &err);
 *     ... on the main loop, when srv_event_fd(srv) is readable:
 *     srv_control ctl;
 *     while (srv_poll_control(srv, &ctl) == 1) {
 *             int rc = do_reload(...);
 *             srv_control_done(srv, ctl.token, rc, rc ? "why" : "reloaded");
 *     }
 *     ... per frame set, on the tracking thread:
 *     srv_keypoints kp;
 *     while (srv_inbox_pop_keypoints(inbox, &kp) == 1)   // inbox = srv_keypoints_inbox(srv)
 *             use(&kp);
 *     srv_destroy(srv);
 */
#ifndef SRV_H
#define SRV_H

#include "base/mc_error.h"
#include "base/mc_limits.h"
#include "body/mc_model.h"
#include "geom/mc_pose.h"
#include "track/mc_tracker.h"

#include <stdbool.h>
#include <stdint.h>
#include <sys/types.h>

#define SRV_DEFAULT_PATH "/run/mocapd/mocapd.sock"
#define SRV_ARG_MAX 256      /* control argument, bytes incl. NUL */
#define SRV_MAX_KEYPOINTS 256 /* per keypoint batch (one camera, one frame) */
#define SRV_MAX_RINGS 16
#define SRV_HEAD_POSE_MAX_M 10000.0 /* farther head poses are refused */
#define SRV_TOKEN_MIN 16     /* bytes of a TCP access token, at least ... */
#define SRV_TOKEN_MAX 256    /* ... and at most, incl. NUL */

typedef struct {
	/* Socket path.  With listen_fd < 0 the server creates it: a stale
	 * socket file (a socket nobody listens on, e.g. after SIGKILL) is
	 * removed; anything else at the path (a live daemon, a regular file)
	 * is an error.  With listen_fd >= 0 it is only used in messages. */
	char path[4096];
	/* An already listening SOCK_SEQPACKET Unix socket (systemd socket
	 * activation: sd_listen_fds), or -1.  The server takes ownership. */
	int listen_fd;
	int max_clients;        /* further connections get an error and are closed */
	int queue_len;          /* frames queued per "all" client (default; clients may ask for less) */
	int max_queue_len;      /* the most a client may ask for */
	unsigned socket_mode;   /* permission bits of a created socket file, e.g. 0660 */
	/* Group whose members may control the daemon, map camera rings and send
	 * keypoints and head poses, besides the daemon's own user and root.
	 * (gid_t)-1: the daemon's effective group.  A created socket file is
	 * given this group. */
	gid_t control_gid;
	/* A head pose is used for a frame when it lies within this many
	 * nanoseconds of the frame's capture time (or brackets it). */
	uint64_t head_pose_max_age_ns;
	char daemon_version[64]; /* reported in the handshake */
	/* Clients on other machines: a TCP listener at "HOST:PORT" (e.g.
	 * "0.0.0.0:7878", "[::]:7878", "192.0.2.7:7878"; port 0 picks a free
	 * one, srv_tcp_port() says which), or "" for none.  Every TCP
	 * connection must first present tcp_token (AUTH; at least
	 * SRV_TOKEN_MIN bytes) or it is closed.  tcp_privileged: whether
	 * such clients may control the daemon and send keypoints and head
	 * poses (never rings: those are shared memory on this machine). */
	char tcp_listen[256];
	char tcp_token[SRV_TOKEN_MAX];
	bool tcp_privileged;
	/* Where the server tells about its clients (a client's name, pid and
	 * uid after its HELLO), called on the server's thread; NULL: nowhere. */
	void (*on_client)(void *ctx, const char *line);
	void *on_client_ctx;
} srv_config;

void srv_config_default(srv_config *cfg);

typedef struct srv_server srv_server;

/* Creates the socket (or adopts cfg->listen_fd) and starts the server
 * thread.  NULL with err set on failure, e.g.
 *   "/run/mocapd/mocapd.sock: another mocapd is listening there". */
srv_server *srv_create(const srv_config *cfg, mc_err *err);
/* The TCP listener's port, or 0 when there is none. */
int srv_tcp_port(srv_server *srv);
/* Stops the thread, closes every client and the socket, removes the socket
 * file if the server created it. NULL is allowed. */
void srv_destroy(srv_server *srv);

/* --- What the daemon publishes ----------------------------------------- */

/* The skeleton definition sent to subscribers (joint names, parents, rest
 * offsets in the parent frame, metres).  Every call gives the definition a
 * new id; subscribers receive it before the next frame.  Frames published
 * afterwards must have the same joints in the same order. */
typedef struct {
	int njoints;
	char name[MC_MAX_JOINTS][MC_JOINT_NAME_MAX];
	int parent[MC_MAX_JOINTS];      /* -1 for the root */
	mc_vec3 rest_offset[MC_MAX_JOINTS];
	/* true when the rig frame already is the world frame (outside-in rigs):
	 * frames for world subscribers are then sent as they are. */
	bool rig_is_world;
} srv_skeleton_def;

int srv_set_skeleton_def(srv_server *srv, const srv_skeleton_def *def, mc_err *err);
/* The same from a model: names, parents, offsets scaled by bone_scale;
 * rig_is_world = model->root_free. */
int srv_set_skeleton_def_from_model(srv_server *srv, const mc_model *model, mc_err *err);

/* The rig in use, as JSON text (sent as is to `mocapctl rig`), and its
 * number of cameras (keypoints naming a camera >= ncams are refused). */
int srv_set_rig(srv_server *srv, const char *rig_json, int ncams, mc_err *err);

/* Publishes one skeleton; `seq` is the daemon's publish counter and should
 * grow by one per call: a jump is reported to "all" subscribers as a gap.
 * sk->timestamp_ns is the capture time.  Never blocks.  Returns -1 (err
 * set) when no skeleton definition was set or sk->njoints differs from it,
 * or when the server thread has fallen so far behind that its mailbox is
 * full (the frame is then dropped and counted, and "all" subscribers get a
 * gap message). */
int srv_publish(srv_server *srv, const mc_skeleton *sk, uint64_t seq, mc_err *err);

/* --- Status ----------------------------------------------------------- */

#define SRV_NAME_MAX 64

typedef enum {
	MC_CAM_STATE_OK = 0,
	MC_CAM_STATE_STALLED = 1, /* no frame for a while */
	MC_CAM_STATE_ERROR = 2,   /* driver error, being reopened */
	MC_CAM_STATE_OFF = 3,     /* not opened */
	MC_CAM_STATE_FAILED = 4,  /* failed for good, not reopened (version 3; older connections get ERROR) */
} srv_cam_state;

typedef enum {
	SRV_TRACKER_OK = MC_TRACK_OK,
	SRV_TRACKER_UNCERTAIN = MC_TRACK_UNCERTAIN,
	SRV_TRACKER_LOST = MC_TRACK_LOST,
	SRV_TRACKER_IDLE = 3, /* not tracking (disabled, no frames yet) */
	SRV_TRACKER_INITIALISING = MC_TRACK_INITIALISING, /* waiting for detections that a body fits */
} srv_tracker_state;

typedef struct {
	char name[SRV_NAME_MAX];
	srv_cam_state state;
	int width, height;
	double fps;          /* frames per second received, recent average */
	uint64_t frames;     /* received since start */
	uint64_t drops;      /* lost or overwritten before use */
} srv_cam_status;

typedef enum {
	SRV_DETECTOR_OFF = 0,     /* no in-process detector configured */
	SRV_DETECTOR_RUNNING = 1,
	SRV_DETECTOR_FAILED = 2,  /* its model did not load: see message */
} srv_detector_state;

/* The daemon's in-process 2D detector (STATUS, protocol version 2). */
typedef struct {
	srv_detector_state state;
	double rate;          /* views detected per second, recent average */
	double used_rate;     /* views tracked with its keypoints per second */
	double ms_mean, ms_last, ms_max; /* per view: recent mean, last, recent maximum */
	uint64_t views;       /* detected since start */
	uint64_t skipped;     /* not detected: a newer frame came first */
	uint64_t used;        /* views tracked with its keypoints, since start */
	char model[256];      /* the configured model file */
	char message[512];    /* FAILED: why (names the file and the mismatch) */
} srv_detector_status;

/* Where a frame set's time goes, from capture to publish (STATUS,
 * protocol version 3): p50, p99 and max in ms of each stage over the
 * newest `window` published frame sets. */
typedef enum {
	SRV_LAT_READY,   /* capture -> the set complete (or released at its deadline) */
	SRV_LAT_WAIT,    /* -> tracking starts (the tracker was busy with an older set) */
	SRV_LAT_DECODE,  /* -> the views copied out of the rings and converted to RGB */
	SRV_LAT_TRACK,   /* -> tracking ends (keypoints, the optimisation) */
	SRV_LAT_PUBLISH, /* -> handed to the socket server (the publishing thread) */
	SRV_LAT_TOTAL,   /* capture -> handed to the socket server */
	SRV_LAT_NSTAGES
} srv_latency_stage;

typedef struct {
	uint32_t window;
	struct {
		double p50, p99, max;
	} stage[SRV_LAT_NSTAGES];
	uint64_t skipped_behind; /* frame sets skipped: a newer one was due when tracking could start */
	uint64_t skipped_stale;  /* skipped: older than [daemon] max_frame_age_ms when tracking could start */
	uint64_t incomplete;     /* sets released at their deadline without every camera */
} srv_latency_status;

typedef struct {
	srv_tracker_state tracker_state;
	bool recording;
	double publish_fps;     /* skeletons per second, recent average */
	double track_ms_mean;   /* time per tracked frame, recent mean */
	double track_ms_max;    /* recent maximum */
	uint64_t frames_published;
	uint64_t frames_dropped; /* frame sets the tracker skipped */
	uint64_t start_ns;       /* CLOCK_MONOTONIC at daemon start */
	char device[SRV_NAME_MAX]; /* compute device, e.g. "pocl: cpu" */
	int ncams;
	srv_cam_status cams[MC_MAX_CAMERAS];
	srv_detector_status detector;
	srv_latency_status latency;
} srv_status;

/* Replaces the snapshot that status requests are answered from (copied).
 * The server adds its own figures (clients, their drops). */
void srv_set_status(srv_server *srv, const srv_status *st);
/* Sets the snapshot's recording flag at once (a record start or stop), so
 * that a client that started a take and asks for STATUS sees it. */
void srv_set_recording(srv_server *srv, bool recording);

/* Figures of the server itself, e.g. for the daemon's log. */
typedef struct {
	int clients;              /* connected now */
	uint64_t accepted;        /* connections accepted since start */
	uint64_t refused;         /* refused: too many clients, bad handshake, wrong TCP token */
	uint64_t protocol_errors; /* clients disconnected for malformed messages */
	uint64_t frames_published;
	uint64_t mailbox_drops;   /* frames dropped because the server thread lagged */
	uint64_t client_drops;    /* frames dropped from "all" queues (sent as gaps) */
	uint64_t keypoint_drops;  /* keypoint batches the daemon did not take in time (oldest dropped) */
} srv_stats;

void srv_get_stats(srv_server *srv, srv_stats *st);

/* --- What clients send to the daemon ----------------------------------- */

/* An fd (eventfd) that is readable exactly while control requests wait to
 * be taken; srv_poll_control resets it when none is left.  Add it to the
 * daemon's main poll set.  Keypoints do not make it readable: the tracking
 * thread takes them from their inbox once per frame set. */
int srv_event_fd(srv_server *srv);

typedef enum {
	MC_CONTROL_RELOAD = 1,          /* reload configuration, rig and model */
	MC_CONTROL_RECORD_START = 2,    /* argument: output path ("" = default) */
	MC_CONTROL_RECORD_STOP = 3,
	MC_CONTROL_ACTOR_SAVE = 4,      /* argument: the actor's name */
	MC_CONTROL_RECORD_STATUS = 5,   /* the reply's message: the take in progress or the last one */
	MC_CONTROL_RECORD_LIST = 6,     /* the reply's message: the directory takes go to */
	MC_CONTROL_STEER = 7,           /* argument: a graph source's target (docs/MOTION_GRAPH.md) */
} mc_control_command;

typedef struct {
	uint64_t token;          /* pass to srv_control_done */
	mc_control_command command;
	char argument[SRV_ARG_MAX];
	pid_t pid;               /* requesting process (SO_PEERCRED) */
	uid_t uid;
	gid_t gid;
} srv_control;

/* 1 and fills *out if a control request is waiting, else 0.  Only
 * privileged clients' requests get here; the others were already refused. */
int srv_poll_control(srv_server *srv, srv_control *out);
/* Answers a polled request: result 0 = done, else failed; message is shown
 * to the user (e.g. "mocapd.conf:12: [tracker] iterations: ...").  A client
 * that left meanwhile is skipped. */
void srv_control_done(srv_server *srv, uint64_t token, int result, const char *message);

/* External 2D detections for one camera image (thesis 6.2.2). */
typedef struct {
	uint64_t capture_ns;     /* timestamp of the camera frame they belong to */
	int cam;                 /* rig camera index */
	int nkeypoints;
	mc_keypoint keypoints[SRV_MAX_KEYPOINTS]; /* .cam = cam; .joint = skeleton joint index */
	pid_t pid;               /* sending process */
} srv_keypoints;

/* The keypoint inbox: the batches clients sent, oldest first, for the
 * daemon's tracking thread to take directly (it needs no other access to
 * the server).  Bounded (64 batches): when a batch arrives at a full inbox
 * the oldest one is dropped and counted in srv_stats.keypoint_drops.
 * Thread-safe: any thread may pop while the server thread pushes. */
typedef struct srv_keypoint_inbox srv_keypoint_inbox;

/* The server's keypoint inbox; valid as long as the server. */
srv_keypoint_inbox *srv_keypoints_inbox(srv_server *srv);
/* 1 and fills *out with the oldest waiting batch, removing it; 0 when
 * none waits.  Never blocks for long (a short lock, no socket). */
int srv_inbox_pop_keypoints(srv_keypoint_inbox *inbox, srv_keypoints *out);

/* The same as srv_inbox_pop_keypoints(srv_keypoints_inbox(srv), out), for
 * callers that hold the server anyway (tests). */
int srv_poll_keypoints(srv_server *srv, srv_keypoints *out);

/* The pose of the rig in a VR runtime's world frame at one instant
 * (world_from_rig: timestamp_ns CLOCK_MONOTONIC, position in metres,
 * orientation a unit quaternion); see core/geom/mc_pose.h. */
typedef mc_pose srv_head_pose;

/* 1 and the newest head pose received, else 0 (none yet).  The server itself
 * uses the head poses to send world-frame skeletons to clients that ask. */
int srv_latest_head_pose(srv_server *srv, srv_head_pose *out);
/* Calls fn(ctx, pose) on the server's thread for every head pose accepted
 * (e.g. the recorder: it must not block); fn NULL stops it.  Returns once
 * no call of the previous fn is running. */
void srv_set_head_pose_tap(srv_server *srv, void (*fn)(void *ctx, const srv_head_pose *hp), void *ctx);

/* --- Camera rings ------------------------------------------------------ */

/* Offers a camera's frame ring (a memfd) to privileged clients, read-only:
 * the server keeps its own O_RDONLY descriptor of it (the caller keeps
 * `fd`).  `size` is the number of bytes a client maps.  Returns the ring's
 * index or -1.  Rings made by mc_ring_create are sealed with
 * F_SEAL_FUTURE_WRITE once the writer has mapped them, so the mapping stays
 * read-only even against a client that reopens /proc/self/fd. */
int srv_add_ring(srv_server *srv, const char *camera_name, int fd, uint64_t size, mc_err *err);
/* Withdraws every ring (e.g. before a reload); clients keep what they have. */
void srv_clear_rings(srv_server *srv);

#endif
