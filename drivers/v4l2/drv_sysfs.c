/* drv_sysfs: USB identity of V4L2 nodes from sysfs.  See drv_sysfs.h. */
#include "drv_sysfs.h"

#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Reads the first line of dir/name into buf (without newline); -1 if absent. */
static int read_attr(const char *dir, const char *name, char *buf, size_t n)
{
	char path[PATH_MAX];
	snprintf(path, sizeof path, "%s/%s", dir, name);
	FILE *f = fopen(path, "r");
	if (!f)
		return -1;
	if (!fgets(buf, (int)n, f))
		buf[0] = 0;
	fclose(f);
	buf[strcspn(buf, "\r\n")] = 0;
	return 0;
}

static int read_uint_attr(const char *dir, const char *name, int base, unsigned *out)
{
	char buf[32], *end;
	if (read_attr(dir, name, buf, sizeof buf) != 0 || !buf[0])
		return -1;
	unsigned long v = strtoul(buf, &end, base);
	if (*end)
		return -1;
	*out = (unsigned)v;
	return 0;
}

/* Walks up from the node's device folder to the first folder that looks
 * like a USB device (has idVendor); at most a few levels. */
static int find_usb_device_dir(const char *start, char *out, size_t n)
{
	char dir[PATH_MAX];
	snprintf(dir, sizeof dir, "%s", start);
	for (int level = 0; level < 4; level++) {
		char probe[PATH_MAX + 16];
		snprintf(probe, sizeof probe, "%s/idVendor", dir);
		if (access(probe, R_OK) == 0) {
			snprintf(out, n, "%s", dir);
			return 0;
		}
		char *slash = strrchr(dir, '/');
		if (!slash || slash == dir)
			return -1;
		*slash = 0;
	}
	return -1;
}

/* Reads the identity of the USB device whose folder is `usb`. */
static int read_usb_device(const char *usb, drv_usb_video_info *out)
{
	unsigned vendor, product;
	if (read_uint_attr(usb, "idVendor", 16, &vendor) || read_uint_attr(usb, "idProduct", 16, &product) ||
	    read_uint_attr(usb, "busnum", 10, &out->busnum) || read_uint_attr(usb, "devnum", 10, &out->devnum))
		return -1;
	out->vendor = (uint16_t)vendor;
	out->product = (uint16_t)product;
	if (read_attr(usb, "serial", out->serial, sizeof out->serial) != 0)
		out->serial[0] = 0;
	if (read_attr(usb, "product", out->name, sizeof out->name) != 0)
		out->name[0] = 0;
	const char *slash = strrchr(usb, '/');
	snprintf(out->port, sizeof out->port, "%s", slash ? slash + 1 : usb);
	return 0;
}

int drv_sysfs_video_usb_info(const char *sysfs_root, const char *node, drv_usb_video_info *out)
{
	memset(out, 0, sizeof *out);
	char class_dir[PATH_MAX], link[PATH_MAX + 16], dev[PATH_MAX], usb[PATH_MAX];
	snprintf(class_dir, sizeof class_dir, "%s/class/video4linux/%s", sysfs_root, node);
	snprintf(link, sizeof link, "%s/device", class_dir);
	if (!realpath(link, dev))
		return -1;
	if (find_usb_device_dir(dev, usb, sizeof usb) != 0 || read_usb_device(usb, out) != 0)
		return -1;
	if (read_uint_attr(class_dir, "index", 10, &out->index) != 0)
		out->index = 0;
	return 0;
}

int drv_sysfs_list_usb_devices(const char *sysfs_root, drv_usb_video_info *out, int max)
{
	char dir[PATH_MAX];
	snprintf(dir, sizeof dir, "%s/bus/usb/devices", sysfs_root);
	DIR *d = opendir(dir);
	if (!d)
		return 0;
	int n = 0;
	struct dirent *e;
	while (n < max && (e = readdir(d))) {
		if (e->d_name[0] == '.' || strchr(e->d_name, ':')) /* interfaces have a ':' */
			continue;
		char link[PATH_MAX + 256], usb[PATH_MAX];
		snprintf(link, sizeof link, "%s/%s", dir, e->d_name);
		memset(&out[n], 0, sizeof out[n]);
		if (realpath(link, usb) && read_usb_device(usb, &out[n]) == 0)
			n++;
	}
	closedir(d);
	return n;
}

int drv_sysfs_usb_device_info(const char *sysfs_root, unsigned busnum, unsigned devnum, drv_usb_video_info *out)
{
	drv_usb_video_info list[128];
	int n = drv_sysfs_list_usb_devices(sysfs_root, list, 128);
	for (int i = 0; i < n; i++) {
		if (list[i].busnum == busnum && list[i].devnum == devnum) {
			*out = list[i];
			return 0;
		}
	}
	return -1;
}

/* The N of "videoN", or -1 for other names. */
static int video_number(const char *name)
{
	if (strncmp(name, "video", 5) != 0 || !name[5])
		return -1;
	char *end;
	long v = strtol(name + 5, &end, 10);
	return *end || v < 0 ? -1 : (int)v;
}

int drv_sysfs_find_usb_video(const char *sysfs_root, unsigned busnum, unsigned devnum, char *node, size_t n)
{
	char dir[PATH_MAX];
	snprintf(dir, sizeof dir, "%s/class/video4linux", sysfs_root);
	DIR *d = opendir(dir);
	if (!d)
		return -1;
	int best_num = -1;
	unsigned best_index = 0;
	struct dirent *e;
	while ((e = readdir(d))) {
		int num = video_number(e->d_name);
		drv_usb_video_info info;
		if (num < 0 || drv_sysfs_video_usb_info(sysfs_root, e->d_name, &info) != 0)
			continue;
		if (info.busnum != busnum || info.devnum != devnum)
			continue;
		if (best_num < 0 || info.index < best_index || (info.index == best_index && num < best_num)) {
			best_num = num;
			best_index = info.index;
		}
	}
	closedir(d);
	if (best_num < 0)
		return -1;
	snprintf(node, n, "video%d", best_num);
	return 0;
}
