/* mocap-driver-faulty: a fault-injection camera for mocapd's tests.
 *
 * Delivers a synthetic moving pattern at `fps` on a grid of CLOCK_MONOTONIC
 * (frame k of every faulty camera has the same timestamp, as if the cameras
 * were hardware-synchronised) and misbehaves on request.  Keys of the
 * camera's config section (all optional):
 *
 *   device = ID              names the camera; faults that must survive a
 *                            reopen (fail_open_count, error_once,
 *                            disappear_after) are remembered per ID
 *   format = rgb24|gray8|yuyv|mjpeg     (rgb24)
 *   width = W, height = H    (64 x 48)
 *   fps = F                  (30)
 *   fail_open = true         every open fails (MDRV_ERR_IO)
 *   fail_open_count = N      the first N opens fail
 *   open_error = io|nodev|config|format  the status of failed opens (io)
 *   open_delay_ms = T        open takes T ms
 *   error_after = N          after N frames next_frame fails (error_code)
 *                            on every call until the camera is reopened
 *   error_code = io|nodev|format|config|nospace  (io)
 *   error_once = true        error_after fires only on the first opening
 *   short_every = N          every Nth frame is short (half its bytes), not flagged
 *   corrupt_every = N        every Nth frame is damaged: for mjpeg a broken
 *                            JPEG (not flagged), for raw formats flagged
 *                            MDRV_FRAME_CORRUPT
 *   drop_every = N           every Nth frame is never delivered
 *   disappear_after = N      after N frames (counted over the device's
 *                            life) the device is gone: next_frame and
 *                            open fail with MDRV_ERR_NODEV ...
 *   return_after_ms = T      ... until T ms later (default: never)
 *   end_after = N            the stream ends (MDRV_ERR_END) after N frames
 *                            (frame_count() says N; without it, not known)
 *   hang_after = N           after N frames next_frame blocks, ignoring its
 *   hang_ms = T              timeout, for T ms (10000), as a stuck driver would
 *   timestamp_offset_ms = T  added to every timestamp (may be negative)
 *   unplug_every_s = S       a periodic unplug: the last unplug_ms of every
 *   unplug_ms = T            S seconds (counted from the device's first
 *                            open, so reopens keep the schedule) the device
 *                            is gone: next_frame and open fail with
 *                            MDRV_ERR_NODEV; then it is back (unplug_ms
 *                            1000 by default, must be below S * 1000)
 *   stall_every = N          before every Nth frame next_frame blocks,
 *   stall_ms = T             ignoring its timeout, for T ms (1000)
 *   wrong_size_every = N     every Nth frame comes in another size than
 *                            get_format announced (half the width and
 *                            height, bytes and stride to match), as a
 *                            driver that switched modes behind the host's
 *                            back would deliver it
 *
 * Every key is read in open(), as mocapd requires of drivers. */
#include "mdrv.h"
#include "base/mc_time.h"

#include <errno.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <turbojpeg.h>

#ifndef FAULTY_ABI_VERSION
#define FAULTY_ABI_VERSION MDRV_ABI_VERSION
#endif
#ifndef FAULTY_NAME
#define FAULTY_NAME "faulty"
#endif

/* State that outlives one opening, per device id. */
typedef struct {
	char id[64];
	int opens_failed;
	bool error_fired;
	bool disappeared;
	uint64_t frames_total; /* over the device's life, for disappear_after */
	bool gone;
	uint64_t gone_since_ns;
	uint64_t first_open_ns; /* origin of the unplug_every_s schedule */
} device_memory;

static pthread_mutex_t memory_lock = PTHREAD_MUTEX_INITIALIZER;
static device_memory memory[16];
static int nmemory;

typedef struct {
	const mdrv_host *host;
	device_memory *mem;
	mdrv_format fmt;
	long fail_open_count, error_after, short_every, corrupt_every, drop_every;
	long disappear_after, return_after_ms, end_after, hang_after, hang_ms;
	long unplug_every_s, unplug_ms, stall_every, stall_ms, wrong_size_every;
	long long offset_ns;
	int error_code;
	bool error_once;
	uint64_t period_ns;
	uint64_t frames;    /* delivered since start */
	uint64_t produced;  /* including dropped ones */
	uint64_t next_ns;   /* timestamp of the next frame */
	unsigned char *jpeg;
	unsigned long jpeg_size;
} faulty_dev;

static void sleep_until(uint64_t t)
{
	struct timespec ts = {.tv_sec = (time_t)(t / 1000000000ull), .tv_nsec = (long)(t % 1000000000ull)};
	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
		;
}

static device_memory *remember(const char *id)
{
	pthread_mutex_lock(&memory_lock);
	device_memory *m = NULL;
	for (int i = 0; i < nmemory && !m; i++)
		if (strcmp(memory[i].id, id) == 0)
			m = &memory[i];
	if (!m && nmemory < 16) {
		m = &memory[nmemory++];
		memset(m, 0, sizeof(*m));
		snprintf(m->id, sizeof(m->id), "%s", id);
	}
	pthread_mutex_unlock(&memory_lock);
	return m;
}

/* Reads an integer key; returns def when absent, -2 (with err) when bad. */
static int get_long(const mdrv_host *h, const char *key, long def, long *out, char *err, size_t errlen)
{
	const char *v = h->config_get(h->ctx, key);
	if (!v) {
		*out = def;
		return 0;
	}
	char *end;
	errno = 0;
	long x = strtol(v, &end, 10);
	if (errno || end == v || *end) {
		snprintf(err, errlen, "%s: expected an integer, got '%s'", key, v);
		return -1;
	}
	*out = x;
	return 0;
}

static bool get_bool(const mdrv_host *h, const char *key)
{
	const char *v = h->config_get(h->ctx, key);
	return v && (strcmp(v, "true") == 0 || strcmp(v, "1") == 0 || strcmp(v, "yes") == 0);
}

static int parse_status(const char *v, int def)
{
	if (!v)
		return def;
	if (strcmp(v, "io") == 0)
		return MDRV_ERR_IO;
	if (strcmp(v, "nodev") == 0)
		return MDRV_ERR_NODEV;
	if (strcmp(v, "config") == 0)
		return MDRV_ERR_CONFIG;
	if (strcmp(v, "format") == 0)
		return MDRV_ERR_FORMAT;
	if (strcmp(v, "nospace") == 0)
		return MDRV_ERR_NOSPACE;
	return 1; /* unknown */
}

static int drv_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host, (void)err, (void)errlen;
	if (max < 1)
		return 0;
	memset(out, 0, sizeof(*out));
	snprintf(out->id, sizeof(out->id), "faulty0");
	snprintf(out->name, sizeof(out->name), "fault-injection test camera");
	snprintf(out->bus_info, sizeof(out->bus_info), "virtual");
	return 1;
}

static void fill_pattern(uint8_t *rgb, int w, int h, uint64_t k)
{
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			uint8_t *p = rgb + 3 * ((size_t)y * (size_t)w + (size_t)x);
			p[0] = (uint8_t)(x * 4 + k);
			p[1] = (uint8_t)(y * 4);
			p[2] = (uint8_t)(128 + ((x / 8 + y / 8) % 2) * 64);
		}
}

static int encode_jpeg(faulty_dev *d, char *err, size_t errlen)
{
	int w = (int)d->fmt.width, h = (int)d->fmt.height;
	uint8_t *rgb = malloc((size_t)w * (size_t)h * 3);
	tjhandle tj = tjInitCompress();
	if (!rgb || !tj) {
		free(rgb);
		if (tj)
			tjDestroy(tj);
		snprintf(err, errlen, "out of memory");
		return -1;
	}
	fill_pattern(rgb, w, h, 0);
	int rc = tjCompress2(tj, rgb, w, 0, h, TJPF_RGB, &d->jpeg, &d->jpeg_size, TJSAMP_420, 90, 0);
	tjDestroy(tj);
	free(rgb);
	if (rc != 0) {
		snprintf(err, errlen, "cannot encode the test JPEG");
		return -1;
	}
	return 0;
}

static int read_keys(faulty_dev *d, const mdrv_host *h, char *err, size_t errlen)
{
	long w, hh, fps, delay, offset_ms;
	if (get_long(h, "width", 64, &w, err, errlen) || get_long(h, "height", 48, &hh, err, errlen) ||
	    get_long(h, "fps", 30, &fps, err, errlen) || get_long(h, "fail_open_count", 0, &d->fail_open_count, err, errlen) ||
	    get_long(h, "error_after", -1, &d->error_after, err, errlen) ||
	    get_long(h, "short_every", 0, &d->short_every, err, errlen) ||
	    get_long(h, "corrupt_every", 0, &d->corrupt_every, err, errlen) ||
	    get_long(h, "drop_every", 0, &d->drop_every, err, errlen) ||
	    get_long(h, "disappear_after", -1, &d->disappear_after, err, errlen) ||
	    get_long(h, "return_after_ms", -1, &d->return_after_ms, err, errlen) ||
	    get_long(h, "end_after", -1, &d->end_after, err, errlen) ||
	    get_long(h, "hang_after", -1, &d->hang_after, err, errlen) ||
	    get_long(h, "hang_ms", 10000, &d->hang_ms, err, errlen) ||
	    get_long(h, "unplug_every_s", 0, &d->unplug_every_s, err, errlen) ||
	    get_long(h, "unplug_ms", 1000, &d->unplug_ms, err, errlen) ||
	    get_long(h, "stall_every", 0, &d->stall_every, err, errlen) ||
	    get_long(h, "stall_ms", 1000, &d->stall_ms, err, errlen) ||
	    get_long(h, "wrong_size_every", 0, &d->wrong_size_every, err, errlen) ||
	    get_long(h, "open_delay_ms", 0, &delay, err, errlen) ||
	    get_long(h, "timestamp_offset_ms", 0, &offset_ms, err, errlen))
		return MDRV_ERR_CONFIG;
	if (w < 8 || hh < 8 || w > 4096 || hh > 4096 || fps < 1 || fps > 1000) {
		snprintf(err, errlen, "width/height must be 8..4096 and fps 1..1000");
		return MDRV_ERR_CONFIG;
	}
	if (d->unplug_every_s < 0 || d->unplug_every_s > 86400 ||
	    (d->unplug_every_s > 0 && (d->unplug_ms < 1 || d->unplug_ms >= d->unplug_every_s * 1000))) {
		snprintf(err, errlen, "unplug_every_s must be 0..86400 and unplug_ms 1..unplug_every_s * 1000 - 1");
		return MDRV_ERR_CONFIG;
	}
	if (d->stall_ms < 0 || d->hang_ms < 0) {
		snprintf(err, errlen, "stall_ms and hang_ms must not be negative");
		return MDRV_ERR_CONFIG;
	}
	d->error_code = parse_status(h->config_get(h->ctx, "error_code"), MDRV_ERR_IO);
	if (d->error_code > 0) {
		snprintf(err, errlen, "error_code: expected io, nodev, format, config or nospace");
		return MDRV_ERR_CONFIG;
	}
	d->error_once = get_bool(h, "error_once");
	d->offset_ns = (long long)offset_ms * 1000000ll;
	d->period_ns = 1000000000ull / (uint64_t)fps;
	const char *f = h->config_get(h->ctx, "format");
	uint32_t pixfmt = MC_PIXFMT_RGB24, bpp = 3;
	if (!f || strcmp(f, "rgb24") == 0)
		;
	else if (strcmp(f, "gray8") == 0)
		pixfmt = MC_PIXFMT_GRAY8, bpp = 1;
	else if (strcmp(f, "yuyv") == 0)
		pixfmt = MC_PIXFMT_YUYV, bpp = 2;
	else if (strcmp(f, "mjpeg") == 0)
		pixfmt = MC_PIXFMT_MJPEG, bpp = 0;
	else {
		snprintf(err, errlen, "format: expected rgb24, gray8, yuyv or mjpeg, got '%s'", f);
		return MDRV_ERR_CONFIG;
	}
	if (pixfmt == MC_PIXFMT_YUYV && (w % 2)) {
		snprintf(err, errlen, "width must be even for yuyv");
		return MDRV_ERR_CONFIG;
	}
	d->fmt = (mdrv_format){.pixfmt = pixfmt, .width = (uint32_t)w, .height = (uint32_t)hh,
				.stride = (uint32_t)w * bpp, .fps = (double)fps};
	d->fmt.max_bytes = bpp ? (size_t)d->fmt.stride * (size_t)hh : (size_t)w * (size_t)hh * 3 + 4096;
	/* Read for the host's unknown-key check even when unused below. */
	(void)h->config_get(h->ctx, "device");
	/* Claims every extra.* key (the host's wildcard rule). */
	(void)h->config_get(h->ctx, "extra.*");
	if (delay > 0)
		sleep_until(mc_now_ns() + (uint64_t)delay * 1000000ull);
	return MDRV_OK;
}

/* unplug_every_s: whether the device is unplugged now.  The schedule
 * starts at the device's first open (mem->first_open_ns, set under
 * memory_lock before this is called). */
static bool unplugged_now(const faulty_dev *d)
{
	if (d->unplug_every_s <= 0 || !d->mem->first_open_ns)
		return false;
	uint64_t period = (uint64_t)d->unplug_every_s * 1000000000ull;
	uint64_t phase = (mc_now_ns() - d->mem->first_open_ns) % period;
	return phase >= period - (uint64_t)d->unplug_ms * 1000000ull;
}

static void *drv_open(const mdrv_host *host, char *err, size_t errlen)
{
	const char *id = host->config_get(host->ctx, "device");
	device_memory *mem = remember(id ? id : "faulty0");
	faulty_dev *d = calloc(1, sizeof(*d));
	if (!d || !mem) {
		free(d);
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	d->host = host;
	d->mem = mem;
	int rc = read_keys(d, host, err, errlen);
	int open_error = parse_status(host->config_get(host->ctx, "open_error"), MDRV_ERR_IO);
	bool fail_open = get_bool(host, "fail_open");
	if (rc == MDRV_OK && open_error > 0) {
		snprintf(err, errlen, "open_error: expected io, nodev, format, config or nospace");
		rc = MDRV_ERR_CONFIG;
	}
	if (rc != MDRV_OK) {
		free(d);
		return NULL;
	}
	pthread_mutex_lock(&memory_lock);
	bool gone = mem->gone;
	if (gone && d->return_after_ms >= 0 && mc_now_ns() - mem->gone_since_ns >= (uint64_t)d->return_after_ms * 1000000ull)
		gone = mem->gone = false;
	if (!mem->first_open_ns)
		mem->first_open_ns = mc_now_ns();
	bool unplugged = !gone && unplugged_now(d);
	bool fail_now = !gone && !unplugged && (fail_open || mem->opens_failed < d->fail_open_count);
	if (fail_now)
		mem->opens_failed++;
	pthread_mutex_unlock(&memory_lock);
	if (unplugged) {
		snprintf(err, errlen, "faulty camera %s: no such device (injected: unplugged)", mem->id);
		free(d);
		return NULL;
	}
	if (gone) {
		snprintf(err, errlen, "faulty camera %s: no such device (injected: disappeared)", mem->id);
		free(d);
		return NULL;
	}
	if (fail_now) {
		snprintf(err, errlen, "faulty camera %s: cannot open (injected, status %d)", mem->id, open_error);
		free(d);
		return NULL;
	}
	if (d->fmt.pixfmt == MC_PIXFMT_MJPEG && encode_jpeg(d, err, errlen)) {
		free(d);
		return NULL;
	}
	return d;
}

static int drv_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	*fmt = ((faulty_dev *)dev)->fmt;
	return MDRV_OK;
}

static int drv_start(void *dev, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	faulty_dev *d = dev;
	d->frames = d->produced = 0;
	d->next_ns = (mc_now_ns() / d->period_ns + 1) * d->period_ns;
	return MDRV_OK;
}

static bool every(long n, uint64_t k)
{
	return n > 0 && (k + 1) % (uint64_t)n == 0;
}

static void write_frame(faulty_dev *d, mdrv_frame *slot, uint64_t k)
{
	const mdrv_format *f = &d->fmt;
	size_t full;
	if (f->pixfmt == MC_PIXFMT_MJPEG) {
		full = d->jpeg_size;
		memcpy(slot->data, d->jpeg, full);
		if (every(d->corrupt_every, k)) {
			/* Keep the headers, wreck the entropy-coded data and drop
			 * the end-of-image marker: a broken JPEG as a flaky USB
			 * link delivers it. */
			for (size_t i = full / 2; i < full; i++)
				slot->data[i] = (uint8_t)(0xA5 ^ i);
			full = full * 3 / 4;
		}
	} else {
		full = (size_t)f->stride * f->height;
		if (f->pixfmt == MC_PIXFMT_RGB24)
			fill_pattern(slot->data, (int)f->width, (int)f->height, k);
		else
			for (size_t i = 0; i < full; i++)
				slot->data[i] = (uint8_t)(i + k);
		if (every(d->corrupt_every, k))
			slot->flags |= MDRV_FRAME_CORRUPT;
	}
	slot->bytesused = every(d->short_every, k) ? full / 2 : full;
	if (every(d->wrong_size_every, k) && f->pixfmt != MC_PIXFMT_MJPEG) {
		/* A consistent frame of another size: half the width (even, for
		 * yuyv) and half the height, tightly packed. */
		uint32_t bpp = f->stride / f->width;
		slot->format.width = (f->width / 2) & ~1u;
		slot->format.height = f->height / 2;
		slot->format.stride = slot->format.width * bpp;
		slot->bytesused = (size_t)slot->format.stride * slot->format.height;
	}
}

static int drv_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	faulty_dev *d = dev;
	device_memory *m = d->mem;
	if (d->end_after >= 0 && d->frames >= (uint64_t)d->end_after)
		return MDRV_ERR_END;
	if (d->disappear_after >= 0 && m->frames_total >= (uint64_t)d->disappear_after) {
		pthread_mutex_lock(&memory_lock);
		if (!m->gone && !m->disappeared) {
			m->gone = true;
			m->disappeared = true; /* disappears once */
			m->gone_since_ns = mc_now_ns();
		}
		bool gone = m->gone;
		pthread_mutex_unlock(&memory_lock);
		if (gone) {
			snprintf(err, errlen, "faulty camera %s: device disappeared (injected)", m->id);
			return MDRV_ERR_NODEV;
		}
	}
	if (d->error_after >= 0 && d->frames >= (uint64_t)d->error_after) {
		bool fire = true;
		if (d->error_once) {
			pthread_mutex_lock(&memory_lock);
			fire = !m->error_fired;
			m->error_fired = true;
			pthread_mutex_unlock(&memory_lock);
		}
		if (fire) {
			snprintf(err, errlen, "faulty camera %s: injected error %d after %ld frames", m->id,
				 d->error_code, d->error_after);
			return d->error_code;
		}
		d->error_after = -1; /* fired on an earlier opening */
	}
	if (unplugged_now(d)) {
		snprintf(err, errlen, "faulty camera %s: device unplugged (injected)", m->id);
		return MDRV_ERR_NODEV;
	}
	if (d->hang_after >= 0 && d->frames >= (uint64_t)d->hang_after) {
		d->hang_after = -1;
		sleep_until(mc_now_ns() + (uint64_t)d->hang_ms * 1000000ull);
	}
	uint64_t deadline = mc_now_ns() + (uint64_t)(timeout_ms < 0 ? 0 : timeout_ms) * 1000000ull;
	for (;;) {
		if (d->next_ns > deadline) {
			sleep_until(deadline);
			return MDRV_ERR_TIMEOUT;
		}
		sleep_until(d->next_ns);
		uint64_t k = d->produced++;
		uint64_t ts = d->next_ns;
		d->next_ns += d->period_ns;
		if (every(d->drop_every, k))
			continue;
		if (every(d->stall_every, k)) {
			/* A stuck driver: the timeout is ignored; the frame after
			 * the stall is delivered late, its timestamp on the grid. */
			sleep_until(mc_now_ns() + (uint64_t)d->stall_ms * 1000000ull);
		}
		if (slot->capacity < d->fmt.max_bytes) {
			snprintf(err, errlen, "slot of %zu bytes, frames need up to %zu", slot->capacity,
				 d->fmt.max_bytes);
			return MDRV_ERR_NOSPACE;
		}
		slot->flags = 0;
		slot->format = d->fmt;
		write_frame(d, slot, k);
		slot->timestamp_ns = (uint64_t)((long long)ts + d->offset_ns);
		slot->sequence = k;
		d->frames++;
		pthread_mutex_lock(&memory_lock);
		m->frames_total++;
		pthread_mutex_unlock(&memory_lock);
		return MDRV_OK;
	}
}

static void drv_stop(void *dev)
{
	(void)dev;
}

static void drv_close(void *dev)
{
	faulty_dev *d = dev;
	if (d->jpeg)
		tjFree(d->jpeg);
	free(d);
}

static int drv_frame_count(void *dev, uint64_t *frames)
{
	faulty_dev *d = dev;
	if (d->end_after < 0)
		return MDRV_ERR_IO;
	*frames = (uint64_t)d->end_after;
	return MDRV_OK;
}

/* Built with FAULTY_ABI_VERSION=3 (mocap-driver-oldabi.so) it still sets
 * frame_count, which the host must not read from an ABI 3 plugin. */
static const mdrv_driver faulty_driver = {
	.abi_version = FAULTY_ABI_VERSION,
	.name = FAULTY_NAME,
	.description = "fault-injection test camera (tests only)",
	.probe = drv_probe,
	.open = drv_open,
	.get_format = drv_get_format,
	.start = drv_start,
	.next_frame = drv_next_frame,
	.stop = drv_stop,
	.close = drv_close,
	.frame_count = drv_frame_count,
};

#ifndef FAULTY_NO_ENTRY
__attribute__((visibility("default"))) const mdrv_driver *mdrv_entry(void)
{
	return &faulty_driver;
}
#else
__attribute__((visibility("default"))) const mdrv_driver *not_the_entry(void)
{
	return &faulty_driver;
}
#endif
