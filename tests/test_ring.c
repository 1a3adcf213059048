/* Tests of core/ring/mc_ring: the seqlocked shared-memory frame ring.
 *
 * Every frame is filled with a pattern derived from its sequence number, so
 * that a reader can tell a frame that mixes two writes from a good one.
 * The concurrent part also runs under ThreadSanitizer (tests/ring.mk). */
#include "ring/mc_ring.h"
#include "base/mc_time.h"
#include "test_util.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* ---- the pattern ---- */

static uint64_t pattern_word(uint64_t seq, size_t i) { return (seq + 1) * 0x9E3779B97F4A7C15ull ^ (i * 0x100000001ull); }

/* Sizes vary with the sequence so that metadata and data must agree too. */
static size_t frame_bytes(uint64_t seq, size_t slot_bytes)
{
	size_t words = slot_bytes / 8;
	return 8 * (words / 2 + (size_t)(seq * 7919 % (words / 2 + 1)));
}

static void fill_frame(uint8_t *p, uint64_t seq, size_t bytes)
{
	uint64_t *w = (uint64_t *)p;
	for (size_t i = 0; i < bytes / 8; i++)
		w[i] = pattern_word(seq, i);
}

static mc_ring_meta frame_meta(uint64_t seq, size_t bytes)
{
	return (mc_ring_meta){.timestamp_ns = 1000000 + seq * 16666667ull, .driver_sequence = seq + 100,
			      .bytesused = bytes, .pixfmt = 3, .width = 640, .height = 480, .stride = 1280,
			      .flags = (uint32_t)(seq & 1)};
}

/* 1 if the frame and its metadata are exactly what the writer wrote. */
static int frame_ok(const uint8_t *p, const mc_ring_meta *m, size_t slot_bytes)
{
	uint64_t seq = m->sequence;
	mc_ring_meta want = frame_meta(seq, frame_bytes(seq, slot_bytes));
	if (m->bytesused != want.bytesused || m->timestamp_ns != want.timestamp_ns ||
	    m->driver_sequence != want.driver_sequence || m->pixfmt != want.pixfmt || m->width != want.width ||
	    m->height != want.height || m->stride != want.stride || m->flags != want.flags || m->commit_ns == 0)
		return 0;
	const uint64_t *w = (const uint64_t *)p;
	for (size_t i = 0; i < m->bytesused / 8; i++)
		if (w[i] != pattern_word(seq, i))
			return 0;
	return 1;
}

static int write_frame(mc_ring *r, uint64_t expect_seq)
{
	size_t cap = 0;
	uint8_t *p = mc_ring_slot_begin(r, &cap);
	if (!p)
		return -1;
	size_t bytes = frame_bytes(expect_seq, cap);
	fill_frame(p, expect_seq, bytes);
	mc_ring_meta m = frame_meta(expect_seq, bytes);
	mc_err err;
	if (mc_ring_slot_commit(r, &m, &err) != 0) {
		fprintf(stderr, "commit: %s\n", err.msg);
		return -1;
	}
	return m.sequence == expect_seq ? 0 : -1;
}

/* ---- single-threaded behaviour ---- */

static void test_basic(void)
{
	mc_err err;
	mc_ring *w = mc_ring_create("basic", 4, 4096, &err);
	CHECK(w != NULL);
	if (!w)
		return;
	CHECK(mc_ring_fd(w) >= 0);
	CHECK(strcmp(mc_ring_name(w), "basic") == 0);
	CHECK(mc_ring_nslots(w) == 4 && mc_ring_slot_bytes(w) == 4096);
	uint8_t buf[4096];
	mc_ring_meta m;
	mc_ring_cursor cur = mc_ring_cursor_oldest(w);
	CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == MC_RING_NONE);
	CHECK(mc_ring_read_latest(w, NULL, buf, sizeof(buf), &m, &err) == MC_RING_NONE);
	for (uint64_t s = 0; s < 3; s++)
		CHECK(write_frame(w, s) == 0);
	CHECK(mc_ring_head(w) == 3);

	/* A separate read-only mapping sees the same frames. */
	mc_ring *rd = mc_ring_map(mc_ring_fd(w), &err);
	CHECK_MSG(rd != NULL, "%s", err.msg);
	if (!rd) {
		mc_ring_close(w);
		return;
	}
	CHECK(strcmp(mc_ring_name(rd), "basic") == 0 && mc_ring_nslots(rd) == 4);
	CHECK(mc_ring_fd(rd) == -1);
	CHECK(mc_ring_slot_begin(rd, NULL) == NULL); /* read-only handle cannot write */
	mc_ring_cursor c2 = mc_ring_cursor_oldest(rd);
	for (uint64_t s = 0; s < 3; s++) {
		CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == MC_RING_FRAME);
		CHECK(m.sequence == s && frame_ok(buf, &m, 4096));
		memset(buf, 0, sizeof(buf));
		CHECK(mc_ring_read_next(rd, &c2, buf, sizeof(buf), &m, &err) == MC_RING_FRAME);
		CHECK(m.sequence == s && frame_ok(buf, &m, 4096));
	}
	CHECK(mc_ring_read_next(rd, &c2, buf, sizeof(buf), &m, &err) == MC_RING_NONE);
	CHECK(c2.missed == 0 && c2.torn == 0);

	/* Latest, with and without a cursor. */
	CHECK(mc_ring_read_latest(rd, NULL, buf, sizeof(buf), &m, &err) == MC_RING_FRAME && m.sequence == 2);
	mc_ring_cursor c3 = mc_ring_cursor_oldest(rd);
	CHECK(c3.next == 0);
	CHECK(mc_ring_read_latest(rd, &c3, buf, sizeof(buf), &m, &err) == MC_RING_FRAME && m.sequence == 2);
	CHECK(c3.next == 3 && c3.missed == 2);
	CHECK(mc_ring_read_latest(rd, &c3, buf, sizeof(buf), &m, &err) == MC_RING_NONE);
	mc_ring_cursor now = mc_ring_cursor_now(rd);
	CHECK(now.next == 3);

	/* A buffer too small is an error that leaves the cursor in place. */
	mc_ring_cursor c4 = mc_ring_cursor_oldest(rd);
	uint64_t before = c4.next;
	CHECK(mc_ring_read_next(rd, &c4, buf, 16, &m, &err) == -1);
	CHECK(strstr(err.msg, "needs") != NULL && strstr(err.msg, "basic") != NULL);
	CHECK(c4.next == before);

	/* Writer misuse. */
	size_t cap;
	uint8_t *p = mc_ring_slot_begin(w, &cap);
	CHECK(p != NULL && cap == 4096);
	CHECK(mc_ring_slot_begin(w, &cap) == NULL); /* already open */
	mc_ring_meta big = {.bytesused = 4097};
	CHECK(mc_ring_slot_commit(w, &big, &err) == -1);
	CHECK(strstr(err.msg, "does not fit") != NULL);
	CHECK(mc_ring_slot_commit(w, &big, &err) == -1); /* the failed commit closed the slot */
	CHECK(strstr(err.msg, "without an open slot") != NULL);
	/* An aborted slot reuses the sequence number. */
	CHECK(mc_ring_slot_begin(w, &cap) != NULL);
	mc_ring_slot_abort(w);
	CHECK(write_frame(w, 3) == 0);

	mc_ring_close(rd);
	mc_ring_close(w);

	CHECK(mc_ring_create("x", 1, 100, &err) == NULL && strstr(err.msg, "slots") != NULL);
	CHECK(mc_ring_create("x", 4, 0, &err) == NULL && strstr(err.msg, "slot size") != NULL);
	mc_ring_close(NULL);
}

/* A reader that falls behind sees a gap, then intact frames. */
/* Only the writer's own mapping may write: the fd handed to readers, even
 * reopened read-write through /proc, cannot be mapped writable or written. */
static void test_readers_cannot_write(void)
{
	mc_err err;
	mc_ring *w = mc_ring_create("sealed", 2, 4096, &err);
	CHECK(w != NULL);
	if (!w)
		return;
	CHECK(write_frame(w, 0) == 0); /* the writer still writes */
	char path[64];
	snprintf(path, sizeof(path), "/proc/self/fd/%d", mc_ring_fd(w));
	int fd = open(path, O_RDWR | O_CLOEXEC);
	CHECK(fd >= 0);
	if (fd >= 0) {
		void *p = mmap(NULL, 4096, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
		CHECK(p == MAP_FAILED && errno == EPERM);
		if (p != MAP_FAILED)
			munmap(p, 4096);
		char byte = 1;
		CHECK(pwrite(fd, &byte, 1, 0) < 0 && errno == EPERM);
		close(fd);
	}
	CHECK(write_frame(w, 1) == 0);
	mc_ring_close(w);
}

static void test_lagging_reader(void)
{
	mc_err err;
	mc_ring *w = mc_ring_create("lag", 4, 1024, &err);
	CHECK(w != NULL);
	if (!w)
		return;
	mc_ring_cursor cur = mc_ring_cursor_oldest(w);
	for (uint64_t s = 0; s < 20; s++)
		CHECK(write_frame(w, s) == 0);
	uint8_t buf[1024];
	mc_ring_meta m;
	CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == MC_RING_GAP);
	CHECK(cur.gap == 16 && cur.missed == 16 && cur.next == 16);
	for (uint64_t s = 16; s < 20; s++) {
		int rc = mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err);
		CHECK(rc == MC_RING_FRAME);
		CHECK(rc == MC_RING_FRAME && m.sequence == s && frame_ok(buf, &m, 1024));
	}
	CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == MC_RING_NONE);
	/* The writer has begun frame 20 in slot 0 (frame 16's): a reader at 16
	 * must not get frame 16. */
	mc_ring_cursor late = {.next = 16};
	size_t cap;
	CHECK(mc_ring_slot_begin(w, &cap) != NULL);
	CHECK(mc_ring_read_next(w, &late, buf, sizeof(buf), &m, &err) == MC_RING_GAP);
	CHECK(late.next == 17 && late.gap == 1 && late.torn == 1);
	CHECK(mc_ring_read_next(w, &late, buf, sizeof(buf), &m, &err) == MC_RING_FRAME && m.sequence == 17);
	mc_ring_slot_abort(w);
	CHECK(mc_ring_cursor_oldest(w).next == 17);
	mc_ring_close(w);
}

/* ---- torn reads, made to happen deterministically ---- */

struct hook_ctx {
	mc_ring *w;
	uint64_t seq;
	int commit; /* 0: only begin (writer mid-frame), 1: write whole frames up to seq */
	int fired;
};

static void overwrite_hook(void *p)
{
	struct hook_ctx *h = p;
	if (h->fired++)
		return;
	if (h->commit) {
		while (mc_ring_head(h->w) <= h->seq)
			write_frame(h->w, mc_ring_head(h->w));
	} else {
		size_t cap;
		uint8_t *d = mc_ring_slot_begin(h->w, &cap);
		memset(d, 0xAB, 64); /* the reader's copy is now half old, half new */
	}
}

static void test_torn_read(void)
{
	mc_err err;
	uint8_t buf[2048];
	mc_ring_meta m;
	for (int commit = 0; commit <= 1; commit++) {
		mc_ring *w = mc_ring_create("torn", 2, 2048, &err);
		CHECK(w != NULL);
		if (!w)
			return;
		CHECK(write_frame(w, 0) == 0);
		CHECK(write_frame(w, 1) == 0);
		mc_ring *rd = mc_ring_map(mc_ring_fd(w), &err);
		CHECK(rd != NULL);
		if (!rd) {
			mc_ring_close(w);
			return;
		}
		/* While the reader copies frame 0, the writer starts (or
		 * finishes) frame 2 in the same slot. */
		struct hook_ctx h = {.w = w, .seq = 2, .commit = commit};
		mc_ring_set_copy_hook(rd, overwrite_hook, &h);
		mc_ring_cursor cur = {.next = 0};
		memset(&m, 0, sizeof(m));
		int rc = mc_ring_read_next(rd, &cur, buf, sizeof(buf), &m, &err);
		CHECK(h.fired == 1);
		CHECK_MSG(rc == MC_RING_GAP, "rc %d (commit %d)", rc, commit);
		CHECK(cur.torn == 1 && cur.missed == 1 && cur.next == 1);
		CHECK(m.sequence == 0 && m.bytesused == 0); /* meta untouched by a torn copy */
		mc_ring_set_copy_hook(rd, NULL, NULL);
		rc = mc_ring_read_next(rd, &cur, buf, sizeof(buf), &m, &err);
		CHECK(rc == MC_RING_FRAME && m.sequence == 1 && frame_ok(buf, &m, 2048));
		if (commit) {
			rc = mc_ring_read_next(rd, &cur, buf, sizeof(buf), &m, &err);
			CHECK(rc == MC_RING_FRAME && m.sequence == 2 && frame_ok(buf, &m, 2048));
		} else {
			mc_ring_slot_abort(w);
		}

		/* read_latest retries past a torn copy and returns the newer
		 * frame (two frames later, the newest one's slot is reused). */
		h = (struct hook_ctx){.w = w, .seq = mc_ring_head(w) + 1, .commit = 1};
		mc_ring_set_copy_hook(rd, overwrite_hook, &h);
		mc_ring_cursor lc = {.next = 0};
		rc = mc_ring_read_latest(rd, &lc, buf, sizeof(buf), &m, &err);
		CHECK(rc == MC_RING_FRAME && m.sequence == h.seq && frame_ok(buf, &m, 2048));
		CHECK(lc.torn == 1 && lc.next == h.seq + 1);
		mc_ring_close(rd);
		mc_ring_close(w);
	}
}

/* The same torn state made by writing into the shared memory directly:
 * an odd lock word (a writer that died mid-frame) is never read as a frame. */
static void test_poked_lock(void)
{
	mc_err err;
	mc_ring *w = mc_ring_create("poke", 4, 1024, &err);
	CHECK(w != NULL);
	if (!w)
		return;
	for (uint64_t s = 0; s < 3; s++)
		CHECK(write_frame(w, s) == 0);
	size_t bytes;
	uint8_t *raw = mc_ring_shared_memory(w, &bytes);
	/* Layout version 1: the slot headers follow the 192-byte header (the
	 * first field, the lock word, at the start of each 64-byte slot). */
	uint64_t *lock1 = (uint64_t *)(raw + 192 + 64 * 1);
	CHECK(*lock1 == 2 * 1 + 2);
	*lock1 = 2 * 1 + 1; /* frame 1 "being written" */
	uint8_t buf[1024];
	mc_ring_meta m;
	mc_ring_cursor cur = {.next = 0};
	CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == MC_RING_FRAME && m.sequence == 0);
	CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == MC_RING_GAP);
	CHECK(cur.torn == 1 && cur.next == 2);
	CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == MC_RING_FRAME && m.sequence == 2);
	/* A corrupt bytesused from a foreign writer is an error, not an overrun. */
	uint64_t *bytesused2 = (uint64_t *)(raw + 192 + 64 * 2 + 32);
	*bytesused2 = 1 << 20;
	cur.next = 2;
	CHECK(mc_ring_read_next(w, &cur, buf, sizeof(buf), &m, &err) == -1);
	CHECK(strstr(err.msg, "corrupt") != NULL);
	mc_ring_close(w);
}

/* ---- mapping bad descriptors and bad headers ---- */

/* A sealed memfd holding a copy of `src` (n bytes) with `patch` applied. */
static int sealed_copy(const uint8_t *src, size_t n, size_t off, const void *patch, size_t plen, int seal)
{
	int fd = memfd_create("bad-ring", MFD_CLOEXEC | MFD_ALLOW_SEALING);
	if (fd < 0)
		return -1;
	uint8_t *tmp = malloc(n);
	memcpy(tmp, src, n);
	if (patch)
		memcpy(tmp + off, patch, plen);
	if (write(fd, tmp, n) != (ssize_t)n) {
		free(tmp);
		close(fd);
		return -1;
	}
	free(tmp);
	if (seal)
		fcntl(fd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW);
	return fd;
}

static void expect_map_fails(int fd, const char *what, const char *needle)
{
	mc_err err = {{0}};
	mc_ring *r = mc_ring_map(fd, &err);
	CHECK_MSG(r == NULL, "%s mapped", what);
	CHECK_MSG(strstr(err.msg, needle) != NULL, "%s: message '%s' lacks '%s'", what, err.msg, needle);
	mc_ring_close(r);
	if (fd >= 0)
		close(fd);
}

static void test_bad_map(void)
{
	mc_err err;
	expect_map_fails(-1, "fd -1", "ring fd -1");
	int pfd[2];
	CHECK(pipe(pfd) == 0);
	close(pfd[1]);
	expect_map_fails(pfd[0], "pipe", "not a ring");

	mc_ring *w = mc_ring_create("good", 3, 5000, &err);
	CHECK(w != NULL);
	if (!w)
		return;
	write_frame(w, 0);
	size_t n = (size_t)lseek(mc_ring_fd(w), 0, SEEK_END);
	uint8_t *img = malloc(n);
	CHECK(pread(mc_ring_fd(w), img, n, 0) == (ssize_t)n);

	/* Sanity: an intact sealed copy maps. */
	int fd = sealed_copy(img, n, 0, NULL, 0, 1);
	mc_ring *ok = mc_ring_map(fd, &err);
	CHECK_MSG(ok != NULL, "%s", err.msg);
	mc_ring_close(ok);
	close(fd);

	expect_map_fails(sealed_copy(img, n, 0, NULL, 0, 0), "unsealed", "not sealed");
	uint8_t garbage[256];
	for (size_t i = 0; i < sizeof(garbage); i++)
		garbage[i] = (uint8_t)(i * 37 + 11);
	expect_map_fails(sealed_copy(garbage, sizeof(garbage), 0, NULL, 0, 1), "garbage", "magic");
	expect_map_fails(sealed_copy(img, 32, 0, NULL, 0, 1), "truncated header", "smaller than its header");
	uint32_t v = 99;
	expect_map_fails(sealed_copy(img, n, 8, &v, 4, 1), "version", "version");
	v = 1;
	expect_map_fails(sealed_copy(img, n, 16, &v, 4, 1), "nslots 1", "nslots");
	v = 100000;
	expect_map_fails(sealed_copy(img, n, 16, &v, 4, 1), "nslots huge", "nslots");
	v = 12;
	expect_map_fails(sealed_copy(img, n, 20, &v, 4, 1), "data_offset", "data_offset");
	uint64_t big = 1ull << 40;
	expect_map_fails(sealed_copy(img, n, 24, &big, 8, 1), "slot_bytes", "slot_bytes");
	uint64_t stride = 8192 * 4;
	expect_map_fails(sealed_copy(img, n, 32, &stride, 8, 1), "slot_stride beyond the file", "total_bytes");
	/* A file cut short (header intact) is refused too. */
	expect_map_fails(sealed_copy(img, n - 4096, 0, NULL, 0, 1), "short file", "total_bytes");
	free(img);
	mc_ring_close(w);
}

/* ---- one producer, several concurrent readers ---- */

#define CONC_FRAMES 4000
#define CONC_SLOT 16384

struct conc {
	mc_ring *w;
	atomic_int done;
};

struct reader {
	struct conc *c;
	const mc_ring *ring; /* the writer's handle or a separate mapping */
	int slow;            /* sleeps between reads: forced gaps */
	int use_wait;        /* blocks on the futex instead of spinning */
	uint64_t frames, bad, order_errors;
	mc_ring_cursor cur;
};

static void *producer(void *arg)
{
	struct conc *c = arg;
	for (uint64_t s = 0; s < CONC_FRAMES; s++) {
		if (write_frame(c->w, s) != 0)
			break;
		if (s % 4 == 0)
			sched_yield();
	}
	atomic_store(&c->done, 1);
	return NULL;
}

static void *reader(void *arg)
{
	struct reader *r = arg;
	uint8_t *buf = malloc(CONC_SLOT);
	mc_err err;
	mc_ring_meta m;
	uint64_t last = 0;
	int have_last = 0;
	r->cur = (mc_ring_cursor){.next = 0};
	for (;;) {
		int done = atomic_load(&r->c->done);
		int rc = mc_ring_read_next(r->ring, &r->cur, buf, CONC_SLOT, &m, &err);
		if (rc == MC_RING_FRAME) {
			r->frames++;
			if (!frame_ok(buf, &m, CONC_SLOT))
				r->bad++;
			if (have_last && m.sequence <= last)
				r->order_errors++;
			last = m.sequence;
			have_last = 1;
			if (r->slow) {
				struct timespec ts = {0, 200000};
				nanosleep(&ts, NULL);
			}
		} else if (rc == MC_RING_NONE) {
			if (done && r->cur.next >= CONC_FRAMES)
				break;
			if (r->use_wait)
				mc_ring_wait(r->ring, &r->cur, 5, &err);
			else
				sched_yield();
		} else if (rc < 0) {
			fprintf(stderr, "reader: %s\n", err.msg);
			r->bad++;
			break;
		}
	}
	free(buf);
	return NULL;
}

static void test_concurrent(void)
{
	mc_err err;
	struct conc c = {.w = mc_ring_create("conc", 8, CONC_SLOT, &err)};
	CHECK(c.w != NULL);
	if (!c.w)
		return;
	atomic_init(&c.done, 0);
	mc_ring *mapped = mc_ring_map(mc_ring_fd(c.w), &err);
	CHECK(mapped != NULL);
	if (!mapped) {
		mc_ring_close(c.w);
		return;
	}
	struct reader rs[4] = {
		{.c = &c, .ring = c.w},
		{.c = &c, .ring = c.w, .use_wait = 1},
		{.c = &c, .ring = mapped, .use_wait = 1},
		{.c = &c, .ring = c.w, .slow = 1},
	};
	pthread_t rt[4], pt;
	for (int i = 0; i < 4; i++)
		pthread_create(&rt[i], NULL, reader, &rs[i]);
	pthread_create(&pt, NULL, producer, &c);
	pthread_join(pt, NULL);
	for (int i = 0; i < 4; i++)
		pthread_join(rt[i], NULL);
	for (int i = 0; i < 4; i++) {
		struct reader *r = &rs[i];
		printf("reader %d: %llu frames, %llu missed, %llu torn\n", i, (unsigned long long)r->frames,
		       (unsigned long long)r->cur.missed, (unsigned long long)r->cur.torn);
		CHECK_MSG(r->bad == 0, "reader %d: %llu corrupt frames", i, (unsigned long long)r->bad);
		CHECK(r->order_errors == 0);
		/* Every frame is either read or counted as missed. */
		CHECK_MSG(r->frames + r->cur.missed == CONC_FRAMES, "reader %d: %llu + %llu != %d", i,
			  (unsigned long long)r->frames, (unsigned long long)r->cur.missed, CONC_FRAMES);
		CHECK(r->frames > 0);
	}
	CHECK(rs[3].cur.missed > 0); /* the slow reader was lapped */
	mc_ring_close(mapped);
	mc_ring_close(c.w);
}

/* ---- waiting ---- */

static void *late_writer(void *arg)
{
	struct timespec ts = {0, 30 * 1000000};
	nanosleep(&ts, NULL);
	write_frame(arg, 0);
	return NULL;
}

static void test_wait(void)
{
	mc_err err;
	mc_ring *w = mc_ring_create("wait", 4, 256, &err);
	CHECK(w != NULL);
	if (!w)
		return;
	mc_ring *rd = mc_ring_map(mc_ring_fd(w), &err);
	CHECK(rd != NULL);
	if (!rd) {
		mc_ring_close(w);
		return;
	}
	mc_ring_cursor cur = mc_ring_cursor_now(rd);
	uint64_t t0 = mc_now_ns();
	CHECK(mc_ring_wait(rd, &cur, 20, &err) == 0);
	double t = (mc_ms_since(t0) / 1e3);
	CHECK_MSG(t >= 0.019 && t < 0.5, "timeout took %.3f s", t);

	pthread_t th;
	t0 = mc_now_ns();
	pthread_create(&th, NULL, late_writer, w);
	CHECK(mc_ring_wait(rd, &cur, 5000, &err) == 1); /* woken through the read-only mapping */
	t = (mc_ms_since(t0) / 1e3);
	pthread_join(th, NULL);
	CHECK_MSG(t < 2.0, "wake took %.3f s", t);
	CHECK(mc_ring_wait(rd, &cur, 0, &err) == 1);
	mc_ring_close(rd);
	mc_ring_close(w);
}

/* ---- another process ---- */

static void test_other_process(void)
{
	mc_err err;
	mc_ring *w = mc_ring_create("fork", 16, 4096, &err);
	CHECK(w != NULL);
	if (!w)
		return;
	fflush(NULL);
	pid_t pid = fork();
	if (pid == 0) {
		/* Child: map the inherited fd read-only, read 50 frames. */
		mc_ring *rd = mc_ring_map(mc_ring_fd(w), &err);
		if (!rd)
			_exit(2);
		mc_ring_cursor cur = {.next = 0};
		uint8_t buf[4096];
		mc_ring_meta m;
		int good = 0, bad = 0;
		while (cur.next < 50) {
			if (mc_ring_wait(rd, &cur, 5000, &err) != 1)
				_exit(3);
			int rc = mc_ring_read_next(rd, &cur, buf, sizeof(buf), &m, &err);
			if (rc == MC_RING_FRAME)
				*(frame_ok(buf, &m, 4096) ? &good : &bad) += 1;
			else if (rc < 0)
				_exit(4);
		}
		_exit(bad ? 5 : good > 0 ? 0 : 6);
	}
	CHECK(pid > 0);
	for (uint64_t s = 0; s < 50; s++) {
		CHECK(write_frame(w, s) == 0);
		if (s % 10 == 0) {
			struct timespec ts = {0, 1000000};
			nanosleep(&ts, NULL);
		}
	}
	int status = 0;
	CHECK(waitpid(pid, &status, 0) == pid);
	CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 0, "child status %d", status);
	mc_ring_close(w);
}

int main(int argc, char **argv)
{
	/* `test_ring concurrent` runs only the threaded part (the TSan build). */
	int only_conc = argc > 1 && strcmp(argv[1], "concurrent") == 0;
	if (!only_conc) {
		test_basic();
		test_readers_cannot_write();
		test_lagging_reader();
		test_torn_read();
		test_poked_lock();
		test_bad_map();
		test_wait();
		test_other_process();
	}
	test_concurrent();
	return mc_test_finish("test_ring");
}
