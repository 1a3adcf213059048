/* mocap-driver-v4l2: USB (UVC) and other V4L2 capture devices.
 *
 * A camera is selected by `device` (a node such as /dev/video0 or a stable
 * link such as /dev/v4l/by-id/...), or by `bus_info` (the physical port, as
 * VIDIOC_QUERYCAP reports it, e.g. usb-0000:00:14.0-2) and/or `serial` (the
 * USB serial number from sysfs), which survive renumbering of /dev/videoN.
 * Config keys are listed in docs/DRIVERS.md. */
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drv_common.h"
#include "drv_v4l2.h"
#include "mdrv.h"

#define DRV "v4l2"
#define MAX_NODES 64

/* True when paths a and b name the same file (e.g. a by-id link and its
 * node). */
static bool same_node(const char *a, const char *b)
{
	char ra[PATH_MAX], rb[PATH_MAX];
	return realpath(a, ra) && realpath(b, rb) && !strcmp(ra, rb);
}

/* Whether the config names a camera (device, bus_info or serial). */
static bool selects_a_camera(const mdrv_host *host, char *err, size_t errlen)
{
	if (drv_cfg_str(host, "device") || drv_cfg_str(host, "bus_info") || drv_cfg_str(host, "serial"))
		return true;
	drv_errf(err, errlen, MDRV_ERR_CONFIG,
		 DRV ": config needs 'device' (e.g. /dev/video0), 'bus_info' or 'serial' to pick a camera");
	return false;
}

/* Picks the node the config's device / bus_info / serial keys select
 * (selects_a_camera said they are there).  Two matching cameras are a
 * config error that unplugging one mends, so it is not permanent. */
static int select_node(const mdrv_host *host, char *path, size_t n, char *err, size_t errlen)
{
	const char *device = drv_cfg_str(host, "device");
	const char *bus_info = drv_cfg_str(host, "bus_info");
	const char *serial = drv_cfg_str(host, "serial");
	if (device && !bus_info && !serial) {
		drv_strlcpy(path, device, n);
		return MDRV_OK;
	}
	drv_v4l2_node *nodes = calloc(MAX_NODES, sizeof *nodes);
	if (!nodes)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": out of memory");
	int count = drv_v4l2_list("/dev", "/sys", nodes, MAX_NODES);
	int match = -1, n_match = 0;
	char seen[768] = "";
	for (int i = 0; i < count; i++) {
		size_t len = strlen(seen);
		snprintf(seen + len, sizeof seen - len, "%s%s [bus_info %s, serial '%s']", i ? ", " : "",
			 nodes[i].path, nodes[i].bus_info, nodes[i].serial);
		if ((device && !same_node(device, nodes[i].path)) || (bus_info && strcmp(bus_info, nodes[i].bus_info)) ||
		    (serial && strcmp(serial, nodes[i].serial)))
			continue;
		if (n_match++ == 0)
			match = i;
	}
	int st = MDRV_OK;
	if (n_match == 0)
		st = drv_errf(err, errlen, MDRV_ERR_NODEV,
			      DRV ": no capture device matches%s%s%s%s%s%s (found: %s)", device ? " device=" : "",
			      device ? device : "", bus_info ? " bus_info=" : "", bus_info ? bus_info : "",
			      serial ? " serial=" : "", serial ? serial : "", count ? seen : "none");
	else if (n_match > 1)
		st = drv_errf(err, errlen, MDRV_ERR_CONFIG,
			      DRV ": %d capture devices match; add 'bus_info' or 'device' to pick one (found: %s)",
			      n_match, seen);
	else
		drv_strlcpy(path, nodes[match].path, n);
	free(nodes);
	return st;
}

static int v4l2_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host;
	(void)err;
	(void)errlen;
	drv_v4l2_node nodes[MAX_NODES];
	int n = drv_v4l2_list("/dev", "/sys", nodes, max < MAX_NODES ? max : MAX_NODES);
	for (int i = 0; i < n; i++) {
		memset(&out[i], 0, sizeof out[i]);
		drv_strlcpy(out[i].id, nodes[i].path, sizeof out[i].id);
		drv_strlcpy(out[i].name, nodes[i].card, sizeof out[i].name);
		drv_strlcpy(out[i].bus_info, nodes[i].bus_info, sizeof out[i].bus_info);
		drv_strlcpy(out[i].serial, nodes[i].serial, sizeof out[i].serial);
	}
	return n;
}

static int v4l2_modes(const mdrv_host *host, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	(void)host;
	return drv_v4l2_modes(id, DRV, out, max, err, errlen);
}

static void *v4l2_open(const mdrv_host *host, char *err, size_t errlen)
{
	drv_v4l2_settings s;
	char path[PATH_MAX];
	int status;
	if (drv_v4l2_read_settings(host, DRV, &s, err, errlen) != MDRV_OK || !selects_a_camera(host, err, errlen))
		return drv_open_failed(host, MDRV_ERR_CONFIG); /* the keys do not change by waiting */
	if (select_node(host, path, sizeof path, err, errlen) != MDRV_OK)
		return NULL; /* retried: the camera may come, or the second match go */
	return drv_v4l2_open(path, &s, host, DRV, &status, err, errlen);
}

static int v4l2_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)err;
	(void)errlen;
	drv_v4l2_get_format(dev, fmt);
	return MDRV_OK;
}

static int v4l2_start(void *dev, char *err, size_t errlen)
{
	return drv_v4l2_start(dev, err, errlen);
}

static int v4l2_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	return drv_v4l2_next_frame(dev, slot, timeout_ms, err, errlen);
}

static void v4l2_stop(void *dev)
{
	drv_v4l2_stop(dev);
}

static void v4l2_close(void *dev)
{
	drv_v4l2_close(dev);
}

/* The keys as open() reads them; which node they select and the
 * ctrl.NAME keys are checked against the device when it opens. */
static int v4l2_check(const mdrv_host *host, char *err, size_t errlen)
{
	drv_v4l2_settings s;
	int st = drv_v4l2_read_settings(host, DRV, &s, err, errlen);
	if (st == MDRV_OK && !selects_a_camera(host, err, errlen))
		st = MDRV_ERR_CONFIG;
	drv_cfg_str(host, "ctrl.*");
	return st;
}

MDRV_DEFINE_DRIVER_MODES(v4l2, "v4l2",
		   "V4L2 capture devices (USB UVC cameras): YUYV, MJPEG, GREY")
