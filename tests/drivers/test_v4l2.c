/* test_v4l2: the v4l2 driver plugin on the build machine, which has no video
 * devices: config errors name the key and the value, a missing or wrong node
 * gives a clear error, and probe works with whatever is there.  Streaming is
 * tested against vivid in a VM (test_v4l2_vivid via tests/vm/vivid-test.sh). */
#include <stdio.h>
#include <string.h>

#include "drv_check.h"
#include "test_util.h"

static drv_harness H;

static void expect_open_error(const char *needle) { drv_check_open_error(&H, "v4l2: ", needle); }

static void with(const char *key, const char *val, const char *needle)
{
	drv_harness_clear(&H);
	drv_harness_set(&H, "device", "/dev/video0");
	drv_harness_set(&H, key, val);
	expect_open_error(needle);
}

int main(void)
{
	char err[512];
	if (drv_harness_load(&H, "v4l2", err, sizeof err) != 0) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	CHECK(!strcmp(H.drv->name, "v4l2"));

	mdrv_device_info info[16];
	int n = H.drv->probe(&H.host, info, 16, err, sizeof err);
	CHECK_MSG(n >= 0, "probe: %s", err);
	printf("probe: %d capture devices here\n", n);
	for (int i = 0; i < n; i++)
		CHECK(strncmp(info[i].id, "/dev/", 5) == 0);

	/* what selects the camera */
	drv_harness_clear(&H);
	expect_open_error("'device'");
	drv_harness_set(&H, "device", "/dev/video-does-not-exist");
	expect_open_error("cannot open /dev/video-does-not-exist: No such file");
	drv_harness_set(&H, "device", "/dev/null");
	expect_open_error("/dev/null is not a V4L2 device");
	drv_harness_clear(&H);
	drv_harness_set(&H, "bus_info", "usb-0000:00:14.0-9");
	expect_open_error("no capture device matches bus_info=usb-0000:00:14.0-9");
	drv_harness_clear(&H);
	drv_harness_set(&H, "serial", "SN42");
	expect_open_error("serial=SN42");

	/* values, checked before any device is touched */
	with("pixel_format", "RGB3", "'pixel_format': expected one of YUYV, MJPEG, GREY");
	with("width", "640", "'width' and 'height' go together");
	with("width", "-5", "'width': expected an integer in [1, 16384], got '-5'");
	with("fps", "fast", "'fps'");
	with("buffers", "100", "'buffers'");
	with("exposure", "-1", "'exposure': expected 'auto' or a number");
	with("gain", "loud", "'gain'");
	with("white_balance", "50", "'white_balance'");

	drv_harness_unload(&H);
	return mc_test_finish("test_v4l2");
}
