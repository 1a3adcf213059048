/* mocap-driver-aravis: GigE Vision (and USB3 Vision) cameras through Aravis 0.8.
 *
 * Frames are delivered in the camera's own pixel format: Mono8 as GRAY8,
 * RGB8 as RGB24 and 8-bit Bayer as MC_PIXFMT_BAYER_* (the host demosaics;
 * the driver does not, so that recordings keep the raw sensor data).
 *
 * Timestamps: Aravis stamps each buffer with the host clock when the frame's
 * first packet arrives (its "system timestamp"); that is converted to
 * CLOCK_MONOTONIC.  The camera's own tick counter is not used, since it is
 * not synchronised with the host unless the rig runs PTP.
 *
 * Unplug: the device's "control-lost" signal (heartbeat failures), and a
 * register read when no frame has come for a while, turn into
 * MDRV_ERR_NODEV.  Config keys are listed in docs/DRIVERS.md. */
#include <arv.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "drv_common.h"
#include "mdrv.h"

#define DRV "aravis"

/* Aravis keeps one process-wide device list; discovery and opening go
 * through it, so they are serialised here. */
static pthread_mutex_t arv_list_lock = PTHREAD_MUTEX_INITIALIZER;

enum trigger_mode { TRIGGER_NONE, TRIGGER_SOFTWARE, TRIGGER_LINE };

typedef struct {
	const char *name; /* GenICam PixelFormat entry */
	ArvPixelFormat arv;
	mc_pixfmt fmt;
	unsigned bytes_per_pixel;
} pixfmt_map;

static const pixfmt_map pixfmts[] = {
	{"Mono8", ARV_PIXEL_FORMAT_MONO_8, MC_PIXFMT_GRAY8, 1},
	{"BayerRG8", ARV_PIXEL_FORMAT_BAYER_RG_8, MC_PIXFMT_BAYER_RGGB8, 1},
	{"BayerGR8", ARV_PIXEL_FORMAT_BAYER_GR_8, MC_PIXFMT_BAYER_GRBG8, 1},
	{"BayerGB8", ARV_PIXEL_FORMAT_BAYER_GB_8, MC_PIXFMT_BAYER_GBRG8, 1},
	{"BayerBG8", ARV_PIXEL_FORMAT_BAYER_BG_8, MC_PIXFMT_BAYER_BGGR8, 1},
	{"RGB8", ARV_PIXEL_FORMAT_RGB_8_PACKED, MC_PIXFMT_RGB24, 3},
};
#define N_PIXFMTS (int)(sizeof pixfmts / sizeof pixfmts[0])

/* Everything the config asks for, parsed before the camera is touched. */
typedef struct {
	const char *device, *serial;
	int pixfmt; /* index into pixfmts, -1 = keep the camera's */
	unsigned width, height, offset_x, offset_y;
	double fps; /* 0 = keep */
	drv_auto_value exposure, gain;
	unsigned packet_size; /* 0 = negotiate the largest that gets through */
	unsigned packet_delay_ns;
	enum trigger_mode trigger;
	const char *trigger_line;
	unsigned buffers;
} arv_config;

typedef struct {
	mdrv_host host;
	arv_config cfg;
	char id[128];
	ArvCamera *camera;
	ArvDevice *device; /* owned by camera */
	gulong lost_handler;
	atomic_bool control_lost;
	ArvStream *stream;
	mdrv_format fmt;
	bool trigger_pending;
	bool have_frame_id;
	guint64 last_frame_id;
	uint64_t sequence;
	uint64_t last_frame_ns;    /* monotonic time of the last frame (or start) */
	uint64_t last_liveness_ns; /* last time the camera was asked if it is there */
	unsigned corrupt_frames;
} arv_dev;

/* Maps an Aravis error to a mdrv_status: a camera that does not answer is
 * gone; a refused value is a config problem; anything else is I/O. */
static int status_of(const GError *e)
{
	if (!e || e->domain != ARV_DEVICE_ERROR)
		return MDRV_ERR_IO;
	switch (e->code) {
	case ARV_DEVICE_ERROR_TIMEOUT:
	case ARV_DEVICE_ERROR_NOT_CONNECTED:
	case ARV_DEVICE_ERROR_NOT_FOUND:
		return MDRV_ERR_NODEV;
	case ARV_DEVICE_ERROR_INVALID_PARAMETER:
	case ARV_DEVICE_ERROR_PROTOCOL_ERROR_INVALID_PARAMETER:
	case ARV_DEVICE_ERROR_FEATURE_NOT_FOUND:
	case ARV_DEVICE_ERROR_WRONG_FEATURE:
		return MDRV_ERR_CONFIG;
	default:
		return MDRV_ERR_IO;
	}
}

/* Moves a GError into err (prefixed with `what`) and frees it. */
static int take_error(GError **e, const char *id, const char *what, char *err, size_t errlen)
{
	int st = status_of(*e);
	drv_errf(err, errlen, st, DRV ": camera '%s': %s: %s", id, what, *e ? (*e)->message : "failed");
	g_clear_error(e);
	return st;
}

static int parse_config(const mdrv_host *host, arv_config *c, char *err, size_t errlen)
{
	memset(c, 0, sizeof *c);
	c->pixfmt = -1;
	c->buffers = 8;
	c->device = drv_cfg_str(host, "device");
	c->serial = drv_cfg_str(host, "serial");
	if (!c->device && !c->serial)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				DRV ": config needs 'device' (an Aravis device id or IP address) or 'serial'");
	const char *names[N_PIXFMTS];
	for (int i = 0; i < N_PIXFMTS; i++)
		names[i] = pixfmts[i].name;
	int st;
	if ((st = drv_cfg_choice(host, DRV, "pixel_format", names, N_PIXFMTS, &c->pixfmt, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "width", 1, 65535, &c->width, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "height", 1, 65535, &c->height, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "offset_x", 0, 65535, &c->offset_x, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "offset_y", 0, 65535, &c->offset_y, err, errlen)) ||
	    (st = drv_cfg_double(host, DRV, "fps", 0.001, 100000, &c->fps, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, DRV, "exposure", 1e-6, 100, &c->exposure, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, DRV, "gain", -100, 100, &c->gain, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "packet_delay", 0, 1000000000, &c->packet_delay_ns, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "buffers", 2, 64, &c->buffers, err, errlen)))
		return st;
	if ((c->width == 0) != (c->height == 0))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, DRV ": config keys 'width' and 'height' go together");
	const char *ps = drv_cfg_str(host, "packet_size");
	if (ps && strcasecmp(ps, "auto") &&
	    (st = drv_cfg_uint(host, DRV, "packet_size", 576, 16384, &c->packet_size, err, errlen)))
		return st;
	const char *trig = drv_cfg_str(host, "trigger");
	if (!trig || !strcasecmp(trig, "none") || !strcasecmp(trig, "off")) {
		c->trigger = TRIGGER_NONE;
	} else if (!strcasecmp(trig, "software")) {
		c->trigger = TRIGGER_SOFTWARE;
	} else {
		c->trigger = TRIGGER_LINE; /* a hardware input such as Line0 or Line1 */
		c->trigger_line = trig;
	}
	return MDRV_OK;
}

/* Finds the Aravis id of the camera with serial number `serial`. */
static int find_by_serial(const char *serial, char *id, size_t idlen, char *err, size_t errlen)
{
	char seen[512] = "";
	pthread_mutex_lock(&arv_list_lock);
	arv_update_device_list();
	unsigned n = arv_get_n_devices();
	int found = 0;
	for (unsigned i = 0; i < n; i++) {
		const char *s = arv_get_device_serial_nbr(i);
		if (s && !strcmp(s, serial)) {
			drv_strlcpy(id, arv_get_device_id(i), idlen);
			found = 1;
			break;
		}
		size_t len = strlen(seen);
		snprintf(seen + len, sizeof seen - len, "%s%s (serial %s)", len ? ", " : "", arv_get_device_id(i),
			 s ? s : "?");
	}
	pthread_mutex_unlock(&arv_list_lock);
	if (!found)
		return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": no camera with serial '%s' found (found: %s)",
				serial, n ? seen : "none");
	return MDRV_OK;
}

static int apply_pixel_format(arv_dev *d, char *err, size_t errlen)
{
	GError *e = NULL;
	if (d->cfg.pixfmt >= 0) {
		guint n = 0;
		const char **avail = arv_camera_dup_available_pixel_formats_as_strings(d->camera, &n, &e);
		if (e)
			return take_error(&e, d->id, "listing pixel formats", err, errlen);
		bool ok = false;
		char list[256] = "";
		for (guint i = 0; i < n; i++) {
			ok = ok || !strcmp(avail[i], pixfmts[d->cfg.pixfmt].name);
			size_t len = strlen(list);
			snprintf(list + len, sizeof list - len, "%s%s", i ? ", " : "", avail[i]);
		}
		g_free(avail);
		if (!ok)
			return drv_errf(err, errlen, MDRV_ERR_FORMAT,
					DRV ": camera '%s': pixel_format %s not offered (it offers %s)", d->id,
					pixfmts[d->cfg.pixfmt].name, list);
		arv_camera_set_pixel_format(d->camera, pixfmts[d->cfg.pixfmt].arv, &e);
		if (e)
			return take_error(&e, d->id, "setting the pixel format", err, errlen);
	}
	ArvPixelFormat cur = arv_camera_get_pixel_format(d->camera, &e);
	if (e)
		return take_error(&e, d->id, "reading the pixel format", err, errlen);
	for (int i = 0; i < N_PIXFMTS; i++) {
		if (pixfmts[i].arv == cur) {
			d->fmt.pixfmt = pixfmts[i].fmt;
			d->fmt.stride = pixfmts[i].bytes_per_pixel; /* times width, below */
			return MDRV_OK;
		}
	}
	return drv_errf(err, errlen, MDRV_ERR_FORMAT,
			DRV ": camera '%s': its pixel format 0x%08x is not supported; set pixel_format to one of "
			    "Mono8, BayerRG8, BayerGR8, BayerGB8, BayerBG8, RGB8",
			d->id, (unsigned)cur);
}

static int apply_region(arv_dev *d, char *err, size_t errlen)
{
	GError *e = NULL;
	if (d->cfg.width) {
		arv_camera_set_region(d->camera, (gint)d->cfg.offset_x, (gint)d->cfg.offset_y, (gint)d->cfg.width,
				      (gint)d->cfg.height, &e);
		if (e)
			return take_error(&e, d->id, "setting the image region", err, errlen);
	}
	gint x, y, w, h;
	arv_camera_get_region(d->camera, &x, &y, &w, &h, &e);
	if (e)
		return take_error(&e, d->id, "reading the image region", err, errlen);
	if (d->cfg.width && ((unsigned)w != d->cfg.width || (unsigned)h != d->cfg.height))
		return drv_errf(err, errlen, MDRV_ERR_FORMAT,
				DRV ": camera '%s': asked for %ux%u, the camera gives %dx%d", d->id, d->cfg.width,
				d->cfg.height, w, h);
	d->fmt.width = (uint32_t)w;
	d->fmt.height = (uint32_t)h;
	return MDRV_OK;
}

static int apply_trigger(arv_dev *d, char *err, size_t errlen)
{
	GError *e = NULL;
	if (d->cfg.trigger == TRIGGER_NONE) {
		arv_camera_clear_triggers(d->camera, &e);
		if (e) /* cameras without trigger features are free-running anyway */
			g_clear_error(&e);
		return MDRV_OK;
	}
	const char *source = d->cfg.trigger == TRIGGER_SOFTWARE ? "Software" : d->cfg.trigger_line;
	guint n = 0;
	const char **avail = arv_camera_dup_available_trigger_sources(d->camera, &n, &e);
	if (e)
		return take_error(&e, d->id, "listing trigger sources", err, errlen);
	bool ok = false;
	char list[256] = "";
	for (guint i = 0; i < n; i++) {
		ok = ok || !strcmp(avail[i], source);
		size_t len = strlen(list);
		snprintf(list + len, sizeof list - len, "%s%s", i ? ", " : "", avail[i]);
	}
	g_free(avail);
	if (!ok)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				DRV ": camera '%s': config key 'trigger': source '%s' not offered (it offers %s)",
				d->id, source, n ? list : "none");
	arv_camera_set_trigger(d->camera, source, &e);
	if (e)
		return take_error(&e, d->id, "setting the trigger", err, errlen);
	return MDRV_OK;
}

static int apply_frame_rate(arv_dev *d, char *err, size_t errlen)
{
	GError *e = NULL;
	if (d->cfg.fps > 0) {
		double lo = 0, hi = 0;
		arv_camera_get_frame_rate_bounds(d->camera, &lo, &hi, &e);
		if (e)
			return take_error(&e, d->id, "reading the frame rate range", err, errlen);
		if (d->cfg.fps < lo || d->cfg.fps > hi)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG,
					DRV ": camera '%s': config key 'fps': %g outside the camera's range [%g, %g]",
					d->id, d->cfg.fps, lo, hi);
		arv_camera_set_frame_rate(d->camera, d->cfg.fps, &e);
		if (e)
			return take_error(&e, d->id, "setting the frame rate", err, errlen);
	}
	double fps = arv_camera_get_frame_rate(d->camera, &e);
	if (e) { /* some cameras have no frame rate feature */
		g_clear_error(&e);
		fps = 0;
	}
	/* A triggered camera runs at the rate of its trigger. */
	d->fmt.fps = d->cfg.trigger == TRIGGER_NONE ? fps : 0;
	return MDRV_OK;
}

/* Exposure (seconds in the config, microseconds in GenICam) and gain (dB). */
static int apply_exposure_gain(arv_dev *d, char *err, size_t errlen)
{
	GError *e = NULL;
	if (d->cfg.exposure.present) {
		if (d->cfg.exposure.is_auto) {
			arv_camera_set_exposure_time_auto(d->camera, ARV_AUTO_CONTINUOUS, &e);
		} else {
			double lo = 0, hi = 0, us = d->cfg.exposure.value * 1e6;
			arv_camera_get_exposure_time_bounds(d->camera, &lo, &hi, &e);
			if (!e && (us < lo || us > hi))
				return drv_errf(err, errlen, MDRV_ERR_CONFIG,
						DRV ": camera '%s': config key 'exposure': %g s outside the camera's "
						    "range [%g, %g] s",
						d->id, d->cfg.exposure.value, lo * 1e-6, hi * 1e-6);
			if (!e)
				arv_camera_set_exposure_time(d->camera, us, &e);
		}
		if (e)
			return take_error(&e, d->id, "setting 'exposure'", err, errlen);
	}
	if (d->cfg.gain.present) {
		if (d->cfg.gain.is_auto) {
			arv_camera_set_gain_auto(d->camera, ARV_AUTO_CONTINUOUS, &e);
		} else {
			double lo = 0, hi = 0;
			arv_camera_get_gain_bounds(d->camera, &lo, &hi, &e);
			if (!e && (d->cfg.gain.value < lo || d->cfg.gain.value > hi))
				return drv_errf(err, errlen, MDRV_ERR_CONFIG,
						DRV ": camera '%s': config key 'gain': %g dB outside the camera's range "
						    "[%g, %g] dB",
						d->id, d->cfg.gain.value, lo, hi);
			if (!e)
				arv_camera_set_gain(d->camera, d->cfg.gain.value, &e);
		}
		if (e)
			return take_error(&e, d->id, "setting 'gain'", err, errlen);
	}
	return MDRV_OK;
}

/* GigE Vision transport: packet size (jumbo frames need it raised) and the
 * inter-packet delay that spreads several cameras' bursts on one link. */
static int apply_gige_transport(arv_dev *d, char *err, size_t errlen)
{
	if (!arv_camera_is_gv_device(d->camera))
		return MDRV_OK;
	GError *e = NULL;
	if (d->cfg.packet_size) {
		arv_camera_gv_set_packet_size(d->camera, (gint)d->cfg.packet_size, &e);
		if (e)
			return take_error(&e, d->id, "setting 'packet_size'", err, errlen);
		guint got = arv_camera_gv_get_packet_size(d->camera, &e);
		if (e)
			return take_error(&e, d->id, "reading the packet size", err, errlen);
		if (got != d->cfg.packet_size)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG,
					DRV ": camera '%s': config key 'packet_size': asked for %u bytes, the camera "
					    "took %u",
					d->id, d->cfg.packet_size, got);
	} else {
		arv_camera_gv_auto_packet_size(d->camera, &e);
		if (e)
			return take_error(&e, d->id, "negotiating the packet size", err, errlen);
	}
	if (d->cfg.packet_delay_ns) {
		arv_camera_gv_set_packet_delay(d->camera, (gint64)d->cfg.packet_delay_ns, &e);
		if (e)
			return take_error(&e, d->id, "setting 'packet_delay'", err, errlen);
	}
	guint ps = arv_camera_gv_get_packet_size(d->camera, &e);
	g_clear_error(&e);
	drv_logf(&d->host, MDRV_LOG_INFO, DRV ": camera '%s': GigE Vision packet size %u bytes", d->id, ps);
	return MDRV_OK;
}

static void on_control_lost(ArvDevice *device, gpointer user)
{
	(void)device;
	arv_dev *d = user;
	atomic_store(&d->control_lost, true);
}

/* The order matters: Aravis' frame rate setter switches the frame-start
 * trigger off, so the trigger comes after it. */
static int configure(arv_dev *d, char *err, size_t errlen)
{
	int st;
	if ((st = apply_gige_transport(d, err, errlen)) || (st = apply_region(d, err, errlen)) ||
	    (st = apply_pixel_format(d, err, errlen)) || (st = apply_frame_rate(d, err, errlen)) ||
	    (st = apply_trigger(d, err, errlen)) || (st = apply_exposure_gain(d, err, errlen)))
		return st;
	d->fmt.stride *= d->fmt.width;
	GError *e = NULL;
	guint payload = arv_camera_get_payload(d->camera, &e);
	if (e)
		return take_error(&e, d->id, "reading the payload size", err, errlen);
	size_t image = (size_t)d->fmt.stride * d->fmt.height;
	d->fmt.max_bytes = payload > image ? payload : image;
	return MDRV_OK;
}

static void aravis_close(void *dev);

static void *aravis_open(const mdrv_host *host, char *err, size_t errlen)
{
	arv_dev *d = calloc(1, sizeof *d);
	if (!d) {
		drv_errf(err, errlen, MDRV_ERR_IO, DRV ": out of memory");
		return NULL;
	}
	d->host = *host;
	if (parse_config(host, &d->cfg, err, errlen) != MDRV_OK) {
		aravis_close(d);
		return drv_open_failed(host, MDRV_ERR_CONFIG); /* the keys do not change by waiting */
	}
	if (d->cfg.device)
		drv_strlcpy(d->id, d->cfg.device, sizeof d->id);
	else if (find_by_serial(d->cfg.serial, d->id, sizeof d->id, err, errlen) != MDRV_OK)
		goto fail;

	GError *e = NULL;
	pthread_mutex_lock(&arv_list_lock);
	d->camera = arv_camera_new(d->id, &e);
	pthread_mutex_unlock(&arv_list_lock);
	if (!d->camera) {
		drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": cannot open camera '%s': %s", d->id,
			 e ? e->message : "not found");
		g_clear_error(&e);
		goto fail;
	}
	d->device = arv_camera_get_device(d->camera);
	if (d->cfg.device && d->cfg.serial) { /* both given: they must agree */
		const char *s = arv_camera_get_device_serial_number(d->camera, &e);
		if (e || !s || strcmp(s, d->cfg.serial)) {
			drv_errf(err, errlen, MDRV_ERR_CONFIG,
				 DRV ": camera '%s' has serial '%s', the config asks for '%s'", d->id,
				 s ? s : "?", d->cfg.serial);
			g_clear_error(&e);
			goto fail;
		}
	}
	d->lost_handler = g_signal_connect(d->device, "control-lost", G_CALLBACK(on_control_lost), d);
	if (configure(d, err, errlen) != MDRV_OK)
		goto fail;
	drv_logf(host, MDRV_LOG_INFO, DRV ": opened '%s': %s %ux%u, %.3g fps%s", d->id,
		 mc_pixfmt_name(d->fmt.pixfmt), d->fmt.width, d->fmt.height, d->fmt.fps,
		 d->cfg.trigger == TRIGGER_NONE ? "" : ", triggered");
	return d;
fail:
	aravis_close(d);
	return NULL;
}

static int aravis_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)err;
	(void)errlen;
	*fmt = ((arv_dev *)dev)->fmt;
	return MDRV_OK;
}

static int aravis_start(void *dev, char *err, size_t errlen)
{
	arv_dev *d = dev;
	if (d->stream)
		return MDRV_OK;
	GError *e = NULL;
	d->stream = arv_camera_create_stream(d->camera, NULL, NULL, &e);
	if (!d->stream)
		return take_error(&e, d->id, "creating the stream", err, errlen);
	for (unsigned i = 0; i < d->cfg.buffers; i++)
		arv_stream_push_buffer(d->stream, arv_buffer_new(d->fmt.max_bytes, NULL));
	arv_camera_set_acquisition_mode(d->camera, ARV_ACQUISITION_MODE_CONTINUOUS, &e);
	if (!e)
		arv_camera_start_acquisition(d->camera, &e);
	if (e) {
		int st = take_error(&e, d->id, "starting acquisition", err, errlen);
		g_clear_object(&d->stream);
		return st;
	}
	d->have_frame_id = false;
	d->trigger_pending = false;
	d->last_frame_ns = d->last_liveness_ns = mc_now_ns();
	return MDRV_OK;
}

static int lost_error(arv_dev *d, char *err, size_t errlen)
{
	return drv_errf(err, errlen, MDRV_ERR_NODEV,
			DRV ": camera '%s' stopped answering (control lost): unplugged, powered off or its link "
			    "is down",
			d->id);
}

/* After a quiet spell, asks the camera for a bootstrap register: a camera
 * that does not answer is gone, even before the heartbeat notices. */
static int check_alive(arv_dev *d, char *err, size_t errlen)
{
	uint64_t now = mc_now_ns();
	uint64_t quiet = d->fmt.fps > 0 ? (uint64_t)(3e9 / d->fmt.fps) : 0;
	if (quiet < 1000000000u)
		quiet = 1000000000u;
	if (now - d->last_frame_ns < quiet || now - d->last_liveness_ns < 1000000000u)
		return MDRV_ERR_TIMEOUT;
	d->last_liveness_ns = now;
	guint32 value;
	GError *e = NULL;
	if (!arv_device_read_register(d->device, 0, &value, &e)) {
		drv_logf(&d->host, MDRV_LOG_WARN, DRV ": camera '%s' does not answer: %s", d->id,
			 e ? e->message : "?");
		g_clear_error(&e);
		atomic_store(&d->control_lost, true);
		return lost_error(d, err, errlen);
	}
	return MDRV_ERR_TIMEOUT;
}

/* Aravis stamps buffers with the wall clock; moves that to CLOCK_MONOTONIC.
 * A stamp that is already monotonic (closer to that clock) is kept. */
static uint64_t to_monotonic(uint64_t stamp)
{
	uint64_t mono = mc_now_ns(), real = mc_realtime_ns();
	if (!stamp)
		return mono;
	uint64_t d_real = stamp > real ? stamp - real : real - stamp;
	uint64_t d_mono = stamp > mono ? stamp - mono : mono - stamp;
	if (d_mono < d_real)
		return stamp;
	int64_t t = (int64_t)stamp - (int64_t)(real - mono);
	return t > 0 ? (uint64_t)t : mono;
}

/* Frame ids are 16-bit (GigE Vision 1.x, wrapping from 65535 to 1) or 64-bit;
 * the sequence counts every id, so that lost frames show up as gaps. */
static void advance_sequence(arv_dev *d, guint64 id)
{
	if (!d->have_frame_id) {
		d->have_frame_id = true;
		d->sequence = 0;
	} else if (id > d->last_frame_id) {
		d->sequence += id - d->last_frame_id;
	} else if (d->last_frame_id <= 0xffff && id <= 0xffff) {
		d->sequence += 0xffff - d->last_frame_id + id;
	} else {
		d->sequence++;
	}
	d->last_frame_id = id;
}

static int aravis_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	arv_dev *d = dev;
	if (!d->stream)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": camera '%s': next_frame before start", d->id);
	if (atomic_load(&d->control_lost))
		return lost_error(d, err, errlen);
	GError *e = NULL;
	if (d->cfg.trigger == TRIGGER_SOFTWARE && !d->trigger_pending) {
		/* frames left from before the request are not what was asked for */
		ArvBuffer *stale;
		while ((stale = arv_stream_try_pop_buffer(d->stream)))
			arv_stream_push_buffer(d->stream, stale);
		arv_camera_software_trigger(d->camera, &e);
		if (e)
			return take_error(&e, d->id, "software trigger", err, errlen);
		d->trigger_pending = true;
	}
	ArvBuffer *buf = arv_stream_timeout_pop_buffer(d->stream, (guint64)(timeout_ms > 0 ? timeout_ms : 0) * 1000);
	if (!buf) {
		if (atomic_load(&d->control_lost))
			return lost_error(d, err, errlen);
		int st = check_alive(d, err, errlen);
		if (st == MDRV_ERR_TIMEOUT)
			drv_errf(err, errlen, st, DRV ": camera '%s': no frame within %d ms", d->id, timeout_ms);
		return st;
	}
	size_t size = 0;
	const void *data = arv_buffer_get_data(buf, &size);
	ArvBufferStatus status = arv_buffer_get_status(buf);
	if (size > slot->capacity) {
		arv_stream_push_buffer(d->stream, buf);
		return drv_errf(err, errlen, MDRV_ERR_NOSPACE, DRV ": camera '%s': frame of %zu bytes, slot holds %zu",
				d->id, size, slot->capacity);
	}
	if (data && size)
		memcpy(slot->data, data, size);
	slot->bytesused = size;
	slot->format = d->fmt;
	slot->flags = 0;
	if (status != ARV_BUFFER_STATUS_SUCCESS) {
		/* missing packets, a size mismatch or a timeout: the data is
		 * there but damaged; the host decides whether to use it */
		slot->flags |= MDRV_FRAME_CORRUPT;
		if (d->corrupt_frames++ % 100 == 0)
			drv_logf(&d->host, MDRV_LOG_WARN, DRV ": camera '%s': damaged frame (Aravis buffer status %d)",
				 d->id, (int)status);
	}
	if (size < (size_t)d->fmt.stride * d->fmt.height)
		slot->flags |= MDRV_FRAME_SHORT;
	slot->timestamp_ns = to_monotonic(arv_buffer_get_system_timestamp(buf));
	advance_sequence(d, arv_buffer_get_frame_id(buf));
	slot->sequence = d->sequence;
	arv_stream_push_buffer(d->stream, buf);
	d->trigger_pending = false;
	d->last_frame_ns = mc_now_ns();
	return MDRV_OK;
}

static void aravis_stop(void *dev)
{
	arv_dev *d = dev;
	if (!d->stream)
		return;
	GError *e = NULL;
	if (!atomic_load(&d->control_lost)) /* else each write would time out */
		arv_camera_stop_acquisition(d->camera, &e);
	if (e) {
		drv_logf(&d->host, MDRV_LOG_WARN, DRV ": camera '%s': stopping acquisition: %s", d->id, e->message);
		g_clear_error(&e);
	}
	g_clear_object(&d->stream);
}

static void aravis_close(void *dev)
{
	arv_dev *d = dev;
	if (!d)
		return;
	aravis_stop(d);
	if (d->lost_handler)
		g_signal_handler_disconnect(d->device, d->lost_handler);
	g_clear_object(&d->camera);
	free(d);
}

static const char *or_empty(const char *s)
{
	return s ? s : "";
}

static int aravis_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host;
	(void)err;
	(void)errlen;
	pthread_mutex_lock(&arv_list_lock);
	arv_update_device_list();
	int n = (int)arv_get_n_devices();
	for (int i = 0; i < n && i < max; i++) {
		mdrv_device_info *o = &out[i];
		memset(o, 0, sizeof *o);
		drv_strlcpy(o->id, arv_get_device_id((unsigned)i), sizeof o->id);
		snprintf(o->name, sizeof o->name, "%s %s", or_empty(arv_get_device_vendor((unsigned)i)),
			 or_empty(arv_get_device_model((unsigned)i)));
		snprintf(o->bus_info, sizeof o->bus_info, "%s:%s", or_empty(arv_get_device_protocol((unsigned)i)),
			 or_empty(arv_get_device_address((unsigned)i)));
		drv_strlcpy(o->serial, arv_get_device_serial_nbr((unsigned)i), sizeof o->serial);
	}
	pthread_mutex_unlock(&arv_list_lock);
	return n < max ? n : max;
}

/* One mode per pixel format the camera offers and this driver takes, at
 * the largest region its Width and Height allow, with the frame rate
 * range at the current settings.  Reads the camera's features only. */
static int list_modes(ArvCamera *cam, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	GError *e = NULL;
	gint wmin = 0, wmax = 0, hmin = 0, hmax = 0;
	double fmin = 0, fmax = 0;
	arv_camera_get_width_bounds(cam, &wmin, &wmax, &e);
	if (!e)
		arv_camera_get_height_bounds(cam, &hmin, &hmax, &e);
	if (e)
		return take_error(&e, id, "reading the region bounds", err, errlen);
	arv_camera_get_frame_rate_bounds(cam, &fmin, &fmax, &e);
	g_clear_error(&e); /* some cameras have no AcquisitionFrameRate: rates unknown */
	guint nfmt = 0;
	gint64 *fmts = arv_camera_dup_available_pixel_formats(cam, &nfmt, &e);
	if (e)
		return take_error(&e, id, "listing pixel formats", err, errlen);
	/* The current format first: --probe suggests the first one listed. */
	gint64 current = (gint64)arv_camera_get_pixel_format(cam, &e);
	g_clear_error(&e);
	for (guint i = 1; i < nfmt; i++)
		if (fmts[i] == current) {
			fmts[i] = fmts[0];
			fmts[0] = current;
		}
	int n = 0;
	for (guint i = 0; i < nfmt; i++)
		for (int k = 0; k < N_PIXFMTS && n < max; k++) {
			if ((gint64)pixfmts[k].arv != fmts[i])
				continue;
			mdrv_mode *m = &out[n++];
			memset(m, 0, sizeof *m);
			drv_strlcpy(m->pixel_format, pixfmts[k].name, sizeof m->pixel_format);
			m->pixfmt = pixfmts[k].fmt;
			m->width = (uint32_t)wmax;
			m->height = (uint32_t)hmax;
			m->fps_min = fmin;
			m->fps_max = fmax;
		}
	g_free(fmts);
	return n;
}

static int aravis_modes(const mdrv_host *host, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	(void)host;
	GError *e = NULL;
	pthread_mutex_lock(&arv_list_lock);
	ArvCamera *cam = arv_camera_new(id, &e);
	pthread_mutex_unlock(&arv_list_lock);
	if (!cam) {
		drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": cannot open camera '%s': %s", id,
			 e ? e->message : "not found");
		g_clear_error(&e);
		return MDRV_ERR_NODEV;
	}
	int n = list_modes(cam, id, out, max, err, errlen);
	g_object_unref(cam);
	return n;
}

/* The keys, parsed as open() parses them; no camera is looked for. */
static int aravis_check(const mdrv_host *host, char *err, size_t errlen)
{
	arv_config c;
	return parse_config(host, &c, err, errlen);
}

MDRV_DEFINE_DRIVER_MODES(aravis, "aravis",
		   "GigE Vision / USB3 Vision cameras through Aravis 0.8")
