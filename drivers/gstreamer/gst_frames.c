/* gst_frames: samples from the appsink as mdrv frames.  See gst_internal.h. */
#include "gst_internal.h"

#include <gst/video/video.h>

#include "base/mc_time.h"
#include "drv_common.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* JPEG headers and tables on top of the pixels, as the files driver
 * bounds an MJPEG slot. */
#define JPEG_SLACK 65536

GstCaps *gp_sink_caps(int format)
{
	switch (format) {
	case GP_FMT_RGB24:
		return gst_caps_from_string("video/x-raw,format=RGB");
	case GP_FMT_GRAY8:
		return gst_caps_from_string("video/x-raw,format=GRAY8");
	case GP_FMT_YUYV:
		return gst_caps_from_string("video/x-raw,format=YUY2");
	case GP_FMT_MJPEG:
		return gst_caps_from_string("image/jpeg");
	default: /* JPEG as it comes, anything else converted to RGB */
		return gst_caps_from_string("image/jpeg; video/x-raw,format=RGB");
	}
}

static double caps_fps(const GstStructure *st)
{
	int n = 0, d = 1;
	if (gst_structure_get_fraction(st, "framerate", &n, &d) && n > 0 && d > 0)
		return (double)n / d;
	return 0;
}

static int raw_format(const GstCaps *caps, mdrv_format *fmt, char *err, size_t errlen)
{
	GstVideoInfo info;
	if (!gst_video_info_from_caps(&info, caps))
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, "%s: unreadable video caps", DRV);
	static const struct {
		GstVideoFormat gst;
		uint32_t pixfmt, bpp;
	} map[] = {{GST_VIDEO_FORMAT_RGB, MC_PIXFMT_RGB24, 3},
		   {GST_VIDEO_FORMAT_GRAY8, MC_PIXFMT_GRAY8, 1},
		   {GST_VIDEO_FORMAT_YUY2, MC_PIXFMT_YUYV, 2}};
	for (size_t i = 0; i < G_N_ELEMENTS(map); i++) {
		if (GST_VIDEO_INFO_FORMAT(&info) != map[i].gst)
			continue;
		fmt->pixfmt = map[i].pixfmt;
		fmt->width = (uint32_t)GST_VIDEO_INFO_WIDTH(&info);
		fmt->height = (uint32_t)GST_VIDEO_INFO_HEIGHT(&info);
		/* Rows are delivered packed (GStreamer pads them to 4 bytes). */
		fmt->stride = fmt->width * map[i].bpp;
		fmt->max_bytes = (size_t)fmt->stride * fmt->height;
		return MDRV_OK;
	}
	return drv_errf(err, errlen, MDRV_ERR_FORMAT, "%s: the stream gives %s, not RGB, GRAY8 or YUY2", DRV,
			gst_video_format_to_string(GST_VIDEO_INFO_FORMAT(&info)));
}

int gp_format_from_caps(const gp_pipe *p, GstCaps *caps, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)p;
	memset(fmt, 0, sizeof(*fmt));
	if (!caps || gst_caps_get_size(caps) == 0)
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, "%s: the first frame has no caps", DRV);
	const GstStructure *st = gst_caps_get_structure(caps, 0);
	fmt->fps = caps_fps(st);
	if (gst_structure_has_name(st, "image/jpeg")) {
		int w = 0, h = 0;
		if (!gst_structure_get_int(st, "width", &w) || !gst_structure_get_int(st, "height", &h) || w <= 0 ||
		    h <= 0)
			return drv_errf(err, errlen, MDRV_ERR_FORMAT,
					"%s: the JPEG stream does not say its size (use format = rgb24)", DRV);
		fmt->pixfmt = MC_PIXFMT_MJPEG;
		fmt->width = (uint32_t)w;
		fmt->height = (uint32_t)h;
		fmt->max_bytes = 3 * (size_t)w * (size_t)h + JPEG_SLACK;
		return MDRV_OK;
	}
	return raw_format(caps, fmt, err, errlen);
}

/* CLOCK_MONOTONIC of the buffer: base time + running time (see
 * gst_pipe.h); the time of delivery when the buffer has no time. */
static uint64_t buffer_time(gp_pipe *p, GstSample *s, GstBuffer *buf)
{
	const GstSegment *seg = gst_sample_get_segment(s);
	GstClockTime pts = GST_BUFFER_PTS(buf);
	if (!seg || !GST_CLOCK_TIME_IS_VALID(pts) || seg->format != GST_FORMAT_TIME)
		return mc_now_ns();
	guint64 rt = 0;
	int sign = gst_segment_to_running_time_full(seg, GST_FORMAT_TIME, pts, &rt);
	int64_t base = (int64_t)gst_element_get_base_time(p->pipeline);
	/* A frame that starts before `start` but reaches past it is kept
	 * (accurate seeks do so): its running time is negative. */
	int64_t t = sign >= 0 ? base + (int64_t)rt : base - (int64_t)rt;
	return t > 0 ? (uint64_t)t : 0;
}

/* Packed rows from GStreamer's (maybe padded) ones. */
static int copy_raw(gp_pipe *p, GstSample *s, GstBuffer *buf, mdrv_frame *slot, char *err, size_t errlen)
{
	GstVideoInfo info;
	GstVideoFrame vf;
	if (!gst_video_info_from_caps(&info, gst_sample_get_caps(s)))
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, "%s: a frame with unreadable caps", DRV);
	if ((uint32_t)GST_VIDEO_INFO_WIDTH(&info) != p->fmt.width ||
	    (uint32_t)GST_VIDEO_INFO_HEIGHT(&info) != p->fmt.height)
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, "%s: a %dx%d frame in a %ux%u stream", DRV,
				GST_VIDEO_INFO_WIDTH(&info), GST_VIDEO_INFO_HEIGHT(&info), p->fmt.width, p->fmt.height);
	if (p->fmt.max_bytes > slot->capacity)
		return drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: a frame needs %zu bytes, the slot holds %zu", DRV,
				p->fmt.max_bytes, slot->capacity);
	if (!gst_video_frame_map(&vf, &info, buf, GST_MAP_READ))
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: cannot map a frame", DRV);
	const uint8_t *src = GST_VIDEO_FRAME_PLANE_DATA(&vf, 0);
	size_t sstride = (size_t)GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0), row = p->fmt.stride;
	if (sstride == row) {
		memcpy(slot->data, src, row * p->fmt.height);
	} else {
		for (uint32_t y = 0; y < p->fmt.height; y++)
			memcpy(slot->data + y * row, src + y * sstride, row);
	}
	gst_video_frame_unmap(&vf);
	slot->bytesused = p->fmt.max_bytes;
	return MDRV_OK;
}

static int copy_jpeg(GstBuffer *buf, mdrv_frame *slot, char *err, size_t errlen)
{
	gsize n = gst_buffer_get_size(buf);
	if (n > slot->capacity)
		return drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: a JPEG of %zu bytes, the slot holds %zu", DRV,
				(size_t)n, slot->capacity);
	slot->bytesused = gst_buffer_extract(buf, 0, slot->data, n);
	return MDRV_OK;
}

/* NTP (ns since 1900) to CLOCK_MONOTONIC, through CLOCK_REALTIME now. */
#define NTP_UNIX_OFFSET_NS (2208988800ull * 1000000000ull)
static int64_t ntp_to_monotonic(uint64_t ntp_ns)
{
	int64_t realtime = (int64_t)(ntp_ns - NTP_UNIX_OFFSET_NS);
	return realtime - ((int64_t)mc_realtime_ns() - (int64_t)mc_now_ns());
}

/* rtsp_timestamps = sender: the first frame with the sender's time (its
 * first RTCP sender report came) says whether rtpbin applied it (the
 * buffer's time is the sender's) or refused it (the sender's clock is
 * more than GP_SENDER_MAX_OFFSET_NS off ours: arrival times go on). */
static void note_sender_time(gp_pipe *p, GstBuffer *buf, uint64_t t)
{
	if (p->sender_seen || !p->live || p->cfg.rtsp_timestamps != GP_STAMP_SENDER)
		return;
	GstReferenceTimestampMeta *m = gst_buffer_get_reference_timestamp_meta(buf, p->ntp_caps);
	if (!m)
		return; /* before the first report: arrival times */
	p->sender_seen = p->note_pending = true;
	double off_ms = (double)(ntp_to_monotonic(m->timestamp) - (int64_t)t) / 1e6;
	char line[300];
	gp_config_line(p, line, sizeof line);
	p->note_level = fabs(off_ms) < 1.0 ? MDRV_LOG_INFO : MDRV_LOG_WARN;
	if (fabs(off_ms) < 1.0)
		snprintf(p->note, sizeof p->note, "%s: %s: timestamps are the sender's capture times from frame %llu on "
			 "(its RTCP sender reports; config key 'rtsp_timestamps')", DRV, line,
			 (unsigned long long)p->seq);
	else
		snprintf(p->note, sizeof p->note, "%s: %s: the sender's clock is %.3f s off ours (not NTP/PTP-synced?): "
			 "timestamps stay arrival times (config key 'rtsp_timestamps')", DRV, line, off_ms / 1e3);
}

int gp_fill_slot(gp_pipe *p, GstSample *s, mdrv_frame *slot, char *err, size_t errlen)
{
	GstBuffer *buf = gst_sample_get_buffer(s);
	if (!buf)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: a sample without a buffer", DRV);
	int rc = p->fmt.pixfmt == MC_PIXFMT_MJPEG ? copy_jpeg(buf, slot, err, errlen)
						  : copy_raw(p, s, buf, slot, err, errlen);
	if (rc != MDRV_OK)
		return rc;
	slot->timestamp_ns = buffer_time(p, s, buf);
	note_sender_time(p, buf, slot->timestamp_ns);
	/* A live frame was not captured after it arrived.  rtspsrc's jitter
	 * buffer slaves its timestamps to the arrivals, and on a loaded
	 * machine (over TCP, where it stamps only the first packet) it has
	 * run up to 200 ms ahead of delivery: such a time becomes the time of
	 * delivery.  Timestamps stay increasing (the next one is at least a
	 * frame after a clamped one, or clamped to a later now). */
	uint64_t now = mc_now_ns();
	if (p->live && slot->timestamp_ns > now)
		slot->timestamp_ns = now;
	/* When the first sender report is applied the times move back from
	 * the arrivals to the captures (tens of ms): the frames that would go
	 * back are not delivered (the host would drop them as late). */
	if (p->live && p->seq > 0 && slot->timestamp_ns <= p->last_ts)
		return MDRV_ERR_TIMEOUT;
	p->last_ts = slot->timestamp_ns;
	slot->sequence = p->seq++;
	slot->flags = GST_BUFFER_FLAG_IS_SET(buf, GST_BUFFER_FLAG_CORRUPTED) ? MDRV_FRAME_CORRUPT : 0;
	slot->format = p->fmt;
	return MDRV_OK;
}
