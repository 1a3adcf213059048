/* mocap-driver-gstreamer: any video GStreamer can decode, as a camera:
 * files (MKV, MP4, ...), RTSP and HTTP streams through uridecodebin, or a
 * gst-launch description ending in `appsink name=mocap`.  The ABI and the
 * config keys are here; the pipeline is gst_pipe.c.  docs/DRIVERS.md,
 * "gstreamer", documents the keys, the timestamps and the errors. */
#include "drv_common.h"
#include "gst_internal.h"
#include "gst_probe.h"
#include "mdrv.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define DEFAULT_LATENCY_MS 200
#define DEFAULT_OPEN_TIMEOUT_MS 10000

typedef struct {
	const mdrv_host *host;
	gp_pipe *pipe;
	bool epoch_given;
	uint64_t epoch_ns;
} gst_dev;

/* ---- config ---- */

/* A file URI must name a readable file: said at --check, and a missing
 * file is permanent. */
static int check_file_uri(const char *uri, char *err, size_t errlen)
{
	gchar *path = g_filename_from_uri(uri, NULL, NULL);
	if (!path)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'uri' = '%s': not a valid file URI", DRV, uri);
	int rc = MDRV_OK;
	if (access(path, R_OK) != 0)
		rc = drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'uri' = '%s': %s: %s", DRV, uri, path,
			      strerror(errno));
	g_free(path);
	return rc;
}

/* `uri` as a URI; a plain path is taken as a file. */
static int read_uri(const char *v, gp_config *cfg, char *err, size_t errlen)
{
	if (!strstr(v, "://")) {
		GError *e = NULL;
		cfg->uri = gst_filename_to_uri(v, &e);
		g_clear_error(&e);
		if (!cfg->uri)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'uri' = '%s': not a path or URI", DRV, v);
	} else {
		cfg->uri = g_strdup(v);
	}
	if (!gst_uri_is_valid(cfg->uri))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key 'uri' = '%s': not a URI (file:///path, rtsp://host/path, ...)", DRV, v);
	gchar *proto = gst_uri_get_protocol(cfg->uri);
	bool file = proto && !strcmp(proto, "file");
	bool known = proto && gst_uri_protocol_is_supported(GST_URI_SRC, proto);
	int rc = MDRV_OK;
	if (!known)
		rc = drv_errf(err, errlen, MDRV_ERR_CONFIG,
			      "%s: config key 'uri' = '%s': no GStreamer source reads '%s://' (for rtsp: "
			      "gstreamer1.0-plugins-good)", DRV, v, proto ? proto : "");
	g_free(proto);
	if (rc == MDRV_OK && file)
		rc = check_file_uri(cfg->uri, err, errlen);
	return rc;
}

static int read_source(const mdrv_host *h, gp_config *cfg, char *err, size_t errlen)
{
	const char *uri = drv_cfg_str(h, "uri"), *launch = drv_cfg_str(h, "pipeline");
	if (!uri == !launch)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key 'uri' or 'pipeline' is required, not both (uri = file:///video.mkv, "
				"rtsp://host/stream; pipeline = ... ! appsink name=%s)", DRV, GP_SINK_NAME);
	if (uri) {
		cfg->key = "uri";
		return read_uri(uri, cfg, err, errlen);
	}
	cfg->key = "pipeline";
	cfg->launch = g_strdup(launch);
	return MDRV_OK; /* parsed by check() and open() */
}

static int parse_config(gst_dev *d, gp_config *cfg, char *err, size_t errlen)
{
	const mdrv_host *h = d->host;
	static const char *const formats[] = {"auto", "rgb24", "gray8", "yuyv", "mjpeg"};
	static const char *const paces[] = {"realtime", "asap"};
	static const char *const transports[] = {"auto", "tcp", "udp"};
	static const char *const stamps[] = {"sender", "arrival"};
	*cfg = (gp_config){.latency_ms = DEFAULT_LATENCY_MS, .open_timeout_ms = DEFAULT_OPEN_TIMEOUT_MS};
	int rc;
	if ((rc = gp_init(err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_choice(h, DRV, "format", formats, 5, &cfg->format, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_choice(h, DRV, "pace", paces, 2, &cfg->pace, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_double(h, DRV, "start", 0, 1e7, &cfg->start_s, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_uint(h, DRV, "latency", 0, 60000, &cfg->latency_ms, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_choice(h, DRV, "rtsp_transport", transports, 3, &cfg->rtsp_transport, err, errlen)) !=
		    MDRV_OK ||
	    (rc = drv_cfg_choice(h, DRV, "rtsp_timestamps", stamps, 2, &cfg->rtsp_timestamps, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_uint(h, DRV, "open_timeout", 100, 600000, &cfg->open_timeout_ms, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_monotonic_ns(h, DRV, "epoch", &d->epoch_ns, &d->epoch_given, err, errlen)) != MDRV_OK)
		return rc;
	/* The source last: its errors may come from opening a file. */
	return read_source(h, cfg, err, errlen);
}

/* ---- the ABI ---- */

/* mocapd --probe: the video sources GStreamer's device providers find
 * (gst_probe.c); the config takes each one's id in `pipeline`. */
static int gstreamer_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host;
	return gp_probe_devices(out, max, err, errlen);
}

static int gstreamer_modes(const mdrv_host *host, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	(void)host;
	return gp_probe_modes(id, out, max, err, errlen);
}

static void gstreamer_close(void *dev)
{
	gst_dev *d = dev;
	if (!d)
		return;
	gp_close(d->pipe);
	free(d);
}

static void *gstreamer_open(const mdrv_host *host, char *err, size_t errlen)
{
	gst_dev *d = calloc(1, sizeof(*d));
	if (!d) {
		drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
		return drv_open_failed(host, MDRV_ERR_IO);
	}
	d->host = host;
	gp_config cfg;
	int rc = parse_config(d, &cfg, err, errlen);
	double start_s = cfg.start_s; /* gp_open takes cfg */
	int pace = cfg.pace;
	if (rc == MDRV_OK)
		rc = gp_open(&cfg, &d->pipe, err, errlen);
	gp_config_clear(&cfg);
	if (rc == MDRV_OK && gp_is_live(d->pipe) && start_s > 0)
		rc = drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'start': the source is live, it cannot start "
				"later", DRV);
	if (rc != MDRV_OK) {
		gstreamer_close(d);
		return drv_open_failed(host, rc);
	}
	mdrv_format f;
	gp_format(d->pipe, &f);
	drv_logf(host, MDRV_LOG_INFO, "%s: %ux%u %s at %g fps (%s)", DRV, f.width, f.height, mc_pixfmt_name(f.pixfmt),
		 f.fps, gp_is_live(d->pipe) ? "live" : pace == GP_PACE_ASAP ? "as fast as taken" : "at its rate");
	return d;
}

static int gstreamer_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	gp_format(((gst_dev *)dev)->pipe, fmt);
	return MDRV_OK;
}

static int gstreamer_start(void *dev, char *err, size_t errlen)
{
	gst_dev *d = dev;
	return gp_start(d->pipe, d->epoch_given, d->epoch_ns, err, errlen);
}

static int gstreamer_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	gst_dev *d = dev;
	int rc = gp_next(d->pipe, slot, timeout_ms, err, errlen);
	int level;
	const char *note = gp_take_note(d->pipe, &level);
	if (note)
		drv_logf(d->host, level, "%s", note);
	return rc;
}

static int gstreamer_frame_count(void *dev, uint64_t *frames) { return gp_frame_count(((gst_dev *)dev)->pipe, frames); }

/* The pipeline cannot be restarted in place: stop() ends it, and the host
 * closes and reopens. */
static void gstreamer_stop(void *dev) { gp_stop(((gst_dev *)dev)->pipe); }

/* The keys, that a file exists and is readable, and that a description
 * parses into elements that exist, with its appsink.  No stream is opened. */
static int gstreamer_check(const mdrv_host *host, char *err, size_t errlen)
{
	gst_dev d = {.host = host};
	gp_config cfg;
	int rc = parse_config(&d, &cfg, err, errlen);
	if (rc == MDRV_OK && cfg.launch) {
		GError *e = NULL;
		GstElement *el = gst_parse_launch_full(cfg.launch, NULL, GST_PARSE_FLAG_FATAL_ERRORS, &e);
		GstElement *sink = el && GST_IS_BIN(el) ? gst_bin_get_by_name(GST_BIN(el), GP_SINK_NAME) : NULL;
		if (!el)
			rc = drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'pipeline': %s", DRV,
				      e ? e->message : "unparsable");
		else if (!sink || !GST_IS_APP_SINK(sink))
			rc = drv_errf(err, errlen, MDRV_ERR_CONFIG,
				      "%s: config key 'pipeline': no appsink named '%s' in it", DRV, GP_SINK_NAME);
		g_clear_error(&e);
		if (sink)
			gst_object_unref(sink);
		if (el)
			gst_object_unref(el);
	}
	gp_config_clear(&cfg);
	return rc == MDRV_OK ? MDRV_OK : MDRV_ERR_CONFIG;
}

MDRV_DEFINE_DRIVER_ALL(gstreamer, DRV, "any video GStreamer decodes (files, RTSP, pipelines) through appsink",
		       gstreamer_modes, gstreamer_frame_count)
