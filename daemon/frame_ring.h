/* frame_ring: one camera's frame ring (core/ring/mc_ring.h) as the daemon
 * holds it, between the capture thread that writes it and the readers.
 *
 * The capture thread writes frames into the ring (mc_ring_slot_begin /
 * _commit on `ring`, without the lock: it is the only writer and the only
 * one that replaces the ring) and replaces the ring when frames outgrow its
 * slots.  The tracking thread reads frames back by ring generation and
 * sequence number; clients get the ring's memfd.  The lock guards the
 * replacement against those readers. */
#ifndef MCD_FRAME_RING_H
#define MCD_FRAME_RING_H

#include "base/mc_error.h"
#include "image/mc_image.h"
#include "ring/mc_ring.h"

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>

typedef struct {
	char name[64];
	unsigned slots;
	pthread_mutex_t lock;
	mc_ring *ring;       /* NULL until the camera first opens */
	uint64_t generation; /* bumped when the ring is replaced */
} mcd_frame_ring;

void mcd_frame_ring_init(mcd_frame_ring *r, const char *name, unsigned slots);
void mcd_frame_ring_destroy(mcd_frame_ring *r);

/* Writer: makes sure the slots hold `bytes` (at most 256 MiB), replacing
 * the ring if not.  Returns 1 when it was replaced, 0 when it was big
 * enough, -1 with err. */
int mcd_frame_ring_ensure(mcd_frame_ring *r, size_t bytes, mc_err *err);

/* Reader: copies frame `sequence` of ring `generation` into *buf (grown
 * with realloc as needed; *cap is its size).  Returns MC_RING_FRAME,
 * MC_RING_GAP (it was overwritten already, or its ring replaced),
 * MC_RING_NONE (no ring yet), or -1 with err. */
int mcd_frame_ring_read(mcd_frame_ring *r, uint64_t generation, uint64_t sequence, uint8_t **buf, size_t *cap,
			mc_ring_meta *meta, mc_err *err);

/* A frame read back (`raw`, as meta describes it) converted to packed
 * RGB24 in *rgb (grown with realloc; *cap is its size); *w, *h get its
 * size (an MJPEG frame without one in meta is sized from its header).
 * The tracking and the detector thread each have their own conv. */
int mcd_frame_to_rgb(mc_image_conv *conv, const mc_ring_meta *meta, const uint8_t *raw, uint8_t **rgb, size_t *cap,
		     int *w, int *h, mc_err *err);

/* The ring's memfd (dup'ed: the caller closes it) and size, for clients;
 * -1 if there is no ring yet. */
int mcd_frame_ring_dup(mcd_frame_ring *r, uint64_t *size);

#endif
