/* gst_pipe: one GStreamer pipeline that ends in an appsink, for the
 * gstreamer driver plugin (gst_plugin.c holds the ABI and the config keys).
 *
 * The pipeline is either uridecodebin on a URI (files, RTSP, HTTP, ...),
 * linked to the appsink by the driver, or a gst-launch description of the
 * user's that ends in `appsink name=mocap`.  Frames come out as RGB24,
 * GRAY8, YUYV or MJPEG (JPEG bytes left undecoded when the source has them).
 *
 * Time: the pipeline runs on GStreamer's system clock, which reads
 * CLOCK_MONOTONIC, so a buffer's running time plus the pipeline's base
 * time is a CLOCK_MONOTONIC instant.  For a file the driver sets that base
 * to the camera's epoch (running time 0 is the `start` position), so that
 * several files opened with one epoch carry the same timestamps for frames
 * recorded together; for a live source (RTSP, a camera) GStreamer chooses
 * the base when the pipeline goes to PLAYING and the running time is the
 * arrival time, or for RTSP with rtsp_timestamps = sender (the default) the
 * sender's capture time from its RTCP sender reports (rtpbin's ntp-sync),
 * once the first report came and when the sender's clock is on ours. */
#ifndef GST_PIPE_H
#define GST_PIPE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "mdrv.h"

/* The element name a `pipeline` description must give its appsink. */
#define GP_SINK_NAME "mocap"

enum { GP_FMT_AUTO, GP_FMT_RGB24, GP_FMT_GRAY8, GP_FMT_YUYV, GP_FMT_MJPEG };
enum { GP_PACE_REALTIME, GP_PACE_ASAP };
enum { GP_RTSP_AUTO, GP_RTSP_TCP, GP_RTSP_UDP };
enum { GP_STAMP_SENDER, GP_STAMP_ARRIVAL };

/* rtsp_timestamps = sender: a sender report whose clock is further than
 * this from ours is not applied (the sender's clock is not on ours). */
#define GP_SENDER_MAX_OFFSET_NS 1000000000ll

typedef struct {
	char *uri;    /* a URI (g_free'd by gp_config_clear), or NULL */
	char *launch; /* a pipeline description, or NULL */
	const char *key; /* "uri" or "pipeline", for messages */
	int format;     /* GP_FMT_* */
	int pace;       /* GP_PACE_* */
	double start_s; /* files: where running time 0 is, seconds into the file */
	unsigned latency_ms;      /* RTSP jitter buffer */
	int rtsp_transport;       /* GP_RTSP_* */
	int rtsp_timestamps;      /* GP_STAMP_*: RTCP sender reports or arrival */
	unsigned open_timeout_ms; /* open(): preroll, or the first frame of a live source */
} gp_config;

typedef struct gp_pipe gp_pipe;

/* GStreamer is initialised once per process and never deinitialised (the
 * plugin stays loaded: -z nodelete).  0, or -1 with a message. */
int gp_init(char *err, size_t errlen);

/* Builds the pipeline and prerolls it (a live source: plays it until its
 * first frame), so that the format is known.  Takes cfg's strings.
 * MDRV_OK with *out, or an mdrv_status with a message. */
int gp_open(gp_config *cfg, gp_pipe **out, char *err, size_t errlen);
void gp_format(const gp_pipe *p, mdrv_format *fmt);
bool gp_is_live(const gp_pipe *p);
/* A file's frames from `start` to its end: its duration times the frame
 * rate of its caps, rounded.  MDRV_ERR_IO when not known (a live source,
 * no duration, a variable frame rate). */
int gp_frame_count(gp_pipe *p, uint64_t *frames);

/* Plays: files from base time epoch_ns (the time of the call when
 * !epoch_given). */
int gp_start(gp_pipe *p, bool epoch_given, uint64_t epoch_ns, char *err, size_t errlen);
int gp_next(gp_pipe *p, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen);
/* A line to log once about the live timestamps (the sender's reports
 * applied, or refused) and its MDRV_LOG_* level, or NULL; cleared by the
 * call. */
const char *gp_take_note(gp_pipe *p, int *level);
void gp_stop(gp_pipe *p);
void gp_close(gp_pipe *p);

void gp_config_clear(gp_config *cfg);

#endif
