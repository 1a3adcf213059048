/* mocap-driver-take: replays one camera of a recorded take
 * (docs/RECORDING.md) through the normal pipeline, with its original
 * timing.
 *
 * Config keys (the camera's section):
 *   take    the take's directory (required)
 *   camera  the camera's name in the take (required; take.json lists them)
 *   speed   1 = as recorded (default), 2 = twice as fast, ...; 0 = as fast
 *           as frames are taken
 *   loop    true/false (default false): start over after the last frame
 *   epoch   CLOCK_MONOTONIC time in ns of the first frame, for several
 *           cameras of one take to share their time origin (as the files
 *           driver; mocapd passes one to every camera)
 *
 * Frame k is delivered at epoch + (capture_k - capture_0) / speed with that
 * timestamp, so the frame sets of a take's cameras group as they did when
 * recorded.  A gap of more than TAKE_MAX_GAP_S between two frames (or a
 * time that goes backwards) is not waited out: it is logged and replayed
 * as one frame interval, so that a damaged or crafted take cannot hold the
 * camera for years while it shows "ok" (issue 34).  Frames come as recorded: JPEG stays JPEG, raw formats keep
 * their bytes.  A take cut by a crash plays up to its last whole frame. */
#include "drv_common.h"
#include "mdrv.h"
#include "take.h"

#include <limits.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DRV "take"
#define TAKE_MAX_GAP_S 10
#define TAKE_MAX_GAP_NS (TAKE_MAX_GAP_S * 1000000000ull)
#define DEFAULT_INTERVAL_NS 33333333ull /* a frame at 30 fps, when a take gives none */

typedef struct {
	const mdrv_host *host;
	char dir[PATH_MAX], camera[64], path[PATH_MAX + 80];
	double speed;
	bool loop, epoch_given, started;
	uint64_t epoch_ns;
	take_reader r;
	mdrv_format fmt;
	uint64_t first_capture_ns, span_ns; /* of the take's frames, gaps bounded */
	uint64_t nframes, delivered, loop_offset_ns;
	/* Replay time: the previous frame's capture time, the bounded time
	 * since the first frame, and the last interval that was not a gap. */
	uint64_t prev_capture_ns, play_ns, interval_ns;
	uint64_t gaps_cut;
	/* The frame read and not yet delivered (its time had not come). */
	bool pending;
	take_frame_meta m;
	const uint8_t *bytes;
	size_t n;
	uint64_t due_ns;
} take_dev;

static int parse_config(take_dev *d, char *err, size_t errlen)
{
	const mdrv_host *h = d->host;
	const char *dir = drv_cfg_str(h, "take"), *cam = drv_cfg_str(h, "camera");
	if (!dir || !*dir)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'take' is required (a take's directory)", DRV);
	if (!cam || !*cam)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key 'camera' is required (a camera of the take: its take.json lists them)", DRV);
	if (strlen(dir) >= sizeof(d->dir) || strlen(cam) >= sizeof(d->camera))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'take' or 'camera': too long", DRV);
	drv_strlcpy(d->dir, dir, sizeof(d->dir));
	drv_strlcpy(d->camera, cam, sizeof(d->camera));
	d->speed = 1;
	int rc;
	if ((rc = drv_cfg_double(h, DRV, "speed", 0, 1000, &d->speed, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_bool(h, DRV, "loop", &d->loop, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_monotonic_ns(h, DRV, "epoch", &d->epoch_ns, &d->epoch_given, err, errlen)) != MDRV_OK)
		return rc;
	/* The take and its camera. */
	take_info info;
	mc_err e;
	if (take_info_read(d->dir, &info, &e) < 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'take': %s", DRV, e.msg);
	for (int c = 0; c < info.ncams; c++)
		if (strcmp(info.cams[c], d->camera) == 0) {
			snprintf(d->path, sizeof(d->path), "%s/cam-%s.mcr", d->dir, d->camera);
			return MDRV_OK;
		}
	return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'camera': the take %s has no camera '%s'", DRV,
			d->dir, d->camera);
}

/* The time from the previous frame (captured at *prev) to one captured at
 * t, as replayed: the recorded interval, or *interval (the last one
 * replayed as recorded) when it is longer than TAKE_MAX_GAP_NS or negative.
 * True when the gap was cut. */
static bool replay_step(uint64_t *prev, uint64_t t, uint64_t *interval, uint64_t *step)
{
	bool cut = t < *prev || t - *prev > TAKE_MAX_GAP_NS;
	*step = cut ? *interval : t - *prev;
	if (!cut && *step > 0)
		*interval = *step;
	*prev = t;
	return cut;
}

/* One pass over the frames: their count, span, largest size and format. */
static int scan(take_dev *d, char *err, size_t errlen)
{
	mc_err e;
	if (take_reader_open(&d->r, d->path, &e) < 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: %s%s", DRV, e.msg,
				strstr(e.msg, "No such file") ? " (the take was recorded with frames = false?)" : "");
	take_frame_meta m;
	const uint8_t *bytes;
	size_t n;
	uint64_t prev = 0, interval = DEFAULT_INTERVAL_NS, step, cut = 0;
	while (take_reader_next_frame(&d->r, &m, &bytes, &n) == 1) {
		if (d->nframes++ == 0) {
			d->first_capture_ns = prev = m.capture_ns;
			d->fmt = (mdrv_format){.pixfmt = m.pixfmt, .width = m.width, .height = m.height, .stride = m.stride};
		}
		cut += replay_step(&prev, m.capture_ns, &interval, &step);
		d->span_ns += step;
		if (n > d->fmt.max_bytes)
			d->fmt.max_bytes = n;
	}
	take_reader_close(&d->r);
	if (d->nframes == 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: %s holds no whole frame", DRV, d->path);
	if (cut)
		drv_logf(d->host, MDRV_LOG_WARN,
			 "%s: %s: %llu gaps between frames over %d s (or times that go backwards): each is replayed as "
			 "one frame interval", DRV, d->path, (unsigned long long)cut, TAKE_MAX_GAP_S);
	d->fmt.fps = d->span_ns > 0 ? (double)(d->nframes - 1) * 1e9 / (double)d->span_ns : 0;
	if (d->speed > 0)
		d->fmt.fps *= d->speed;
	return MDRV_OK;
}

static int take_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host, (void)out, (void)max, (void)err, (void)errlen;
	return 0; /* takes are not hardware */
}

static void take_close(void *dev)
{
	take_dev *d = dev;
	if (!d)
		return;
	take_reader_close(&d->r);
	free(d);
}

static void *take_open(const mdrv_host *host, char *err, size_t errlen)
{
	take_dev *d = calloc(1, sizeof(*d));
	if (!d) {
		drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
		return drv_open_failed(host, MDRV_ERR_IO);
	}
	d->host = host;
	int rc = parse_config(d, err, errlen);
	if (rc == MDRV_OK)
		rc = scan(d, err, errlen);
	if (rc != MDRV_OK) {
		take_close(d);
		return drv_open_failed(host, rc); /* the take does not change by waiting */
	}
	drv_logf(host, MDRV_LOG_INFO, "%s: %llu frames of camera %s from %s (%ux%u %s, %.1f s, speed %g%s)", DRV,
		 (unsigned long long)d->nframes, d->camera, d->dir, d->fmt.width, d->fmt.height,
		 mc_pixfmt_name(d->fmt.pixfmt), (double)d->span_ns * 1e-9, d->speed, d->loop ? ", looping" : "");
	return d;
}

static int take_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	*fmt = ((take_dev *)dev)->fmt;
	return MDRV_OK;
}

/* The camera's file from its first record again. */
static int rewind_take(take_dev *d, char *err, size_t errlen)
{
	mc_err e;
	take_reader_close(&d->r);
	if (take_reader_open(&d->r, d->path, &e) < 0)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s", DRV, e.msg);
	return MDRV_OK;
}

static int take_start(void *dev, char *err, size_t errlen)
{
	take_dev *d = dev;
	int rc = rewind_take(d, err, errlen);
	if (rc != MDRV_OK)
		return rc;
	if (!d->epoch_given)
		d->epoch_ns = mc_now_ns();
	d->delivered = 0;
	d->loop_offset_ns = 0;
	d->prev_capture_ns = d->first_capture_ns;
	d->play_ns = 0;
	d->interval_ns = DEFAULT_INTERVAL_NS;
	d->pending = false;
	d->started = true;
	return MDRV_OK;
}

static void take_stop(void *dev) { ((take_dev *)dev)->started = false; }

/* The next frame record: 1, 0 at the end of the take (after looping back
 * when looping), or an error status. */
static int next_record(take_dev *d, take_frame_meta *m, const uint8_t **bytes, size_t *n, char *err, size_t errlen)
{
	for (int pass = 0; pass < 2; pass++) {
		if (take_reader_next_frame(&d->r, m, bytes, n) == 1)
			return 1;
		if (!d->loop || pass == 1)
			return 0;
		/* Over again, one frame interval after the last frame. */
		int rc = rewind_take(d, err, errlen);
		if (rc != MDRV_OK)
			return rc;
		d->loop_offset_ns += d->span_ns + (d->nframes > 1 ? d->span_ns / (d->nframes - 1) : DEFAULT_INTERVAL_NS);
		d->prev_capture_ns = d->first_capture_ns;
		d->play_ns = 0;
	}
	return 0;
}

static int take_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	take_dev *d = dev;
	if (!d->started)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: next_frame before start", DRV);
	if (!d->pending) { /* the record stays in the reader's buffer until delivered */
		int rc = next_record(d, &d->m, &d->bytes, &d->n, err, errlen);
		if (rc < 0)
			return rc;
		if (rc == 0)
			return drv_errf(err, errlen, MDRV_ERR_END, "%s: end of %s (%llu frames)", DRV, d->path,
					(unsigned long long)d->delivered);
		d->pending = true;
		/* The first frame of a pass steps 0 from first_capture_ns. */
		uint64_t step, at = d->prev_capture_ns;
		if (replay_step(&d->prev_capture_ns, d->m.capture_ns, &d->interval_ns, &step) && d->gaps_cut++ < 10)
			drv_logf(d->host, MDRV_LOG_WARN, "%s: %s: frame %llu is %+.3g s from the previous one; "
				 "replayed %.1f ms after it (gaps over %d s are cut)", DRV, d->path,
				 (unsigned long long)d->m.sequence, ((double)d->m.capture_ns - (double)at) * 1e-9,
				 (double)step * 1e-6, TAKE_MAX_GAP_S);
		d->play_ns += step;
		d->due_ns = d->speed > 0 ? d->epoch_ns + (uint64_t)((double)(d->play_ns + d->loop_offset_ns) / d->speed)
					 : 0;
	}
	uint64_t now = mc_now_ns(), ts = d->speed > 0 ? d->due_ns : now;
	if (ts > now) {
		if (timeout_ms >= 0 && ts - now > (uint64_t)timeout_ms * 1000000ull) {
			mc_sleep_until_ns(now + (uint64_t)timeout_ms * 1000000ull);
			return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, "%s: next frame due in %.1f ms", DRV,
					(double)(ts - now) * 1e-6 - timeout_ms);
		}
		mc_sleep_until_ns(ts);
	}
	if (d->n > slot->capacity)
		return drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: frame %llu has %zu bytes, the slot holds %zu", DRV,
				(unsigned long long)d->m.sequence, d->n, slot->capacity);
	memcpy(slot->data, d->bytes, d->n);
	slot->bytesused = d->n;
	slot->timestamp_ns = ts;
	slot->sequence = d->delivered++;
	slot->flags = d->m.flags;
	slot->format = d->fmt;
	slot->format.width = d->m.width;
	slot->format.height = d->m.height;
	slot->format.stride = d->m.stride;
	d->pending = false;
	return MDRV_OK;
}

/* The keys, that the take opens and names the camera, and that its file
 * holds frames. */
static int take_check(const mdrv_host *host, char *err, size_t errlen)
{
	take_dev *d = calloc(1, sizeof(*d));
	if (!d)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
	d->host = host;
	int rc = parse_config(d, err, errlen);
	if (rc == MDRV_OK)
		rc = scan(d, err, errlen);
	take_close(d);
	return rc == MDRV_OK ? MDRV_OK : MDRV_ERR_CONFIG;
}

MDRV_DEFINE_DRIVER(take, DRV, "replays one camera of a take recorded by mocapd, with its original timing")
