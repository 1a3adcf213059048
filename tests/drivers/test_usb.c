/* test_usb: the usb driver plugin without hardware.
 *
 * 1. The sysfs mapping (drivers/v4l2/drv_sysfs.c) on a fake sysfs tree built
 *    in a temporary folder, laid out as the kernel does for a UVC camera
 *    (capture node + metadata node on one interface), a second camera on a
 *    hub port, and a platform (non-USB) node.
 * 2. The plugin through the ABI: config errors, a camera that is not plugged
 *    in (open succeeds, next_frame waits its timeout then says NODEV),
 *    the format from the config while absent, probe. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "drv_check.h"
#include "drv_sysfs.h"
#include "test_util.h"

static char root[256];

static void mkdirs(const char *rel)
{
	char path[512], *p;
	snprintf(path, sizeof path, "%s/%s", root, rel);
	for (p = path + strlen(root) + 1; (p = strchr(p, '/')); p++) {
		*p = 0;
		mkdir(path, 0755);
		*p = '/';
	}
	mkdir(path, 0755);
}

static void put(const char *rel, const char *text)
{
	char path[512];
	snprintf(path, sizeof path, "%s/%s", root, rel);
	FILE *f = fopen(path, "w");
	if (!f) {
		perror(path);
		exit(1);
	}
	fputs(text, f);
	fclose(f);
}

static void link_to(const char *target, const char *rel)
{
	char path[512];
	snprintf(path, sizeof path, "%s/%s", root, rel);
	if (symlink(target, path) != 0) {
		perror(path);
		exit(1);
	}
}

/* A USB device folder with its identity files. */
static void usb_device(const char *dir, const char *vid, const char *pid, const char *serial, const char *bus,
		       const char *dev, const char *name)
{
	char rel[256];
	mkdirs(dir);
#define ATTR(file, text)                                   \
	do {                                               \
		snprintf(rel, sizeof rel, "%s/" file, dir); \
		put(rel, text);                            \
	} while (0)
	ATTR("idVendor", vid);
	ATTR("idProduct", pid);
	ATTR("busnum", bus);
	ATTR("devnum", dev);
	ATTR("product", name);
	if (serial)
		ATTR("serial", serial);
#undef ATTR
}

/* A video node: class/video4linux/videoN/device -> the interface folder. */
static void video_node(const char *node, const char *iface_rel, const char *index)
{
	char rel[256], target[512];
	snprintf(rel, sizeof rel, "%s/video4linux/%s", iface_rel, node);
	mkdirs(rel);
	snprintf(rel, sizeof rel, "%s/video4linux/%s/index", iface_rel, node);
	put(rel, index);
	snprintf(rel, sizeof rel, "class/video4linux/%s", node);
	mkdirs(rel);
	snprintf(target, sizeof target, "%s/%s", root, iface_rel);
	snprintf(rel, sizeof rel, "class/video4linux/%s/device", node);
	link_to(target, rel);
	snprintf(rel, sizeof rel, "class/video4linux/%s/index", node);
	put(rel, index);
}

static void build_tree(void)
{
	const char *cam1 = "devices/pci0000:00/0000:00:14.0/usb1/1-2";
	const char *cam2 = "devices/pci0000:00/0000:00:14.0/usb1/1-4/1-4.3";
	usb_device(cam1, "046d\n", "0825\n", "A1B2C3\n", "1\n", "5\n", "HD Webcam C270\n");
	usb_device("devices/pci0000:00/0000:00:14.0/usb1/1-4", "05e3\n", "0610\n", NULL, "1\n", "3\n", "USB2.0 Hub\n");
	usb_device(cam2, "1bcf\n", "2c99\n", NULL, "1\n", "9\n", "Fisheye\n");
	/* the metadata node is listed first and has the lower number */
	video_node("video1", "devices/pci0000:00/0000:00:14.0/usb1/1-2/1-2:1.0", "0\n");
	video_node("video0", "devices/pci0000:00/0000:00:14.0/usb1/1-2/1-2:1.0", "1\n");
	video_node("video2", "devices/pci0000:00/0000:00:14.0/usb1/1-4/1-4.3/1-4.3:1.0", "0\n");
	video_node("video3", "devices/pci0000:00/0000:00:14.0/usb1/1-4/1-4.3/1-4.3:1.0", "1\n");
	/* a platform device, such as vivid: not USB */
	mkdirs("devices/platform/vivid.0");
	mkdirs("class/video4linux/video4");
	char target[512];
	snprintf(target, sizeof target, "%s/devices/platform/vivid.0", root);
	link_to(target, "class/video4linux/video4/device");
	mkdirs("bus/usb/devices");
	snprintf(target, sizeof target, "%s/%s", root, cam1);
	link_to(target, "bus/usb/devices/1-2");
	snprintf(target, sizeof target, "%s/%s", root, cam2);
	link_to(target, "bus/usb/devices/1-4.3");
	snprintf(target, sizeof target, "%s/devices/pci0000:00/0000:00:14.0/usb1/1-2/1-2:1.0", root);
	link_to(target, "bus/usb/devices/1-2:1.0");
}

static void test_sysfs(void)
{
	drv_usb_video_info info;
	CHECK(drv_sysfs_video_usb_info(root, "video1", &info) == 0);
	CHECK(info.vendor == 0x046d && info.product == 0x0825);
	CHECK(!strcmp(info.serial, "A1B2C3"));
	CHECK(!strcmp(info.name, "HD Webcam C270"));
	CHECK(!strcmp(info.port, "1-2"));
	CHECK(info.busnum == 1 && info.devnum == 5 && info.index == 0);
	CHECK(drv_sysfs_video_usb_info(root, "video0", &info) == 0 && info.index == 1);
	/* behind a hub: the port path names the hub port; no serial */
	CHECK(drv_sysfs_video_usb_info(root, "video2", &info) == 0);
	CHECK(info.vendor == 0x1bcf && !strcmp(info.port, "1-4.3") && info.serial[0] == 0 && info.devnum == 9);
	/* not USB, and not there */
	CHECK(drv_sysfs_video_usb_info(root, "video4", &info) == -1);
	CHECK(drv_sysfs_video_usb_info(root, "video9", &info) == -1);

	/* USB device -> its main node: the capture node (index 0), not the
	 * lower-numbered metadata node */
	char node[32] = "";
	CHECK(drv_sysfs_find_usb_video(root, 1, 5, node, sizeof node) == 0);
	CHECK_MSG(!strcmp(node, "video1"), "node %s", node);
	CHECK(drv_sysfs_find_usb_video(root, 1, 9, node, sizeof node) == 0);
	CHECK_MSG(!strcmp(node, "video2"), "node %s", node);
	CHECK(drv_sysfs_find_usb_video(root, 1, 3, node, sizeof node) == -1); /* the hub */
	CHECK(drv_sysfs_find_usb_video(root, 2, 5, node, sizeof node) == -1);

	CHECK(drv_sysfs_usb_device_info(root, 1, 9, &info) == 0);
	CHECK(info.product == 0x2c99 && !strcmp(info.port, "1-4.3") && !strcmp(info.name, "Fisheye"));
	CHECK(drv_sysfs_usb_device_info(root, 1, 6, &info) == -1);

	/* a missing root is not a crash */
	CHECK(drv_sysfs_find_usb_video("/nonexistent", 1, 5, node, sizeof node) == -1);
}

static drv_harness H;

static void test_plugin(void)
{
	char err[1024];
	if (drv_harness_load(&H, "usb", err, sizeof err) != 0) {
		fprintf(stderr, "%s\n", err);
		mc_test_failures++;
		return;
	}
	mdrv_device_info info[16];
	drv_check_probe(&H, info, 16, "USB cameras here");

	static const drv_bad_config bad[] = {
		{{NULL}, "'vendor' and 'product'"},
		{{"vendor", "046d"}, "'vendor' and 'product'"},
		{{"vendor", "046d", "product", "xyz"}, "'product': expected a 16-bit hexadecimal id"},
		{{"device", "logitech"}, "VENDOR:PRODUCT"},
		{{"device", "046d:0825", "pixel_format", "RGB3"}, "'pixel_format'"},
	};
	drv_check_open_errors(&H, "usb: ", bad, sizeof bad / sizeof bad[0]);

	/* a camera that is not plugged in (ids no one uses) */
	drv_harness_clear(&H);
	drv_harness_set(&H, "vendor", "f00d");
	drv_harness_set(&H, "product", "beef");
	drv_harness_set(&H, "serial", "NOTHERE");
	void *dev = H.drv->open(&H.host, err, sizeof err);
	CHECK_MSG(dev != NULL, "open of an absent camera should succeed: %s", err);
	if (!dev)
		return;
	CHECK(drv_harness_logged(&H, "waiting for USB camera f00d:beef serial NOTHERE"));
	mdrv_format fmt;
	CHECK(H.drv->get_format(dev, &fmt, err, sizeof err) == MDRV_ERR_NODEV);
	CHECK_MSG(strstr(err, "pixel_format, width and height") != NULL, "%s", err);
	CHECK(H.drv->start(dev, err, sizeof err) == MDRV_OK);
	static uint8_t buf[1 << 16];
	mdrv_frame f;
	unsigned long long t0 = drv_harness_now_ns();
	int st = drv_harness_frame(&H, dev, &f, buf, sizeof buf, 300, err, sizeof err);
	double took = (double)(drv_harness_now_ns() - t0) * 1e-9;
	printf("absent camera: status %d after %.2f s: %s\n", st, took, err);
	CHECK(st == MDRV_ERR_NODEV);
	CHECK(strstr(err, "f00d:beef serial NOTHERE is not plugged in") != NULL);
	/* it waited for the camera, without spinning past its timeout */
	CHECK_MSG(took > 0.25 && took < 1.0, "took %.2f s", took);
	H.drv->stop(dev);
	H.drv->close(dev);

	/* with the format in the config, the host can size its ring anyway */
	drv_harness_clear(&H);
	drv_harness_set(&H, "device", "f00d:beef:NOTHERE");
	drv_harness_set(&H, "pixel_format", "YUYV");
	drv_harness_set(&H, "width", "640");
	drv_harness_set(&H, "height", "480");
	drv_harness_set(&H, "fps", "30");
	dev = H.drv->open(&H.host, err, sizeof err);
	CHECK_MSG(dev != NULL, "%s", err);
	if (dev) {
		CHECK(H.drv->get_format(dev, &fmt, err, sizeof err) == MDRV_OK);
		CHECK(fmt.pixfmt == MC_PIXFMT_YUYV && fmt.width == 640 && fmt.height == 480 && fmt.stride == 1280);
		CHECK(fmt.max_bytes == 640u * 480 * 2 && fmt.fps == 30);
		H.drv->close(dev);
	}
	drv_harness_unload(&H);
}

int main(void)
{
	snprintf(root, sizeof root, "/tmp/mocapd-test-usb-XXXXXX");
	if (!mkdtemp(root)) {
		perror("mkdtemp");
		return 1;
	}
	build_tree();
	test_sysfs();
	char cmd[300];
	snprintf(cmd, sizeof cmd, "rm -rf '%s'", root);
	if (system(cmd) != 0)
		fprintf(stderr, "could not remove %s\n", root);
	test_plugin();
	return mc_test_finish("test_usb");
}
