/* gst_probe: the video sources GStreamer's device providers find, and
 * their caps as modes, for mocapd --probe (mdrv_driver.probe and .modes). */
#ifndef GST_PROBE_H
#define GST_PROBE_H

#include "mdrv.h"

#include <gst/gst.h>

/* Up to max devices (GstDeviceMonitor, "Video/Source"): id = the
 * gst-launch description of the capturing element ("v4l2src
 * device=/dev/video0"), name = its display name, bus_info and serial from
 * its properties where the provider gives them.  How many (0 with no
 * device or no provider), or a negative status. */
int gp_probe_devices(mdrv_device_info *out, int max, char *err, size_t errlen);
/* The modes of the device whose description is id; MDRV_ERR_NODEV if it
 * is not found (any more). */
int gp_probe_modes(const char *id, mdrv_mode *out, int max, char *err, size_t errlen);
/* Caps as modes, in order: raw video of system memory (pixel_format =
 * its GStreamer format, e.g. "YUY2"; delivered as RGB24) and JPEG
 * ("MJPEG"; passed through); sizes fixed, or the largest of a range or a
 * list; rates highest first, or a range.  Other structures (H.264,
 * Bayer, DMA buffers) are left out.  How many, at most max. */
int gp_caps_modes(const GstCaps *caps, mdrv_mode *out, int max);

#endif
