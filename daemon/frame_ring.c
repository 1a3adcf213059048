#include "frame_ring.h"

#include "image/mc_pixfmt.h"

#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>

#define MAX_SLOT_BYTES (256u << 20)

void mcd_frame_ring_init(mcd_frame_ring *r, const char *name, unsigned slots)
{
	snprintf(r->name, sizeof(r->name), "%s", name);
	r->slots = slots;
	pthread_mutex_init(&r->lock, NULL);
	r->ring = NULL;
	r->generation = 0;
}

void mcd_frame_ring_destroy(mcd_frame_ring *r)
{
	mc_ring_close(r->ring);
	r->ring = NULL;
	pthread_mutex_destroy(&r->lock);
}

int mcd_frame_ring_ensure(mcd_frame_ring *r, size_t bytes, mc_err *err)
{
	if (r->ring && mc_ring_slot_bytes(r->ring) >= bytes)
		return 0;
	if (bytes > MAX_SLOT_BYTES)
		return mc_err_set(err, "frames of %zu bytes are larger than the %u MiB limit", bytes, MAX_SLOT_BYTES >> 20);
	mc_ring *ring = mc_ring_create(r->name, r->slots, bytes, err);
	if (!ring)
		return -1;
	pthread_mutex_lock(&r->lock);
	mc_ring *old = r->ring;
	r->ring = ring;
	r->generation++;
	pthread_mutex_unlock(&r->lock);
	mc_ring_close(old);
	return 1;
}

/* Grows *buf to the ring's slot size. */
static int fit(mcd_frame_ring *r, uint8_t **buf, size_t *cap, mc_err *err)
{
	size_t need = mc_ring_slot_bytes(r->ring);
	if (*cap >= need)
		return 0;
	uint8_t *grown = realloc(*buf, need);
	if (!grown)
		return mc_err_set(err, "camera %s: out of memory", r->name);
	*buf = grown;
	*cap = need;
	return 0;
}

int mcd_frame_ring_read(mcd_frame_ring *r, uint64_t generation, uint64_t sequence, uint8_t **buf, size_t *cap,
			mc_ring_meta *meta, mc_err *err)
{
	pthread_mutex_lock(&r->lock);
	int rc = MC_RING_NONE;
	if (r->ring && generation != r->generation)
		rc = MC_RING_GAP; /* the ring it was in is gone */
	else if (r->ring && fit(r, buf, cap, err))
		rc = -1;
	else if (r->ring) {
		mc_ring_cursor cur = {.next = sequence};
		rc = mc_ring_read_next(r->ring, &cur, *buf, *cap, meta, err);
		if (rc == MC_RING_NONE || (rc == MC_RING_FRAME && meta->sequence != sequence))
			rc = MC_RING_GAP;
	}
	pthread_mutex_unlock(&r->lock);
	return rc;
}

int mcd_frame_ring_dup(mcd_frame_ring *r, uint64_t *size)
{
	pthread_mutex_lock(&r->lock);
	int fd = -1;
	if (r->ring) {
		fd = fcntl(mc_ring_fd(r->ring), F_DUPFD_CLOEXEC, 3);
		struct stat st;
		if (fd >= 0 && fstat(fd, &st) == 0)
			*size = (uint64_t)st.st_size;
	}
	pthread_mutex_unlock(&r->lock);
	return fd;
}

int mcd_frame_to_rgb(mc_image_conv *conv, const mc_ring_meta *meta, const uint8_t *raw, uint8_t **rgb, size_t *cap,
		     int *w, int *h, mc_err *err)
{
	mc_image_frame fr = {.pixfmt = meta->pixfmt, .width = meta->width, .height = meta->height,
			     .stride = meta->stride, .data = raw, .bytes = meta->bytesused};
	*w = (int)meta->width;
	*h = (int)meta->height;
	if (meta->pixfmt == MC_PIXFMT_MJPEG && (*w == 0 || *h == 0)) {
		if (mc_image_jpeg_size(conv, raw, meta->bytesused, w, h, err))
			return -1;
	}
	size_t need = (size_t)*w * (size_t)*h * 3;
	if (*cap < need) {
		uint8_t *grown = realloc(*rgb, need);
		if (!grown)
			return mc_err_set(err, "out of memory");
		*rgb = grown;
		*cap = need;
	}
	return mc_image_to_rgb24(conv, &fr, *rgb, need, err);
}
