/* test_v4l2_vivid: the v4l2 driver plugin against the kernel's vivid virtual
 * video driver.  Meant to run inside the qemu guest that tests/vm/vivid-test.sh
 * boots, with vivid loaded as `n_devs=2 node_types=0x1,0x1 num_inputs=1,1
 * input_types=0,0` (two webcam-like capture nodes, /dev/video0 and 1); on
 * any other machine it skips.
 *
 * Checks: probe, formats and sizes (YUYV, GREY), frame rate and monotonic
 * timestamps, bad formats, controls (gain, ctrl.NAME, missing controls),
 * selection by bus_info, and unplug (unbinding vivid) and replug. */
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "drv_check.h"
#include "test_util.h"

#define VIVID_SYSFS "/sys/bus/platform/drivers/vivid"

static drv_harness H;
static uint8_t frame_buf[8 << 20];

static int write_sysfs(const char *path, const char *text)
{
	int fd = open(path, O_WRONLY);
	if (fd < 0)
		return -1;
	ssize_t n = write(fd, text, strlen(text));
	close(fd);
	return n == (ssize_t)strlen(text) ? 0 : -1;
}

/* Reads control `id` through a separate descriptor, as another program
 * (v4l2-ctl) would, to see what the driver really set. */
static int read_ctrl(const char *node, uint32_t id, int *value)
{
	int fd = open(node, O_RDWR | O_NONBLOCK);
	if (fd < 0)
		return -1;
	struct v4l2_control c = {.id = id};
	int r = ioctl(fd, VIDIOC_G_CTRL, &c);
	close(fd);
	*value = c.value;
	return r;
}

static void expect_open_error(int status, const char *needle)
{
	(void)status; /* open() returns no status, only NULL and the message */
	drv_check_open_error(&H, "v4l2: ", needle);
}

static int cmp_ull(const void *a, const void *b)
{
	unsigned long long x = *(const unsigned long long *)a, y = *(const unsigned long long *)b;
	return x < y ? -1 : x > y;
}

/* Pulls n frames and checks sizes, timestamps and sequence numbers; returns
 * the median frame interval in seconds (0 if frames were missing). */
static double pull_frames(void *dev, int n, const mdrv_format *fmt)
{
	char err[512];
	unsigned long long ts[64], dt[64];
	int got = 0, gaps = 0;
	unsigned long long last_seq = 0;
	for (int i = 0; i < n && i < 64; i++) {
		mdrv_frame f;
		int st = drv_harness_frame(&H, dev, &f, frame_buf, sizeof frame_buf, 3000, err, sizeof err);
		unsigned long long now = drv_harness_now_ns();
		CHECK_MSG(st == MDRV_OK, "frame %d: status %d: %s", i, st, err);
		if (st != MDRV_OK)
			return 0;
		CHECK_MSG(f.bytesused == (size_t)fmt->stride * fmt->height, "bytesused %zu, expected %u", f.bytesused,
			  fmt->stride * fmt->height);
		CHECK_MSG(f.flags == 0, "flags 0x%x", f.flags);
		CHECK(f.format.pixfmt == fmt->pixfmt && f.format.width == fmt->width && f.format.height == fmt->height);
		/* CLOCK_MONOTONIC, stamped by vivid when it filled the buffer */
		CHECK_MSG(f.timestamp_ns <= now && f.timestamp_ns + 2000000000ull > now,
			  "timestamp %llu not within 2 s before now %llu", (unsigned long long)f.timestamp_ns, now);
		if (got) {
			CHECK_MSG(f.timestamp_ns > ts[got - 1], "timestamps must increase");
			CHECK_MSG(f.sequence > last_seq, "sequence %llu after %llu", (unsigned long long)f.sequence,
				  last_seq);
			gaps += f.sequence != last_seq + 1;
			dt[got - 1] = f.timestamp_ns - ts[got - 1];
		}
		last_seq = f.sequence;
		ts[got++] = f.timestamp_ns;
	}
	if (gaps)
		printf("  (%d sequence gaps: frames dropped while the emulated CPU was busy)\n", gaps);
	if (got < 2)
		return 0;
	qsort(dt, (size_t)got - 1, sizeof dt[0], cmp_ull);
	return (double)dt[(got - 1) / 2] * 1e-9;
}

static void test_probe(int expect)
{
	mdrv_device_info info[8];
	char err[256];
	int n = H.drv->probe(&H.host, info, 8, err, sizeof err);
	CHECK_MSG(n == expect, "probe found %d devices, expected %d", n, expect);
	for (int i = 0; i < n; i++) {
		printf("probe: %s '%s' bus_info %s serial '%s'\n", info[i].id, info[i].name, info[i].bus_info,
		       info[i].serial);
		CHECK(strncmp(info[i].id, "/dev/video", 10) == 0);
		CHECK(strstr(info[i].name, "vivid") != NULL || strstr(info[i].name, "Virtual") != NULL);
		CHECK(strncmp(info[i].bus_info, "platform:vivid-", 15) == 0);
	}
}

static void test_mode(const char *pixfmt, const char *w, const char *h, const char *fps, uint32_t expect_fmt,
		      unsigned bpp)
{
	char err[1024];
	drv_harness_clear(&H);
	drv_harness_set(&H, "device", "/dev/video0");
	drv_harness_set(&H, "pixel_format", pixfmt);
	drv_harness_set(&H, "width", w);
	drv_harness_set(&H, "height", h);
	drv_harness_set(&H, "fps", fps);
	/* vivid stamps the end of the frame by default, a frame period ahead
	 * of the time it hands the buffer over; a camera stamps the start of
	 * exposure.  A menu control set by the name of its entry: */
	drv_harness_set(&H, "ctrl.timestamp_source", "Start of Exposure");
	void *dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "%s %sx%s@%s: %s", pixfmt, w, h, fps, err);
	if (!dev)
		return;
	mdrv_format fmt;
	CHECK(H.drv->get_format(dev, &fmt, err, sizeof err) == MDRV_OK);
	CHECK_MSG(fmt.pixfmt == expect_fmt, "pixfmt %u", fmt.pixfmt);
	CHECK(fmt.width == (uint32_t)atoi(w) && fmt.height == (uint32_t)atoi(h));
	CHECK(fmt.stride == fmt.width * bpp);
	CHECK(fmt.max_bytes >= (size_t)fmt.stride * fmt.height);
	CHECK_NEAR(fmt.fps, atof(fps), 0.01);
	double median = pull_frames(dev, 16, &fmt);
	printf("%s %sx%s@%s: median frame interval %.1f ms\n", pixfmt, w, h, fps, median * 1e3);
	CHECK_NEAR(median, 1.0 / atof(fps), 0.25 / atof(fps));
	/* vivid draws a test pattern: not a blank frame */
	size_t distinct = 0;
	int seen[256] = {0};
	for (size_t i = 0; i < (size_t)fmt.stride * fmt.height; i++)
		if (!seen[frame_buf[i]]++)
			distinct++;
	CHECK_MSG(distinct >= 4, "%zu distinct byte values", distinct);
	/* stop and start again on the same handle */
	H.drv->stop(dev);
	CHECK(H.drv->start(dev, err, sizeof err) == MDRV_OK);
	CHECK(pull_frames(dev, 3, &fmt) > 0);
	H.drv->stop(dev);
	H.drv->close(dev);
}

static void test_bad_modes(void)
{
	drv_harness_clear(&H);
	drv_harness_set(&H, "device", "/dev/video0");
	drv_harness_set(&H, "pixel_format", "MJPEG");
	expect_open_error(MDRV_ERR_FORMAT, "not offered");
	expect_open_error(MDRV_ERR_FORMAT, "YUYV 320x180@");
	drv_harness_set(&H, "pixel_format", "YUYV");
	drv_harness_set(&H, "width", "333");
	drv_harness_set(&H, "height", "222");
	expect_open_error(MDRV_ERR_FORMAT, "asked for 333x222");
	drv_harness_set(&H, "width", "320");
	drv_harness_set(&H, "height", "180");
	drv_harness_set(&H, "fps", "1000");
	expect_open_error(MDRV_ERR_FORMAT, "asked for 1000 fps");
}

static void test_controls(void)
{
	char err[1024];
	drv_harness_clear(&H);
	drv_harness_set(&H, "device", "/dev/video0");
	drv_harness_set(&H, "gain", "42");
	drv_harness_set(&H, "ctrl.brightness", "200");
	drv_harness_set(&H, "ctrl.contrast", "100");
	void *dev = H.drv->open(&H.host, err, sizeof err);
	CHECK_MSG(dev != NULL, "controls: %s", err);
	if (dev) {
		int v = -1;
		CHECK(read_ctrl("/dev/video0", V4L2_CID_AUTOGAIN, &v) == 0 && v == 0);
		CHECK_MSG(read_ctrl("/dev/video0", V4L2_CID_GAIN, &v) == 0 && v == 42, "gain %d", v);
		CHECK_MSG(read_ctrl("/dev/video0", V4L2_CID_BRIGHTNESS, &v) == 0 && v == 200, "brightness %d", v);
		CHECK_MSG(read_ctrl("/dev/video0", V4L2_CID_CONTRAST, &v) == 0 && v == 100, "contrast %d", v);
		H.drv->close(dev);
	}
	drv_harness_set(&H, "gain", "auto");
	drv_harness_set(&H, "ctrl.brightness", "100");
	dev = H.drv->open(&H.host, err, sizeof err);
	CHECK_MSG(dev != NULL, "auto gain: %s", err);
	if (dev) {
		int v = -1;
		CHECK(read_ctrl("/dev/video0", V4L2_CID_AUTOGAIN, &v) == 0 && v == 1);
		H.drv->close(dev);
	}
	static const drv_bad_config bad[] = { /* MDRV_ERR_CONFIG */
		{{"device", "/dev/video0", "ctrl.brightness", "999"}, "outside the control's range"},
		{{"device", "/dev/video0", "ctrl.brightness", "bright"}, "'ctrl.brightness'"},
		{{"device", "/dev/video0", "gain", "1000"}, "'gain'"},
		/* vivid has neither exposure nor white balance controls */
		{{"device", "/dev/video0", "exposure", "0.01"}, "no absolute exposure control"},
		{{"device", "/dev/video0", "white_balance", "auto"}, "no automatic white balance control"},
	};
	drv_check_open_errors(&H, "v4l2: ", bad, sizeof bad / sizeof bad[0]);
}

static void test_selection(void)
{
	char err[1024];
	drv_harness_clear(&H);
	drv_harness_set(&H, "bus_info", "platform:vivid-001");
	void *dev = H.drv->open(&H.host, err, sizeof err);
	CHECK_MSG(dev != NULL, "bus_info: %s", err);
	if (dev) {
		CHECK_MSG(drv_harness_logged(&H, "opened /dev/video1"), "bus_info vivid-001 should open /dev/video1");
		H.drv->close(dev);
	}
	static const drv_bad_config bad[] = { /* MDRV_ERR_NODEV */
		{{"bus_info", "usb-0000:00:14.0-9"}, "platform:vivid-000"},
		{{"serial", "SN1234"}, "serial=SN1234"},
		{{"device", "/dev/video0", "bus_info", "platform:vivid-001"}, "no capture device matches"},
		{{"device", "/dev/video7"}, "/dev/video7"},
	};
	drv_check_open_errors(&H, "v4l2: ", bad, sizeof bad / sizeof bad[0]);
}

/* Unbinding the vivid platform device is what a USB unplug looks like to a
 * V4L2 program: the node goes away under an open descriptor. */
static void test_unplug(void)
{
	char err[1024];
	drv_harness_clear(&H);
	drv_harness_set(&H, "bus_info", "platform:vivid-000");
	drv_harness_set(&H, "width", "320");
	drv_harness_set(&H, "height", "180");
	drv_harness_set(&H, "fps", "30");
	drv_harness_set(&H, "ctrl.timestamp_source", "Start of Exposure");
	void *dev = drv_harness_open_start(&H, err, sizeof err);
	CHECK_MSG(dev != NULL, "unplug: %s", err);
	if (!dev)
		return;
	mdrv_format fmt;
	H.drv->get_format(dev, &fmt, err, sizeof err);
	CHECK(pull_frames(dev, 2, &fmt) > 0);
	CHECK(write_sysfs(VIVID_SYSFS "/unbind", "vivid.0") == 0);
	int st = MDRV_OK;
	for (int i = 0; i < 20 && (st == MDRV_OK || st == MDRV_ERR_TIMEOUT); i++) {
		mdrv_frame f;
		st = drv_harness_frame(&H, dev, &f, frame_buf, sizeof frame_buf, 500, err, sizeof err);
	}
	printf("after unbind: status %d: %s\n", st, err);
	CHECK_MSG(st == MDRV_ERR_NODEV, "status %d: %s", st, err);
	CHECK(strstr(err, "unplugged") != NULL);
	H.drv->stop(dev);
	H.drv->close(dev);
	test_probe(0); /* one platform device carries both vivid instances */
	expect_open_error(MDRV_ERR_NODEV, "no capture device matches");

	CHECK(write_sysfs(VIVID_SYSFS "/bind", "vivid.0") == 0);
	dev = NULL;
	for (int i = 0; i < 20 && !dev; i++) { /* devtmpfs creates the node */
		dev = drv_harness_open_start(&H, err, sizeof err);
		if (!dev)
			usleep(100000);
	}
	CHECK_MSG(dev != NULL, "after replug: %s", err);
	if (!dev)
		return;
	H.drv->get_format(dev, &fmt, err, sizeof err);
	CHECK(pull_frames(dev, 3, &fmt) > 0);
	H.drv->stop(dev);
	H.drv->close(dev);
	test_probe(2);
}

int main(void)
{
	struct stat st;
	if (stat(VIVID_SYSFS, &st) != 0)
		TEST_SKIP("the vivid driver is not loaded here (tests/vm/vivid-test.sh runs this in a VM)");
	drv_check_load(&H, "v4l2");
	test_probe(2);
	test_mode("YUYV", "320", "180", "30", MC_PIXFMT_YUYV, 2);
	test_mode("GREY", "640", "360", "15", MC_PIXFMT_GRAY8, 1);
	test_bad_modes();
	test_controls();
	test_selection();
	test_unplug();
	drv_harness_unload(&H);
	return mc_test_finish("test_v4l2_vivid");
}
