/* take: the files of one recorded take (docs/RECORDING.md).
 *
 * A take is a directory.  Its streams are append-only record files: every
 * record is a 24-byte header (magic "MCR1", type, payload size, CRC-32 of
 * the payload, the time it was written) and its payload, so that a reader
 * takes every whole record and stops at the first torn or missing one: a
 * take cut by SIGKILL or power loss opens, and what was lost is at most the
 * records written after the last sync.  No index: nothing to rebuild.
 *
 *   take.json          what, when, which cameras; "complete" once stopped
 *   poses.mcr          skeleton definitions, skeletons, gaps
 *   cam-NAME.mcr       one camera's frames as delivered (JPEG as it came,
 *                      raw formats as their bytes), with their times
 *   rig.json, model.json, actor.json, mocapd.conf   copies of those in use
 *
 * Writers are not thread safe; one thread writes a take.  Readers only read. */
#ifndef TAKE_H
#define TAKE_H

#include "base/mc_error.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#define TAKE_RECORD_MAGIC 0x3152434du /* "MCR1" */
#define TAKE_HEADER_SIZE 24
#define TAKE_MAX_PAYLOAD (256u << 20)  /* a 256 MiB frame at most, as the rings */
#define TAKE_NAME_MAX 128
#define TAKE_JOINT_NAME 32
#define TAKE_MAX_JOINTS 128
#define TAKE_MAX_DOF 96 /* the tracker's pose vector (body/mc_model.h MC_MAX_DOF) */

typedef enum {
	TAKE_DEF = 1,      /* a skeleton definition: joints' names, parents, rest offsets */
	TAKE_SKELETON = 2, /* one pose */
	TAKE_GAP = 3,      /* poses the recorder did not get */
	TAKE_FRAME = 4,    /* one camera frame */
	TAKE_KEYPOINTS = 5, /* the 2D keypoints a skeleton was tracked with */
	TAKE_HEAD_POSE = 6, /* a VR runtime's head pose (world_from_rig) */
} take_record_type;

typedef struct {
	uint64_t timestamp_ns;  /* CLOCK_MONOTONIC */
	double position[3];     /* metres */
	double orientation[4];  /* w, x, y, z */
} take_head_pose;

#define TAKE_MAX_KEYPOINTS 1024

typedef struct {
	uint16_t cam, joint; /* rig camera, skeleton joint */
	float u, v;          /* native pixels */
	float confidence;
} take_keypoint;

typedef struct {
	char name[TAKE_JOINT_NAME];
	int parent;
	double offset[3]; /* in the parent's frame, metres (rest: frames aligned) */
} take_joint_def;

typedef struct {
	uint32_t id;
	int njoints;
	take_joint_def joints[TAKE_MAX_JOINTS];
} take_def;

typedef struct {
	double position[3];
	double orientation[4]; /* w, x, y, z: rig (or world) from joint */
	float confidence;
} take_joint;

typedef struct {
	uint64_t seq;          /* the daemon's publish counter */
	uint64_t capture_ns;   /* CLOCK_MONOTONIC */
	uint64_t realtime_ns;  /* the same instant, CLOCK_REALTIME */
	int state;             /* tracking state, as FRAME's */
	uint32_t def_id;
	int njoints;
	take_joint joints[TAKE_MAX_JOINTS];
	int ndof;              /* the tracker's pose vector (0: not recorded), for the actor.json of the take */
	double dofs[TAKE_MAX_DOF];
} take_pose;

typedef struct {
	uint64_t sequence;     /* the ring's */
	uint64_t capture_ns, realtime_ns, driver_sequence;
	uint32_t pixfmt, width, height, stride, flags;
} take_frame_meta;

/* ---- writing ---- */

typedef struct {
	int fd;
	char path[4096];
	uint64_t bytes;     /* written so far */
	uint64_t synced;    /* bytes made durable */
} take_file;

/* Creates (O_EXCL) an empty record file. */
int take_file_create(take_file *f, const char *path, mc_err *err);
/* Appends one record whose payload is a (an bytes) then b (bn bytes; b may
 * be NULL with bn 0), header and payload in one write.  A short write is
 * cut back to the last whole record, so a failure leaves the file valid.
 * -1 with err naming the file and errno (ENOSPC: "No space left ..."). */
int take_file_append(take_file *f, take_record_type type, const void *a, size_t an, const void *b, size_t bn,
		     uint64_t now_ns, mc_err *err);
/* fdatasync when there is anything new. */
int take_file_sync(take_file *f, mc_err *err);
void take_file_close(take_file *f);

/* Payload encoders: they return the size written into buf (cap bytes). */
size_t take_encode_def(const take_def *d, uint8_t *buf, size_t cap);
size_t take_encode_pose(const take_pose *p, uint8_t *buf, size_t cap);
size_t take_encode_gap(uint64_t first_seq, uint64_t count, uint8_t *buf, size_t cap);
/* Keypoints of the skeleton `seq` (captured at capture_ns). */
size_t take_encode_keypoints(uint64_t seq, uint64_t capture_ns, const take_keypoint *kp, int n, uint8_t *buf,
			     size_t cap);
#define TAKE_HEAD_POSE_SIZE 64
void take_encode_head_pose(const take_head_pose *h, uint8_t *buf);
int take_decode_head_pose(const uint8_t *p, size_t size, take_head_pose *h);
/* Frame records: the meta (56 bytes) then the bytes as delivered. */
#define TAKE_FRAME_META_SIZE 56
void take_encode_frame_meta(const take_frame_meta *m, uint8_t *buf);

/* ---- reading ---- */

typedef struct {
	FILE *f;
	uint8_t *buf;       /* the current record's payload */
	size_t cap;
	uint64_t size;      /* the file's size when opened */
	uint64_t pos;       /* offset of the next record */
	uint64_t valid_end; /* after the reader stopped: where the good records end */
	char path[4096];
	bool torn;          /* stopped at a torn or foreign record, not at the end */
} take_reader;

/* Streams a record file: one record in memory at a time. */
int take_reader_open(take_reader *r, const char *path, mc_err *err);
void take_reader_close(take_reader *r);
/* The next whole record: 1 with type, payload (valid until the next call)
 * and size, 0 at the end (or at a torn record: r->torn says which). */
int take_reader_next(take_reader *r, take_record_type *type, const uint8_t **payload, size_t *size,
		     uint64_t *written_ns);

/* The next whole camera frame record of a camera file (other records are
 * skipped): 1 with its meta and its bytes (valid until the next call), 0
 * at the end or at a torn record. */
int take_reader_next_frame(take_reader *r, take_frame_meta *m, const uint8_t **bytes, size_t *n);

int take_decode_def(const uint8_t *p, size_t size, take_def *d);
int take_decode_pose(const uint8_t *p, size_t size, take_pose *o);
int take_decode_gap(const uint8_t *p, size_t size, uint64_t *first_seq, uint64_t *count);
int take_decode_frame_meta(const uint8_t *p, size_t size, take_frame_meta *m);
/* A raw (not JPEG) frame's meta against its n bytes: a known raw format,
 * 1..TAKE_MAX_FRAME_SIDE pixels a side, a stride that holds a row, and as
 * many bytes as height rows take.  -1 with err naming the field: checked
 * before anything is allocated from width and height (issue 34). */
#define TAKE_MAX_FRAME_SIDE 16384
int take_frame_check_raw(const take_frame_meta *m, size_t n, mc_err *err);
/* *n keypoints (at most cap) into kp; -1 when the record does not decode. */
int take_decode_keypoints(const uint8_t *p, size_t size, uint64_t *seq, uint64_t *capture_ns, take_keypoint *kp,
			  int cap, int *n);

/* ---- the take as a whole ---- */

/* Poses of a take with the definition each follows, as read from
 * DIR/poses.mcr, or with track != NULL from DIR/poses-TRACK.mcr (a track
 * mocap-track wrote); whole records only. */
typedef struct {
	take_def def;          /* the first definition (a take with several: the first) */
	take_pose *poses;
	int nposes;
	uint64_t gap_frames;   /* poses the recorder did not get */
	bool torn;             /* the file ended in a torn record (a crash) */
} take_poses;

int take_poses_load(const char *dir, const char *track, take_poses *out, mc_err *err);
void take_poses_free(take_poses *t);

/* ---- BVH (take_bvh.c) ----
 * A skeleton definition and its poses as BVH: the HIERARCHY (rest offsets
 * in centimetres), the MOTION header, then one line per pose (the root's
 * position in centimetres, every joint's rotation relative to its parent as
 * Z X Y Euler angles in degrees).  Write errors show in ferror(f). */
void take_bvh_write_hierarchy(FILE *f, const take_def *d);
void take_bvh_write_motion(FILE *f, int nframes, double frame_time);
void take_bvh_write_pose(FILE *f, const take_def *d, const take_pose *p);

/* ---- take.json ---- */

#define TAKE_MAX_CAMERAS 16

typedef struct {
	char name[TAKE_NAME_MAX];
	uint64_t start_realtime_ns, start_monotonic_ns;
	uint64_t stop_realtime_ns; /* 0 while recording (or after a crash) */
	bool complete;             /* stopped cleanly: the counts below are final */
	char stop_reason[256];     /* "stopped by request", "limit: ...", "error: ..." */
	int ncams;
	char cams[TAKE_MAX_CAMERAS][64];
	char rig_cams[TAKE_MAX_CAMERAS][64]; /* the rig camera each one is ("" = not tracked) */
	uint64_t poses, pose_gaps; /* skeletons written, and not received by the recorder */
	uint64_t frames[TAKE_MAX_CAMERAS], frame_drops[TAKE_MAX_CAMERAS];
	uint64_t bytes;
} take_info;

/* Writes DIR/take.json atomically (a new file renamed over the old, both
 * synced): a crash leaves the old one or the new one. */
int take_info_write(const char *dir, const take_info *t, mc_err *err);
int take_info_read(const char *dir, take_info *t, mc_err *err);
/* Copies a file into the take (synced); "" or NULL src: nothing. */
int take_copy_file(const char *src, const char *dir, const char *name, mc_err *err);

#endif
