/* test_uvc_vm: the v4l2 and usb driver plugins against a real USB
 * camera stack: the kernel's uvcvideo driver talking over dummy_hcd to
 * tests/vm/uvc_gadget, a software UVC camera on the device side (gadgetfs).
 * Meant to run inside the qemu guest that tests/vm/uvc-test.sh boots (with
 * dummy_hcd, gadgetfs and uvcvideo loaded); anywhere else it skips.
 *
 * Checks: the camera's USB serial and port through real sysfs, YUYV frames
 * (the gadget's pattern arrives intact), MJPEG frames (whole JPEGs of the
 * right size), selection by serial, unplug and replug: the v4l2 driver
 * reports NODEV, the usb driver reports NODEV while the camera is away and
 * streams again on the same handle when it comes back.
 *
 * libcamera is not tested here: its UVC pipeline names a camera after the
 * firmware node (ACPI or device tree) of the USB controller and refuses
 * cameras whose controller has none ("Can not find controller ID"), which
 * is the case of dummy_hcd. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "drv_harness.h"
#include "test_util.h"

#define SERIAL "MOCAPUVC01"
#define USB_ID "1d6b:0102"

static pid_t gadget = -1;
static uint8_t buf[1 << 20];

static void stop_gadget(void)
{
	if (gadget > 0) {
		kill(gadget, SIGTERM);
		for (int i = 0; i < 50 && waitpid(gadget, NULL, WNOHANG) == 0; i++)
			usleep(20000);
		kill(gadget, SIGKILL);
		waitpid(gadget, NULL, 0);
	}
	gadget = -1;
}

/* The /dev/videoN of uvcvideo's capture node, or "" (after `seconds`). */
static void find_uvc_node(double seconds, char *out, size_t n)
{
	out[0] = 0;
	unsigned long long end = drv_harness_now_ns() + (unsigned long long)(seconds * 1e9);
	do {
		for (int i = 0; i < 16 && !out[0]; i++) {
			char path[32];
			snprintf(path, sizeof path, "/dev/video%d", i);
			int fd = open(path, O_RDWR | O_NONBLOCK);
			if (fd < 0)
				continue;
			struct v4l2_capability cap;
			memset(&cap, 0, sizeof cap);
			if (ioctl(fd, VIDIOC_QUERYCAP, &cap) == 0 && !strcmp((char *)cap.driver, "uvcvideo") &&
			    (cap.device_caps & V4L2_CAP_VIDEO_CAPTURE))
				snprintf(out, n, "%s", path);
			close(fd);
		}
		if (!out[0])
			usleep(100000);
	} while (!out[0] && drv_harness_now_ns() < end);
}

static int node_gone(double seconds)
{
	char node[32];
	unsigned long long end = drv_harness_now_ns() + (unsigned long long)(seconds * 1e9);
	do {
		find_uvc_node(0, node, sizeof node);
		if (!node[0])
			return 1;
		usleep(100000);
	} while (drv_harness_now_ns() < end);
	return 0;
}

/* Checks the gadget's YUYV pattern, Y = (x + y + k) mod 256, U = V = 128;
 * returns k, or -1. */
static int yuyv_pattern(const uint8_t *f)
{
	int k = f[0];
	for (int y = 0; y < 240; y += 7)
		for (int x = 0; x < 320; x += 3) {
			const uint8_t *p = f + (y * 320 + x) * 2;
			if (p[0] != (uint8_t)(x + y + k) || p[1] != 128)
				return -1;
		}
	return k;
}

/* Width and height from a JPEG's SOF0 marker; 0 if it is not a whole JPEG. */
static int jpeg_size(const uint8_t *j, size_t n, int *w, int *h)
{
	if (n < 4 || j[0] != 0xff || j[1] != 0xd8 || j[n - 2] != 0xff || j[n - 1] != 0xd9)
		return 0;
	for (size_t i = 2; i + 9 < n;) {
		if (j[i] != 0xff)
			return 0;
		unsigned marker = j[i + 1], len = (unsigned)(j[i + 2] << 8 | j[i + 3]);
		if (marker == 0xc0) {
			*h = j[i + 5] << 8 | j[i + 6];
			*w = j[i + 7] << 8 | j[i + 8];
			return 1;
		}
		i += 2 + len;
	}
	return 0;
}

/* Pulls n frames and checks them; returns how many were good. */
static int pull(drv_harness *h, void *dev, int n, uint32_t pixfmt)
{
	char err[512];
	int good = 0, last_k = -1;
	unsigned long long last_ts = 0;
	for (int i = 0; i < n; i++) {
		mdrv_frame f;
		int st = drv_harness_frame(h, dev, &f, buf, sizeof buf, 3000, err, sizeof err);
		unsigned long long now = drv_harness_now_ns();
		CHECK_MSG(st == MDRV_OK, "frame %d: status %d: %s", i, st, err);
		if (st != MDRV_OK)
			break;
		CHECK(f.format.pixfmt == pixfmt && f.format.width == 320 && f.format.height == 240);
		CHECK_MSG(f.timestamp_ns <= now && f.timestamp_ns + 2000000000ull > now, "timestamp %llu, now %llu",
			  (unsigned long long)f.timestamp_ns, now);
		CHECK(f.timestamp_ns > last_ts);
		last_ts = f.timestamp_ns;
		if (pixfmt == MC_PIXFMT_YUYV) {
			CHECK_MSG(f.bytesused == 320 * 240 * 2 && f.flags == 0, "bytesused %zu flags %x", f.bytesused,
				  f.flags);
			int k = yuyv_pattern(buf);
			CHECK_MSG(k >= 0, "frame %d: the gadget's pattern did not arrive intact", i);
			CHECK_MSG(k != last_k, "frame %d repeats the previous picture", i);
			last_k = k;
			good += k >= 0;
		} else {
			int w = 0, hh = 0;
			int ok = jpeg_size(buf, f.bytesused, &w, &hh) && w == 320 && hh == 240;
			/* The first frame after the format switch came cut (no EOI)
			 * in 1 of about 6 runs under load, as real UVC cameras' first
			 * frames sometimes do (mocapd drops such frames): allowed
			 * for frame 0 only, and said. */
			if (!ok && i == 0)
				printf("frame 0: not a whole 320x240 JPEG (%zu bytes); the first frame may be cut\n",
				       f.bytesused);
			else
				CHECK_MSG(ok, "frame %d: not a whole 320x240 JPEG (%zu bytes)", i, f.bytesused);
			good += ok;
		}
	}
	return good;
}

static void test_v4l2(drv_harness *h, const char *node)
{
	char err[1024];
	mdrv_device_info info[8];
	int n = h->drv->probe(&h->host, info, 8, err, sizeof err);
	int found = 0;
	for (int i = 0; i < n; i++) {
		printf("v4l2 probe: %s '%s' bus_info %s serial '%s'\n", info[i].id, info[i].name, info[i].bus_info,
		       info[i].serial);
		if (!strcmp(info[i].id, node)) {
			found = 1;
			CHECK_MSG(!strcmp(info[i].serial, SERIAL), "serial '%s' from sysfs", info[i].serial);
			CHECK(strncmp(info[i].bus_info, "usb-dummy_hcd", 13) == 0);
		}
	}
	CHECK_MSG(found, "probe should list %s", node);

	/* by USB serial number, YUYV at 30 fps */
	drv_harness_clear(h);
	drv_harness_set(h, "serial", SERIAL);
	drv_harness_set(h, "pixel_format", "YUYV");
	drv_harness_set(h, "width", "320");
	drv_harness_set(h, "height", "240");
	drv_harness_set(h, "fps", "30");
	void *dev = drv_harness_open_start(h, err, sizeof err);
	CHECK_MSG(dev != NULL, "v4l2 YUYV: %s", err);
	if (dev) {
		CHECK(pull(h, dev, 8, MC_PIXFMT_YUYV) == 8);
		h->drv->stop(dev);
		h->drv->close(dev);
	}
	/* MJPEG at 15 fps, on the same node */
	drv_harness_set(h, "pixel_format", "MJPEG");
	drv_harness_set(h, "fps", "15");
	dev = drv_harness_open_start(h, err, sizeof err);
	CHECK_MSG(dev != NULL, "v4l2 MJPEG: %s", err);
	if (dev) {
		mdrv_format fmt;
		h->drv->get_format(dev, &fmt, err, sizeof err);
		CHECK(fmt.pixfmt == MC_PIXFMT_MJPEG && fmt.stride == 0 && fmt.fps == 15);
		CHECK(pull(h, dev, 6, MC_PIXFMT_MJPEG) >= 5);
		h->drv->stop(dev);
		h->drv->close(dev);
	}
	/* a size the camera does not have: the error lists what it has */
	drv_harness_set(h, "width", "640");
	drv_harness_set(h, "height", "480");
	dev = h->drv->open(&h->host, err, sizeof err);
	CHECK(dev == NULL);
	CHECK_MSG(strstr(err, "MJPEG 320x240@30,15") && strstr(err, "YUYV 320x240@30,15"), "%s", err);
	if (dev)
		h->drv->close(dev);
}

/* Unplugs the camera under a streaming v4l2 handle. */
static void test_v4l2_unplug(drv_harness *h)
{
	char err[1024];
	drv_harness_clear(h);
	drv_harness_set(h, "serial", SERIAL);
	drv_harness_set(h, "pixel_format", "YUYV");
	void *dev = drv_harness_open_start(h, err, sizeof err);
	CHECK_MSG(dev != NULL, "v4l2: %s", err);
	if (!dev)
		return;
	CHECK(pull(h, dev, 2, MC_PIXFMT_YUYV) == 2);
	kill(gadget, SIGUSR1);
	int st = MDRV_OK;
	for (int i = 0; i < 30 && (st == MDRV_OK || st == MDRV_ERR_TIMEOUT); i++) {
		mdrv_frame f;
		st = drv_harness_frame(h, dev, &f, buf, sizeof buf, 300, err, sizeof err);
	}
	printf("v4l2 after unplug: %d %s\n", st, err);
	CHECK_MSG(st == MDRV_ERR_NODEV, "status %d: %s", st, err);
	h->drv->stop(dev);
	h->drv->close(dev);
	CHECK(node_gone(5));
	drv_harness_clear(h);
	drv_harness_set(h, "serial", SERIAL);
	dev = h->drv->open(&h->host, err, sizeof err);
	CHECK(dev == NULL && strstr(err, "no capture device matches serial=" SERIAL));
	if (dev)
		h->drv->close(dev);
	kill(gadget, SIGUSR2);
}

/* The usb driver keeps one handle across unplug and replug. */
static void test_usb(drv_harness *h)
{
	char err[1024];
	drv_harness_clear(h);
	drv_harness_set(h, "device", USB_ID ":" SERIAL);
	drv_harness_set(h, "pixel_format", "YUYV");
	drv_harness_set(h, "width", "320");
	drv_harness_set(h, "height", "240");
	void *dev = h->drv->open(&h->host, err, sizeof err);
	CHECK_MSG(dev != NULL, "usb: %s", err);
	if (!dev)
		return;
	CHECK(h->drv->start(dev, err, sizeof err) == MDRV_OK);
	/* the camera may still be coming back from the previous test */
	mdrv_frame f;
	int st = MDRV_ERR_NODEV;
	for (int i = 0; i < 40 && st != MDRV_OK; i++)
		st = drv_harness_frame(h, dev, &f, buf, sizeof buf, 500, err, sizeof err);
	CHECK_MSG(st == MDRV_OK, "usb: no frame: %s", err);
	CHECK(drv_harness_logged(h, "arrived as /dev/video"));
	CHECK(pull(h, dev, 4, MC_PIXFMT_YUYV) == 4);
	unsigned long long seq_before = 0;
	if (drv_harness_frame(h, dev, &f, buf, sizeof buf, 3000, err, sizeof err) == MDRV_OK)
		seq_before = f.sequence;

	kill(gadget, SIGUSR1);
	st = MDRV_OK;
	for (int i = 0; i < 30 && (st == MDRV_OK || st == MDRV_ERR_TIMEOUT); i++)
		st = drv_harness_frame(h, dev, &f, buf, sizeof buf, 300, err, sizeof err);
	printf("usb after unplug: %d %s\n", st, err);
	CHECK_MSG(st == MDRV_ERR_NODEV && strstr(err, "was unplugged"), "status %d: %s", st, err);
	st = drv_harness_frame(h, dev, &f, buf, sizeof buf, 500, err, sizeof err);
	CHECK_MSG(st == MDRV_ERR_NODEV && strstr(err, "is not plugged in"), "status %d: %s", st, err);

	kill(gadget, SIGUSR2);
	unsigned long long t0 = drv_harness_now_ns();
	st = MDRV_ERR_NODEV;
	for (int i = 0; i < 40 && st != MDRV_OK; i++)
		st = drv_harness_frame(h, dev, &f, buf, sizeof buf, 500, err, sizeof err);
	printf("usb: replugged camera streams again after %.1f s\n", (double)(drv_harness_now_ns() - t0) * 1e-9);
	CHECK_MSG(st == MDRV_OK, "usb after replug: %s", err);
	if (st == MDRV_OK) {
		CHECK_MSG(f.sequence > seq_before + 1, "sequence %llu after %llu: a gap marks the replug",
			  (unsigned long long)f.sequence, seq_before);
		CHECK(yuyv_pattern(buf) >= 0);
	}
	h->drv->stop(dev);
	h->drv->close(dev);
}

int main(void)
{
	struct stat st;
	if (stat("/sys/module/dummy_hcd", &st) != 0 || stat("/sys/module/uvcvideo", &st) != 0)
		TEST_SKIP("dummy_hcd and uvcvideo are not loaded here (tests/vm/uvc-test.sh runs this in a VM)");
	mkdir("/dev/gadget", 0755);
	if (mount("gadgetfs", "/dev/gadget", "gadgetfs", 0, NULL) != 0 && errno != EBUSY) {
		perror("mount gadgetfs");
		return 1;
	}
	gadget = fork();
	if (gadget == 0) {
		execl("./uvc_gadget", "uvc_gadget", SERIAL, (char *)NULL);
		_exit(127);
	}
	atexit(stop_gadget);
	char node[32];
	find_uvc_node(20, node, sizeof node);
	if (!node[0]) {
		fprintf(stderr, "uvcvideo never offered a capture node for the gadget\n");
		return 1;
	}
	printf("the gadget camera is %s\n", node);

	static drv_harness v4l2, usb;
	char err[512];
	if (drv_harness_load(&v4l2, "v4l2", err, sizeof err) || drv_harness_load(&usb, "usb", err, sizeof err)) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	test_v4l2(&v4l2, node);
	test_v4l2_unplug(&v4l2);
	test_usb(&usb);
	stop_gadget();
	drv_harness_unload(&v4l2);
	drv_harness_unload(&usb);
	return mc_test_finish("test_uvc_vm");
}
