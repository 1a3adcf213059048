/* gst_internal: what the gstreamer plugin's own files share (not the ABI):
 * the pipeline's state, the mapping of GStreamer errors to driver
 * statuses (gst_errors.c) and of samples to frames (gst_frames.c). */
#ifndef GST_INTERNAL_H
#define GST_INTERNAL_H

#include <gst/app/gstappsink.h>
#include <gst/gst.h>

#include "gst_pipe.h"

#define DRV "gstreamer"

struct gp_pipe {
	gp_config cfg;
	GstElement *pipeline;
	GstElement *sink;    /* the appsink */
	GstElement *convert; /* uri mode: videoconvert in front of the sink */
	GstBus *bus;
	bool network; /* not a local file: failures are retried */
	bool live;    /* NO_PREROLL: RTSP, cameras */
	bool started;
	bool stopped; /* a stopped pipeline is not restarted (the host reopens) */
	int failed;   /* once the pipeline posted an error: its status, sticky */
	char fail_msg[512];
	GstSample *pending; /* a live source's first frame, pulled by open() */
	mdrv_format fmt;
	uint64_t seq;
	uint64_t last_ts; /* the newest delivered timestamp (live: kept increasing) */
	/* rtsp_timestamps = sender: the caps of the sender-time meta, whether
	 * a frame carried one yet, and a line for the plugin to log once. */
	GstCaps *ntp_caps;
	bool sender_seen;
	char note[512];
	bool note_pending;
	int note_level; /* MDRV_LOG_* */
	/* Set from streaming threads (pad-added, no-more-pads), read after
	 * the state waits: under `lock`. */
	GMutex lock;
	bool video_linked;
	bool no_video; /* uridecodebin exposed every stream, none is video */
	char missing[256]; /* a missing-plugin message's description */
};

/* gst_errors.c */
/* Formats `msg` (an ERROR message) into err and returns what it means:
 * MDRV_ERR_CONFIG when waiting cannot help (a missing or unreadable file,
 * an unknown format, no decoder, refused credentials), MDRV_ERR_FORMAT when
 * the stream cannot give the asked format, MDRV_ERR_NODEV for a network
 * source that failed (retried with backoff), MDRV_ERR_IO for the rest. */
int gp_error_from_message(gp_pipe *p, GstMessage *msg, char *err, size_t errlen);
/* Pops the bus: the first ERROR as above, MDRV_ERR_END for EOS when
 * want_eos, missing-plugin descriptions kept; MDRV_OK when none. */
int gp_poll_bus(gp_pipe *p, bool want_eos, char *err, size_t errlen);
/* "config key 'uri' = 'VALUE'" for messages. */
const char *gp_config_line(const gp_pipe *p, char *buf, size_t n);

/* gst_frames.c */
/* The mdrv format of a sample's caps; MDRV_ERR_FORMAT with a message when
 * the caps are none the driver delivers. */
int gp_format_from_caps(const gp_pipe *p, GstCaps *caps, mdrv_format *fmt, char *err, size_t errlen);
/* The appsink caps for a GP_FMT_*. */
GstCaps *gp_sink_caps(int format);
/* Copies a sample into the slot, timestamped (see gst_pipe.h).
 * MDRV_ERR_TIMEOUT for a live frame whose time is not after the previous
 * one's (the first sender report moved the times back): not delivered. */
int gp_fill_slot(gp_pipe *p, GstSample *s, mdrv_frame *slot, char *err, size_t errlen);

#endif
