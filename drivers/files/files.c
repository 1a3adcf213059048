/* mocap-driver-files: plays a folder of numbered image files as a camera.
 *
 * Layout: one folder per camera holding numbered JPEG, PNG or binary
 * PPM/PGM files, e.g. shared/data/ego/<clip>/left/00000.jpg.  The frame
 * number of a file is the last run of digits in its name; files play in
 * that order.
 *
 * Config keys (the camera's section):
 *   path    folder of one camera (required)
 *   rate    frames per second (default 30); 0 = as fast as they are taken
 *   loop    true/false (default false): start over after the last file
 *   format  mjpeg (JPEG bytes as they are in the files; JPEG files only) or
 *           rgb24 (decoded here); default mjpeg if every file is a JPEG
 *   start   first frame number to play (default 0)
 *   count   number of frames to play (default 0 = all from start)
 *   epoch   CLOCK_MONOTONIC time in ns of the first frame (see below)
 *
 * Timestamps: with rate > 0, the k-th frame delivered since start() (k
 * counts on across loops) has timestamp epoch + k / rate and is delivered no
 * earlier than that; a reader that takes frames late gets every frame, late,
 * with those timestamps.  epoch defaults to the time of start(): cameras
 * started separately then differ by their start skew.  A host that wants
 * frame k of several cameras to carry the same timestamp passes them all
 * the same `epoch`.  With rate 0 the timestamp is the delivery time.
 *
 * probe() lists nothing (files are not hardware).  next_frame() returns
 * MDRV_ERR_END after the last frame unless loop is set; frame_count() says
 * how many frames that is (unknown with loop). */
#include "drv_common.h"
#include "image/mc_image.h"
#include "mdrv.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define DRV "files"

typedef struct {
	char *path;
	unsigned long long number;
	size_t bytes;
	bool jpeg;
} frame_file;

typedef struct {
	const mdrv_host *host;
	char dir[PATH_MAX];
	frame_file *files;
	int nfiles;
	double rate;
	bool loop;
	bool rgb24; /* decode; else deliver JPEG bytes */
	bool epoch_given;
	uint64_t epoch_ns;
	mdrv_format fmt;
	mc_image_conv *conv;
	uint8_t *buf; /* file bytes, for decoding */
	size_t bufcap;
	bool started;
	uint64_t delivered; /* frames delivered (or skipped as unreadable) since start() */
	int next;           /* index into files */
} files_dev;

/* ---- the folder ---- */

static bool has_image_extension(const char *name)
{
	const char *dot = strrchr(name, '.');
	static const char *const exts[] = {".jpg", ".jpeg", ".png", ".ppm", ".pgm"};
	for (size_t i = 0; dot && i < sizeof(exts) / sizeof(exts[0]); i++)
		if (strcasecmp(dot, exts[i]) == 0)
			return true;
	return false;
}

/* The last run of digits before the extension; false if there is none. */
static bool frame_number(const char *name, unsigned long long *out)
{
	const char *dot = strrchr(name, '.');
	const char *end = dot ? dot : name + strlen(name);
	const char *p = end;
	while (p > name && !isdigit((unsigned char)p[-1]))
		p--;
	const char *digits_end = p;
	while (p > name && isdigit((unsigned char)p[-1]))
		p--;
	if (p == digits_end || digits_end - p > 18)
		return false;
	*out = strtoull(p, NULL, 10);
	return true;
}

static int cmp_files(const void *a, const void *b)
{
	const frame_file *x = a, *y = b;
	if (x->number != y->number)
		return x->number < y->number ? -1 : 1;
	return strcmp(x->path, y->path);
}

static void free_files(files_dev *d)
{
	for (int i = 0; i < d->nfiles; i++)
		free(d->files[i].path);
	free(d->files);
	d->files = NULL;
	d->nfiles = 0;
}

static int scan_folder(files_dev *d, unsigned start, unsigned count, char *err, size_t errlen)
{
	DIR *dir = opendir(d->dir);
	if (!dir)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'path': '%s': %s", DRV, d->dir,
				strerror(errno));
	int cap = 0;
	struct dirent *e;
	while ((e = readdir(dir))) {
		unsigned long long num;
		if (!has_image_extension(e->d_name) || !frame_number(e->d_name, &num) || num < start)
			continue;
		char path[PATH_MAX];
		if (snprintf(path, sizeof(path), "%s/%s", d->dir, e->d_name) >= (int)sizeof(path))
			continue;
		struct stat st;
		if (stat(path, &st) != 0 || !S_ISREG(st.st_mode))
			continue;
		if (d->nfiles == cap) {
			cap = cap ? 2 * cap : 256;
			frame_file *grown = realloc(d->files, sizeof(frame_file) * (size_t)cap);
			if (!grown) {
				closedir(dir);
				return drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory listing '%s'", DRV, d->dir);
			}
			d->files = grown;
		}
		const char *dot = strrchr(e->d_name, '.');
		d->files[d->nfiles++] = (frame_file){.path = strdup(path), .number = num, .bytes = (size_t)st.st_size,
						     .jpeg = !strcasecmp(dot, ".jpg") || !strcasecmp(dot, ".jpeg")};
	}
	closedir(dir);
	if (d->nfiles == 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key 'path': no numbered JPEG/PNG/PPM files in '%s' from frame %u", DRV, d->dir,
				start);
	qsort(d->files, (size_t)d->nfiles, sizeof(frame_file), cmp_files);
	for (int i = 1; i < d->nfiles; i++)
		if (d->files[i].number == d->files[i - 1].number)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: '%s' and '%s' have the same frame number %llu",
					DRV, d->files[i - 1].path, d->files[i].path, d->files[i].number);
	if (count && (unsigned)d->nfiles > count) {
		for (int i = (int)count; i < d->nfiles; i++)
			free(d->files[i].path);
		d->nfiles = (int)count;
	}
	return MDRV_OK;
}

/* Reads a file into d->buf. */
static int read_file(files_dev *d, const char *path, size_t *bytes, char *err, size_t errlen)
{
	FILE *f = fopen(path, "rb");
	if (!f)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: '%s': %s", DRV, path, strerror(errno));
	struct stat st;
	if (fstat(fileno(f), &st) != 0) {
		fclose(f);
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: '%s': %s", DRV, path, strerror(errno));
	}
	size_t n = (size_t)st.st_size;
	if (n > d->bufcap) {
		uint8_t *grown = realloc(d->buf, n);
		if (!grown) {
			fclose(f);
			return drv_errf(err, errlen, MDRV_ERR_IO, "%s: '%s': out of memory", DRV, path);
		}
		d->buf = grown;
		d->bufcap = n;
	}
	size_t got = fread(d->buf, 1, n, f);
	fclose(f);
	if (got != n)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: '%s': short read (%zu of %zu bytes)", DRV, path, got, n);
	*bytes = n;
	return MDRV_OK;
}

/* The slot size of an MJPEG stream: its largest file, but no more than a
 * JPEG of the stream's size can take (its raw pixels, plus 64 KiB of
 * headers and tables).  One larger file (a 50 MB photo among the frames)
 * must not size every slot of the camera's ring: it is refused when its
 * turn comes (fill_slot: MDRV_ERR_NOSPACE), and said here once. */
static size_t mjpeg_slot_bytes(files_dev *d, size_t pixels)
{
	size_t bound = 3 * pixels + 65536, most = 0;
	int over = 0;
	for (int i = 0; i < d->nfiles; i++) {
		if (d->files[i].bytes > bound)
			over++;
		else if (d->files[i].bytes > most)
			most = d->files[i].bytes;
	}
	if (over)
		drv_logf(d->host, MDRV_LOG_WARN,
			 "%s: %d file(s) in '%s' are larger than a frame of this size can be (%zu bytes); they will be "
			 "refused",
			 DRV, over, d->dir, bound);
	return most;
}

/* The format comes from the first file. */
static int probe_first_file(files_dev *d, char *err, size_t errlen)
{
	size_t n;
	const char *path = d->files[0].path;
	int rc = read_file(d, path, &n, err, errlen);
	if (rc != MDRV_OK)
		return rc;
	uint8_t *rgb = NULL;
	int w, h;
	mc_err e;
	if (mc_image_decode(d->conv, d->buf, n, path, &rgb, &w, &h, &e) != 0)
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, "%s: %s", DRV, e.msg);
	free(rgb);
	d->fmt.width = (uint32_t)w;
	d->fmt.height = (uint32_t)h;
	d->fmt.fps = d->rate;
	if (d->rgb24) {
		d->fmt.pixfmt = MC_PIXFMT_RGB24;
		d->fmt.stride = (uint32_t)w * 3;
		d->fmt.max_bytes = (size_t)w * (size_t)h * 3;
	} else {
		d->fmt.pixfmt = MC_PIXFMT_MJPEG;
		d->fmt.stride = 0;
		d->fmt.max_bytes = mjpeg_slot_bytes(d, (size_t)w * (size_t)h);
	}
	return MDRV_OK;
}

/* ---- config ---- */

static int parse_config(files_dev *d, unsigned *start, unsigned *count, int *format, char *err, size_t errlen)
{
	const mdrv_host *h = d->host;
	const char *path = drv_cfg_str(h, "path");
	if (!path)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key 'path' is required (a folder of numbered JPEG/PNG/PPM files)", DRV);
	if (strlen(path) >= sizeof(d->dir))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'path': too long", DRV);
	drv_strlcpy(d->dir, path, sizeof(d->dir));
	d->rate = 30;
	static const char *const formats[] = {"mjpeg", "rgb24"};
	int rc;
	if ((rc = drv_cfg_double(h, DRV, "rate", 0, 10000, &d->rate, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_bool(h, DRV, "loop", &d->loop, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_choice(h, DRV, "format", formats, 2, format, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_uint(h, DRV, "start", 0, UINT_MAX, start, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_uint(h, DRV, "count", 0, UINT_MAX, count, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_monotonic_ns(h, DRV, "epoch", &d->epoch_ns, &d->epoch_given, err, errlen)) != MDRV_OK)
		return rc;
	return MDRV_OK;
}

/* ---- the ABI ---- */

static int files_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host, (void)out, (void)max, (void)err, (void)errlen;
	return 0;
}

static void files_close(void *dev)
{
	files_dev *d = dev;
	if (!d)
		return;
	free_files(d);
	mc_image_conv_free(d->conv);
	free(d->buf);
	free(d);
}

static void *files_open(const mdrv_host *host, char *err, size_t errlen)
{
	files_dev *d = calloc(1, sizeof(*d));
	if (!d) {
		drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
		return NULL;
	}
	d->host = host;
	unsigned start = 0, count = 0;
	int format = -1;
	mc_err e;
	int rc = parse_config(d, &start, &count, &format, err, errlen);
	if (rc == MDRV_OK)
		rc = scan_folder(d, start, count, err, errlen);
	if (rc != MDRV_OK)
		goto fail;
	bool all_jpeg = true;
	for (int i = 0; i < d->nfiles; i++)
		all_jpeg &= d->files[i].jpeg;
	if (format == 0 && !all_jpeg) {
		rc = drv_errf(err, errlen, MDRV_ERR_CONFIG,
			      "%s: config key 'format': mjpeg needs JPEG files, '%s' holds others (use rgb24)", DRV, d->dir);
		goto fail;
	}
	d->rgb24 = format == 1 || !all_jpeg;
	if (!(d->conv = mc_image_conv_new(&e))) {
		rc = drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s", DRV, e.msg);
		goto fail;
	}
	rc = probe_first_file(d, err, errlen);
	if (rc != MDRV_OK)
		goto fail;
	drv_logf(host, MDRV_LOG_INFO, "%s: %d frames from %s (%ux%u %s, %g fps%s)", DRV, d->nfiles, d->dir,
		 d->fmt.width, d->fmt.height, mc_pixfmt_name(d->fmt.pixfmt), d->rate, d->loop ? ", looping" : "");
	return d;
fail:
	files_close(d);
	/* The folder, its files and the keys do not change by waiting: an
	 * empty folder or an undecodable first file is permanent too. */
	return drv_open_failed(host, rc == MDRV_ERR_FORMAT ? MDRV_ERR_CONFIG : rc);
}

static int files_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	*fmt = ((files_dev *)dev)->fmt;
	return MDRV_OK;
}

static int files_start(void *dev, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	files_dev *d = dev;
	if (!d->epoch_given)
		d->epoch_ns = mc_now_ns();
	d->delivered = 0;
	d->next = 0;
	d->started = true;
	return MDRV_OK;
}

static void files_stop(void *dev) { ((files_dev *)dev)->started = false; }

/* Copies or decodes file `f` into the slot. */
static int fill_slot(files_dev *d, const frame_file *f, mdrv_frame *slot, char *err, size_t errlen)
{
	if (!d->rgb24) {
		if (f->bytes > slot->capacity)
			return drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: '%s' has %zu bytes, the slot holds %zu", DRV,
					f->path, f->bytes, slot->capacity);
		size_t n;
		int rc = read_file(d, f->path, &n, err, errlen);
		if (rc != MDRV_OK)
			return rc;
		if (n > slot->capacity) /* grew since the folder was listed */
			return drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: '%s' has %zu bytes, the slot holds %zu",
					DRV, f->path, n, slot->capacity);
		memcpy(slot->data, d->buf, n);
		slot->bytesused = n;
		return MDRV_OK;
	}
	size_t need = d->fmt.max_bytes, n;
	if (need > slot->capacity)
		return drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: a %ux%u RGB frame needs %zu bytes, the slot holds %zu",
				DRV, d->fmt.width, d->fmt.height, need, slot->capacity);
	int rc = read_file(d, f->path, &n, err, errlen);
	if (rc != MDRV_OK)
		return rc;
	uint8_t *rgb = NULL;
	int w, h;
	mc_err e;
	if (mc_image_decode(d->conv, d->buf, n, f->path, &rgb, &w, &h, &e) != 0)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s", DRV, e.msg);
	if ((uint32_t)w != d->fmt.width || (uint32_t)h != d->fmt.height) {
		free(rgb);
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, "%s: '%s' is %dx%d, the stream is %ux%u", DRV, f->path, w,
				h, d->fmt.width, d->fmt.height);
	}
	memcpy(slot->data, rgb, need);
	free(rgb);
	slot->bytesused = need;
	return MDRV_OK;
}

static int files_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	files_dev *d = dev;
	if (!d->started)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: next_frame before start", DRV);
	if (d->next >= d->nfiles) {
		if (!d->loop)
			return drv_errf(err, errlen, MDRV_ERR_END, "%s: end of '%s' (%d frames)", DRV, d->dir, d->nfiles);
		d->next = 0;
	}
	uint64_t ts;
	if (d->rate > 0) {
		ts = d->epoch_ns + (uint64_t)((double)d->delivered * 1e9 / d->rate + 0.5);
		uint64_t now = mc_now_ns();
		if (ts > now) {
			if (timeout_ms >= 0 && ts - now > (uint64_t)timeout_ms * 1000000ull) {
				mc_sleep_until_ns(now + (uint64_t)timeout_ms * 1000000ull);
				return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, "%s: next frame due in %.1f ms", DRV,
						(double)(ts - now) * 1e-6 - timeout_ms);
			}
			mc_sleep_until_ns(ts);
		}
	} else {
		ts = mc_now_ns();
	}
	const frame_file *f = &d->files[d->next];
	/* An unreadable file is skipped: it keeps its place in time. */
	uint64_t seq = d->delivered++;
	d->next++;
	int rc = fill_slot(d, f, slot, err, errlen);
	if (rc != MDRV_OK)
		return rc;
	slot->timestamp_ns = ts;
	slot->sequence = seq;
	slot->flags = 0;
	slot->format = d->fmt;
	return MDRV_OK;
}

/* The files from `start` (and up to `count`), unless they loop. */
static int files_frame_count(void *dev, uint64_t *frames)
{
	files_dev *d = dev;
	if (d->loop)
		return MDRV_ERR_IO;
	*frames = (uint64_t)d->nfiles;
	return MDRV_OK;
}

/* The keys, and that the folder holds numbered images (it is listed, no
 * image is decoded). */
static int files_check(const mdrv_host *host, char *err, size_t errlen)
{
	files_dev *d = calloc(1, sizeof(*d));
	if (!d)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
	d->host = host;
	unsigned start = 0, count = 0;
	int format = -1;
	int rc = parse_config(d, &start, &count, &format, err, errlen);
	if (rc == MDRV_OK)
		rc = scan_folder(d, start, count, err, errlen);
	files_close(d);
	return rc == MDRV_OK ? MDRV_OK : MDRV_ERR_CONFIG;
}

MDRV_DEFINE_DRIVER_COUNT(files, DRV,
		   "plays a folder of numbered JPEG/PNG/PPM files as a camera")
