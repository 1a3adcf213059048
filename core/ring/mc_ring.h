/* mc_ring: a frame ring per camera in sealed memfd shared memory.
 *
 * One producer (the camera's capture thread) writes frames into a fixed
 * number of equal slots, overwriting the oldest.  Any number of readers,
 * threads of the same process or other processes that were handed the ring's
 * file descriptor, copy frames out.  A reader never blocks the writer: a slow
 * reader sees the frames it missed as a gap in the sequence numbers.
 *
 * Each slot is a seqlock.  Its 64-bit `lock` word encodes both state and
 * content: 2N+1 while frame N is being written, 2N+2 once frame N is
 * committed (0: never written).  A reader loads the lock, copies the slot,
 * then loads the lock again; if it was odd, or changed, or does not name the
 * frame the reader asked for, the copy is thrown away (a torn read) and
 * reported as a gap.  A reader therefore never returns a corrupted frame.
 *
 * Writer:
 *     mc_ring *r = mc_ring_create("left", 8, max_frame_bytes, &err);
 *     size_t cap; uint8_t *p = mc_ring_slot_begin(r, &cap);
 *     ... fill p (at most cap bytes) ...
 *     mc_ring_slot_commit(r, &meta, &err);   (or mc_ring_slot_abort(r))
 *     int fd = mc_ring_fd(r);                (hand it to other processes)
 *
 * Reader (thread or process):
 *     mc_ring *rd = mc_ring_map(fd, &err);   (read-only mapping)
 *     mc_ring_cursor cur = mc_ring_cursor_oldest(rd);
 *     mc_ring_wait(rd, &cur, 100);
 *     switch (mc_ring_read_next(rd, &cur, buf, bufsize, &meta, &err)) ...
 *
 * Reader functions take any ring handle, the writer's included.
 *
 * The bulk frame bytes are written with plain stores (drivers fill the slot
 * through a raw pointer) and copied with memcpy: the usual seqlock
 * compromise.  The lock and the metadata are C11 atomics; under
 * ThreadSanitizer the reader's bulk copy is annotated as ignored, since its
 * result is discarded whenever it raced with the writer. */
#ifndef MC_RING_H
#define MC_RING_H

#include "base/mc_error.h"

#include <stddef.h>
#include <stdint.h>

#define MC_RING_MAGIC 0x31474e4952434d4dull /* "MMCRING1" little-endian */
#define MC_RING_VERSION 1u
#define MC_RING_NAME_MAX 64
#define MC_RING_MAX_SLOTS 1024

typedef struct mc_ring mc_ring;

/* Per-frame metadata. */
typedef struct {
	uint64_t sequence;        /* assigned by the ring: 0, 1, 2, ... per ring */
	uint64_t timestamp_ns;    /* capture time, CLOCK_MONOTONIC */
	uint64_t commit_ns;       /* when the ring published it, CLOCK_MONOTONIC */
	uint64_t driver_sequence; /* the driver's own frame counter */
	uint64_t bytesused;
	uint32_t pixfmt;          /* mc_pixfmt (image/mc_pixfmt.h) */
	uint32_t width, height;
	uint32_t stride;          /* bytes per row; 0 for compressed formats */
	uint32_t flags;           /* MDRV_FRAME_* */
} mc_ring_meta;

/* A reader's position.  Each reader keeps its own. */
typedef struct {
	uint64_t next;   /* sequence number of the next frame to read */
	uint64_t gap;    /* frames lost in the last MC_RING_GAP result */
	uint64_t missed; /* frames lost in total (the writer lapped this reader) */
	uint64_t torn;   /* copies discarded because the writer rewrote the slot */
} mc_ring_cursor;

/* Results of the read functions (errors are -1). */
enum {
	MC_RING_NONE = 0,  /* no frame newer than the cursor yet */
	MC_RING_FRAME = 1, /* a frame was copied, meta filled */
	MC_RING_GAP = 2,   /* cursor->gap frames were lost; the cursor moved past them */
};

/* Creates a ring of nslots (2..MC_RING_MAX_SLOTS) slots of slot_bytes each
 * in a new memfd, sealed against resizing.  `name` labels the memfd and is
 * stored in the header. NULL on error. */
mc_ring *mc_ring_create(const char *name, unsigned nslots, size_t slot_bytes, mc_err *err);

/* Maps a ring created by mc_ring_create (in this or another process)
 * read-only.  Validates the header against the file: magic, version, slot
 * count and sizes within the file size, and the size seals (so that the file
 * cannot shrink under the mapping).  The fd stays the caller's. */
mc_ring *mc_ring_map(int fd, mc_err *err);

/* Unmaps; the writer's handle also closes its memfd. NULL is allowed. */
void mc_ring_close(mc_ring *ring);

/* The memfd of a ring made by mc_ring_create (-1 for a mapped one). */
int mc_ring_fd(const mc_ring *ring);
const char *mc_ring_name(const mc_ring *ring);
unsigned mc_ring_nslots(const mc_ring *ring);
size_t mc_ring_slot_bytes(const mc_ring *ring);
/* Frames committed so far (the sequence number the next one will get). */
uint64_t mc_ring_head(const mc_ring *ring);

/* Writer.  Marks the slot of the next frame as being written (readers that
 * still wanted the oldest frame in it will see a gap) and returns its data,
 * *capacity bytes.  NULL for a read-only handle or if a slot is already open. */
uint8_t *mc_ring_slot_begin(mc_ring *ring, size_t *capacity);
/* Publishes the open slot.  meta's sequence and commit_ns are assigned by the
 * ring (and written back into *meta); bytesused must fit the slot. */
int mc_ring_slot_commit(mc_ring *ring, mc_ring_meta *meta, mc_err *err);
/* Gives up the open slot (e.g. the driver timed out).  The oldest frame that
 * slot held is lost; the next begin reuses the slot and sequence number. */
void mc_ring_slot_abort(mc_ring *ring);

/* A cursor at the oldest frame still in the ring, or at the next frame to be
 * written (a reader that only wants what comes after it attached). */
mc_ring_cursor mc_ring_cursor_oldest(const mc_ring *ring);
mc_ring_cursor mc_ring_cursor_now(const mc_ring *ring);

/* Copies the frame at cursor->next into dst (cap bytes).  Returns
 * MC_RING_FRAME (cursor advanced by one), MC_RING_NONE, MC_RING_GAP (the frame
 * at the cursor, and maybe more, were overwritten before or while it was
 * copied: cursor->gap says how many, the cursor moved past them; call
 * again), or -1 with err (dst too small: the cursor stays, retry with a
 * larger buffer; or a corrupt slot written by a foreign writer). */
int mc_ring_read_next(const mc_ring *ring, mc_ring_cursor *cursor, void *dst, size_t cap, mc_ring_meta *meta,
		      mc_err *err);

/* Copies the newest frame.  With a cursor (may be NULL): returns MC_RING_NONE
 * if there is nothing newer than cursor->next, and afterwards moves the
 * cursor past the frame returned, counting the frames skipped as missed.
 * Returns MC_RING_FRAME, MC_RING_NONE or -1 with err. */
int mc_ring_read_latest(const mc_ring *ring, mc_ring_cursor *cursor, void *dst, size_t cap, mc_ring_meta *meta,
			mc_err *err);

/* Blocks until a frame at or after cursor->next is committed, or timeout_ms
 * passes (< 0: forever).  Returns 1 if one is there, 0 on timeout, -1 with
 * err.  Works across processes (a shared futex in the ring). */
int mc_ring_wait(const mc_ring *ring, const mc_ring_cursor *cursor, int timeout_ms, mc_err *err);

/* The mapped shared memory and its size: writable for the ring's creator,
 * read-only for a mapped reader.  For tests that fake a foreign writer's
 * damage, and for diagnostics; the ring's memfd itself is sealed against
 * new writable mappings. */
void *mc_ring_shared_memory(mc_ring *ring, size_t *bytes);

/* Test hook: called by the read functions after copying a slot and before
 * checking its lock again, so that a test can rewrite the slot in between
 * and make a torn read happen deterministically. NULL removes it. */
void mc_ring_set_copy_hook(mc_ring *ring, void (*hook)(void *ctx), void *ctx);

#endif
