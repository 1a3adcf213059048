/* gst_rtsp_serve: a loopback RTSP server for test_gstreamer_rtsp, built on
 * libgstrtspserver.  Usage: gst_rtsp_serve PORT (0: any free port).  It
 * prints "PORT <n>" once it listens on 127.0.0.1 and serves until killed:
 *   /raw     64x48 RGB at 30 fps, raw RTP (rtpvrawpay, so bytes arrive as
 *            sent); the first 8 bytes of each frame hold the frame's capture
 *            time on CLOCK_MONOTONIC (the media pipeline's base time plus the
 *            live source's timestamp), little-endian, for the test to
 *            measure the driver's timestamps against;
 *   /h264    the same picture as H.264 (x264enc, zero latency), when x264enc
 *            is installed;
 * With `auth`, every mount asks for basic authentication (user "mocap",
 * password "secret"): clients without a token get 401, not the 404 a
 * token without the mount's role gets (gst-rtsp-server hides mounts so).
 *
 * Its RTCP sender reports map RTP timestamps to the frames' capture times
 * (rtpbin rtcp-sync-send-time = false; GStreamer's default is the time of
 * sending, here about 50 ms later), on the NTP clock read from
 * CLOCK_REALTIME, as an IP camera on an NTP- or PTP-synced clock does.
 * With `offclock` the reports' NTP times are CLOCK_MONOTONIC instead (a
 * sender whose clock is not on the receiver's: about 126 years off). */
#include <gst/gst.h>
#include <gst/rtsp-server/rtsp-server.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RAW_LAUNCH                                                                                       \
	"( videotestsrc is-live=true pattern=ball ! video/x-raw,format=RGB,width=64,height=48,framerate=30/1 ! " \
	"identity name=stamp ! rtpvrawpay name=pay0 pt=96 )"
#define H264_LAUNCH                                                                                       \
	"( videotestsrc is-live=true pattern=ball ! video/x-raw,width=320,height=240,framerate=30/1 ! "       \
	"x264enc tune=zerolatency speed-preset=ultrafast key-int-max=15 ! rtph264pay name=pay0 pt=96 )"

static GstPadProbeReturn stamp_frame(GstPad *pad, GstPadProbeInfo *info, gpointer data)
{
	(void)data;
	GstBuffer *buf = gst_buffer_make_writable(GST_PAD_PROBE_INFO_BUFFER(info));
	GST_PAD_PROBE_INFO_DATA(info) = buf;
	/* Every element of a playing pipeline has the pipeline's base time. */
	guint64 t = gst_element_get_base_time(GST_ELEMENT(GST_PAD_PARENT(pad))) + GST_BUFFER_PTS(buf);
	guint8 b[8];
	for (int i = 0; i < 8; i++)
		b[i] = (guint8)(t >> (8 * i));
	gst_buffer_fill(buf, 0, b, sizeof b);
	return GST_PAD_PROBE_OK;
}

/* The media's rtpbin, once it is added to the media's pipeline. */
static void on_element_added(GstBin *bin, GstElement *el, gpointer data)
{
	(void)bin;
	GObjectClass *klass = G_OBJECT_GET_CLASS(el);
	if (!g_object_class_find_property(klass, "rtcp-sync-send-time"))
		return;
	g_object_set(el, "rtcp-sync-send-time", FALSE, NULL);
	if (GPOINTER_TO_INT(data))
		gst_util_set_object_arg(G_OBJECT(el), "ntp-time-source", "clock-time");
}

static void on_media_configure(GstRTSPMediaFactory *f, GstRTSPMedia *media, gpointer data)
{
	(void)f;
	GstElement *el = gst_rtsp_media_get_element(media);
	GstObject *pipeline = gst_object_get_parent(GST_OBJECT(el)); /* the factory made it */
	if (pipeline) {
		g_signal_connect(pipeline, "element-added", G_CALLBACK(on_element_added), data);
		gst_object_unref(pipeline);
	}
	GstElement *stamp = gst_bin_get_by_name_recurse_up(GST_BIN(el), "stamp");
	if (stamp) { /* only /raw has it */
		GstPad *src = gst_element_get_static_pad(stamp, "src");
		gst_pad_add_probe(src, GST_PAD_PROBE_TYPE_BUFFER, stamp_frame, NULL, NULL);
		gst_object_unref(src);
		gst_object_unref(stamp);
	}
	gst_object_unref(el);
}

static GstRTSPMediaFactory *factory(const char *launch, bool offclock)
{
	GstRTSPMediaFactory *f = gst_rtsp_media_factory_new();
	gst_rtsp_media_factory_set_launch(f, launch);
	gst_rtsp_media_factory_set_shared(f, TRUE);
	g_signal_connect(f, "media-configure", G_CALLBACK(on_media_configure), GINT_TO_POINTER(offclock));
	return f;
}

static void require_auth(GstRTSPServer *server)
{
	GstRTSPAuth *auth = gst_rtsp_auth_new();
	GstRTSPToken *token = gst_rtsp_token_new(GST_RTSP_TOKEN_MEDIA_FACTORY_ROLE, G_TYPE_STRING, "user", NULL);
	gchar *basic = gst_rtsp_auth_make_basic("mocap", "secret");
	gst_rtsp_auth_add_basic(auth, basic, token);
	g_free(basic);
	gst_rtsp_token_unref(token);
	gst_rtsp_server_set_auth(server, auth);
	g_object_unref(auth);
}

static void allow_user(GstRTSPMediaFactory *f)
{
	gst_rtsp_media_factory_add_role(f, "user", GST_RTSP_PERM_MEDIA_FACTORY_ACCESS, G_TYPE_BOOLEAN, TRUE,
					GST_RTSP_PERM_MEDIA_FACTORY_CONSTRUCT, G_TYPE_BOOLEAN, TRUE, NULL);
}

int main(int argc, char **argv)
{
	gst_init(&argc, &argv);
	if (argc < 2 || argc > 3) {
		fprintf(stderr, "usage: %s PORT [auth|offclock]\n", argv[0]);
		return 2;
	}
	bool auth = argc == 3 && !strcmp(argv[2], "auth");
	bool offclock = argc == 3 && !strcmp(argv[2], "offclock");
	GstRTSPServer *server = gst_rtsp_server_new();
	gst_rtsp_server_set_address(server, "127.0.0.1");
	gst_rtsp_server_set_service(server, argv[1]);
	if (auth)
		require_auth(server);
	GstRTSPMountPoints *mounts = gst_rtsp_server_get_mount_points(server);
	GstRTSPMediaFactory *raw = factory(RAW_LAUNCH, offclock);
	gst_rtsp_mount_points_add_factory(mounts, "/raw", raw);
	if (auth)
		allow_user(raw);
	GstElementFactory *x264 = gst_element_factory_find("x264enc");
	if (x264) {
		gst_rtsp_mount_points_add_factory(mounts, "/h264", factory(H264_LAUNCH, offclock));
		gst_object_unref(x264);
	}
	g_object_unref(mounts);
	if (gst_rtsp_server_attach(server, NULL) == 0) {
		fprintf(stderr, "gst_rtsp_serve: cannot listen on 127.0.0.1:%s\n", argv[1]);
		return 1;
	}
	printf("PORT %d\n", gst_rtsp_server_get_bound_port(server));
	fflush(stdout);
	g_main_loop_run(g_main_loop_new(NULL, FALSE));
	return 0;
}
