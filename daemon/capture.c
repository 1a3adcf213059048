#include "capture.h"

#include "backoff.h"
#include "log.h"
#include "base/mc_thread.h"
#include "base/mc_throttle.h"
#include "base/mc_time.h"
#include "image/mc_image.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define FRAME_TIMEOUT_MS 200 /* how often the capture loop looks up */
#define IO_ERRORS_BEFORE_REOPEN 3
/* Frames in a row that the driver refuses for their format or size (a
 * file of another size in a folder, a corrupt frame) before the camera is
 * reopened: one such frame is dropped and counted, and the stream goes on
 * (reopening restarted a folder's playback at its first frame). */
#define FORMAT_ERRORS_BEFORE_REOPEN 30
#define NAP_STEP_NS (100 * MC_NS_PER_MS) /* a napping thread's heartbeat */
#define TURN_POLL_MS 1.0 /* offline mode: how often a waiting camera looks again */

struct mcd_camera {
	int index;
	mcd_camera_config cfg;
	char config_file[PATH_MAX];
	const mdrv_driver *drv;
	mcd_camera_sink sink;
	mdrv_host host;
	bool key_read[MCD_MAX_DRIVER_KEYS];
	/* Keys the driver asked for that the section lacks, during --check:
	 * what an unknown key may be a typo of. */
	char asked[MCD_MAX_DRIVER_KEYS][MCD_NAME_MAX];
	int nasked;
	char epoch[32]; /* offered as "epoch" on the first opening; "" = none */
	unsigned outages; /* times the camera went away after streaming (capture thread only) */
	int open_status;  /* what the last failed open() said (host_open_status) */
	bool opened_once;

	pthread_t thread;
	bool thread_started;
	atomic_bool stop;
	atomic_bool attempted;
	atomic_uint_fast64_t heartbeat;
	atomic_bool finished;

	/* Guards state, counters, format, last_error, limits and the wake-up. */
	pthread_mutex_t lock;
	pthread_cond_t wake;
	mcd_cam_state state;
	mcd_cam_counters counters;
	mdrv_format format;
	char last_error[512];
	double reopen_initial_ms, reopen_max_ms, stall_timeout_ms;
	bool limits_changed;

	mcd_frame_ring ring;
};

const char *mcd_cam_state_name(mcd_cam_state s)
{
	static const char *const names[] = {"off", "opening", "streaming", "stalled", "retrying", "failed", "ended"};
	return (unsigned)s < sizeof(names) / sizeof(names[0]) ? names[s] : "?";
}

/* ---- the host side of the driver ABI ------------------------------------ */

static const char *host_config_get(void *ctx, const char *key)
{
	mcd_camera *c = ctx;
	if (!key)
		return NULL;
	/* "prefix.*" claims every key with that prefix as read (a driver that
	 * reads them later, e.g. camera controls once the camera appears). */
	size_t n = strlen(key);
	if (n >= 2 && strcmp(key + n - 2, ".*") == 0) {
		for (int i = 0; i < c->cfg.nkeys; i++)
			if (strncmp(c->cfg.keys[i].key, key, n - 1) == 0)
				c->key_read[i] = true;
		return NULL;
	}
	for (int i = 0; i < c->cfg.nkeys; i++)
		if (strcmp(c->cfg.keys[i].key, key) == 0) {
			c->key_read[i] = true;
			return c->cfg.keys[i].value;
		}
	if (c->nasked < MCD_MAX_DRIVER_KEYS && n < MCD_NAME_MAX)
		memcpy(c->asked[c->nasked++], key, n + 1);
	/* The shared time origin, so that frame k of every camera carries the
	 * same timestamp (drivers that pace recorded frames ask for it). Only
	 * on the first opening: a reopened camera starts a new stream. */
	if (strcmp(key, "epoch") == 0 && !c->opened_once && c->epoch[0])
		return c->epoch;
	/* The daemon's own keys are visible too (read-only, never "unknown"). */
	if (strcmp(key, "driver") == 0)
		return c->cfg.driver;
	if (strcmp(key, "rig_camera") == 0)
		return c->cfg.rig_camera[0] ? c->cfg.rig_camera : NULL;
	return NULL;
}

/* open() said why it failed (drv_open_failed); read by open_and_start. */
static void host_open_status(void *ctx, int status)
{
	mcd_camera *c = ctx;
	c->open_status = status;
}

static void host_log(void *ctx, int level, const char *msg)
{
	mcd_camera *c = ctx;
	mcd_log(level, "camera %s (%s): %s", c->cfg.name, c->drv->name, msg ? msg : "");
}

/* ---- state ---------------------------------------------------------------- */

static void set_state(mcd_camera *c, mcd_cam_state s)
{
	pthread_mutex_lock(&c->lock);
	bool changed = c->state != s;
	c->state = s;
	pthread_mutex_unlock(&c->lock);
	if (changed && c->sink.on_change)
		c->sink.on_change(c->sink.ctx, c->index);
}

static void set_error(mcd_camera *c, const char *what, const char *msg)
{
	pthread_mutex_lock(&c->lock);
	snprintf(c->last_error, sizeof(c->last_error), "%.40s: %.440s", what, msg);
	c->counters.errors++;
	pthread_mutex_unlock(&c->lock);
}

static void count(mcd_camera *c, uint64_t *field)
{
	pthread_mutex_lock(&c->lock);
	(*field)++;
	pthread_mutex_unlock(&c->lock);
}

/* Sleeps up to ms, waking early on stop.  Returns false when stopping. */
static bool nap(mcd_camera *c, double ms)
{
	uint64_t until = mc_now_ns() + (uint64_t)(ms * 1e6);
	pthread_mutex_lock(&c->lock);
	while (!atomic_load(&c->stop)) {
		uint64_t now = mc_now_ns();
		if (now >= until)
			break;
		/* Wake at least every 100 ms so that the heartbeat keeps going. */
		uint64_t step = until - now < NAP_STEP_NS ? until - now : NAP_STEP_NS;
		struct timespec ts = mc_cond_deadline(step);
		pthread_cond_timedwait(&c->wake, &c->lock, &ts);
		atomic_fetch_add(&c->heartbeat, 1);
	}
	pthread_mutex_unlock(&c->lock);
	return !atomic_load(&c->stop);
}

/* ---- frames ---------------------------------------------------------------- */

/* Why a frame from a driver is unusable (NULL if it is fine); *kind gets
 * one of the mcd_cam_counters fields it counts towards: 's'hort,
 * 'c'orrupt or 'b'ad. */
static const char *frame_problem(const mdrv_frame *f, size_t capacity, char *kind)
{
	const mdrv_format *fmt = &f->format;
	*kind = 'b';
	if (f->bytesused > capacity)
		return "the driver reports more bytes than the slot holds";
	if (fmt->pixfmt == MC_PIXFMT_NONE || fmt->pixfmt > MC_PIXFMT_DEPTH16)
		return "unknown pixel format";
	if (fmt->width == 0 || fmt->height == 0 || fmt->width > 16384 || fmt->height > 16384)
		return "width or height out of range";
	*kind = 'c';
	if (f->flags & MDRV_FRAME_CORRUPT)
		return "flagged corrupt by the driver";
	*kind = 's';
	if (f->flags & MDRV_FRAME_SHORT)
		return "flagged short by the driver";
	if (fmt->pixfmt == MC_PIXFMT_MJPEG) {
		*kind = 'c';
		if (f->bytesused < 4 || f->data[0] != 0xFF || f->data[1] != 0xD8)
			return "not a JPEG (no start-of-image marker)";
		return NULL;
	}
	size_t bpp = (size_t)mc_image_bytes_per_pixel(fmt->pixfmt);
	size_t row = (size_t)fmt->width * bpp;
	size_t stride = fmt->stride ? fmt->stride : row;
	*kind = 'b';
	if (bpp == 0 || stride < row)
		return "stride smaller than a row";
	*kind = 's';
	if (f->bytesused < stride * (fmt->height - 1) + row)
		return "fewer bytes than the format needs";
	return NULL;
}

/* The slot size for a format: what the driver promises, or what the format
 * needs when it does not say. */
static size_t slot_bytes_for(const mdrv_format *f)
{
	size_t need = (size_t)f->width * f->height * 3 + 65536; /* MJPEG worst case is below raw RGB */
	int bpp = mc_image_bytes_per_pixel(f->pixfmt);
	if (bpp > 0)
		need = (size_t)(f->stride ? f->stride : f->width * (uint32_t)bpp) * f->height;
	return f->max_bytes > need ? f->max_bytes : need;
}

/* Makes sure the ring's slots hold `bytes`; replaces the ring if not. */
static int ensure_ring(mcd_camera *c, size_t bytes, mc_err *err)
{
	int rc = mcd_frame_ring_ensure(&c->ring, bytes, err);
	if (rc <= 0)
		return rc;
	mcd_debug("camera %s: frame ring of %d slots x %zu bytes", c->cfg.name, c->cfg.ring_slots, bytes);
	if (c->sink.on_change)
		c->sink.on_change(c->sink.ctx, c->index);
	return 0;
}

static void commit_frame(mcd_camera *c, mdrv_frame *slot)
{
	uint64_t now = mc_now_ns();
	mc_ring_meta meta = {
		.timestamp_ns = slot->timestamp_ns ? slot->timestamp_ns : now,
		.driver_sequence = slot->sequence,
		.bytesused = slot->bytesused,
		.pixfmt = slot->format.pixfmt,
		.width = slot->format.width,
		.height = slot->format.height,
		.stride = slot->format.stride,
		.flags = slot->flags,
	};
	mc_err err;
	if (mc_ring_slot_commit(c->ring.ring, &meta, &err) != 0) {
		mcd_warn("camera %s: %s", c->cfg.name, err.msg);
		count(c, &c->counters.bad_frames);
		return;
	}
	pthread_mutex_lock(&c->lock);
	c->counters.frames++;
	c->counters.last_frame_ns = meta.commit_ns ? meta.commit_ns : now;
	pthread_mutex_unlock(&c->lock);
	if (c->sink.on_frame)
		c->sink.on_frame(c->sink.ctx, c->index, c->ring.generation, &meta);
}

/* Logs a dropped frame, at warn level for the first few and then only at
 * debug level, so that a flaky cable does not flood the journal. */
static void note_bad_frame(mcd_camera *c, const char *why, uint64_t *field)
{
	pthread_mutex_lock(&c->lock);
	uint64_t n = ++(*field);
	snprintf(c->last_error, sizeof(c->last_error), "frame dropped: %s", why);
	pthread_mutex_unlock(&c->lock);
	int level = mc_throttle_should_log(n) ? MCD_LOG_WARN : MCD_LOG_DEBUG;
	mcd_log(level, "camera %s: frame dropped (%s); %llu so far", c->cfg.name, why, (unsigned long long)n);
}

/* ---- the capture thread ------------------------------------------------------ */

typedef enum { RUN_REOPEN, RUN_FAILED, RUN_ENDED, RUN_STOP } run_result;

static int unknown_keys(mcd_camera *c)
{
	for (int i = 0; i < c->cfg.nkeys; i++)
		if (!c->key_read[i]) {
			char msg[500];
			snprintf(msg, sizeof(msg), "%.200s:%d: [camera %s] %s: unknown key (the %s driver does not read it)",
				 c->config_file, c->cfg.keys[i].line, c->cfg.name, c->cfg.keys[i].key, c->drv->name);
			mcd_error("%s", msg);
			pthread_mutex_lock(&c->lock);
			snprintf(c->last_error, sizeof(c->last_error), "%s", msg);
			pthread_mutex_unlock(&c->lock);
			return -1;
		}
	return 0;
}

/* The config line a driver's message is about: the line of the key it
 * names ("config key 'rate': ..." is drv_common's form), else the line of
 * the camera's section. */
static int line_of_message(const mcd_camera *c, const char *msg)
{
	const char *at = strstr(msg, "config key '");
	for (int i = 0; at && i < c->cfg.nkeys; i++) {
		size_t n = strlen(c->cfg.keys[i].key);
		if (strncmp(at + 12, c->cfg.keys[i].key, n) == 0 && at[12 + n] == '\'')
			return c->cfg.keys[i].line;
	}
	return c->cfg.line;
}

int mcd_camera_check(mcd_camera *c, mc_err *err)
{
	if (!c->drv->check) {
		mcd_warn("camera %s: the %s driver checks its keys only when it opens", c->cfg.name, c->drv->name);
		return 0;
	}
	char msg[512] = "";
	memset(c->key_read, 0, sizeof(c->key_read));
	c->nasked = 0;
	if (c->drv->check(&c->host, msg, sizeof(msg)) != MDRV_OK)
		return mc_err_set(err, "%s:%d: [camera %s] %s", c->config_file, line_of_message(c, msg), c->cfg.name,
				  msg[0] ? msg : "bad keys");
	for (int i = 0; i < c->cfg.nkeys; i++) {
		if (c->key_read[i])
			continue;
		const char *near = mcd_suggest_name(c->cfg.keys[i].key, c->asked[0], sizeof(c->asked[0]), c->nasked);
		return mc_err_set(err, "%s:%d: [camera %s] %s: unknown key (the %s driver does not read it%s%s%s)",
				  c->config_file, c->cfg.keys[i].line, c->cfg.name, c->cfg.keys[i].key, c->drv->name,
				  near ? "; did you mean '" : "", near ? near : "", near ? "'?" : "");
	}
	return 0;
}

/* Opens the device, reads its format and starts it.  Returns the device,
 * or NULL with *result telling whether to retry. */
static void *open_and_start(mcd_camera *c, mdrv_format *fmt, run_result *result)
{
	char err[512] = "";
	*result = RUN_REOPEN;
	c->open_status = 0;
	void *dev = c->drv->open(&c->host, err, sizeof(err));
	if (!dev) {
		set_error(c, "open", err[0] ? err : "failed");
		if (c->open_status == MDRV_ERR_CONFIG)
			*result = RUN_FAILED; /* the driver says retrying cannot help */
		return NULL;
	}
	int rc = c->drv->get_format(dev, fmt, err, sizeof(err));
	if (rc == MDRV_OK)
		rc = c->drv->start(dev, err, sizeof(err));
	else
		snprintf(err + strlen(err), sizeof(err) - strlen(err), " (get_format)");
	if (rc != MDRV_OK) {
		set_error(c, "start", err[0] ? err : "failed");
		c->drv->close(dev);
		if (rc == MDRV_ERR_CONFIG)
			*result = RUN_FAILED;
		return NULL;
	}
	return dev;
}

/* Opens and starts the device, checks its keys and sizes the ring.
 * Returns the device, or NULL with *result telling whether to retry. */
static void *open_device(mcd_camera *c, run_result *result)
{
	set_state(c, MCD_CAM_OPENING);
	memset(c->key_read, 0, sizeof(c->key_read));
	mdrv_format fmt;
	void *dev = open_and_start(c, &fmt, result);
	if (!dev)
		return NULL;
	mc_err merr;
	if (unknown_keys(c))
		*result = RUN_FAILED;
	else if (ensure_ring(c, slot_bytes_for(&fmt), &merr)) {
		set_error(c, "frame ring", merr.msg);
		*result = RUN_REOPEN;
	} else {
		uint64_t expected = mcd_driver_frame_count(c->drv, dev);
		pthread_mutex_lock(&c->lock);
		c->format = fmt;
		c->counters.expected_frames = expected;
		pthread_mutex_unlock(&c->lock);
		c->opened_once = true;
		mcd_info("camera %s: opened (%s driver, %s %ux%u, %.4g fps)", c->cfg.name, c->drv->name,
			 mc_pixfmt_name(fmt.pixfmt), fmt.width, fmt.height, fmt.fps);
		return dev;
	}
	c->drv->stop(dev);
	c->drv->close(dev);
	return NULL;
}

/* What the capture loop keeps about the stream of one opening. */
typedef struct {
	mcd_backoff *backoff;
	int io_errors;      /* in a row */
	int format_errors;  /* in a row */
	/* The driver's sequence number of the last frame it delivered (good
	 * or dropped here), to count the frames it never delivered; and the
	 * frames it refused since (FORMAT errors), counted already. */
	bool have_sequence;
	uint64_t last_sequence;
	uint64_t refused;
	bool first;         /* no good frame yet */
	bool streaming;     /* in state STREAMING */
	uint64_t last_good; /* when the last good frame came */
} stream_state;

#define RUN_ON -1 /* keep streaming */

/* A frame the driver delivered into the slot: dropped and counted, or
 * committed. */
/* Counts the frames missing between the last delivered one and this one
 * (a sequence that goes back is a restarted device: nothing is counted). */
static void count_sequence_gap(mcd_camera *c, stream_state *s, uint64_t sequence)
{
	if (s->have_sequence && sequence > s->last_sequence + 1) {
		uint64_t gap = sequence - s->last_sequence - 1;
		gap = gap > s->refused ? gap - s->refused : 0;
		if (gap) {
			pthread_mutex_lock(&c->lock);
			c->counters.lost += gap;
			pthread_mutex_unlock(&c->lock);
		}
	}
	s->have_sequence = true;
	s->last_sequence = sequence;
	s->refused = 0;
}

static void handle_frame(mcd_camera *c, stream_state *s, mdrv_frame *slot, size_t cap)
{
	count_sequence_gap(c, s, slot->sequence);
	char kind;
	const char *why = frame_problem(slot, cap, &kind);
	if (why) {
		mc_ring_slot_abort(c->ring.ring);
		note_bad_frame(c, why,
			       kind == 's'   ? &c->counters.short_frames
			       : kind == 'c' ? &c->counters.corrupt_frames
					     : &c->counters.bad_frames);
		return;
	}
	commit_frame(c, slot);
	s->io_errors = 0;
	s->format_errors = 0;
	s->last_good = mc_now_ns();
	if (s->first) {
		/* Only a good frame proves the device works again. */
		s->first = false;
		mcd_backoff_reset(s->backoff);
	}
	if (!s->streaming) {
		s->streaming = true;
		set_state(c, MCD_CAM_STREAMING);
	}
}

/* No frame within FRAME_TIMEOUT_MS: stalled after half the stall limit,
 * reopened after all of it. */
static int handle_timeout(mcd_camera *c, stream_state *s)
{
	count(c, &c->counters.timeouts);
	pthread_mutex_lock(&c->lock);
	double stall_ms = c->stall_timeout_ms;
	pthread_mutex_unlock(&c->lock);
	double quiet_ms = (double)(mc_now_ns() - s->last_good) / 1e6;
	if (quiet_ms >= stall_ms) {
		char msg[128];
		snprintf(msg, sizeof(msg), "no frame for %.0f ms", quiet_ms);
		set_error(c, "stalled", msg);
		mcd_warn("camera %s: stalled: %s; reopening", c->cfg.name, msg);
		set_state(c, MCD_CAM_STALLED);
		return RUN_REOPEN;
	}
	if (s->streaming && quiet_ms >= stall_ms / 2) {
		/* Not expected in groups any more until frames return. */
		s->streaming = false;
		set_state(c, MCD_CAM_STALLED);
	}
	return RUN_ON;
}

/* The frame did not fit its slot: doubles the slots. */
static int handle_nospace(mcd_camera *c, const char *err)
{
	count(c, &c->counters.nospace);
	size_t bigger = mc_ring_slot_bytes(c->ring.ring) * 2;
	mc_err merr;
	mcd_warn("camera %s: frame larger than the slot (%s); growing the ring to %zu-byte slots", c->cfg.name, err,
		 bigger);
	if (ensure_ring(c, bigger, &merr)) {
		set_error(c, "frame ring", merr.msg);
		return RUN_REOPEN;
	}
	return RUN_ON;
}

/* What next_frame's error code means for the stream. */
static int handle_error(mcd_camera *c, stream_state *s, int rc, const char *err)
{
	switch (rc) {
	case MDRV_ERR_TIMEOUT:
		return handle_timeout(c, s);
	case MDRV_ERR_END:
		return RUN_ENDED;
	case MDRV_ERR_NOSPACE:
		return handle_nospace(c, err);
	case MDRV_ERR_IO:
		set_error(c, "next_frame", err[0] ? err : "I/O error");
		if (++s->io_errors < IO_ERRORS_BEFORE_REOPEN) {
			mcd_warn("camera %s: %s (retrying)", c->cfg.name, err);
			return RUN_ON;
		}
		return RUN_REOPEN;
	case MDRV_ERR_CONFIG:
		set_error(c, "next_frame", err[0] ? err : "config error");
		return RUN_FAILED;
	case MDRV_ERR_FORMAT:
		if (++s->format_errors < FORMAT_ERRORS_BEFORE_REOPEN) {
			note_bad_frame(c, err[0] ? err : "format or size", &c->counters.bad_frames);
			s->refused++; /* its sequence number is skipped, and counted here */
			return RUN_ON;
		}
		set_error(c, "next_frame", err[0] ? err : "format error");
		return RUN_REOPEN;
	default: /* NODEV, unknown codes */
		set_error(c, "next_frame", err[0] ? err : "driver error");
		return RUN_REOPEN;
	}
}

/* Offline mode: waits until the tracking thread took the camera's frames
 * (sink.may_deliver); false when stopping.  The time waited does not count
 * towards the stall limit: the camera is held back, not quiet. */
static bool wait_for_turn(mcd_camera *c, stream_state *s)
{
	if (!c->sink.may_deliver)
		return true;
	bool waited = false;
	while (!c->sink.may_deliver(c->sink.ctx, c->index)) {
		if (!nap(c, TURN_POLL_MS))
			return false;
		waited = true;
	}
	if (waited)
		s->last_good = mc_now_ns();
	return true;
}

/* Reads frames until the device fails, ends or we are asked to stop. */
static run_result stream(mcd_camera *c, void *dev, mcd_backoff *backoff)
{
	char err[512];
	stream_state s = {.backoff = backoff, .first = true, .last_good = mc_now_ns()};
	while (!atomic_load(&c->stop)) {
		atomic_fetch_add(&c->heartbeat, 1);
		if (!wait_for_turn(c, &s))
			break;
		size_t cap;
		uint8_t *data = mc_ring_slot_begin(c->ring.ring, &cap);
		if (!data) {
			set_error(c, "frame ring", "no slot available");
			return RUN_REOPEN;
		}
		mdrv_frame slot = {.data = data, .capacity = cap};
		err[0] = 0;
		int rc = c->drv->next_frame(dev, &slot, FRAME_TIMEOUT_MS, err, sizeof(err));
		if (rc == MDRV_OK) {
			handle_frame(c, &s, &slot, cap);
			continue;
		}
		mc_ring_slot_abort(c->ring.ring);
		int next = handle_error(c, &s, rc, err);
		if (next != RUN_ON)
			return (run_result)next;
	}
	return RUN_STOP;
}

/* One opening: open, stream until it ends, close. */
static run_result open_and_stream(mcd_camera *c, mcd_backoff *backoff, bool *opened_before)
{
	run_result result = RUN_REOPEN;
	void *dev = open_device(c, &result);
	atomic_store(&c->attempted, true);
	if (!dev)
		return result;
	if (*opened_before)
		count(c, &c->counters.reopens);
	*opened_before = true;
	result = stream(c, dev, backoff);
	c->drv->stop(dev);
	c->drv->close(dev);
	return result;
}

/* For good (true) after a stop, the end of the stream or a config error. */
static bool is_final(mcd_camera *c, run_result result, const char *last)
{
	if (result == RUN_ENDED) {
		mcd_info("camera %s: end of stream", c->cfg.name);
		set_state(c, MCD_CAM_ENDED);
	} else if (result == RUN_FAILED) {
		mcd_error("%s:%d: [camera %s]: %s; giving up on this camera (fix the config and restart)", c->config_file,
			  line_of_message(c, last), c->cfg.name, last);
		set_state(c, MCD_CAM_FAILED);
	}
	return result != RUN_REOPEN;
}

/* Waits out the backoff before the next opening; false when stopping. */
static bool wait_to_reopen(mcd_camera *c, mcd_backoff *backoff, const char *last)
{
	pthread_mutex_lock(&c->lock);
	if (c->limits_changed) {
		mcd_backoff_set_limits(backoff, c->reopen_initial_ms, c->reopen_max_ms);
		c->limits_changed = false;
	}
	pthread_mutex_unlock(&c->lock);
	double wait_ms = mcd_backoff_next(backoff);
	/* A camera that stays away is reported at attempts 1, 2, 3, 4, 8,
	 * 16, ...; one that keeps going away (a loose cable: the attempts
	 * start again at 1 after each good frame) at its outages 1, 2, 3, 4,
	 * 8, 16, ..., so that the journal is not flooded either way. */
	unsigned n = backoff->failures;
	if (n == 1)
		c->outages++;
	bool warn = mc_throttle_should_log(n) && (n > 1 || mc_throttle_should_log(c->outages));
	mcd_log(warn ? MCD_LOG_WARN : MCD_LOG_DEBUG,
		"camera %s: %s; reopening in %.0f ms (attempt %u)", c->cfg.name, last, wait_ms, n);
	set_state(c, MCD_CAM_RETRYING);
	return nap(c, wait_ms);
}

static void *capture_main(void *arg)
{
	mcd_camera *c = arg;
	mcd_backoff backoff;
	mc_thread_set_name("mocapd-cam%d", c->index);
	pthread_mutex_lock(&c->lock);
	mcd_backoff_init(&backoff, c->reopen_initial_ms, c->reopen_max_ms);
	pthread_mutex_unlock(&c->lock);
	bool opened_before = false;
	while (!atomic_load(&c->stop)) {
		atomic_fetch_add(&c->heartbeat, 1);
		run_result result = open_and_stream(c, &backoff, &opened_before);
		char last[512];
		mcd_camera_last_error(c, last, sizeof(last));
		if (is_final(c, result, last) || !wait_to_reopen(c, &backoff, last))
			break;
	}
	atomic_store(&c->attempted, true);
	atomic_store(&c->finished, true);
	if (c->sink.on_change)
		c->sink.on_change(c->sink.ctx, c->index);
	return NULL;
}

/* ---- lifetime and queries ------------------------------------------------------ */

mcd_camera *mcd_camera_create(int index, const mcd_camera_config *cfg, const char *config_file,
			      const mcd_plugin *plugin, const mcd_camera_sink *sink, mc_err *err)
{
	mcd_camera *c = calloc(1, sizeof(*c));
	if (!c) {
		mc_err_set(err, "camera %s: out of memory", cfg->name);
		return NULL;
	}
	c->index = index;
	c->cfg = *cfg;
	snprintf(c->config_file, sizeof(c->config_file), "%s", config_file);
	c->drv = plugin->driver;
	if (sink)
		c->sink = *sink;
	c->host = (mdrv_host){.ctx = c, .config_get = host_config_get, .log = host_log, .open_status = host_open_status};
	pthread_mutex_init(&c->lock, NULL);
	mcd_frame_ring_init(&c->ring, cfg->name, (unsigned)cfg->ring_slots);
	mc_cond_init_monotonic(&c->wake);
	c->reopen_initial_ms = 250;
	c->reopen_max_ms = 10000;
	c->stall_timeout_ms = 3000;
	return c;
}

int mcd_camera_start(mcd_camera *c, mc_err *err)
{
	int rc = pthread_create(&c->thread, NULL, capture_main, c);
	if (rc != 0)
		return mc_err_set(err, "camera %s: cannot start its thread: %s", c->cfg.name, strerror(rc));
	c->thread_started = true;
	return 0;
}

void mcd_camera_request_stop(mcd_camera *c)
{
	pthread_mutex_lock(&c->lock);
	atomic_store(&c->stop, true);
	pthread_cond_broadcast(&c->wake);
	pthread_mutex_unlock(&c->lock);
}

int mcd_camera_join(mcd_camera *c, int timeout_ms)
{
	if (!c->thread_started)
		return 0;
	/* pthread_timedjoin_np takes a CLOCK_REALTIME deadline */
	struct timespec ts = mc_ns_timespec(mc_realtime_ns() + (uint64_t)timeout_ms * MC_NS_PER_MS);
	if (pthread_timedjoin_np(c->thread, NULL, &ts) != 0)
		return -1;
	c->thread_started = false;
	return 0;
}

void mcd_camera_destroy(mcd_camera *c)
{
	if (!c)
		return;
	if (c->thread_started) {
		/* A thread stuck in its driver: leave everything to it. */
		pthread_detach(c->thread);
		return;
	}
	mcd_frame_ring_destroy(&c->ring);
	pthread_mutex_destroy(&c->lock);
	pthread_cond_destroy(&c->wake);
	free(c);
}

void mcd_camera_set_epoch(mcd_camera *c, uint64_t epoch_ns)
{
	snprintf(c->epoch, sizeof(c->epoch), "%llu", (unsigned long long)epoch_ns);
}

void mcd_camera_set_limits(mcd_camera *c, double reopen_initial_ms, double reopen_max_ms, double stall_timeout_ms)
{
	pthread_mutex_lock(&c->lock);
	c->reopen_initial_ms = reopen_initial_ms;
	c->reopen_max_ms = reopen_max_ms;
	c->stall_timeout_ms = stall_timeout_ms;
	c->limits_changed = true;
	pthread_mutex_unlock(&c->lock);
}

const char *mcd_camera_name(const mcd_camera *c)
{
	return c->cfg.name;
}

const char *mcd_camera_driver(const mcd_camera *c)
{
	return c->cfg.driver;
}

mcd_cam_state mcd_camera_state(const mcd_camera *c)
{
	pthread_mutex_lock((pthread_mutex_t *)&c->lock);
	mcd_cam_state s = c->state;
	pthread_mutex_unlock((pthread_mutex_t *)&c->lock);
	return s;
}

bool mcd_camera_attempted(const mcd_camera *c)
{
	return atomic_load(&c->attempted);
}

uint64_t mcd_camera_heartbeat(const mcd_camera *c)
{
	/* A thread that has finished is not stuck. */
	if (atomic_load(&c->finished))
		return UINT64_MAX;
	return atomic_load(&c->heartbeat);
}

void mcd_camera_counters(const mcd_camera *c, mcd_cam_counters *out)
{
	pthread_mutex_lock((pthread_mutex_t *)&c->lock);
	*out = c->counters;
	pthread_mutex_unlock((pthread_mutex_t *)&c->lock);
}

mdrv_format mcd_camera_format(const mcd_camera *c)
{
	pthread_mutex_lock((pthread_mutex_t *)&c->lock);
	mdrv_format f = c->format;
	pthread_mutex_unlock((pthread_mutex_t *)&c->lock);
	return f;
}

void mcd_camera_last_error(const mcd_camera *c, char *buf, size_t cap)
{
	pthread_mutex_lock((pthread_mutex_t *)&c->lock);
	snprintf(buf, cap, "%s", c->last_error);
	pthread_mutex_unlock((pthread_mutex_t *)&c->lock);
}

mcd_frame_ring *mcd_camera_ring(mcd_camera *c)
{
	return &c->ring;
}
