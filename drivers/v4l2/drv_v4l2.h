/* drv_v4l2: one V4L2 capture device: format negotiation, controls, mmap
 * streaming, monotonic timestamps and unplug detection.  Used by the v4l2
 * plugin and by the usb plugin, which opens the node of a USB camera when it
 * arrives.  Plain libc and the kernel's videodev2.h; no libv4l. */
#ifndef DRV_V4L2_H
#define DRV_V4L2_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drv_common.h"
#include "mdrv.h"

typedef struct drv_v4l2 drv_v4l2;

/* What the config asks of the device (all optional). */
typedef struct {
	uint32_t fourcc;        /* V4L2_PIX_FMT_YUYV, _MJPEG or _GREY; 0 = keep the device's */
	unsigned width, height; /* 0 = keep */
	double fps;             /* 0 = keep */
	unsigned buffers;       /* mmap buffers, default 4 */
	drv_auto_value exposure;      /* seconds, or auto */
	drv_auto_value gain;          /* the device's units, or auto */
	drv_auto_value white_balance; /* kelvin, or auto */
} drv_v4l2_settings;

/* Reads pixel_format, width, height, fps, buffers, exposure, gain and
 * white_balance from the config.  Error messages start with `drv`. */
int drv_v4l2_read_settings(const mdrv_host *host, const char *drv, drv_v4l2_settings *s, char *err,
			   size_t errlen);

/* Opens `path`, negotiates the format and applies the controls, including
 * any `ctrl.NAME` config key for a control the device has (NAME is the
 * control's name in lower case with '_' for other characters, e.g.
 * ctrl.brightness, ctrl.power_line_frequency).  NULL with *status and err
 * on failure. */
drv_v4l2 *drv_v4l2_open(const char *path, const drv_v4l2_settings *s, const mdrv_host *host, const char *drv,
			int *status, char *err, size_t errlen);
void drv_v4l2_get_format(const drv_v4l2 *v, mdrv_format *fmt);
int drv_v4l2_start(drv_v4l2 *v, char *err, size_t errlen);
/* MDRV_OK, MDRV_ERR_TIMEOUT, MDRV_ERR_NODEV (unplugged), or another error. */
int drv_v4l2_next_frame(drv_v4l2 *v, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen);
void drv_v4l2_stop(drv_v4l2 *v);
void drv_v4l2_close(drv_v4l2 *v);

/* A capture node found in /dev. */
typedef struct {
	char path[64];
	char card[64];
	char driver[32];
	char bus_info[64];
	char serial[64]; /* from sysfs for USB cameras, else "" */
} drv_v4l2_node;

/* Lists capture nodes (video capture + streaming) in dev_dir (normally
 * "/dev"), by node number; returns how many (at most max). */
int drv_v4l2_list(const char *dev_dir, const char *sysfs_root, drv_v4l2_node *out, int max);

/* Writes the modes the device offers in the formats this driver takes, e.g.
 * "YUYV 640x480@30,15 320x240@30; GREY 640x480@30", into buf. */
void drv_v4l2_describe_modes(int fd, char *buf, size_t n);

/* The modes of the node at `path` in the formats this driver delivers
 * (mdrv_driver.modes): how many (at most max), or a negative mdrv_status
 * with err.  Opens the node without streaming or changing its format. */
int drv_v4l2_modes(const char *path, const char *drv, mdrv_mode *out, int max, char *err, size_t errlen);

#endif
