/* test_gstreamer: the gstreamer driver plugin on files made here from the
 * bundled demo frames (tests/data/ego_demo/left, 60 JPEGs of 256x256):
 *   - an MKV holding the JPEGs as they are: delivered as MJPEG with the
 *     same bytes, frame for frame, as the files driver delivers the folder,
 *     and with its timestamps (epoch + k/30 s, to the MKV's millisecond);
 *     decoded (format = rgb24) close to the files driver's RGB;
 *   - an MP4 of lossless H.264 (4:4:4): RGB close to the files driver's,
 *     timestamps to the microsecond, GRAY8 too;
 *   - pace: realtime delivers no frame before its time and takes the
 *     clip's 2 s; asap delivers faster with the same timestamps;
 *   - start: running time 0 at 1 s into the file (frame 30 first);
 *   - the end of the file (MDRV_ERR_END); a pipeline description;
 *   - errors: config keys, a missing file, garbage, a codec without a
 *     decoder (an MKV whose codec id is changed), an audio-only file;
 *   - check() (mocapd --check);
 *   - two files as one rig: a flash at 37/30 s in one and 12/30 s in the
 *     other, found by drivers/gstreamer/find-flash.sh, whose `start`
 *     offsets, with one epoch, give the flash frames one timestamp.
 * The comparison is with frames at driver level; the daemon's tracking is
 * not run on them here. */
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <sys/stat.h>
#include <unistd.h>

#include "gst_test_util.h"

#define DEMO "tests/data/ego_demo/left"
#define NFRAMES 60
#define W 256
#define H 256

static drv_harness G, F; /* the gstreamer and files plugins */
static char dir[64];
static uint8_t *ref_jpeg[NFRAMES], *ref_rgb[NFRAMES];
static size_t ref_jpeg_n[NFRAMES];
static uint8_t buf[4 << 20];

static void path_in(char *out, size_t n, const char *name) { snprintf(out, n, "%s/%s", dir, name); }

/* ---- media made here ---- */

static void make_media(void)
{
	char cmd[1024], out[256];
	path_in(out, sizeof out, "mjpeg.mkv");
	snprintf(cmd, sizeof cmd,
		 "imagesequencesrc location=" DEMO "/%%05d.jpg start-index=0 stop-index=%d framerate=30/1 ! jpegparse ! "
		 "matroskamux ! filesink location=%s", NFRAMES - 1, out);
	CHECK(gst_test_run(cmd) == 0);
	path_in(out, sizeof out, "h264.mp4");
	snprintf(cmd, sizeof cmd,
		 "imagesequencesrc location=" DEMO "/%%05d.jpg start-index=0 stop-index=%d framerate=30/1 ! jpegdec ! "
		 "videoconvert ! video/x-raw,format=RGB ! videoconvert ! video/x-raw,format=Y444,colorimetry=bt601 ! x264enc quantizer=0 pass=quant speed-preset=ultrafast ! "
		 "mp4mux ! filesink location=%s", NFRAMES - 1, out);
	CHECK(gst_test_run(cmd) == 0);
	path_in(out, sizeof out, "audio.mkv");
	snprintf(cmd, sizeof cmd, "audiotestsrc num-buffers=20 ! audioconvert ! matroskamux ! filesink location=%s", out);
	CHECK(gst_test_run(cmd) == 0);
}

static uint8_t *read_all(const char *path, size_t *n)
{
	FILE *f = fopen(path, "rb");
	if (!f)
		return NULL;
	fseek(f, 0, SEEK_END);
	long len = ftell(f);
	fseek(f, 0, SEEK_SET);
	uint8_t *b = malloc((size_t)len);
	*n = fread(b, 1, (size_t)len, f);
	fclose(f);
	return b;
}

static void write_all(const char *path, const uint8_t *b, size_t n)
{
	FILE *f = fopen(path, "wb");
	CHECK(f && fwrite(b, 1, n, f) == n);
	if (f)
		fclose(f);
}

/* Garbage, and the MKV with its codec's FourCC MJPG made XJPG (a codec
 * nothing decodes; the file stays valid Matroska). */
static void make_bad_files(void)
{
	char path[256];
	uint8_t junk[65536];
	unsigned s = 12345;
	for (size_t i = 0; i < sizeof junk; i++)
		junk[i] = (uint8_t)((s = s * 1103515245u + 12345u) >> 16);
	path_in(path, sizeof path, "garbage.mkv");
	write_all(path, junk, sizeof junk);
	size_t n;
	path_in(path, sizeof path, "mjpeg.mkv");
	uint8_t *mkv = read_all(path, &n);
	CHECK(mkv != NULL);
	int patched = 0;
	for (size_t i = 0; mkv && i + 7 <= n; i++)
		if (!memcmp(mkv + i, "MJPG", 4)) {
			mkv[i] = 'X';
			patched++;
		}
	CHECK_MSG(patched == 1, "codec id found %d times", patched);
	path_in(path, sizeof path, "unknown.mkv");
	if (mkv)
		write_all(path, mkv, n);
	free(mkv);
}

/* ---- the reference: the files driver on the folder ---- */

static void load_reference(const char *format, uint8_t **out, size_t *sizes)
{
	char err[1024];
	drv_harness_clear(&F);
	drv_harness_set(&F, "path", DEMO);
	drv_harness_set(&F, "rate", "0");
	drv_harness_set(&F, "format", format);
	void *dev = drv_harness_open_start(&F, err, sizeof err);
	CHECK_MSG(dev != NULL, "files: %s", err);
	for (int k = 0; dev && k < NFRAMES; k++) {
		mdrv_frame f;
		int rc = drv_harness_frame(&F, dev, &f, buf, sizeof buf, 1000, err, sizeof err);
		CHECK_MSG(rc == MDRV_OK, "files frame %d: %s", k, err);
		out[k] = malloc(f.bytesused);
		memcpy(out[k], buf, f.bytesused);
		if (sizes)
			sizes[k] = f.bytesused;
	}
	if (dev) {
		F.drv->stop(dev);
		F.drv->close(dev);
	}
}

/* ---- pulling frames ---- */

typedef struct {
	int frames;
	int ended;
	double first_ms, last_ms; /* wall time of the first and last frame after start */
	int early;                /* frames delivered before their timestamp */
	double max_ts_err_ms;     /* against epoch + (k + first) / 30 */
	double max_pix_err, mean_pix_err;
	int bytes_differ;
	int misplaced; /* RGB frames closer to a neighbour of their reference frame */
	mdrv_format fmt;
} run_stats;

static double mean_diff(const uint8_t *a, const uint8_t *b)
{
	double s = 0;
	for (size_t i = 0; i < (size_t)W * H * 3; i++)
		s += fabs((double)a[i] - b[i]);
	return s / ((double)W * H * 3);
}

static void compare_frame(const mdrv_frame *f, int k, run_stats *st, double *sum, size_t *count)
{
	if (f->format.pixfmt == MC_PIXFMT_MJPEG) {
		st->bytes_differ += f->bytesused != ref_jpeg_n[k] || memcmp(buf, ref_jpeg[k], f->bytesused);
		return;
	}
	if (f->format.pixfmt != MC_PIXFMT_RGB24)
		return;
	for (size_t i = 0; i < (size_t)W * H * 3; i++) {
		double d = fabs((double)buf[i] - ref_rgb[k][i]);
		*sum += d;
		if (d > st->max_pix_err)
			st->max_pix_err = d;
	}
	*count += (size_t)W * H * 3;
	/* Neighbouring frames of the clip are alike: the frame must still be
	 * nearer its own reference than theirs. */
	double own = mean_diff(buf, ref_rgb[k]);
	st->misplaced += (k > 0 && mean_diff(buf, ref_rgb[k - 1]) <= own) ||
			 (k + 1 < NFRAMES && mean_diff(buf, ref_rgb[k + 1]) <= own);
}

/* Opens with G's config and the given epoch, pulls every frame, compares
 * frame k with reference frame first + k. */
static run_stats pull_all(int first, unsigned long long epoch)
{
	run_stats st = {0};
	char err[1024], ep[32];
	snprintf(ep, sizeof ep, "%llu", epoch);
	drv_harness_set(&G, "epoch", ep);
	void *dev = G.drv->open(&G.host, err, sizeof err);
	CHECK_MSG(dev != NULL, "open: %s", err);
	if (!dev)
		return st;
	CHECK(G.drv->get_format(dev, &st.fmt, err, sizeof err) == MDRV_OK);
	CHECK_MSG(G.drv->start(dev, err, sizeof err) == MDRV_OK, "start: %s", err);
	unsigned long long t0 = drv_harness_now_ns();
	double sum = 0;
	size_t count = 0;
	for (int k = 0;; k++) {
		mdrv_frame f;
		int rc = drv_harness_frame(&G, dev, &f, buf, sizeof buf, 5000, err, sizeof err);
		unsigned long long now = drv_harness_now_ns();
		if (rc == MDRV_ERR_END) {
			st.ended = 1;
			break;
		}
		CHECK_MSG(rc == MDRV_OK, "frame %d: %s", k, err);
		if (rc != MDRV_OK || k + first >= NFRAMES)
			break;
		CHECK_MSG(f.sequence == (uint64_t)k, "sequence %llu at frame %d", (unsigned long long)f.sequence, k);
		double due = (double)epoch + k * 1e9 / 30.0;
		double ts_err = fabs((double)f.timestamp_ns - due) / 1e6;
		if (ts_err > st.max_ts_err_ms)
			st.max_ts_err_ms = ts_err;
		st.early += (double)now < (double)f.timestamp_ns - 2e6; /* 2 ms of wake-up slack */
		st.last_ms = (double)(now - t0) / 1e6;
		if (k == 0)
			st.first_ms = st.last_ms;
		compare_frame(&f, k + first, &st, &sum, &count);
		st.frames++;
	}
	st.mean_pix_err = count ? sum / (double)count : 0;
	G.drv->stop(dev);
	G.drv->close(dev);
	return st;
}

static void set_source(const char *file, const char *format, const char *pace)
{
	char uri[300];
	drv_harness_clear(&G);
	snprintf(uri, sizeof uri, "file://%s/%s", dir, file);
	drv_harness_set(&G, "uri", uri);
	drv_harness_set(&G, "format", format);
	drv_harness_set(&G, "pace", pace);
}

/* ---- the tests ---- */

static void test_mkv_mjpeg_passthrough(void)
{
	printf("MKV of JPEGs, format auto (MJPEG passed through), pace asap\n");
	set_source("mjpeg.mkv", NULL, "asap");
	unsigned long long epoch = drv_harness_now_ns();
	run_stats st = pull_all(0, epoch);
	printf("  %d frames, %s %ux%u, ended %d, bytes differ in %d, max timestamp error %.3f ms, %.0f ms\n",
	       st.frames, mc_pixfmt_name(st.fmt.pixfmt), st.fmt.width, st.fmt.height, st.ended, st.bytes_differ,
	       st.max_ts_err_ms, st.last_ms);
	CHECK(st.fmt.pixfmt == MC_PIXFMT_MJPEG && st.fmt.width == W && st.fmt.height == H);
	CHECK_NEAR(st.fmt.fps, 30, 0.01);
	CHECK(st.frames == NFRAMES && st.ended);
	CHECK(st.bytes_differ == 0);
	CHECK(st.max_ts_err_ms <= 0.5); /* Matroska stores milliseconds */
	/* asap: 60 frames of a 2 s clip in well under 2 s */
	CHECK_MSG(st.last_ms < 1500, "asap took %.0f ms", st.last_ms);
}

static void test_mkv_realtime(void)
{
	printf("MKV of JPEGs, pace realtime, epoch 300 ms ahead\n");
	set_source("mjpeg.mkv", "mjpeg", NULL);
	unsigned long long epoch = drv_harness_now_ns() + 300000000ull;
	run_stats st = pull_all(0, epoch);
	printf("  %d frames, early %d, first after %.0f ms, last after %.0f ms, max timestamp error %.3f ms\n",
	       st.frames, st.early, st.first_ms, st.last_ms, st.max_ts_err_ms);
	CHECK(st.frames == NFRAMES && st.ended && st.bytes_differ == 0);
	CHECK(st.early == 0);
	CHECK(st.max_ts_err_ms <= 0.5);
	/* Opening takes some of the 300 ms; the last frame is due 300 ms +
	 * 59/30 s after the epoch was taken. */
	CHECK_MSG(st.last_ms > 1950 && st.last_ms < 2600, "last frame after %.0f ms", st.last_ms);
}

static void test_mkv_decoded(void)
{
	printf("MKV of JPEGs, format rgb24 (decoded by GStreamer)\n");
	set_source("mjpeg.mkv", "rgb24", "asap");
	run_stats st = pull_all(0, drv_harness_now_ns());
	printf("  %d frames, %s, pixel error mean %.3f max %.0f, max timestamp error %.3f ms, misplaced %d\n",
	       st.frames, mc_pixfmt_name(st.fmt.pixfmt), st.mean_pix_err, st.max_pix_err, st.max_ts_err_ms,
	       st.misplaced);
	CHECK(st.fmt.pixfmt == MC_PIXFMT_RGB24 && st.fmt.stride == W * 3 && st.fmt.max_bytes == W * H * 3);
	CHECK(st.frames == NFRAMES && st.ended && st.misplaced == 0);
	/* Two JPEG decoders (libjpeg-turbo's and GStreamer's with its colour
	 * conversion) differ by rounding and chroma upsampling. */
	CHECK_MSG(st.mean_pix_err < 2.0, "mean pixel error %.3f", st.mean_pix_err);
}

static void test_mp4(void)
{
	printf("MP4 of lossless H.264 4:4:4, format auto (decoded to RGB)\n");
	set_source("h264.mp4", NULL, "asap");
	unsigned long long epoch = drv_harness_now_ns();
	run_stats st = pull_all(0, epoch);
	printf("  %d frames, %s, pixel error mean %.3f max %.0f, max timestamp error %.4f ms, misplaced %d\n",
	       st.frames, mc_pixfmt_name(st.fmt.pixfmt), st.mean_pix_err, st.max_pix_err, st.max_ts_err_ms,
	       st.misplaced);
	CHECK(st.fmt.pixfmt == MC_PIXFMT_RGB24 && st.fmt.width == W && st.fmt.height == H);
	CHECK(st.frames == NFRAMES && st.ended && st.misplaced == 0);
	/* The H.264 stream is lossless (its Y444 planes decode bit-exact), but
	 * videoconvert's 8-bit RGB -> limited-range Y444 -> RGB round trip
	 * alone costs 2.8 levels on average on these frames (measured with
	 * gst-launch), on top of the two JPEG decoders' 1.3. */
	CHECK_MSG(st.mean_pix_err < 5.0, "mean pixel error %.3f", st.mean_pix_err);
	CHECK(st.max_ts_err_ms < 0.01);

	printf("MP4, format gray8\n");
	set_source("h264.mp4", "gray8", "asap");
	st = pull_all(0, drv_harness_now_ns());
	CHECK(st.fmt.pixfmt == MC_PIXFMT_GRAY8 && st.fmt.stride == W && st.fmt.max_bytes == W * H);
	CHECK(st.frames == NFRAMES && st.ended);
}

static void test_start_offset(void)
{
	printf("start = 1.0: running time 0 at frame 30\n");
	set_source("mjpeg.mkv", NULL, "asap");
	drv_harness_set(&G, "start", "1.0");
	run_stats st = pull_all(30, drv_harness_now_ns());
	printf("  %d frames, bytes differ in %d, max timestamp error %.3f ms\n", st.frames, st.bytes_differ,
	       st.max_ts_err_ms);
	CHECK(st.frames == NFRAMES - 30 && st.ended && st.bytes_differ == 0);
	CHECK(st.max_ts_err_ms <= 0.5);

	printf("start = 1.0 on the MP4 (a seek into H.264, decoded from its key frame)\n");
	set_source("h264.mp4", NULL, "asap");
	drv_harness_set(&G, "start", "1.0");
	st = pull_all(30, drv_harness_now_ns());
	printf("  %d frames, pixel error mean %.3f, max timestamp error %.4f ms\n", st.frames, st.mean_pix_err,
	       st.max_ts_err_ms);
	CHECK(st.frames == NFRAMES - 30 && st.ended && st.mean_pix_err < 5.0 && st.max_ts_err_ms < 0.01);
	CHECK(st.misplaced == 0);
}

/* frame_count(): a file's frames from `start` on (offline progress). */
static void expect_frame_count(const char *file, const char *start, uint64_t want)
{
	char err[1024];
	set_source(file, NULL, "asap");
	drv_harness_set(&G, "start", start);
	void *dev = drv_harness_open_start(&G, err, sizeof err);
	CHECK_MSG(dev != NULL, "%s: %s", file, err);
	uint64_t n = 0;
	int rc = dev && G.drv->frame_count ? G.drv->frame_count(dev, &n) : MDRV_ERR_IO;
	printf("  %s, start %s: frame_count %d, %llu frames\n", file, start, rc, (unsigned long long)n);
	CHECK_MSG(rc == MDRV_OK && n == want, "%s from %s s: %llu frames, not %llu", file, start,
		  (unsigned long long)n, (unsigned long long)want);
	if (dev) {
		G.drv->stop(dev);
		G.drv->close(dev);
	}
}

static void test_frame_count(void)
{
	printf("frame_count()\n");
	expect_frame_count("mjpeg.mkv", "0", NFRAMES);
	expect_frame_count("mjpeg.mkv", "1.0", NFRAMES - 30);
	expect_frame_count("h264.mp4", "0", NFRAMES);
	expect_frame_count("h264.mp4", "1.0", NFRAMES - 30);
}

static void test_pipeline(void)
{
	printf("pipeline = videotestsrc (white) ! appsink name=mocap, format gray8\n");
	drv_harness_clear(&G);
	drv_harness_set(&G, "pipeline",
			"videotestsrc pattern=white num-buffers=10 ! video/x-raw,width=64,height=48,framerate=30/1 ! "
			"videoconvert ! appsink name=mocap");
	drv_harness_set(&G, "format", "gray8");
	drv_harness_set(&G, "pace", "asap");
	char err[1024];
	void *dev = drv_harness_open_start(&G, err, sizeof err);
	CHECK_MSG(dev != NULL, "%s", err);
	int frames = 0, rc = MDRV_OK, bright = 1;
	while (dev && (rc = drv_harness_frame(&G, dev, &(mdrv_frame){0}, buf, sizeof buf, 2000, err, sizeof err)) ==
			      MDRV_OK) {
		frames++;
		for (int i = 0; i < 64 * 48; i++)
			bright &= buf[i] >= 200;
	}
	CHECK_MSG(dev && rc == MDRV_ERR_END, "%d: %s", dev ? rc : 0, err);
	CHECK(frames == 10 && bright);
	if (dev) {
		G.drv->stop(dev);
		G.drv->close(dev);
	}
}

static void test_errors(void)
{
	char uri[300];
	printf("config and stream errors\n");
	static const drv_bad_config bad[] = {
		{{NULL}, "'uri' or 'pipeline' is required"},
		{{"uri", "file:///x.mkv", "pipeline", "fakesrc ! appsink name=mocap"}, "not both"},
		{{"uri", "/nonexistent/clip.mkv"}, "No such file"},
		{{"uri", "nosuchproto://host/x"}, "no GStreamer source reads 'nosuchproto://'"},
		{{"pipeline", "videotestsrc ! fakesink"}, "appsink name=mocap"},
		{{"pipeline", "videotestsrc ! nosuchelement ! appsink name=mocap"}, "nosuchelement"},
		{{"uri", "/nonexistent", "format", "rgb32"}, "config key 'format'"},
	};
	drv_check_open_errors(&G, "gstreamer: ", bad, sizeof bad / sizeof bad[0]);

	set_source("mjpeg.mkv", NULL, "sometimes");
	gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"config key 'pace'", "sometimes", NULL});
	set_source("garbage.mkv", NULL, NULL);
	gst_test_open_fails(&G, MDRV_ERR_CONFIG,
			    (const char *const[]){"config key 'uri'", "garbage.mkv", "type of stream", NULL});
	set_source("unknown.mkv", NULL, NULL);
	gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"config key 'uri'", "unknown.mkv", "plug", NULL});
	set_source("audio.mkv", NULL, NULL);
	gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"audio.mkv", "no video stream", NULL});
	set_source("mjpeg.mkv", NULL, NULL);
	drv_harness_set(&G, "start", "5");
	gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"config key 'start'", NULL});
	/* An unreadable file is permanent too (root reads anything). */
	if (geteuid() != 0) {
		snprintf(uri, sizeof uri, "%s/unreadable.mkv", dir);
		write_all(uri, (const uint8_t *)"x", 1);
		chmod(uri, 0);
		drv_harness_clear(&G);
		drv_harness_set(&G, "uri", uri);
		gst_test_open_fails(&G, MDRV_ERR_CONFIG, (const char *const[]){"Permission denied", NULL});
	}
}

static void test_check(void)
{
	char err[1024];
	printf("check() (mocapd --check)\n");
	set_source("mjpeg.mkv", NULL, "asap");
	drv_harness_set(&G, "start", "0.5");
	CHECK_MSG(G.drv->check(&G.host, err, sizeof err) == MDRV_OK, "%s", err);
	drv_harness_clear(&G);
	drv_harness_set(&G, "pipeline", "videotestsrc ! videoconvert ! appsink name=mocap");
	CHECK_MSG(G.drv->check(&G.host, err, sizeof err) == MDRV_OK, "%s", err);
	drv_harness_set(&G, "pipeline", "videotestsrc ! videoconvert ! fakesink name=mocap");
	CHECK(G.drv->check(&G.host, err, sizeof err) == MDRV_ERR_CONFIG && strstr(err, "no appsink named 'mocap'"));
	printf("  %s\n", err);
	drv_harness_clear(&G);
	drv_harness_set(&G, "uri", "/nonexistent/phone.mp4");
	CHECK(G.drv->check(&G.host, err, sizeof err) == MDRV_ERR_CONFIG && strstr(err, "config key 'uri'") &&
	      strstr(err, "No such file"));
	printf("  %s\n", err);
	set_source("mjpeg.mkv", NULL, NULL);
	drv_harness_set(&G, "latency", "-3");
	CHECK(G.drv->check(&G.host, err, sizeof err) == MDRV_ERR_CONFIG && strstr(err, "config key 'latency'"));
	printf("  %s\n", err);
}

/* A clip whose frames are black, then white from frame `flash` on. */
static void make_flash_clip(const char *name, int flash, const char *mux)
{
	char cmd[1024], out[256];
	path_in(out, sizeof out, name);
	snprintf(cmd, sizeof cmd,
		 "concat name=c ! videoconvert ! video/x-raw,format=I420 ! x264enc speed-preset=ultrafast ! %s ! "
		 "filesink location=%s videotestsrc pattern=black num-buffers=%d ! "
		 "video/x-raw,framerate=30/1,width=160,height=120 ! c. videotestsrc pattern=white num-buffers=30 ! "
		 "video/x-raw,framerate=30/1,width=160,height=120 ! c.",
		 mux, out, flash);
	CHECK(gst_test_run(cmd) == 0);
}

/* Runs find-flash.sh on the two clips; their `start` values. */
static int find_starts(const char *a, const char *b, double starts[2])
{
	char cmd[700], line[512];
	snprintf(cmd, sizeof cmd, "drivers/gstreamer/find-flash.sh %s/%s %s/%s", dir, a, dir, b);
	FILE *p = popen(cmd, "r");
	int n = 0;
	while (p && fgets(line, sizeof line, p)) {
		printf("  find-flash.sh: %s", line);
		char *at = strstr(line, ": start = ");
		if (at && n < 2)
			starts[n++] = atof(at + 10);
	}
	CHECK(p && pclose(p) == 0);
	return n;
}

/* Opens a camera on clip `name` with `start` and `epoch`, started. */
static void *open_rig_camera(const char *name, double start, const char *epoch)
{
	char v[32], err[1024];
	set_source(name, "gray8", "asap");
	snprintf(v, sizeof v, "%.3f", start);
	drv_harness_set(&G, "start", v);
	drv_harness_set(&G, "epoch", epoch);
	void *dev = drv_harness_open_start(&G, err, sizeof err);
	CHECK_MSG(dev != NULL, "%s: %s", name, err);
	return dev;
}

/* The timestamp of the camera's first bright frame; 0 if none. */
static unsigned long long first_bright(void *dev)
{
	char err[1024];
	mdrv_frame f;
	while (dev && drv_harness_frame(&G, dev, &f, buf, sizeof buf, 2000, err, sizeof err) == MDRV_OK) {
		unsigned long sum = 0;
		for (size_t i = 0; i < f.bytesused; i++)
			sum += buf[i];
		if (f.bytesused && sum / f.bytesused > 128)
			return f.timestamp_ns;
	}
	return 0;
}

static void test_rig(void)
{
	printf("two files as one rig, lined up on a flash\n");
	make_flash_clip("flash_a.mp4", 37, "mp4mux");
	make_flash_clip("flash_b.mkv", 12, "matroskamux");
	double starts[2] = {0, 0};
	CHECK(find_starts("flash_a.mp4", "flash_b.mkv", starts) == 2);
	CHECK_NEAR(starts[0], 25 / 30.0, 0.002);
	CHECK_NEAR(starts[1], 0, 0.002);
	char epoch[32];
	snprintf(epoch, sizeof epoch, "%llu", drv_harness_now_ns());
	void *a = open_rig_camera("flash_a.mp4", starts[0], epoch);
	void *b = open_rig_camera("flash_b.mkv", starts[1], epoch);
	unsigned long long ta = first_bright(a), tb = first_bright(b);
	printf("  flash frames: %.3f and %.3f ms after the epoch\n", (double)(ta - atoll(epoch)) / 1e6,
	       (double)(tb - atoll(epoch)) / 1e6);
	CHECK(ta && tb);
	CHECK_NEAR((double)ta, (double)tb, 1e6); /* within a millisecond */
	CHECK_NEAR((double)(tb - atoll(epoch)), 12e9 / 30, 1e6);
	void *devs[2] = {a, b};
	for (int i = 0; i < 2; i++)
		if (devs[i]) {
			G.drv->stop(devs[i]);
			G.drv->close(devs[i]);
		}
}

int main(void)
{
	static const char *const need[] = {"uridecodebin", "appsink",  "videoconvert", "matroskamux", "matroskademux",
					   "jpegparse",    "jpegdec",  "x264enc",      "avdec_h264",  "mp4mux",
					   "qtdemux",      "imagesequencesrc", "audiotestsrc", "videotestsrc"};
	gst_test_require(need, sizeof need / sizeof need[0]);
	drv_check_load(&G, "gstreamer");
	drv_check_load(&F, "files");
	G.quiet = F.quiet = 1;
	snprintf(dir, sizeof dir, "/tmp/mocap-gst-XXXXXX");
	CHECK(mkdtemp(dir) != NULL);
	make_media();
	make_bad_files();
	load_reference("mjpeg", ref_jpeg, ref_jpeg_n);
	load_reference("rgb24", ref_rgb, NULL);

	test_mkv_mjpeg_passthrough();
	test_mkv_realtime();
	test_mkv_decoded();
	test_mp4();
	test_start_offset();
	test_frame_count();
	test_pipeline();
	test_errors();
	test_check();
	if (gst_test_have("videoanalyse") && gst_test_have("concat"))
		test_rig();
	else
		printf("two files as one rig: videoanalyse or concat not installed, not tested\n");

	for (int k = 0; k < NFRAMES; k++) {
		free(ref_jpeg[k]);
		free(ref_rgb[k]);
	}
	char cmd[128];
	snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
	CHECK(system(cmd) == 0);
	drv_harness_unload(&G);
	drv_harness_unload(&F);
	return mc_test_failures ? 1 : 0;
}
