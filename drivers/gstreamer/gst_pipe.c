/* gst_pipe: building, prerolling, playing and reading the pipeline.  See
 * gst_pipe.h for the design, in particular the timestamps. */
#include "gst_internal.h"

#include "base/mc_time.h"
#include "drv_common.h"

#include <pthread.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

#define STATE_POLL_MS 20

/* ---- process-wide ---- */

static pthread_once_t init_once = PTHREAD_ONCE_INIT;
static char init_error[256];

static void init_gstreamer(void)
{
	GError *e = NULL;
	if (!gst_init_check(NULL, NULL, &e)) {
		snprintf(init_error, sizeof init_error, "%s", e ? e->message : "unknown error");
		if (e)
			g_error_free(e);
		return;
	}
	/* Our timestamps assume the system clock reads CLOCK_MONOTONIC (its
	 * default): say so rather than rely on it. */
	GstClock *clock = gst_system_clock_obtain();
	g_object_set(clock, "clock-type", GST_CLOCK_TYPE_MONOTONIC, NULL);
	gst_object_unref(clock);
}

int gp_init(char *err, size_t errlen)
{
	pthread_once(&init_once, init_gstreamer);
	if (init_error[0])
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: cannot initialise GStreamer: %s", DRV, init_error);
	return MDRV_OK;
}

void gp_config_clear(gp_config *cfg)
{
	g_free(cfg->uri);
	g_free(cfg->launch);
	cfg->uri = cfg->launch = NULL;
}

/* ---- uri mode: uridecodebin, linked on pad-added ---- */

/* A stream we do not deliver (audio, subtitles, a second video) goes to a
 * fakesink, so that decodebin does not see it as not-linked. */
static void discard_pad(GstElement *bin, GstPad *pad)
{
	GstElement *fake = gst_element_factory_make("fakesink", NULL);
	if (!fake)
		return;
	g_object_set(fake, "sync", FALSE, "async", FALSE, NULL);
	gst_bin_add(GST_BIN(bin), fake);
	GstPad *sinkpad = gst_element_get_static_pad(fake, "sink");
	gst_pad_link(pad, sinkpad);
	gst_object_unref(sinkpad);
	gst_element_sync_state_with_parent(fake);
}

static void on_pad_added(GstElement *src, GstPad *pad, gpointer data)
{
	gp_pipe *p = data;
	(void)src;
	GstCaps *caps = gst_pad_get_current_caps(pad);
	if (!caps)
		caps = gst_pad_query_caps(pad, NULL);
	const GstStructure *st = gst_caps_get_size(caps) ? gst_caps_get_structure(caps, 0) : NULL;
	bool jpeg = st && gst_structure_has_name(st, "image/jpeg");
	bool video = st && (jpeg || gst_structure_has_name(st, "video/x-raw"));
	gst_caps_unref(caps);
	g_mutex_lock(&p->lock);
	bool take = video && !p->video_linked;
	p->video_linked |= take;
	g_mutex_unlock(&p->lock);
	if (!take) {
		discard_pad(p->pipeline, pad);
		return;
	}
	/* JPEG goes to the sink as it is (MJPEG passed through); raw video
	 * through videoconvert to the format asked for. */
	GstElement *to = jpeg ? p->sink : p->convert;
	if (!jpeg)
		gst_element_link(p->convert, p->sink);
	GstPad *sinkpad = gst_element_get_static_pad(to, "sink");
	gst_pad_link(pad, sinkpad);
	gst_object_unref(sinkpad);
}

static void on_no_more_pads(GstElement *src, gpointer data)
{
	gp_pipe *p = data;
	(void)src;
	g_mutex_lock(&p->lock);
	p->no_video = !p->video_linked;
	g_mutex_unlock(&p->lock);
}

/* rtsp_timestamps = sender: rtpbin maps each RTP timestamp to the
 * sender's NTP time through its RTCP sender reports, and that to our
 * running time through our own NTP clock (ntp-sync; both NTP clocks read
 * CLOCK_REALTIME, so the hosts' realtime clocks must agree: NTP or PTP).
 * `synced` keeps the RTP timestamps' spacing (no arrival jitter, no drift
 * between reports); an offset over GP_SENDER_MAX_OFFSET_NS (a sender
 * whose clock is not on ours) is not applied, leaving arrival times; the
 * reference-timestamp meta (the sender's NTP time of each frame, once a
 * report came) tells the driver which it got (gst_frames.c). */
static void use_sender_reports(GstElement *source)
{
	g_object_set(source, "ntp-sync", TRUE, "max-ts-offset", (gint64)GP_SENDER_MAX_OFFSET_NS,
		     "add-reference-timestamp-meta", TRUE, NULL);
	gst_util_set_object_arg(G_OBJECT(source), "buffer-mode", "synced");
	gst_util_set_object_arg(G_OBJECT(source), "ntp-time-source", "ntp");
}

/* RTSP sources get the latency, transport and timestamps from the config. */
static void on_source_setup(GstElement *bin, GstElement *source, gpointer data)
{
	gp_pipe *p = data;
	(void)bin;
	GObjectClass *klass = G_OBJECT_GET_CLASS(source);
	if (g_object_class_find_property(klass, "latency"))
		g_object_set(source, "latency", (guint)p->cfg.latency_ms, NULL);
	if (g_object_class_find_property(klass, "protocols") && p->cfg.rtsp_transport != GP_RTSP_AUTO)
		gst_util_set_object_arg(G_OBJECT(source), "protocols",
					p->cfg.rtsp_transport == GP_RTSP_TCP ? "tcp" : "udp+udp-mcast");
	if (p->cfg.rtsp_timestamps == GP_STAMP_SENDER && g_object_class_find_property(klass, "ntp-sync") &&
	    g_object_class_find_property(klass, "add-reference-timestamp-meta"))
		use_sender_reports(source);
}

/* What uridecodebin stops at: its defaults, plus JPEG when JPEG may be
 * delivered undecoded. */
static GstCaps *decode_caps(int format)
{
	GstCaps *caps = gst_caps_from_string("video/x-raw(ANY); audio/x-raw(ANY); text/x-raw(ANY); "
					     "subpicture/x-dvd; subpicture/x-dvb; subpicture/x-pgs");
	if (format == GP_FMT_AUTO || format == GP_FMT_MJPEG)
		gst_caps_append(caps, gst_caps_from_string("image/jpeg"));
	return caps;
}

static int build_uri(gp_pipe *p, char *err, size_t errlen)
{
	GstElement *src = gst_element_factory_make("uridecodebin", "src");
	p->convert = gst_element_factory_make("videoconvert", "convert");
	p->sink = gst_element_factory_make("appsink", GP_SINK_NAME);
	if (!src || !p->convert || !p->sink) {
		if (src)
			gst_object_unref(src);
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: uridecodebin, videoconvert or appsink is missing (install gstreamer1.0-plugins-base)",
				DRV);
	}
	p->pipeline = gst_pipeline_new("mocap-gst");
	/* convert is linked to the sink when a raw stream comes (on_pad_added). */
	gst_bin_add_many(GST_BIN(p->pipeline), src, p->convert, p->sink, NULL);
	GstCaps *caps = decode_caps(p->cfg.format);
	g_object_set(src, "uri", p->cfg.uri, "caps", caps, NULL);
	gst_caps_unref(caps);
	g_signal_connect(src, "pad-added", G_CALLBACK(on_pad_added), p);
	g_signal_connect(src, "no-more-pads", G_CALLBACK(on_no_more_pads), p);
	g_signal_connect(src, "source-setup", G_CALLBACK(on_source_setup), p);
	gst_object_ref(p->sink); /* gp_close unrefs it in both modes */
	return MDRV_OK;
}

/* ---- pipeline mode: the user's description ---- */

static int build_launch(gp_pipe *p, char *err, size_t errlen)
{
	GError *e = NULL;
	char line[300];
	gp_config_line(p, line, sizeof line);
	GstElement *el = gst_parse_launch_full(p->cfg.launch, NULL, GST_PARSE_FLAG_FATAL_ERRORS, &e);
	if (!el) {
		int rc = drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: %s: %s", DRV, line, e ? e->message : "unparsable");
		g_clear_error(&e);
		return rc;
	}
	g_clear_error(&e);
	if (!GST_IS_PIPELINE(el)) {
		GstElement *pipe = gst_pipeline_new("mocap-gst");
		gst_bin_add(GST_BIN(pipe), el);
		el = pipe;
	}
	p->pipeline = el;
	p->sink = gst_bin_get_by_name(GST_BIN(el), GP_SINK_NAME);
	if (!p->sink || !GST_IS_APP_SINK(p->sink))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: %s: the pipeline must end in 'appsink name=%s'", DRV,
				line, GP_SINK_NAME);
	return MDRV_OK;
}

/* ---- states ---- */

/* Before prerolling: the caps the driver delivers (a description that
 * gives its appsink caps of its own keeps them), two frames queued. */
static void configure_caps(gp_pipe *p)
{
	GstCaps *have = NULL;
	g_object_get(p->sink, "caps", &have, NULL);
	if (have) {
		gst_caps_unref(have);
	} else {
		GstCaps *caps = gp_sink_caps(p->cfg.format);
		g_object_set(p->sink, "caps", caps, NULL);
		gst_caps_unref(caps);
	}
	g_object_set(p->sink, "max-buffers", 2u, "emit-signals", FALSE, NULL);
}

/* Once we know whether the source is live. */
static void configure_pace(gp_pipe *p)
{
	/* Files at the file's rate: the sink waits for each frame's time.
	 * Live sources are already paced; their frames go out on arrival. */
	bool sync = p->cfg.pace == GP_PACE_REALTIME && !p->live;
	/* Files: the decoder waits for the host (nothing is dropped).  Live
	 * sources: the newest two, older ones dropped when the host is slow. */
	g_object_set(p->sink, "sync", (gboolean)sync, "drop", (gboolean)p->live, NULL);
}

/* Waits until the pipeline reached its target state, an error, or the
 * open timeout. */
static int wait_state(gp_pipe *p, const char *what, char *err, size_t errlen)
{
	uint64_t end = mc_now_ns() + (uint64_t)p->cfg.open_timeout_ms * 1000000ull;
	char line[300];
	for (;;) {
		int rc = gp_poll_bus(p, true, err, errlen);
		if (rc == MDRV_ERR_END)
			rc = drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: %s: no frame (ended while %s%s)", DRV,
				      gp_config_line(p, line, sizeof line), what,
				      p->cfg.start_s > 0 ? "; is config key 'start' past the end?" : "");
		if (rc != MDRV_OK)
			return rc;
		g_mutex_lock(&p->lock);
		bool no_video = p->no_video;
		g_mutex_unlock(&p->lock);
		if (no_video)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: %s: no video stream", DRV,
					gp_config_line(p, line, sizeof line));
		GstState cur;
		GstStateChangeReturn r = gst_element_get_state(p->pipeline, &cur, NULL, STATE_POLL_MS * GST_MSECOND);
		if (r == GST_STATE_CHANGE_SUCCESS || r == GST_STATE_CHANGE_NO_PREROLL)
			return MDRV_OK;
		if (r == GST_STATE_CHANGE_FAILURE) {
			/* The element that failed may post its error just after. */
			GstMessage *m = gst_bus_timed_pop_filtered(p->bus, 500 * GST_MSECOND, GST_MESSAGE_ERROR);
			if (m) {
				rc = gp_error_from_message(p, m, err, errlen);
				gst_message_unref(m);
				return rc;
			}
			return rc != MDRV_OK ? rc
					     : drv_errf(err, errlen, p->network ? MDRV_ERR_NODEV : MDRV_ERR_IO,
							"%s: %s: the pipeline failed while %s", DRV,
							gp_config_line(p, line, sizeof line), what);
		}
		if (mc_now_ns() >= end)
			return drv_errf(err, errlen, p->network || p->live ? MDRV_ERR_NODEV : MDRV_ERR_IO,
					"%s: %s: still %s after %u ms (config key 'open_timeout')", DRV,
					gp_config_line(p, line, sizeof line), what, p->cfg.open_timeout_ms);
	}
}

/* Running time 0 at `start` seconds into the file. */
static int seek_start(gp_pipe *p, char *err, size_t errlen)
{
	if (p->cfg.start_s <= 0)
		return MDRV_OK;
	gint64 dur = -1;
	if (gst_element_query_duration(p->pipeline, GST_FORMAT_TIME, &dur) && dur > 0 &&
	    p->cfg.start_s * GST_SECOND >= (double)dur)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'start' = %g: past the end of '%s' (%.3f s)",
				DRV, p->cfg.start_s, p->cfg.uri ? p->cfg.uri : "the pipeline", (double)dur / GST_SECOND);
	gint64 pos = (gint64)(p->cfg.start_s * GST_SECOND + 0.5);
	if (!gst_element_seek_simple(p->pipeline, GST_FORMAT_TIME, GST_SEEK_FLAG_FLUSH | GST_SEEK_FLAG_ACCURATE, pos))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'start' = %g: the source cannot seek", DRV,
				p->cfg.start_s);
	return wait_state(p, "seeking to config key 'start'", err, errlen);
}

/* A live source's first frame, watching the bus meanwhile (a refused
 * connection is said at once, not after the timeout). */
static GstSample *pull_first_live(gp_pipe *p, int *rc, char *err, size_t errlen)
{
	gst_element_set_state(p->pipeline, GST_STATE_PLAYING);
	uint64_t end = mc_now_ns() + (uint64_t)p->cfg.open_timeout_ms * 1000000ull;
	while (mc_now_ns() < end) {
		GstSample *s = gst_app_sink_try_pull_sample(GST_APP_SINK(p->sink), STATE_POLL_MS * GST_MSECOND);
		if (s)
			return s;
		if ((*rc = gp_poll_bus(p, true, err, errlen)) != MDRV_OK)
			return NULL;
	}
	return NULL;
}

/* The format from the first frame: the preroll of a file, the first frame
 * of a live source (kept for next_frame). */
static int first_frame_format(gp_pipe *p, char *err, size_t errlen)
{
	GstSample *s;
	char line[300];
	int rc = MDRV_OK;
	if (p->live)
		s = p->pending = pull_first_live(p, &rc, err, errlen);
	else
		s = gst_app_sink_try_pull_preroll(GST_APP_SINK(p->sink), 0);
	if (!s) {
		if (rc == MDRV_OK)
			rc = gp_poll_bus(p, true, err, errlen);
		if (rc == MDRV_ERR_END && p->live)
			return drv_errf(err, errlen, MDRV_ERR_NODEV, "%s: %s: the live stream ended before its first frame",
					DRV, gp_config_line(p, line, sizeof line));
		if (rc != MDRV_OK && rc != MDRV_ERR_END)
			return rc;
		return drv_errf(err, errlen, p->live ? MDRV_ERR_NODEV : MDRV_ERR_CONFIG,
				"%s: %s: no video frame within %u ms (config key 'open_timeout')", DRV,
				gp_config_line(p, line, sizeof line), p->cfg.open_timeout_ms);
	}
	rc = gp_format_from_caps(p, gst_sample_get_caps(s), &p->fmt, err, errlen);
	if (!p->live)
		gst_sample_unref(s);
	return rc;
}

/* To PAUSED and the first frame.  A live source does not preroll; it
 * plays from here on. */
static int preroll(gp_pipe *p, char *err, size_t errlen)
{
	configure_caps(p);
	GstStateChangeReturn r = gst_element_set_state(p->pipeline, GST_STATE_PAUSED);
	p->live = r == GST_STATE_CHANGE_NO_PREROLL;
	int rc = wait_state(p, "opening", err, errlen);
	if (rc != MDRV_OK)
		return rc;
	GstState cur;
	p->live |= gst_element_get_state(p->pipeline, &cur, NULL, 0) == GST_STATE_CHANGE_NO_PREROLL;
	configure_pace(p);
	if (!p->live && (rc = seek_start(p, err, errlen)) != MDRV_OK)
		return rc;
	return first_frame_format(p, err, errlen);
}

int gp_open(gp_config *cfg, gp_pipe **out, char *err, size_t errlen)
{
	*out = NULL;
	/* calloc, not g_new0: LeakSanitizer sees our frames only through
	 * malloc itself (GLib has no frame pointers). */
	gp_pipe *p = calloc(1, sizeof(*p));
	if (!p) {
		gp_config_clear(cfg);
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
	}
	g_mutex_init(&p->lock);
	p->cfg = *cfg;
	memset(cfg, 0, sizeof(*cfg)); /* the strings are ours now */
	p->network = p->cfg.launch || !g_str_has_prefix(p->cfg.uri, "file:");
	p->ntp_caps = gst_caps_new_empty_simple("timestamp/x-ntp");
	int rc = p->cfg.uri ? build_uri(p, err, errlen) : build_launch(p, err, errlen);
	if (rc == MDRV_OK) {
		GstClock *clock = gst_system_clock_obtain();
		gst_pipeline_use_clock(GST_PIPELINE(p->pipeline), clock);
		gst_object_unref(clock);
		p->bus = gst_element_get_bus(p->pipeline);
		rc = preroll(p, err, errlen);
	}
	if (rc != MDRV_OK) {
		gp_close(p);
		return rc;
	}
	*out = p;
	return MDRV_OK;
}

void gp_format(const gp_pipe *p, mdrv_format *fmt) { *fmt = p->fmt; }

int gp_frame_count(gp_pipe *p, uint64_t *frames)
{
	gint64 dur = -1;
	if (p->live || p->fmt.fps <= 0 || !gst_element_query_duration(p->pipeline, GST_FORMAT_TIME, &dur) || dur <= 0)
		return MDRV_ERR_IO; /* not known */
	double n = ((double)dur / GST_SECOND - p->cfg.start_s) * p->fmt.fps;
	if (n < 0.5)
		return MDRV_ERR_IO;
	*frames = (uint64_t)(n + 0.5);
	return MDRV_OK;
}
bool gp_is_live(const gp_pipe *p) { return p->live; }

int gp_start(gp_pipe *p, bool epoch_given, uint64_t epoch_ns, char *err, size_t errlen)
{
	if (p->stopped) /* it would play from the file's beginning, not `start` */
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: stopped; close and open again", DRV);
	p->seq = 0;
	if (p->live) { /* playing since open */
		p->started = true;
		return MDRV_OK;
	}
	/* Running time r plays at epoch + r on CLOCK_MONOTONIC. */
	gst_element_set_start_time(p->pipeline, GST_CLOCK_TIME_NONE);
	gst_element_set_base_time(p->pipeline, epoch_given ? epoch_ns : mc_now_ns());
	if (gst_element_set_state(p->pipeline, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE) {
		int rc = gp_poll_bus(p, false, err, errlen);
		return rc != MDRV_OK ? rc : drv_errf(err, errlen, MDRV_ERR_IO, "%s: the pipeline does not play", DRV);
	}
	p->started = true;
	return MDRV_OK;
}

/* No sample: an error on the bus, the end, or nothing yet. */
static int no_sample(gp_pipe *p, char *err, size_t errlen)
{
	int rc = gp_poll_bus(p, false, err, errlen);
	if (rc != MDRV_OK)
		return rc;
	char line[300];
	if (gst_app_sink_is_eos(GST_APP_SINK(p->sink))) {
		/* A live stream that ends (the server stopped it) is a source
		 * gone: the host reconnects.  A file's end is the end. */
		if (p->live)
			return drv_errf(err, errlen, MDRV_ERR_NODEV, "%s: %s: the live stream ended", DRV,
					gp_config_line(p, line, sizeof line));
		return drv_errf(err, errlen, MDRV_ERR_END, "%s: %s: end of stream (%llu frames)", DRV,
				gp_config_line(p, line, sizeof line), (unsigned long long)p->seq);
	}
	return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, "%s: no frame yet", DRV);
}

/* A pipeline that posted an error stays failed: the same status and
 * message on every later call, until the host closes it. */
static int fail(gp_pipe *p, int rc, const char *err)
{
	if (rc != MDRV_OK && rc != MDRV_ERR_TIMEOUT && rc != MDRV_ERR_END) {
		p->failed = rc;
		drv_strlcpy(p->fail_msg, err ? err : "", sizeof p->fail_msg);
	}
	return rc;
}

int gp_next(gp_pipe *p, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	if (!p->started)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: next_frame before start", DRV);
	if (p->failed)
		return drv_errf(err, errlen, p->failed, "%s", p->fail_msg);
	int rc = gp_poll_bus(p, false, err, errlen);
	if (rc != MDRV_OK)
		return fail(p, rc, err);
	GstSample *s = p->pending;
	p->pending = NULL;
	if (!s) {
		GstClockTime wait = timeout_ms < 0 ? GST_CLOCK_TIME_NONE : (GstClockTime)timeout_ms * GST_MSECOND;
		s = gst_app_sink_try_pull_sample(GST_APP_SINK(p->sink), wait);
	}
	if (!s)
		return fail(p, no_sample(p, err, errlen), err);
	rc = gp_fill_slot(p, s, slot, err, errlen);
	gst_sample_unref(s);
	if (rc == MDRV_ERR_TIMEOUT) /* a frame not delivered: its time went back */
		drv_errf(err, errlen, rc, "%s: a frame stamped before the previous one, not delivered", DRV);
	return rc;
}

const char *gp_take_note(gp_pipe *p, int *level)
{
	if (!p->note_pending)
		return NULL;
	p->note_pending = false;
	*level = p->note_level;
	return p->note;
}

void gp_stop(gp_pipe *p)
{
	gst_element_set_state(p->pipeline, GST_STATE_NULL);
	p->started = false;
	p->stopped = true;
}

void gp_close(gp_pipe *p)
{
	if (!p)
		return;
	if (p->pending)
		gst_sample_unref(p->pending);
	if (p->pipeline) {
		gst_element_set_state(p->pipeline, GST_STATE_NULL);
		gst_object_unref(p->pipeline);
	}
	if (p->sink)
		gst_object_unref(p->sink);
	if (p->bus)
		gst_object_unref(p->bus);
	if (p->ntp_caps)
		gst_caps_unref(p->ntp_caps);
	gp_config_clear(&p->cfg);
	g_mutex_clear(&p->lock);
	free(p);
}
