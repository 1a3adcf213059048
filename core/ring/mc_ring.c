/* mc_ring: seqlocked frame slots in sealed memfd shared memory (see mc_ring.h). */
#include "ring/mc_ring.h"

#include "base/mc_time.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <linux/futex.h>
#include <stdalign.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

/* The ring is shared between processes: its atomics must not hide a lock. */
_Static_assert(ATOMIC_LLONG_LOCK_FREE == 2, "64-bit atomics must be lock-free");
_Static_assert(ATOMIC_INT_LOCK_FREE == 2, "32-bit atomics must be lock-free");

#define RING_PAGE 4096u

/* ThreadSanitizer cannot see that a raced copy is discarded by the seqlock
 * check, so the bulk copy is hidden from it (the lock and the metadata,
 * which are atomics, stay checked). */
#if defined(__SANITIZE_THREAD__)
#define RING_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define RING_TSAN 1
#endif
#endif
#ifdef RING_TSAN
void AnnotateIgnoreReadsBegin(const char *file, int line);
void AnnotateIgnoreReadsEnd(const char *file, int line);
#define RACY_READS_BEGIN() AnnotateIgnoreReadsBegin(__FILE__, __LINE__)
#define RACY_READS_END() AnnotateIgnoreReadsEnd(__FILE__, __LINE__)
/* TSan does not model fences; GCC warns about them under -Werror. The
 * orders they give are still needed on real hardware and stay in. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wtsan"
#endif
#else
#define RACY_READS_BEGIN() ((void)0)
#define RACY_READS_END() ((void)0)
#endif

/* One slot's seqlock and metadata: a cache line. */
struct ring_slot {
	_Atomic uint64_t lock; /* 2N+1: writing frame N; 2N+2: frame N committed; 0: empty */
	_Atomic uint64_t timestamp_ns;
	_Atomic uint64_t commit_ns;
	_Atomic uint64_t driver_sequence;
	_Atomic uint64_t bytesused;
	_Atomic uint32_t pixfmt, width, height, stride, flags;
	uint32_t pad_;
};
_Static_assert(sizeof(struct ring_slot) == 64, "slot header is one cache line");

/* The shared header at offset 0 of the memfd; layout version MC_RING_VERSION. */
struct ring_shm {
	uint64_t magic;
	uint32_t version;
	uint32_t slot_header_size; /* sizeof(struct ring_slot), catches layout drift */
	uint32_t nslots;
	uint32_t data_offset;      /* where slot 0's data starts (page multiple) */
	uint64_t slot_bytes;       /* data capacity of a slot */
	uint64_t slot_stride;      /* distance between two slots' data */
	uint64_t total_bytes;      /* size of the whole file */
	char name[MC_RING_NAME_MAX];
	alignas(64) _Atomic uint64_t head; /* frames committed = next sequence */
	_Atomic uint32_t wake;             /* futex word, bumped on every commit */
	alignas(64) struct ring_slot slots[];
};

/* The offsets docs/PROTOCOL_SHM.md ("Camera rings") gives to clients in other
 * languages. */
_Static_assert(offsetof(struct ring_shm, nslots) == 16 && offsetof(struct ring_shm, data_offset) == 20 &&
		       offsetof(struct ring_shm, slot_bytes) == 24 && offsetof(struct ring_shm, slot_stride) == 32 &&
		       offsetof(struct ring_shm, name) == 48 && offsetof(struct ring_shm, head) == 128 &&
		       offsetof(struct ring_shm, wake) == 136 && offsetof(struct ring_shm, slots) == 192,
	       "ring header layout (docs/PROTOCOL_SHM.md)");
_Static_assert(offsetof(struct ring_slot, timestamp_ns) == 8 && offsetof(struct ring_slot, bytesused) == 32 &&
		       offsetof(struct ring_slot, pixfmt) == 40 && offsetof(struct ring_slot, flags) == 56,
	       "ring slot layout (docs/PROTOCOL_SHM.md)");

struct mc_ring {
	struct ring_shm *shm;
	size_t map_bytes;
	int fd;        /* writer only; -1 for a mapped reader */
	bool writable;
	/* Copied from the header once validated, never re-read from shared
	 * memory: a foreign writer cannot change them under a reader. */
	unsigned nslots;
	size_t slot_bytes, slot_stride, data_offset;
	char name[MC_RING_NAME_MAX];
	/* writer state */
	bool slot_open;
	uint64_t next_seq;
	/* test hook */
	void (*copy_hook)(void *ctx);
	void *copy_hook_ctx;
};

static size_t round_up(size_t v, size_t a) { return (v + a - 1) / a * a; }

static struct ring_slot *slot_of(const mc_ring *r, uint64_t seq) { return &r->shm->slots[seq % r->nslots]; }

static uint8_t *data_of(const mc_ring *r, uint64_t seq)
{
	return (uint8_t *)r->shm + r->data_offset + (seq % r->nslots) * r->slot_stride;
}

static size_t header_bytes(unsigned nslots)
{
	return round_up(sizeof(struct ring_shm) + nslots * sizeof(struct ring_slot), RING_PAGE);
}

mc_ring *mc_ring_create(const char *name, unsigned nslots, size_t slot_bytes, mc_err *err)
{
	if (!name)
		name = "";
	if (nslots < 2 || nslots > MC_RING_MAX_SLOTS) {
		mc_err_set(err, "ring '%s': %u slots; need 2 to %d", name, nslots, MC_RING_MAX_SLOTS);
		return NULL;
	}
	if (slot_bytes == 0 || slot_bytes > ((size_t)1 << 32)) {
		mc_err_set(err, "ring '%s': slot size %zu bytes out of range (1 byte to 4 GiB)", name, slot_bytes);
		return NULL;
	}
	size_t data_offset = header_bytes(nslots);
	size_t stride = round_up(slot_bytes, RING_PAGE);
	size_t total = data_offset + (size_t)nslots * stride;

	char label[MC_RING_NAME_MAX + 16];
	snprintf(label, sizeof(label), "mocap-ring:%s", name);
	int fd = memfd_create(label, MFD_CLOEXEC | MFD_ALLOW_SEALING);
	if (fd < 0) {
		mc_err_set(err, "ring '%s': memfd_create: %s", name, strerror(errno));
		return NULL;
	}
	if (ftruncate(fd, (off_t)total) != 0) {
		mc_err_set(err, "ring '%s': ftruncate to %zu bytes: %s", name, total, strerror(errno));
		close(fd);
		return NULL;
	}
	/* Readers in other processes must be able to trust the size. */
	if (fcntl(fd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW) != 0) {
		mc_err_set(err, "ring '%s': sealing the memfd: %s", name, strerror(errno));
		close(fd);
		return NULL;
	}
	void *p = mmap(NULL, total, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
	if (p == MAP_FAILED) {
		mc_err_set(err, "ring '%s': mmap of %zu bytes: %s", name, total, strerror(errno));
		close(fd);
		return NULL;
	}
	/* Only this mapping may write: a reader given the fd (or reopening
	 * /proc/self/fd/N) cannot map it writable or write() to it. */
	if (fcntl(fd, F_ADD_SEALS, F_SEAL_FUTURE_WRITE | F_SEAL_SEAL) != 0) {
		mc_err_set(err, "ring '%s': sealing the memfd against writers: %s", name, strerror(errno));
		munmap(p, total);
		close(fd);
		return NULL;
	}
	mc_ring *r = calloc(1, sizeof(*r));
	if (!r) {
		mc_err_set(err, "ring '%s': out of memory", name);
		munmap(p, total);
		close(fd);
		return NULL;
	}
	struct ring_shm *shm = p; /* the fresh memfd is zero-filled */
	shm->magic = MC_RING_MAGIC;
	shm->version = MC_RING_VERSION;
	shm->slot_header_size = sizeof(struct ring_slot);
	shm->nslots = nslots;
	shm->data_offset = (uint32_t)data_offset;
	shm->slot_bytes = slot_bytes;
	shm->slot_stride = stride;
	shm->total_bytes = total;
	snprintf(shm->name, sizeof(shm->name), "%s", name);
	atomic_store_explicit(&shm->head, 0, memory_order_release);

	*r = (mc_ring){.shm = shm, .map_bytes = total, .fd = fd, .writable = true, .nslots = nslots,
		       .slot_bytes = slot_bytes, .slot_stride = stride, .data_offset = data_offset};
	snprintf(r->name, sizeof(r->name), "%s", name);
	return r;
}

/* Checks a foreign header; the message names the field that is wrong. */
static int validate_header(const struct ring_shm *h, size_t file_bytes, mc_err *err)
{
	if (h->magic != MC_RING_MAGIC)
		return mc_err_set(err, "magic: 0x%016llx is not a mocap frame ring", (unsigned long long)h->magic);
	if (h->version != MC_RING_VERSION)
		return mc_err_set(err, "version: %u, this build reads version %u", h->version, MC_RING_VERSION);
	if (h->slot_header_size != sizeof(struct ring_slot))
		return mc_err_set(err, "slot_header_size: %u, expected %zu", h->slot_header_size,
				  sizeof(struct ring_slot));
	if (h->nslots < 2 || h->nslots > MC_RING_MAX_SLOTS)
		return mc_err_set(err, "nslots: %u out of range 2..%d", h->nslots, MC_RING_MAX_SLOTS);
	if (h->data_offset % RING_PAGE || h->data_offset < header_bytes(h->nslots))
		return mc_err_set(err, "data_offset: %u overlaps the slot headers or is not page aligned",
				  h->data_offset);
	if (h->slot_bytes == 0 || h->slot_stride < h->slot_bytes || h->slot_stride > ((uint64_t)1 << 33))
		return mc_err_set(err, "slot_bytes %llu / slot_stride %llu inconsistent",
				  (unsigned long long)h->slot_bytes, (unsigned long long)h->slot_stride);
	uint64_t need = h->data_offset + (uint64_t)h->nslots * h->slot_stride;
	if (h->total_bytes != need || need > file_bytes)
		return mc_err_set(err, "total_bytes: header says %llu, slots need %llu, the file has %zu",
				  (unsigned long long)h->total_bytes, (unsigned long long)need, file_bytes);
	return 0;
}

mc_ring *mc_ring_map(int fd, mc_err *err)
{
	struct stat st;
	if (fstat(fd, &st) != 0) {
		mc_err_set(err, "ring fd %d: %s", fd, strerror(errno));
		return NULL;
	}
	if (!S_ISREG(st.st_mode) || (size_t)st.st_size < sizeof(struct ring_shm)) {
		mc_err_set(err, "ring fd %d: not a ring (%lld bytes, smaller than its header)", fd,
			   (long long)st.st_size);
		return NULL;
	}
	int seals = fcntl(fd, F_GET_SEALS);
	if (seals < 0 || !(seals & F_SEAL_SHRINK)) {
		mc_err_set(err, "ring fd %d: not sealed against shrinking (F_SEAL_SHRINK), refusing to map", fd);
		return NULL;
	}
	size_t bytes = (size_t)st.st_size;
	void *p = mmap(NULL, bytes, PROT_READ, MAP_SHARED, fd, 0);
	if (p == MAP_FAILED) {
		mc_err_set(err, "ring fd %d: mmap: %s", fd, strerror(errno));
		return NULL;
	}
	const struct ring_shm *h = p;
	if (validate_header(h, bytes, err) != 0) {
		mc_err_prefix(err, "ring fd %d: header", fd);
		munmap(p, bytes);
		return NULL;
	}
	mc_ring *r = calloc(1, sizeof(*r));
	if (!r) {
		mc_err_set(err, "ring fd %d: out of memory", fd);
		munmap(p, bytes);
		return NULL;
	}
	*r = (mc_ring){.shm = p, .map_bytes = bytes, .fd = -1, .writable = false, .nslots = h->nslots,
		       .slot_bytes = h->slot_bytes, .slot_stride = h->slot_stride, .data_offset = h->data_offset};
	memcpy(r->name, h->name, sizeof(r->name));
	r->name[sizeof(r->name) - 1] = 0;
	return r;
}

void mc_ring_close(mc_ring *ring)
{
	if (!ring)
		return;
	munmap(ring->shm, ring->map_bytes);
	if (ring->fd >= 0)
		close(ring->fd);
	free(ring);
}

int mc_ring_fd(const mc_ring *ring) { return ring->fd; }
const char *mc_ring_name(const mc_ring *ring) { return ring->name; }
unsigned mc_ring_nslots(const mc_ring *ring) { return ring->nslots; }
size_t mc_ring_slot_bytes(const mc_ring *ring) { return ring->slot_bytes; }

uint64_t mc_ring_head(const mc_ring *ring)
{
	return atomic_load_explicit(&ring->shm->head, memory_order_acquire);
}

void *mc_ring_shared_memory(mc_ring *ring, size_t *bytes)
{
	*bytes = ring->map_bytes;
	return ring->shm;
}

void mc_ring_set_copy_hook(mc_ring *ring, void (*hook)(void *ctx), void *ctx)
{
	ring->copy_hook = hook;
	ring->copy_hook_ctx = ctx;
}

/* ---- writer ---- */

uint8_t *mc_ring_slot_begin(mc_ring *ring, size_t *capacity)
{
	if (!ring->writable || ring->slot_open)
		return NULL;
	uint64_t seq = ring->next_seq;
	struct ring_slot *s = slot_of(ring, seq);
	/* Odd: readers of the frame this slot held see it as being rewritten.
	 * The release fence keeps the data stores that follow after this one. */
	atomic_store_explicit(&s->lock, 2 * seq + 1, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
	ring->slot_open = true;
	if (capacity)
		*capacity = ring->slot_bytes;
	return data_of(ring, seq);
}

static void futex_wake_all(_Atomic uint32_t *word)
{
	syscall(SYS_futex, (uint32_t *)word, FUTEX_WAKE, INT_MAX, NULL, NULL, 0);
}

int mc_ring_slot_commit(mc_ring *ring, mc_ring_meta *meta, mc_err *err)
{
	if (!ring->slot_open)
		return mc_err_set(err, "ring '%s': commit without an open slot", ring->name);
	if (meta->bytesused > ring->slot_bytes) {
		mc_ring_slot_abort(ring);
		return mc_err_set(err, "ring '%s': frame of %llu bytes does not fit a %zu-byte slot", ring->name,
				  (unsigned long long)meta->bytesused, ring->slot_bytes);
	}
	uint64_t seq = ring->next_seq;
	struct ring_slot *s = slot_of(ring, seq);
	meta->sequence = seq;
	meta->commit_ns = mc_now_ns();
	atomic_store_explicit(&s->timestamp_ns, meta->timestamp_ns, memory_order_relaxed);
	atomic_store_explicit(&s->commit_ns, meta->commit_ns, memory_order_relaxed);
	atomic_store_explicit(&s->driver_sequence, meta->driver_sequence, memory_order_relaxed);
	atomic_store_explicit(&s->bytesused, meta->bytesused, memory_order_relaxed);
	atomic_store_explicit(&s->pixfmt, meta->pixfmt, memory_order_relaxed);
	atomic_store_explicit(&s->width, meta->width, memory_order_relaxed);
	atomic_store_explicit(&s->height, meta->height, memory_order_relaxed);
	atomic_store_explicit(&s->stride, meta->stride, memory_order_relaxed);
	atomic_store_explicit(&s->flags, meta->flags, memory_order_relaxed);
	/* Release: a reader that sees 2N+2 sees the data and metadata above. */
	atomic_store_explicit(&s->lock, 2 * seq + 2, memory_order_release);
	atomic_store_explicit(&ring->shm->head, seq + 1, memory_order_release);
	ring->next_seq = seq + 1;
	ring->slot_open = false;
	atomic_fetch_add_explicit(&ring->shm->wake, 1, memory_order_release);
	futex_wake_all(&ring->shm->wake);
	return 0;
}

void mc_ring_slot_abort(mc_ring *ring)
{
	/* The slot stays odd: the frame it held is gone, and the next begin
	 * writes the same sequence number into it again. */
	ring->slot_open = false;
}

/* ---- readers ---- */

mc_ring_cursor mc_ring_cursor_now(const mc_ring *ring)
{
	return (mc_ring_cursor){.next = mc_ring_head(ring)};
}

mc_ring_cursor mc_ring_cursor_oldest(const mc_ring *ring)
{
	uint64_t head = mc_ring_head(ring);
	/* The slot after the newest may be being rewritten already. */
	uint64_t keep = ring->nslots - 1;
	return (mc_ring_cursor){.next = head > keep ? head - keep : 0};
}

enum copy_result { COPY_OK, COPY_LOST, COPY_TORN, COPY_TOO_SMALL, COPY_CORRUPT };

/* Copies frame `seq` if its slot still holds it; never returns raced data. */
static enum copy_result copy_frame(const mc_ring *r, uint64_t seq, void *dst, size_t cap, mc_ring_meta *meta,
				   uint64_t *need)
{
	struct ring_slot *s = slot_of(r, seq);
	uint64_t want = 2 * seq + 2;
	uint64_t l1 = atomic_load_explicit(&s->lock, memory_order_acquire);
	if (l1 != want)
		return (l1 & 1) ? COPY_TORN : COPY_LOST; /* being rewritten, or already overwritten */
	mc_ring_meta m = {
		.sequence = seq,
		.timestamp_ns = atomic_load_explicit(&s->timestamp_ns, memory_order_relaxed),
		.commit_ns = atomic_load_explicit(&s->commit_ns, memory_order_relaxed),
		.driver_sequence = atomic_load_explicit(&s->driver_sequence, memory_order_relaxed),
		.bytesused = atomic_load_explicit(&s->bytesused, memory_order_relaxed),
		.pixfmt = atomic_load_explicit(&s->pixfmt, memory_order_relaxed),
		.width = atomic_load_explicit(&s->width, memory_order_relaxed),
		.height = atomic_load_explicit(&s->height, memory_order_relaxed),
		.stride = atomic_load_explicit(&s->stride, memory_order_relaxed),
		.flags = atomic_load_explicit(&s->flags, memory_order_relaxed),
	};
	enum copy_result res = COPY_OK;
	if (m.bytesused > r->slot_bytes)
		res = COPY_CORRUPT;
	else if (m.bytesused > cap)
		res = COPY_TOO_SMALL;
	else {
		RACY_READS_BEGIN();
		memcpy(dst, data_of(r, seq), m.bytesused);
		RACY_READS_END();
	}
	if (r->copy_hook)
		r->copy_hook(r->copy_hook_ctx);
	/* Acquire fence: the copy above completes before the lock is re-read. */
	atomic_thread_fence(memory_order_acquire);
	uint64_t l2 = atomic_load_explicit(&s->lock, memory_order_relaxed);
	if (l2 != l1)
		return COPY_TORN; /* metadata or data may mix two frames: discard */
	*need = m.bytesused;
	if (res == COPY_OK && meta)
		*meta = m;
	return res;
}

static uint64_t oldest_kept(const mc_ring *r, uint64_t head)
{
	return head > r->nslots ? head - r->nslots : 0;
}

static int report_copy_error(const mc_ring *r, enum copy_result res, uint64_t seq, uint64_t need, size_t cap,
			     mc_err *err)
{
	if (res == COPY_TOO_SMALL)
		return mc_err_set(err, "ring '%s': frame %llu needs %llu bytes, the buffer holds %zu", r->name,
				  (unsigned long long)seq, (unsigned long long)need, cap);
	return mc_err_set(err, "ring '%s': frame %llu: bytesused %llu exceeds the slot size %zu (corrupt ring)",
			  r->name, (unsigned long long)seq, (unsigned long long)need, r->slot_bytes);
}

int mc_ring_read_next(const mc_ring *ring, mc_ring_cursor *cursor, void *dst, size_t cap, mc_ring_meta *meta,
		      mc_err *err)
{
	uint64_t head = mc_ring_head(ring);
	if (cursor->next >= head)
		return MC_RING_NONE;
	uint64_t oldest = oldest_kept(ring, head);
	if (cursor->next < oldest) {
		cursor->gap = oldest - cursor->next;
		cursor->missed += cursor->gap;
		cursor->next = oldest;
		return MC_RING_GAP;
	}
	uint64_t seq = cursor->next, need = 0;
	enum copy_result res = copy_frame(ring, seq, dst, cap, meta, &need);
	switch (res) {
	case COPY_OK:
		cursor->next = seq + 1;
		cursor->gap = 0;
		return MC_RING_FRAME;
	case COPY_TORN:
	case COPY_LOST: {
		/* The writer lapped us while we looked: skip to what is still there. */
		if (res == COPY_TORN)
			cursor->torn++;
		uint64_t next = oldest_kept(ring, mc_ring_head(ring));
		if (next <= seq)
			next = seq + 1;
		cursor->gap = next - seq;
		cursor->missed += cursor->gap;
		cursor->next = next;
		return MC_RING_GAP;
	}
	default:
		return report_copy_error(ring, res, seq, need, cap, err);
	}
}

int mc_ring_read_latest(const mc_ring *ring, mc_ring_cursor *cursor, void *dst, size_t cap, mc_ring_meta *meta,
			mc_err *err)
{
	/* A few tries: each failure means a newer frame has just been written. */
	for (int attempt = 0; attempt < 8; attempt++) {
		uint64_t head = mc_ring_head(ring);
		if (head == 0 || (cursor && cursor->next >= head))
			return MC_RING_NONE;
		uint64_t seq = head - 1, need = 0;
		enum copy_result res = copy_frame(ring, seq, dst, cap, meta, &need);
		if (res == COPY_OK) {
			if (cursor) {
				cursor->gap = seq - cursor->next;
				cursor->missed += cursor->gap;
				cursor->next = seq + 1;
			}
			return MC_RING_FRAME;
		}
		if (res == COPY_TORN) {
			if (cursor)
				cursor->torn++;
			continue;
		}
		if (res == COPY_LOST)
			continue;
		return report_copy_error(ring, res, seq, need, cap, err);
	}
	return mc_err_set(err, "ring '%s': the writer kept overwriting the newest frame while it was read",
			  ring->name);
}

int mc_ring_wait(const mc_ring *ring, const mc_ring_cursor *cursor, int timeout_ms, mc_err *err)
{
	uint64_t deadline = timeout_ms >= 0 ? mc_now_ns() + (uint64_t)timeout_ms * 1000000ull : 0;
	_Atomic uint32_t *word = &ring->shm->wake;
	for (;;) {
		/* Read the futex word before checking, so that a commit in
		 * between makes the wait return at once. */
		uint32_t seen = atomic_load_explicit(word, memory_order_acquire);
		if (mc_ring_head(ring) > cursor->next)
			return 1;
		struct timespec ts, *tsp = NULL;
		if (timeout_ms >= 0) {
			uint64_t now = mc_now_ns();
			if (now >= deadline)
				return 0;
			uint64_t left = deadline - now;
			ts.tv_sec = (time_t)(left / 1000000000ull);
			ts.tv_nsec = (long)(left % 1000000000ull);
			tsp = &ts;
		}
		long rc = syscall(SYS_futex, (uint32_t *)word, FUTEX_WAIT, seen, tsp, NULL, 0);
		if (rc != 0 && errno != EAGAIN && errno != EINTR && errno != ETIMEDOUT)
			return mc_err_set(err, "ring '%s': futex wait: %s", ring->name, strerror(errno));
	}
}
