/* mocap-driver-usb: a USB camera named by vendor, product and serial number,
 * opened when it is plugged in and closed cleanly when it is pulled out.
 *
 * Design: this is a wrapper around the v4l2 driver code (drivers/v4l2).  It
 * learns of arrivals and departures from libusb's hotplug callbacks (which
 * need udev running) and, as a safety net, by listing the USB devices in
 * sysfs every 2 s (0.5 s without hotplug); it maps the matching USB device
 * to its V4L2 node through sysfs
 * (/sys/class/video4linux/videoN/device -> the USB interface -> the device),
 * and delegates formats, controls and frames to the V4L2 code.  open()
 * succeeds whether or not the camera is there; while it is absent,
 * next_frame() waits up to its timeout for it to arrive and then returns
 * MDRV_ERR_NODEV, so a host that keeps calling gets frames as soon as the
 * camera is back, and a host that closes and reopens on NODEV works too.
 *
 * The USB device is never opened through libusb (the kernel's uvcvideo
 * driver owns it), so no access to /dev/bus/usb is needed.
 * Config keys are listed in docs/DRIVERS.md. */
#include <libusb.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

#include "drv_common.h"
#include "drv_sysfs.h"
#include "drv_v4l2.h"
#include "mdrv.h"

#define DRV "usb"
#define SYSFS "/sys"
/* How often the bus is listed when nothing was announced: hotplug events
 * need udev, which containers and initramfs setups often lack, so listing
 * goes on as a safety net, slowly where events do work. */
#define SCAN_INTERVAL_NS 500000000ull
#define SCAN_INTERVAL_HOTPLUG_NS 2000000000ull
/* A matching device whose video node is not there yet (uvcvideo binds it
 * shortly after the USB device appears) is looked at again this soon. */
#define SCAN_PENDING_NS 200000000ull
#define MAX_USB_DEVICES 128

typedef struct {
	mdrv_host host;
	uint16_t vendor, product;
	char serial[64]; /* "" = any */
	char port[64];   /* "" = any */
	char what[256];  /* "USB camera 046d:0825 serial X" for messages */
	drv_v4l2_settings settings;
	libusb_context *usb;
	bool hotplug;
	libusb_hotplug_callback_handle hotplug_handle;
	bool bus_changed; /* a matching device arrived or left since last look */
	uint64_t last_scan_ns;
	drv_v4l2 *cam;    /* the V4L2 node while the camera is there */
	unsigned busnum, devnum;
	bool started; /* the host wants frames */
	bool delivered;        /* a frame was delivered since open */
	uint64_t sequence_base, last_sequence;
	uint64_t last_frame_ns;
	bool have_base;   /* the V4L2 counter's first value on this attach is known */
	uint64_t first_v4l2_seq;
} usb_dev;

static int LIBUSB_CALL on_hotplug(libusb_context *ctx, libusb_device *dev, libusb_hotplug_event event, void *user)
{
	(void)ctx;
	(void)dev;
	(void)event;
	((usb_dev *)user)->bus_changed = true;
	return 0; /* stay registered */
}

/* device = "046d:0825" or "046d:0825:SERIAL", a shorthand for the keys. */
static int parse_device_key(usb_dev *u, const char *v, char *err, size_t errlen)
{
	unsigned vid, pid;
	int used = 0;
	if (sscanf(v, "%4x:%4x%n", &vid, &pid, &used) != 2 || (v[used] && v[used] != ':'))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				DRV ": config key 'device': expected VENDOR:PRODUCT[:SERIAL] in hex, e.g. 046d:0825, "
				    "got '%s'",
				v);
	u->vendor = (uint16_t)vid;
	u->product = (uint16_t)pid;
	if (v[used] == ':')
		drv_strlcpy(u->serial, v + used + 1, sizeof u->serial);
	return MDRV_OK;
}

static int parse_config(usb_dev *u, const mdrv_host *host, char *err, size_t errlen)
{
	bool has_vendor = false, has_product = false;
	int st;
	const char *device = drv_cfg_str(host, "device");
	if (device && (st = parse_device_key(u, device, err, errlen)))
		return st;
	if ((st = drv_cfg_hex16(host, DRV, "vendor", &u->vendor, &has_vendor, err, errlen)) ||
	    (st = drv_cfg_hex16(host, DRV, "product", &u->product, &has_product, err, errlen)))
		return st;
	if (!device && (!has_vendor || !has_product))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				DRV ": config needs 'vendor' and 'product' (USB ids in hex, e.g. 046d and 0825; "
				    "see lsusb), or 'device' = VENDOR:PRODUCT[:SERIAL]");
	const char *serial = drv_cfg_str(host, "serial");
	if (serial)
		drv_strlcpy(u->serial, serial, sizeof u->serial);
	drv_strlcpy(u->port, drv_cfg_str(host, "port"), sizeof u->port);
	if ((st = drv_v4l2_read_settings(host, DRV, &u->settings, err, errlen)))
		return st;
	snprintf(u->what, sizeof u->what, "USB camera %04x:%04x%s%s%s%s", u->vendor, u->product,
		 u->serial[0] ? " serial " : "", u->serial, u->port[0] ? " on port " : "", u->port);
	return MDRV_OK;
}

/* Looks for the configured camera in sysfs (libusb's own device list only
 * changes on udev events, so it is not asked); fills busnum/devnum and the
 * V4L2 node name.  0 if it is there with a video node, 1 if it is there
 * without one (yet), -1 if it is not there. */
static int find_camera(usb_dev *u, char *node, size_t n)
{
	drv_usb_video_info list[MAX_USB_DEVICES];
	int count = drv_sysfs_list_usb_devices(SYSFS, list, MAX_USB_DEVICES);
	int found = -1;
	for (int i = 0; i < count && found != 0; i++) {
		const drv_usb_video_info *d = &list[i];
		if (d->vendor != u->vendor || d->product != u->product || (u->serial[0] && strcmp(u->serial, d->serial)) ||
		    (u->port[0] && strcmp(u->port, d->port)))
			continue;
		if (drv_sysfs_find_usb_video(SYSFS, d->busnum, d->devnum, node, n) != 0) {
			found = 1;
			continue;
		}
		u->busnum = d->busnum;
		u->devnum = d->devnum;
		found = 0;
	}
	return found;
}

static void detach(usb_dev *u, const char *why)
{
	if (!u->cam)
		return;
	drv_v4l2_close(u->cam);
	u->cam = NULL;
	drv_logf(&u->host, MDRV_LOG_WARN, DRV ": %s %s", u->what, why);
}

/* Opens the camera's V4L2 node if the camera is there.  MDRV_OK when it is
 * open, MDRV_ERR_NODEV when absent, or the V4L2 code's error. */
static int try_attach(usb_dev *u, char *err, size_t errlen)
{
	if (u->cam)
		return MDRV_OK;
	uint64_t now = mc_now_ns();
	uint64_t interval = u->hotplug ? SCAN_INTERVAL_HOTPLUG_NS : SCAN_INTERVAL_NS;
	if (!u->bus_changed && u->last_scan_ns && now - u->last_scan_ns < interval)
		return MDRV_ERR_NODEV; /* nothing announced, looked recently */
	u->bus_changed = false;
	u->last_scan_ns = now;
	char node[32], path[64];
	int where = find_camera(u, node, sizeof node);
	if (where == 1) {
		drv_logf(&u->host, MDRV_LOG_DEBUG, DRV ": %s is on the bus without a video node (yet)", u->what);
		u->last_scan_ns = now - interval + SCAN_PENDING_NS;
	}
	if (where != 0)
		return MDRV_ERR_NODEV;
	snprintf(path, sizeof path, "/dev/%s", node);
	int st;
	u->cam = drv_v4l2_open(path, &u->settings, &u->host, DRV, &st, err, errlen);
	if (!u->cam) {
		/* udev may still be setting the node's permissions: look again */
		if (st == MDRV_ERR_NODEV || st == MDRV_ERR_IO)
			u->bus_changed = true;
		return st;
	}
	drv_logf(&u->host, MDRV_LOG_INFO, DRV ": %s arrived as %s (bus %u device %u)", u->what, path, u->busnum,
		 u->devnum);
	if (u->started && (st = drv_v4l2_start(u->cam, err, errlen)) != MDRV_OK) {
		detach(u, "could not start streaming");
		return st;
	}
	/* Sequence numbers go on across replugs, leaving out as many numbers
	 * as frames were missed while the camera was away (at least one). */
	if (u->delivered) {
		mdrv_format fmt;
		drv_v4l2_get_format(u->cam, &fmt);
		double away_s = (double)(mc_now_ns() - u->last_frame_ns) * 1e-9;
		uint64_t missed = fmt.fps > 0 ? (uint64_t)(away_s * fmt.fps) : 1;
		u->sequence_base = u->last_sequence + 1 + (missed ? missed : 1);
	}
	u->have_base = false;
	return MDRV_OK;
}

/* Lets libusb deliver hotplug callbacks, waiting at most `wait_ms`. */
static void pump_events(usb_dev *u, int wait_ms)
{
	if (!u->hotplug) {
		if (wait_ms > 0)
			usleep((useconds_t)wait_ms * 1000);
		return;
	}
	struct timeval tv = {.tv_sec = wait_ms / 1000, .tv_usec = (wait_ms % 1000) * 1000};
	libusb_handle_events_timeout_completed(u->usb, &tv, NULL);
}

static void usb_close(void *dev);

static void *usb_open(const mdrv_host *host, char *err, size_t errlen)
{
	usb_dev *u = calloc(1, sizeof *u);
	if (!u) {
		drv_errf(err, errlen, MDRV_ERR_IO, DRV ": out of memory");
		return NULL;
	}
	u->host = *host;
	if (parse_config(u, host, err, errlen) != MDRV_OK) {
		usb_close(u);
		return drv_open_failed(host, MDRV_ERR_CONFIG); /* the keys do not change by waiting */
	}
	int r = libusb_init(&u->usb);
	if (r != 0) {
		drv_errf(err, errlen, MDRV_ERR_IO, DRV ": cannot start libusb: %s", libusb_strerror(r));
		u->usb = NULL;
		goto fail;
	}
	if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) {
		r = libusb_hotplug_register_callback(u->usb,
						     LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT,
						     0, u->vendor, u->product, LIBUSB_HOTPLUG_MATCH_ANY, on_hotplug, u,
						     &u->hotplug_handle);
		u->hotplug = r == LIBUSB_SUCCESS;
	}
	if (!u->hotplug)
		drv_logf(host, MDRV_LOG_INFO, DRV ": no USB hotplug events here; listing the bus twice a second");
	int st = try_attach(u, err, errlen);
	if (st != MDRV_OK && st != MDRV_ERR_NODEV)
		goto fail; /* there, but its format or controls are wrong */
	if (!u->cam) {
		/* The ctrl.NAME keys are read when the camera's controls are
		 * known, i.e. once it is here.  This asks a host that checks
		 * for unread keys to count every ctrl.* key as read (a host
		 * without that convention answers NULL; see docs/DRIVERS.md). */
		drv_cfg_str(host, "ctrl.*");
		drv_logf(host, MDRV_LOG_INFO, DRV ": waiting for %s to be plugged in", u->what);
	}
	return u;
fail:
	usb_close(u);
	return NULL;
}

/* The format from the config alone, for when the camera is not there. */
static int configured_format(usb_dev *u, mdrv_format *fmt, char *err, size_t errlen)
{
	const drv_v4l2_settings *s = &u->settings;
	if (!s->fourcc || !s->width)
		return drv_errf(err, errlen, MDRV_ERR_NODEV,
				DRV ": %s is not plugged in, and without it the format is unknown: give "
				    "pixel_format, width and height in the config",
				u->what);
	memset(fmt, 0, sizeof *fmt);
	fmt->width = s->width;
	fmt->height = s->height;
	fmt->fps = s->fps;
	if (s->fourcc == V4L2_PIX_FMT_MJPEG) {
		fmt->pixfmt = MC_PIXFMT_MJPEG;
		fmt->max_bytes = (size_t)s->width * s->height * 2; /* what UVC cameras announce */
	} else {
		bool yuyv = s->fourcc == V4L2_PIX_FMT_YUYV;
		fmt->pixfmt = yuyv ? MC_PIXFMT_YUYV : MC_PIXFMT_GRAY8;
		fmt->stride = s->width * (yuyv ? 2 : 1);
		fmt->max_bytes = (size_t)fmt->stride * s->height;
	}
	return MDRV_OK;
}

static int usb_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	usb_dev *u = dev;
	if (u->cam) {
		drv_v4l2_get_format(u->cam, fmt);
		return MDRV_OK;
	}
	return configured_format(u, fmt, err, errlen);
}

static int usb_start(void *dev, char *err, size_t errlen)
{
	usb_dev *u = dev;
	u->started = true;
	if (!u->cam)
		return MDRV_OK; /* streams from when it arrives */
	int st = drv_v4l2_start(u->cam, err, errlen);
	if (st == MDRV_ERR_NODEV)
		detach(u, "was unplugged");
	return st;
}

static int absent_error(usb_dev *u, char *err, size_t errlen)
{
	return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": %s is not plugged in", u->what);
}

static int usb_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	usb_dev *u = dev;
	if (!u->started)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": next_frame before start");
	uint64_t deadline = mc_now_ns() + (uint64_t)(timeout_ms > 0 ? timeout_ms : 0) * 1000000u;
	pump_events(u, 0);
	/* wait for the camera to arrive, within the timeout */
	while (!u->cam) {
		int st = try_attach(u, err, errlen);
		if (st != MDRV_OK && st != MDRV_ERR_NODEV)
			return st;
		if (u->cam)
			break;
		uint64_t now = mc_now_ns();
		if (now >= deadline)
			return absent_error(u, err, errlen);
		uint64_t left_ms = (deadline - now) / 1000000u;
		pump_events(u, (int)(left_ms < 100 ? left_ms : 100));
	}
	uint64_t now = mc_now_ns();
	int left_ms = now >= deadline ? 0 : (int)((deadline - now) / 1000000u);
	int st = drv_v4l2_next_frame(u->cam, slot, left_ms, err, errlen);
	if (st == MDRV_ERR_NODEV) {
		detach(u, "was unplugged");
		u->bus_changed = true; /* it may come back on another node */
		return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": %s was unplugged", u->what);
	}
	if (st == MDRV_OK) {
		/* count from the first frame of this attach, after the base */
		if (!u->have_base) {
			u->have_base = true;
			u->first_v4l2_seq = slot->sequence;
		}
		slot->sequence = u->sequence_base + (slot->sequence - u->first_v4l2_seq);
		u->last_sequence = slot->sequence;
		u->last_frame_ns = mc_now_ns();
		u->delivered = true;
	}
	return st;
}

static void usb_stop(void *dev)
{
	usb_dev *u = dev;
	u->started = false;
	if (u->cam)
		drv_v4l2_stop(u->cam);
}

static void usb_close(void *dev)
{
	usb_dev *u = dev;
	if (!u)
		return;
	if (u->cam)
		drv_v4l2_close(u->cam);
	if (u->hotplug)
		libusb_hotplug_deregister_callback(u->usb, u->hotplug_handle);
	if (u->usb)
		libusb_exit(u->usb);
	free(u);
}

static void usb_id(const drv_usb_video_info *d, char *id, size_t n)
{
	snprintf(id, n, "%04x:%04x%s%s", d->vendor, d->product, d->serial[0] ? ":" : "", d->serial);
}

/* Lists USB devices that have a V4L2 node: id is VENDOR:PRODUCT[:SERIAL]. */
static int usb_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host;
	(void)err;
	(void)errlen;
	drv_usb_video_info list[MAX_USB_DEVICES];
	int count = drv_sysfs_list_usb_devices(SYSFS, list, MAX_USB_DEVICES);
	int n = 0;
	for (int i = 0; i < count && n < max; i++) {
		const drv_usb_video_info *d = &list[i];
		char node[32];
		if (drv_sysfs_find_usb_video(SYSFS, d->busnum, d->devnum, node, sizeof node) != 0)
			continue;
		mdrv_device_info *o = &out[n++];
		memset(o, 0, sizeof *o);
		usb_id(d, o->id, sizeof o->id);
		snprintf(o->name, sizeof o->name, "%s (/dev/%s)", d->name[0] ? d->name : "USB camera", node);
		snprintf(o->bus_info, sizeof o->bus_info, "usb port %s", d->port);
		drv_strlcpy(o->serial, d->serial, sizeof o->serial);
	}
	return n;
}

/* The modes of the V4L2 node of the camera that probe listed as `id`. */
static int usb_modes(const mdrv_host *host, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	(void)host;
	drv_usb_video_info list[MAX_USB_DEVICES];
	int count = drv_sysfs_list_usb_devices(SYSFS, list, MAX_USB_DEVICES);
	for (int i = 0; i < count; i++) {
		char this_id[128], node[32], path[48];
		usb_id(&list[i], this_id, sizeof this_id);
		if (strcmp(this_id, id) != 0 ||
		    drv_sysfs_find_usb_video(SYSFS, list[i].busnum, list[i].devnum, node, sizeof node) != 0)
			continue;
		snprintf(path, sizeof path, "/dev/%s", node);
		return drv_v4l2_modes(path, DRV, out, max, err, errlen);
	}
	return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": %s is not plugged in", id);
}

/* The keys, parsed as open() parses them; the ctrl.NAME keys are checked
 * against the camera's controls when it is there. */
static int usb_check(const mdrv_host *host, char *err, size_t errlen)
{
	usb_dev *u = calloc(1, sizeof *u);
	if (!u)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": out of memory");
	int st = parse_config(u, host, err, errlen);
	drv_cfg_str(host, "ctrl.*");
	free(u);
	return st;
}

MDRV_DEFINE_DRIVER_MODES(usb, "usb",
		   "USB cameras by vendor/product/serial, opened on plug-in (libusb hotplug + V4L2)")
