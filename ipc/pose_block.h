/* pose_block: the latest-pose shared-memory block (docs/PROTOCOL_SHM.md,
 * "Latest-pose block").  The server writes every published skeleton into
 * a memfd (ipc/server/pose.c); clients map it read-only (GET_POSE_BLOCK,
 * libmocap's mocap_pose_block_*) and read the newest poses without a
 * socket round trip.  Shared by both ends: the layout and the seqlock.
 *
 * Layout (little-endian; offsets in bytes):
 *   0   u32 magic        POSE_BLOCK_MAGIC
 *   4   u32 version      POSE_BLOCK_VERSION
 *   8   u32 seqlock      even: stable; odd: a write is in progress.  Also
 *                        the futex word writers wake readers on.
 *   12  u32 nslots       POSE_BLOCK_SLOTS
 *   16  u64 written      poses written; the newest is in slot (written-1) % nslots
 *   24  u32 slot_bytes
 *   28  u32 max_joints
 *   32  reserved to 64
 *   64  nslots slots of slot_bytes:
 *       0  u64 seq, 8 u64 capture_ns, 16 u64 publish_ns, 24 u32 skeleton_id,
 *       28 u16 njoints, 30 u8 state, 31 u8 space (0: rig), 32 reserved to 64,
 *       64 njoints joints of 64 bytes: f64 position[3], f64 orientation[4]
 *          (w, x, y, z), f32 confidence, u32 reserved.
 *
 * Writer (one at a time): seqlock += 1 (odd), write the slot and
 * `written`, seqlock += 1 (even), wake the futex.  Reader: read seqlock
 * (retry while odd), copy, read seqlock again; equal means the copy is
 * whole. */
#ifndef POSE_BLOCK_H
#define POSE_BLOCK_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define POSE_BLOCK_MAGIC 0x4b4c4250u /* "PBLK" as bytes 50 42 4c 4b */
#define POSE_BLOCK_VERSION 1u
#define POSE_BLOCK_SLOTS 4u
#define POSE_BLOCK_MAX_JOINTS 128u
#define POSE_BLOCK_HEADER 64u
#define POSE_BLOCK_JOINT_BYTES 64u
#define POSE_BLOCK_SLOT_BYTES (64u + POSE_BLOCK_MAX_JOINTS * POSE_BLOCK_JOINT_BYTES)
#define POSE_BLOCK_SIZE (POSE_BLOCK_HEADER + POSE_BLOCK_SLOTS * POSE_BLOCK_SLOT_BYTES)

/* This code reads and writes the fields in the host's order: the block
 * never leaves the machine, and every Linux target mocapd builds for is
 * little-endian (checked at compile time). */
_Static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the pose block is little-endian");

typedef struct {
	double position[3];
	double orientation[4];
	float confidence;
	uint32_t reserved;
} pose_block_joint;

typedef struct {
	uint64_t seq, capture_ns, publish_ns;
	uint32_t skeleton_id;
	uint16_t njoints;
	uint8_t state, space;
	uint8_t reserved[32];
	pose_block_joint joints[POSE_BLOCK_MAX_JOINTS];
} pose_block_slot;

typedef struct {
	uint32_t magic, version;
	_Atomic uint32_t seqlock;
	uint32_t nslots;
	uint64_t written;
	uint32_t slot_bytes, max_joints;
	uint8_t reserved[32];
	pose_block_slot slots[POSE_BLOCK_SLOTS];
} pose_block;

_Static_assert(sizeof(pose_block_joint) == POSE_BLOCK_JOINT_BYTES, "joint layout");
_Static_assert(offsetof(pose_block_slot, joints) == 64 && sizeof(pose_block_slot) == POSE_BLOCK_SLOT_BYTES,
	       "slot layout");
_Static_assert(offsetof(pose_block, seqlock) == 8 && offsetof(pose_block, written) == 16 &&
		       offsetof(pose_block, slots) == POSE_BLOCK_HEADER && sizeof(pose_block) == POSE_BLOCK_SIZE,
	       "header layout");

/* The first bytes of a slot worth copying: its header and njoints joints. */
static inline size_t pose_block_slot_used(uint16_t njoints)
{
	return offsetof(pose_block_slot, joints) + (size_t)njoints * sizeof(pose_block_joint);
}

/* Copies the `count` newest slots (newest first) into out; returns how
 * many there were (0 before the first pose), or -1 when a writer kept
 * the block busy for `tries` attempts. */
static inline int pose_block_read(const pose_block *b, pose_block_slot *out, int count, int tries)
{
	pose_block *w = (pose_block *)b; /* atomics take non-const pointers; nothing is written */
	for (int attempt = 0; attempt < tries; attempt++) {
		uint32_t s1 = atomic_load_explicit(&w->seqlock, memory_order_acquire);
		if (s1 & 1u)
			continue;
		uint64_t written = b->written;
		int n = written < (uint64_t)count ? (int)written : count;
		for (int i = 0; i < n; i++) {
			const pose_block_slot *s = &b->slots[(written - 1 - (uint64_t)i) % POSE_BLOCK_SLOTS];
			uint16_t nj = s->njoints <= POSE_BLOCK_MAX_JOINTS ? s->njoints : POSE_BLOCK_MAX_JOINTS;
			memcpy(&out[i], s, pose_block_slot_used(nj));
			out[i].njoints = nj;
		}
		atomic_thread_fence(memory_order_acquire);
		if (atomic_load_explicit(&w->seqlock, memory_order_relaxed) == s1)
			return n;
	}
	return -1;
}

#endif
