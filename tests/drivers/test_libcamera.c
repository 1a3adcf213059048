/* test_libcamera: the libcamera driver plugin loads, probes and explains
 * clearly that there is no camera.  No camera that libcamera drives exists on
 * the build machine or in the vivid VM (libcamera has no vivid pipeline and
 * Debian's kernel has no vimc); see docs/DRIVERS.md. */
#include <stdio.h>
#include <string.h>

#include "drv_check.h"
#include "test_util.h"

static drv_harness H;

static void expect_open_error(const char *needle) { drv_check_open_error(&H, "libcamera: ", needle); }

int main(void)
{
	char err[1024];
	drv_check_load(&H, "libcamera");
	CHECK(!strcmp(H.drv->name, "libcamera"));
	mdrv_device_info info[8];
	int n = drv_check_probe(&H, info, 8, "cameras");
	/* twice: the shared camera manager starts and stops cleanly */
	CHECK(H.drv->probe(&H.host, info, 8, err, sizeof err) == n);

	static const drv_bad_config bad[] = {
		{{"pixel_format", "NV12"}, "'pixel_format': expected one of YUYV, MJPEG, GREY, RGB24"},
		{{"width", "640"}, "'width' and 'height' go together"},
		{{"exposure", "long"}, "'exposure'"},
	};
	drv_check_open_errors(&H, "libcamera: ", bad, sizeof bad / sizeof bad[0]);
	if (n == 0) {
		drv_harness_clear(&H);
		expect_open_error("no camera found; set 'device' to one of: none");
		drv_harness_set(&H, "device", "\\_SB_.PCI0.XHC_.RHUB.HS05-5:1.0-0c45:6366");
		expect_open_error("no camera '\\_SB_.PCI0.XHC_.RHUB.HS05-5:1.0-0c45:6366' (found: none)");
		/* modes (driver ABI 3, mocapd --probe) of a camera that is not there */
		mdrv_mode m[4];
		CHECK(H.drv->modes != NULL);
		CHECK(H.drv->modes && H.drv->modes(&H.host, "no-such-camera", m, 4, err, sizeof err) == MDRV_ERR_NODEV);
		CHECK_MSG(strstr(err, "libcamera: no camera 'no-such-camera' (found: none)"), "%s", err);
	} else {
		printf("cameras are present: the no-camera checks are left out\n");
	}
	drv_harness_unload(&H);
	return mc_test_finish("test_libcamera");
}
