/* test_openni2: the openni2 driver plugin against OpenNI2's own DummyDevice
 * driver (libDummyDevice.so, shipped with libopenni2-0): opening the URI
 * "Dummy" gives a device with a 320x240 DEPTH_1_MM stream (first row at
 * 2000 mm, a bouncing disc near 1000 mm) and a 320x240 RGB888 stream, at
 * about 30 fps, through the real OpenNI2 runtime and driver interface.
 *
 * Checks: probe, errors (no device, bad keys, missing sensor, unsupported
 * mode and mirror, playback keys on a live device), depth frames (format,
 * values, sequence, timestamps), a colour stream of the same device open at
 * the same time, and closing and reopening. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drv_check.h"
#include "test_util.h"

static drv_harness H;
static uint8_t buf[1 << 20];

static void expect_open_error(const char *needle) { drv_check_open_error(&H, "openni2: ", needle); }

static void dummy(const char *stream)
{
	drv_harness_clear(&H);
	drv_harness_set(&H, "device", "Dummy");
	drv_harness_set(&H, "stream", stream);
}

static int cmp_ull(const void *a, const void *b)
{
	unsigned long long x = *(const unsigned long long *)a, y = *(const unsigned long long *)b;
	return x < y ? -1 : x > y;
}

static void check_depth_frames(void *dev, int n)
{
	char err[512];
	unsigned long long ts[32], dt[32], seq[32];
	int got = 0;
	for (int i = 0; i < n && i < 32; i++) {
		mdrv_frame f;
		int st = drv_harness_frame(&H, dev, &f, buf, sizeof buf, 1000, err, sizeof err);
		unsigned long long now = drv_harness_now_ns();
		CHECK_MSG(st == MDRV_OK, "depth frame %d: %d %s", i, st, err);
		if (st != MDRV_OK)
			return;
		CHECK(f.format.pixfmt == MC_PIXFMT_DEPTH16 && f.format.width == 320 && f.format.height == 240);
		CHECK(f.bytesused == 320 * 240 * 2 && f.flags == 0);
		const uint16_t *mm = (const uint16_t *)buf;
		int row0 = 1, disc = 0;
		for (int x = 0; x < 320; x++)
			row0 &= mm[x] == 2000;
		for (int p = 320; p < 320 * 240; p++)
			disc += mm[p] > 500 && mm[p] < 1600;
		CHECK_MSG(row0, "the first row should read 2000 mm");
		CHECK_MSG(disc > 0 && disc < 1000, "%d disc pixels", disc);
		CHECK_MSG(f.timestamp_ns <= now && f.timestamp_ns + 500000000ull > now, "timestamp %llu, now %llu",
			  (unsigned long long)f.timestamp_ns, now);
		ts[got] = f.timestamp_ns;
		seq[got++] = f.sequence;
	}
	for (int i = 1; i < got; i++) {
		CHECK_MSG(seq[i] == seq[i - 1] + 1, "sequence %llu after %llu", seq[i], seq[i - 1]);
		CHECK(ts[i] > ts[i - 1]);
		dt[i - 1] = ts[i] - ts[i - 1];
	}
	if (got > 2) {
		qsort(dt, (size_t)got - 1, sizeof dt[0], cmp_ull);
		double median = (double)dt[(got - 1) / 2] * 1e-9;
		printf("depth: median frame interval %.1f ms\n", median * 1e3);
		CHECK_NEAR(median, 0.033, 0.012);
	}
}

static void test_streams(void)
{
	char err[1024];
	dummy("depth");
	void *depth = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(depth != NULL, "depth: %s", err);
	if (!depth)
		return;
	mdrv_format fmt;
	CHECK(H.drv->get_format(depth, &fmt, err, sizeof err) == MDRV_OK);
	CHECK(fmt.pixfmt == MC_PIXFMT_DEPTH16 && fmt.width == 320 && fmt.height == 240 && fmt.stride == 640);
	CHECK(fmt.max_bytes == 320 * 240 * 2 && fmt.fps == 30);
	check_depth_frames(depth, 10);

	/* the colour stream of the same device, open at the same time */
	dummy("color");
	void *color = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(color != NULL, "color: %s", err);
	if (color) {
		H.drv->get_format(color, &fmt, err, sizeof err);
		CHECK(fmt.pixfmt == MC_PIXFMT_RGB24 && fmt.stride == 960);
		for (int i = 0; i < 3; i++) {
			mdrv_frame f;
			int st = drv_harness_frame(&H, color, &f, buf, sizeof buf, 1000, err, sizeof err);
			CHECK_MSG(st == MDRV_OK, "color frame: %s", err);
			CHECK(f.bytesused == 320 * 240 * 3);
			CHECK_MSG(buf[2] == 255, "the first pixel's blue byte is %u", buf[2]); /* DummyDevice's marker */
		}
		check_depth_frames(depth, 3);
		H.drv->stop(color);
		H.drv->close(color);
	}
	/* the shared device stays open for the depth stream */
	check_depth_frames(depth, 3);
	H.drv->stop(depth);
	CHECK(H.drv->start(depth, err, sizeof err) == MDRV_OK);
	check_depth_frames(depth, 3);
	H.drv->stop(depth);
	H.drv->close(depth);

	/* and it opens again after the last user closed it */
	dummy("depth");
	depth = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(depth != NULL, "reopen: %s", err);
	if (depth) {
		check_depth_frames(depth, 3);
		H.drv->stop(depth);
		H.drv->close(depth);
	}
}

/* mdrv_driver.modes (driver ABI 3, mocapd --probe): the Dummy device's
 * depth and colour streams, each 320x240 at 30 fps, under the `stream`
 * key; a device that is not there is NODEV. */
static void test_modes(void)
{
	CHECK(H.drv->modes != NULL);
	if (!H.drv->modes)
		return;
	mdrv_mode m[16];
	char err[512] = "";
	int n = H.drv->modes(&H.host, "Dummy", m, 16, err, sizeof err);
	CHECK_MSG(n == 2, "modes: %d (%s)", n, err);
	for (int i = 0; i < n; i++)
		printf("modes: %s = %s %ux%u @ %g (%u rates)\n", m[i].format_key, m[i].pixel_format, m[i].width,
		       m[i].height, m[i].nfps ? m[i].fps[0] : 0.0, m[i].nfps);
	CHECK(n >= 1 && !strcmp(m[0].format_key, "stream") && !strcmp(m[0].pixel_format, "depth") &&
	      m[0].pixfmt == MC_PIXFMT_DEPTH16 && m[0].width == 320 && m[0].height == 240 && m[0].nfps == 1 &&
	      m[0].fps[0] == 30);
	CHECK(n >= 2 && !strcmp(m[1].pixel_format, "color") && m[1].pixfmt == MC_PIXFMT_RGB24 && m[1].width == 320);
	CHECK(H.drv->modes(&H.host, "/nonexistent/take1.oni", m, 16, err, sizeof err) == MDRV_ERR_NODEV);
	CHECK_MSG(strstr(err, "cannot open device '/nonexistent/take1.oni'"), "%s", err);
}

int main(void)
{
	drv_check_load(&H, "openni2");
	test_modes();
	mdrv_device_info info[8];
	int n = drv_check_probe(&H, info, 8, "devices");

	drv_harness_clear(&H);
	if (n == 0)
		expect_open_error("no OpenNI2 device found");
	static const drv_bad_config bad[] = {
		{{"device", "/nonexistent/take1.oni"}, "cannot open device '/nonexistent/take1.oni'"},
		{{"device", "Dummy", "stream", "thermal"}, "'stream': expected one of depth, color, colour, ir"},
		{{"device", "Dummy", "stream", "depth", "width", "640"}, "'width' and 'height' go together"},
		{{"device", "Dummy", "stream", "depth", "width", "640", "height", "480"}, "320x240@30 DEPTH_1_MM"},
		{{"device", "Dummy", "stream", "ir"}, "device 'Dummy' has no ir sensor"},
		{{"device", "Dummy", "stream", "depth", "mirror", "true"}, "'mirror': not supported"},
		{{"device", "Dummy", "stream", "depth", "speed", "2"}, "'speed' and 'loop' apply to .oni recordings only"},
	};
	drv_check_open_errors(&H, "openni2: ", bad, sizeof bad / sizeof bad[0]);

	test_streams();
	drv_harness_unload(&H);
	return mc_test_finish("test_openni2");
}
