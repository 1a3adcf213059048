/* drv_sysfs: what sysfs says about video nodes that belong to USB cameras.
 *
 * A V4L2 node /dev/videoN has /sys/class/video4linux/videoN/device, a link to
 * the USB interface it serves (e.g. .../usb1/1-2/1-2:1.0); the USB device is
 * the folder above, with idVendor, idProduct, serial, busnum and devnum.  Its
 * folder name (1-2, 1-2.3, ...) is the physical port path, stable across
 * replugs into the same socket.
 *
 * Every function takes the sysfs root ("/sys" on a running system) so that
 * tests can run on a fake tree in a temporary folder. */
#ifndef DRV_SYSFS_H
#define DRV_SYSFS_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
	uint16_t vendor, product;
	unsigned busnum, devnum;
	char serial[64];  /* "" when the device has none */
	char name[64];    /* the device's product string, "" if none */
	char port[64];    /* the USB device's folder name, e.g. "1-2.3" */
	unsigned index;   /* the node's index within its interface: 0 = main capture node */
} drv_usb_video_info;

/* Fills `out` for the node named `node` ("video0").  0, or -1 when the node
 * does not exist or is not on USB. */
int drv_sysfs_video_usb_info(const char *sysfs_root, const char *node, drv_usb_video_info *out);

/* Finds the main video node ("videoN", lowest index, then lowest N) of the
 * USB device at busnum/devnum.  0, or -1 when it has none (yet). */
int drv_sysfs_find_usb_video(const char *sysfs_root, unsigned busnum, unsigned devnum, char *node, size_t n);

/* Fills `out` (all but `index`) for the USB device at busnum/devnum, from
 * /sys/bus/usb/devices.  0, or -1 when there is no such device. */
int drv_sysfs_usb_device_info(const char *sysfs_root, unsigned busnum, unsigned devnum, drv_usb_video_info *out);

/* Lists the USB devices (not their interfaces) in /sys/bus/usb/devices, at
 * most max; returns how many. */
int drv_sysfs_list_usb_devices(const char *sysfs_root, drv_usb_video_info *out, int max);

#endif
