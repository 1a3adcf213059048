/* mocap.h: libmocap, the client library of mocapd.
 *
 * Connects to the daemon's Unix socket, subscribes to skeleton frames and
 * makes requests (status, skeleton definition, rig, control, camera rings,
 * external keypoints, VR head poses).  The wire protocol is documented in
 * docs/PROTOCOL.md; this library is one client of it.
 *
 *     mocap_client *c = mocap_connect(NULL, "my-app");   // $MOCAP_SOCKET or the default path
 *     if (!c) { fprintf(stderr, "%s\n", mocap_errmsg()); return 1; }
 *     mocap_subscribe(c, MOCAP_LATEST, MOCAP_SPACE_RIG, 0);
 *     mocap_skeleton_frame f;
 *     while (mocap_read_frame(c, &f, -1) == 1)
 *             use(f.joints[0].position);
 *     mocap_close(c);
 *
 * Threads: every function may be called from any thread at the same time on
 * the same client (e.g. one thread reading frames while another asks for
 * the status); replies reach the thread that asked.  No callbacks.  Only
 * mocap_close() must wait until no other thread uses the client.
 *
 * Errors: functions return a negative MOCAP_E_* code on failure, and
 * mocap_errmsg() gives a message for the user of the last failure in the
 * calling thread, e.g. "daemon not running at /run/mocapd/mocapd.sock".
 *
 * Times are CLOCK_MONOTONIC nanoseconds (same clock as the daemon's). Units
 * are metres; quaternions are (w, x, y, z). */
#ifndef MOCAP_H
#define MOCAP_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MOCAP_LIB_VERSION "1.2.0" /* = IPC_SO_VERSION in ipc/module.mk */
#define MOCAP_PROTOCOL_VERSION 3 /* the highest it speaks; it speaks 1 and 2 too */
#define MOCAP_DEFAULT_SOCKET "/run/mocapd/mocapd.sock"
#define MOCAP_SOCKET_ENV "MOCAP_SOCKET" /* a socket path or tcp://HOST:PORT */
#define MOCAP_TOKEN_ENV "MOCAP_TOKEN"   /* the token for tcp:// addresses */
#define MOCAP_TOKEN_FILE_ENV "MOCAP_TOKEN_FILE" /* or a file holding it */

#define MOCAP_MAX_JOINTS 128
#define MOCAP_MAX_CAMERAS 16
#define MOCAP_MAX_RINGS 16
#define MOCAP_MAX_KEYPOINTS 256
#define MOCAP_NAME_MAX 64  /* bytes, with the terminating NUL */

/* Error codes (negative return values). */
#define MOCAP_E_NOT_RUNNING -1  /* no daemon listens at the socket path */
#define MOCAP_E_ACCESS -2       /* the socket exists but we may not connect (TCP: no or wrong token) */
#define MOCAP_E_VERSION -3      /* the daemon speaks another protocol version */
#define MOCAP_E_PROTOCOL -4     /* the daemon sent something this library does not understand */
#define MOCAP_E_DISCONNECTED -5 /* the connection is closed (daemon stopped, or it closed us) */
#define MOCAP_E_TIMEOUT -6      /* no reply in time (mocap_set_timeout) */
#define MOCAP_E_PERMISSION -7   /* needs the daemon's user or group */
#define MOCAP_E_REFUSED -8      /* the daemon refused the request (see the message) */
#define MOCAP_E_UNAVAILABLE -9  /* nothing to answer yet (no skeleton, no rig) */
#define MOCAP_E_FAILED -10      /* a control command ran and failed */
#define MOCAP_E_ARG -11         /* bad argument */
#define MOCAP_E_SYSTEM -12      /* a system call failed (out of memory, descriptors, ...) */

typedef enum { MOCAP_LATEST = 1, MOCAP_ALL = 2 } mocap_mode;
typedef enum { MOCAP_SPACE_RIG = 0, MOCAP_SPACE_WORLD = 1 } mocap_space;
typedef enum {
	MOCAP_TRACK_OK = 0,
	MOCAP_TRACK_UNCERTAIN = 1,
	MOCAP_TRACK_LOST = 2,
	MOCAP_TRACK_IDLE = 3, /* status only: the daemon is not tracking */
	MOCAP_TRACK_INITIALISING = 4, /* waiting for detections that a body fits: no pose yet */
} mocap_track_state;
typedef enum {
	MOCAP_CMD_RELOAD = 1,
	MOCAP_CMD_RECORD_START = 2, /* argument: a take name or an absolute path, "" = a name from the time */
	MOCAP_CMD_RECORD_STOP = 3,
	MOCAP_CMD_ACTOR_SAVE = 4, /* argument: a name; the daemon writes [tracker] actor_dir/NAME.json */
	MOCAP_CMD_RECORD_STATUS = 5, /* msg: the take being recorded, or how the last one ended */
	MOCAP_CMD_RECORD_LIST = 6,   /* msg: the directory the daemon records takes into */
	MOCAP_CMD_STEER = 7,         /* argument: a graph source's target, e.g. "class walk",
				      * "direction 90 speed 1.2", "frame 120", "none" */
} mocap_command;

typedef struct {
	double position[3];    /* metres */
	double orientation[4]; /* w, x, y, z: space_from_joint */
	float confidence;      /* 0..1 */
} mocap_joint;

typedef struct {
	uint64_t seq;          /* the daemon's publish counter */
	uint64_t capture_ns;   /* when the cameras exposed the images */
	uint64_t publish_ns;   /* when the daemon published the skeleton */
	uint64_t receive_ns;   /* when this library received it */
	uint64_t missed;       /* frames lost just before this one ("all" mode gaps) */
	uint32_t skeleton_id;  /* the mocap_skeleton_def these joints follow */
	mocap_track_state state;
	mocap_space space;     /* WORLD only when the daemon had a head pose (or the rig is the world) */
	int njoints;
	mocap_joint joints[MOCAP_MAX_JOINTS];
} mocap_skeleton_frame;

typedef struct {
	char name[MOCAP_NAME_MAX];
	int parent;            /* -1 for the root; parents come first */
	double rest_offset[3]; /* in the parent's frame, metres */
} mocap_joint_def;

typedef struct {
	uint32_t id;
	int rig_is_world;      /* 1 for outside-in rigs */
	int njoints;
	mocap_joint_def joints[MOCAP_MAX_JOINTS];
} mocap_skeleton_def;

typedef struct {
	char name[MOCAP_NAME_MAX];
	int state;             /* 0 ok, 1 stalled, 2 error (being reopened), 3 off, 4 failed (for good) */
	int width, height;
	double fps;
	uint64_t frames, drops;
} mocap_camera_status;

typedef enum {
	MOCAP_DETECTOR_OFF = 0,     /* no in-process detector configured */
	MOCAP_DETECTOR_RUNNING = 1,
	MOCAP_DETECTOR_FAILED = 2,  /* its model did not load: see message */
	MOCAP_DETECTOR_UNKNOWN = 3, /* the daemon speaks protocol version 1 only */
} mocap_detector_state;

/* The daemon's in-process 2D joint detector ([detector] in its config). */
typedef struct {
	mocap_detector_state state;
	double rate;      /* views detected per second, recent average */
	double used_rate; /* views tracked with its keypoints per second */
	double ms_mean, ms_last, ms_max; /* ms per view: recent mean, last, recent maximum */
	uint64_t views, skipped, used; /* since start: detected, not detected (a newer frame came first), tracked with */
	char model[1024];   /* the model file */
	char message[1024]; /* FAILED: why, naming the file and the mismatch */
} mocap_detector_status;

/* Where a frame set's time goes in the daemon, capture to publish. */
typedef enum {
	MOCAP_LAT_READY = 0,   /* capture -> the frame set complete (or released at its deadline) */
	MOCAP_LAT_WAIT = 1,    /* -> tracking starts (the tracker was busy) */
	MOCAP_LAT_DECODE = 2,  /* -> the views copied out and converted to RGB */
	MOCAP_LAT_TRACK = 3,   /* -> tracking ends (keypoints, the optimisation) */
	MOCAP_LAT_PUBLISH = 4, /* -> handed to the socket server */
	MOCAP_LAT_TOTAL = 5,   /* capture -> handed to the socket server */
	MOCAP_LAT_NSTAGES = 6
} mocap_latency_stage;

typedef struct {
	int known;    /* 0: the daemon speaks protocol version 2 or older */
	unsigned window; /* the newest frame sets the figures are over */
	struct {
		double p50, p99, max; /* ms */
	} stage[MOCAP_LAT_NSTAGES];
	uint64_t skipped_behind; /* frame sets skipped: a newer one was due */
	uint64_t skipped_stale;  /* skipped: older than the daemon's max_frame_age_ms */
	uint64_t incomplete;     /* released at their deadline without every camera */
} mocap_latency_status;

typedef struct {
	mocap_track_state tracker_state;
	int recording;
	double publish_fps, track_ms_mean, track_ms_max;
	uint64_t frames_published, frames_dropped;
	uint64_t client_drops; /* frames dropped from slow clients' queues, all clients */
	uint64_t server_time_ns, uptime_ns;
	int clients;
	char device[MOCAP_NAME_MAX];
	int ncams;
	mocap_camera_status cams[MOCAP_MAX_CAMERAS];
	/* Since libmocap 1.1 (symbol version MOCAP_2 of mocap_get_status;
	 * programs built against 1.0 keep the old layout without it). */
	mocap_detector_status detector;
	/* Since libmocap 1.2 (MOCAP_3; 1.1 programs get the layout above). */
	mocap_latency_status latency;
} mocap_daemon_status;

typedef struct {
	char camera[MOCAP_NAME_MAX];
	int fd;                /* read-only; mmap(NULL, size, PROT_READ, MAP_SHARED, fd, 0); close it yourself */
	uint64_t size;
} mocap_ring;

typedef struct {
	int joint;             /* index in the mocap_skeleton_def */
	float u, v;            /* pixels of the camera's native image */
	float confidence;      /* 0..1 */
} mocap_keypoint;

typedef struct mocap_client mocap_client;

/* $MOCAP_SOCKET if set, else MOCAP_DEFAULT_SOCKET. */
const char *mocap_default_socket(void);

/* Connects and performs the handshake.  path NULL: mocap_default_socket().
 * client_name (may be NULL) shows in the daemon's log.  NULL on failure;
 * mocap_errcode() and mocap_errmsg() say why.
 *
 * path may also be "tcp://HOST:PORT" (or tcp://[IPV6]:PORT): a daemon on
 * another machine, through its [network] listener.  Its token is taken
 * from $MOCAP_TOKEN, else from the first line of the file
 * $MOCAP_TOKEN_FILE (or given with mocap_connect_token).  Everything but
 * camera rings works over TCP; timestamps stay the daemon's clock
 * (mocap_ping gives it, to estimate the offset). */
mocap_client *mocap_connect(const char *path, const char *client_name);
/* The same with the TCP token given (NULL: as mocap_connect finds it);
 * the token is ignored for a Unix socket path.  Since libmocap 1.2. */
mocap_client *mocap_connect_token(const char *address, const char *client_name, const char *token);
void mocap_close(mocap_client *c);

/* 1 if this client may control the daemon, map rings and send inputs. */
int mocap_is_privileged(const mocap_client *c);

/* What the daemon said of itself when this client connected (WELCOME's
 * daemon_version, e.g. "mocapd 1.2.0"; "" if it said nothing), and the
 * protocol version of this connection.  Since libmocap 1.2 (MOCAP_3). */
const char *mocap_daemon_version(const mocap_client *c);
int mocap_protocol_version(const mocap_client *c);

/* Timeout for requests (status, control, ...), milliseconds; default 10000. */
void mocap_set_timeout(mocap_client *c, int timeout_ms);

/* LATEST: only the newest frame, nothing queued (VR).  ALL: every frame,
 * through a queue of queue_len frames at the daemon (0 = its default);
 * frames lost on overflow are counted in the next frame's `missed`.
 * Subscribing again replaces the subscription.  Returns 0 or an error. */
int mocap_subscribe(mocap_client *c, mocap_mode mode, mocap_space space, unsigned queue_len);
int mocap_unsubscribe(mocap_client *c);

/* The next frame: 1 and *f filled, 0 on timeout, or an error.  timeout_ms
 * -1 waits forever, 0 only looks.  In LATEST mode it is the newest frame
 * received (older ones are skipped). */
int mocap_read_frame(mocap_client *c, mocap_skeleton_frame *f, int timeout_ms);

/* An fd for poll/epoll that is readable when mocap_read_frame may have a
 * frame (or an error) to return without waiting.  Do not read from it. */
int mocap_fd(mocap_client *c);

/* The newest skeleton definition (joint names, parents, rest offsets). */
int mocap_get_skeleton(mocap_client *c, mocap_skeleton_def *s);
int mocap_get_status(mocap_client *c, mocap_daemon_status *st);
/* The rig in use as JSON text; *json is malloc'd, free() it. */
int mocap_get_rig(mocap_client *c, char **json, int *ncams);

/* Runs a command in the daemon and waits for its result.  msg (may be
 * NULL) receives the daemon's message.  0 done, MOCAP_E_FAILED (message
 * says why), MOCAP_E_PERMISSION, or another error. */
int mocap_control(mocap_client *c, mocap_command cmd, const char *argument, char *msg, size_t msglen);

/* Read-only descriptors of the camera frame rings.  Returns how many (at
 * most max) or an error; the caller closes each fd. */
int mocap_get_rings(mocap_client *c, mocap_ring *rings, int max);

/* 2D detections for one camera image (the image's capture_ns), as input to
 * the tracker.  Not acknowledged, so it costs no round trip: when the
 * daemon refuses a batch or a head pose (bad camera or joint index, no
 * permission), the next mocap_send_keypoints or mocap_send_head_pose call
 * returns that error (MOCAP_E_REFUSED, MOCAP_E_PERMISSION) with the
 * daemon's message.  n <= MOCAP_MAX_KEYPOINTS. */
int mocap_send_keypoints(mocap_client *c, uint64_t capture_ns, int camera, const mocap_keypoint *kp, int n);

/* The rig's pose in a VR runtime's world frame (world_from_rig), so the
 * daemon can send skeletons in world space.  Not acknowledged. */
int mocap_send_head_pose(mocap_client *c, uint64_t timestamp_ns, const double position[3],
			 const double orientation_wxyz[4]);

/* --- The latest-pose block (since libmocap 1.2) ------------------------
 *
 * The daemon writes every published skeleton (rig space) into a shared
 * memory block; a client on the daemon's machine maps it once and reads
 * the newest pose without a socket round trip (well under a microsecond),
 * or waits for the next one on a futex.  Not over TCP.
 *
 *     mocap_pose_block *b = mocap_pose_block_map(c);
 *     mocap_skeleton_frame f;
 *     uint64_t seen = 0;
 *     while (mocap_pose_block_wait(b, seen, &f, 1000) == 1) {
 *             seen = f.seq;
 *             mocap_pose_block_predict(b, display_time_ns, &f);   // the pose when the frame is shown
 *             ...
 *     }
 *     mocap_pose_block_unmap(b);
 *
 * Frames read from the block have receive_ns set to the time of reading,
 * missed = 0, space = MOCAP_SPACE_RIG; their joints follow the skeleton
 * definition `skeleton_id` (mocap_get_skeleton).  Any thread may read a
 * mapped block; unmap it after the client is closed or before, as you like. */
typedef struct mocap_pose_block mocap_pose_block;

/* Maps the daemon's block read-only; NULL on failure (MOCAP_E_UNAVAILABLE
 * over TCP or from a daemon older than protocol version 3). */
mocap_pose_block *mocap_pose_block_map(mocap_client *c);
void mocap_pose_block_unmap(mocap_pose_block *b);
/* The newest pose: 1 and *f filled, 0 when the daemon has published none
 * yet.  Never blocks (retries while a write is in progress). */
int mocap_pose_block_read(const mocap_pose_block *b, mocap_skeleton_frame *f);
/* Waits until a pose newer than after_seq is there (timeout_ms -1: for
 * ever): 1 and *f filled, 0 on timeout. */
int mocap_pose_block_wait(const mocap_pose_block *b, uint64_t after_seq, mocap_skeleton_frame *f, int timeout_ms);
/* The newest pose predicted to t_ns (mocap_predict from the two newest
 * poses in the block): what mocap_predict returns, or MOCAP_E_UNAVAILABLE
 * before the first pose. */
int mocap_pose_block_predict(const mocap_pose_block *b, uint64_t t_ns, mocap_skeleton_frame *f);

/* --- Prediction (since libmocap 1.2) ------------------------------------
 *
 * Extrapolates newer (a pose at newer->capture_ns) to t_ns from the
 * motion between older and newer: constant velocity for positions,
 * constant angular velocity for orientations.  out gets newer's fields
 * with the predicted joints and capture_ns = t_ns (out may be newer).
 * At most MOCAP_PREDICT_MAX_NS ahead of newer: further is clamped there
 * (a pose is worth extrapolating over a display's latency, not over a
 * lost tracker's gap).  t_ns before newer's time predicts backwards the
 * same way.  Returns 0 predicted to t_ns, 1 clamped to the limit, 2 newer
 * held as it is (older is not an earlier frame of the same skeleton, or
 * more than MOCAP_PREDICT_MAX_GAP_NS older), or MOCAP_E_ARG. */
#define MOCAP_PREDICT_MAX_NS 100000000ull     /* 100 ms ahead */
#define MOCAP_PREDICT_MAX_GAP_NS 200000000ull /* older at most 200 ms before newer */
int mocap_predict(const mocap_skeleton_frame *older, const mocap_skeleton_frame *newer, uint64_t t_ns,
		  mocap_skeleton_frame *out);

/* Round trip to the daemon; *server_time_ns may be NULL. */
int mocap_ping(mocap_client *c, uint64_t *server_time_ns);

/* CLOCK_MONOTONIC now, in nanoseconds. */
uint64_t mocap_now_ns(void);

/* Name of an error code, e.g. "daemon not running". */
const char *mocap_strerror(int code);
/* The last failure of a mocap_ call in the calling thread. */
int mocap_errcode(void);
const char *mocap_errmsg(void);

/* "ok", "uncertain", "lost", "idle". */
const char *mocap_track_state_name(mocap_track_state s);

#ifdef __cplusplus
}
#endif

#endif
