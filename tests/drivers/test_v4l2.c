/* test_v4l2: the v4l2 driver plugin on the build machine, which has no video
 * devices: config errors name the key and the value, a missing or wrong node
 * gives a clear error, and probe works with whatever is there.  Streaming is
 * tested against vivid in a VM (test_v4l2_vivid via tests/vm/vivid-test.sh). */
#include <stdio.h>
#include <string.h>

#include "drv_check.h"
#include "test_util.h"

static drv_harness H;

int main(void)
{
	drv_check_load(&H, "v4l2");
	CHECK(!strcmp(H.drv->name, "v4l2"));

	mdrv_device_info info[16];
	int n = drv_check_probe(&H, info, 16, "capture devices here");
	for (int i = 0; i < n; i++)
		CHECK(strncmp(info[i].id, "/dev/", 5) == 0);

	static const drv_bad_config bad[] = {
		/* what selects the camera */
		{{NULL}, "'device'"},
		{{"device", "/dev/video-does-not-exist"}, "cannot open /dev/video-does-not-exist: No such file"},
		{{"device", "/dev/null"}, "/dev/null is not a V4L2 device"},
		{{"bus_info", "usb-0000:00:14.0-9"}, "no capture device matches bus_info=usb-0000:00:14.0-9"},
		{{"serial", "SN42"}, "serial=SN42"},
		/* values, checked before any device is touched */
		{{"device", "/dev/video0", "pixel_format", "RGB3"}, "'pixel_format': expected one of YUYV, MJPEG, GREY"},
		{{"device", "/dev/video0", "width", "640"}, "'width' and 'height' go together"},
		{{"device", "/dev/video0", "width", "-5"}, "'width': expected an integer in [1, 16384], got '-5'"},
		{{"device", "/dev/video0", "fps", "fast"}, "'fps'"},
		{{"device", "/dev/video0", "buffers", "100"}, "'buffers'"},
		{{"device", "/dev/video0", "exposure", "-1"}, "'exposure': expected 'auto' or a number"},
		{{"device", "/dev/video0", "gain", "loud"}, "'gain'"},
		{{"device", "/dev/video0", "white_balance", "50"}, "'white_balance'"},
	};
	drv_check_open_errors(&H, "v4l2: ", bad, sizeof bad / sizeof bad[0]);

	drv_harness_unload(&H);
	return mc_test_finish("test_v4l2");
}
