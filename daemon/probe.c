/* probe: see probe.h.  The report is for a person at a terminal:
 *
 *   v4l2: 1 device
 *     /dev/video0  "HD USB Camera"  bus_info usb-0000:00:14.0-2  serial A1B2
 *       MJPEG 1280x1024 @ 30, 15
 *       YUYV 640x480 @ 30
 *     paste into mocapd.conf (then set rig_camera to its camera in your rig):
 *       [camera video0]
 *       ...
 */
#include "probe.h"

#include "plugin.h"

#include <ctype.h>
#include <stdbool.h>
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_DEVICES 32
#define MAX_MODES 64
#define MAX_DRIVERS 32

/* What --probe offers the drivers: no config keys, and their log lines
 * only from warnings up, on stderr, so that the report stays readable. */
static const char *no_key(void *ctx, const char *key)
{
	(void)ctx;
	(void)key;
	return NULL;
}

static void log_to_stderr(void *ctx, int level, const char *msg)
{
	if (level <= MDRV_LOG_WARN)
		fprintf(stderr, "mocapd: %s: %s\n", (const char *)ctx, msg);
}

static int by_name(const void *a, const void *b)
{
	return strcmp(a, b);
}

/* The driver names in dir (mocap-driver-NAME.so), sorted; how many. */
static int list_drivers(DIR *d, char names[][64], int max)
{
	int n = 0;
	struct dirent *e;
	while ((e = readdir(d)) && n < max) {
		size_t len = strlen(e->d_name);
		if (strncmp(e->d_name, "mocap-driver-", 13) != 0 || len < 17 || len - 16 >= 64 ||
		    strcmp(e->d_name + len - 3, ".so") != 0)
			continue;
		snprintf(names[n++], 64, "%.*s", (int)(len - 16), e->d_name + 13);
	}
	qsort(names, (size_t)n, sizeof names[0], by_name);
	return n;
}

static void print_rates(FILE *out, const mdrv_mode *m)
{
	if (m->nfps) {
		for (uint32_t k = 0; k < m->nfps; k++)
			fprintf(out, "%s%.4g", k ? ", " : " @ ", m->fps[k]);
	} else if (m->fps_max > 0) {
		fprintf(out, " @ %.4g-%.4g", m->fps_min, m->fps_max);
	}
	fputc('\n', out);
}

static double top_rate(const mdrv_mode *m)
{
	return m->nfps ? m->fps[0] : m->fps_max;
}

/* Motion capture wants a steady rate more than pixels: the pasted section
 * asks for the largest size of the first format listed (a driver lists
 * the one it prefers first) that reaches this rate, else the fastest. */
#define SUGGESTED_MIN_FPS 25.0

static const mdrv_mode *suggested_mode(const mdrv_mode *modes, int n)
{
	const mdrv_mode *best = NULL, *fastest = NULL;
	for (int i = 0; i < n; i++) {
		const mdrv_mode *m = &modes[i];
		if (strcmp(m->pixel_format, modes[0].pixel_format) != 0)
			continue;
		if (!fastest || top_rate(m) > top_rate(fastest))
			fastest = m;
		bool fast = top_rate(m) >= SUGGESTED_MIN_FPS || top_rate(m) == 0; /* 0: rate unknown */
		if (fast && (!best || (uint64_t)m->width * m->height > (uint64_t)best->width * best->height))
			best = m;
	}
	return best ? best : fastest;
}

/* A section name from the device id: its last path part, with anything
 * but letters, digits, '-' and '_' made '_'. */
static void section_name(const char *driver, const char *id, char *out, size_t cap)
{
	const char *base = strrchr(id, '/');
	base = base && base[1] ? base + 1 : id;
	snprintf(out, cap, "%s", *base ? base : driver);
	for (char *c = out; *c; c++)
		if (!isalnum((unsigned char)*c) && *c != '-' && *c != '_')
			*c = '_';
}

/* A rate as a GStreamer fraction: 30/1, 30000/1001; "" when neither. */
static void rate_fraction(double fps, char *out, size_t cap)
{
	out[0] = 0;
	if (fps > 0 && fabs(fps - round(fps)) < 1e-6)
		snprintf(out, cap, ",framerate=%.0f/1", fps);
	else if (fps > 0 && fabs(fps * 1.001 - round(fps * 1.001)) < 1e-3)
		snprintf(out, cap, ",framerate=%.0f/1001", round(fps * 1.001) * 1000);
}

/* The gstreamer driver takes a device as the start of a `pipeline` (its
 * id is the capturing element's description): the mode as caps, then a
 * conversion for raw video, then the appsink. */
static void print_pipeline(FILE *out, const mdrv_device_info *dev, const mdrv_mode *m)
{
	if (!m) {
		fprintf(out, "      pipeline = %s ! videoconvert ! appsink name=mocap\n", dev->id);
		return;
	}
	char rate[48];
	rate_fraction(m->nfps ? m->fps[0] : m->fps_max, rate, sizeof rate);
	if (m->pixfmt == MC_PIXFMT_MJPEG)
		fprintf(out, "      pipeline = %s ! image/jpeg,width=%u,height=%u%s ! appsink name=mocap\n", dev->id,
			(unsigned)m->width, (unsigned)m->height, rate);
	else
		fprintf(out, "      pipeline = %s ! video/x-raw,format=%s,width=%u,height=%u%s ! videoconvert ! appsink "
			"name=mocap\n", dev->id, m->pixel_format, (unsigned)m->width, (unsigned)m->height, rate);
}

static void print_section(FILE *out, const char *driver, const mdrv_device_info *dev, const mdrv_mode *m)
{
	char name[sizeof dev->id];
	section_name(driver, dev->id, name, sizeof name);
	if (!strcmp(driver, "gstreamer")) {
		fprintf(out, "    paste into mocapd.conf (set rig_camera to this camera's name in your rig file):\n");
		fprintf(out, "      [camera %s]\n      driver = gstreamer\n      rig_camera = %s\n", name, name);
		print_pipeline(out, dev, m);
		return;
	}
	fprintf(out, "    paste into mocapd.conf (set rig_camera to this camera's name in your rig file):\n");
	fprintf(out, "      [camera %s]\n      driver = %s\n      rig_camera = %s\n      device = %s\n", name, driver,
		name, dev->id);
	if (!strcmp(driver, "v4l2") && dev->bus_info[0])
		fprintf(out, "      ; or, stable across renumbering: bus_info = %s\n", dev->bus_info);
	if (!m)
		return;
	fprintf(out, "      %s = %s\n      width = %u\n      height = %u\n",
		m->format_key[0] ? m->format_key : "pixel_format", m->pixel_format, (unsigned)m->width,
		(unsigned)m->height);
	if (m->nfps)
		fprintf(out, "      fps = %.4g\n", m->fps[0]);
	else if (m->fps_max > 0)
		fprintf(out, "      ; fps = %.4g   (the camera takes %.4g to %.4g)\n", m->fps_max, m->fps_min,
			m->fps_max);
}

static void print_device(FILE *out, const mcd_plugin *pl, const mdrv_host *host, const mdrv_device_info *dev,
			 mdrv_mode *modes)
{
	fprintf(out, "  %s  \"%s\"  bus_info %s  serial %s\n", dev->id, dev->name, dev->bus_info[0] ? dev->bus_info : "-",
		dev->serial[0] ? dev->serial : "-");
	int n = 0;
	if (pl->driver->modes) {
		char err[512] = "";
		n = pl->driver->modes(host, dev->id, modes, MAX_MODES, err, sizeof err);
		if (n < 0) {
			fprintf(out, "    modes: cannot list: %s\n", err);
			n = 0;
		}
		for (int i = 0; i < n; i++) {
			fprintf(out, "    %s %ux%u", modes[i].pixel_format, (unsigned)modes[i].width,
				(unsigned)modes[i].height);
			print_rates(out, &modes[i]);
		}
		if (n == 0 && !err[0])
			fprintf(out, "    modes: none in a format the %s driver takes\n", pl->name);
	} else {
		fprintf(out, "    modes: the %s driver does not list them\n", pl->name);
	}
	print_section(out, pl->name, dev, suggested_mode(modes, n));
}

static bool reads_files(const char *driver)
{
	return !strcmp(driver, "files") || !strcmp(driver, "take") || !strcmp(driver, "sim");
}

/* One driver's part of the report; returns its device count. */
static int probe_driver(const char *dir, const char *name, FILE *out)
{
	mcd_plugin pl;
	mc_err err = {{0}};
	if (mcd_plugin_load(dir, name, geteuid(), getegid(), &pl, &err)) {
		fprintf(out, "%s: not probed: %s\n", name, err.msg);
		return 0;
	}
	mdrv_host host = {.ctx = pl.name, .config_get = no_key, .log = log_to_stderr};
	mdrv_device_info *devs = calloc(MAX_DEVICES, sizeof *devs);
	mdrv_mode *modes = calloc(MAX_MODES, sizeof *modes);
	int n = 0;
	if (!devs || !modes) {
		fprintf(out, "%s: out of memory\n", name);
	} else if (pl.driver->probe) {
		char msg[512] = "";
		n = pl.driver->probe(&host, devs, MAX_DEVICES, msg, sizeof msg);
		if (n < 0)
			fprintf(out, "%s: probe failed: %s\n", name, msg);
		else
			fprintf(out, "%s: %d device%s%s\n", name, n, n == 1 ? "" : "s",
				reads_files(name) ? " (it reads files, not hardware)" : "");
		for (int i = 0; i < n; i++)
			print_device(out, &pl, &host, &devs[i], modes);
	}
	free(devs);
	free(modes);
	mcd_plugin_keep(&pl);
	return n > 0 ? n : 0;
}

int mcd_probe_all(const char *plugin_dir, FILE *out, mc_err *err)
{
	DIR *d = opendir(plugin_dir);
	if (!d)
		return mc_err_set(err, "plugin directory %s: %s (give another with --plugin-dir)", plugin_dir,
				  strerror(errno));
	char (*names)[64] = calloc(MAX_DRIVERS, sizeof *names);
	if (!names) {
		closedir(d);
		return mc_err_set(err, "out of memory");
	}
	int nd = list_drivers(d, names, MAX_DRIVERS);
	closedir(d);
	fprintf(out, "driver plugins in %s: %d\n", plugin_dir, nd);
	int total = 0;
	for (int i = 0; i < nd; i++)
		total += probe_driver(plugin_dir, names[i], out);
	free(names);
	return total;
}
