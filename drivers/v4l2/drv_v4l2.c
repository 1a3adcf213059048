/* drv_v4l2: one V4L2 capture device.  See drv_v4l2.h.
 *
 * Timestamps: V4L2 buffers stamped with V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC
 * are on CLOCK_MONOTONIC already (uvcvideo takes the stamp at the start of
 * the frame, other drivers at its end, see V4L2_BUF_FLAG_TSTAMP_SRC_*); the
 * rare driver with another clock gets the dequeue time instead.
 *
 * Unplug: once the kernel unregisters the node, poll() reports POLLERR and
 * POLLHUP and every ioctl fails with ENODEV; both become MDRV_ERR_NODEV. */
#include "drv_v4l2.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <math.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "drv_sysfs.h"

#define MAX_BUFFERS 32

typedef struct {
	void *start;
	size_t length;
} mapped_buffer;

struct drv_v4l2 {
	int fd;
	char path[64];
	char card[64];
	const char *drv; /* name for messages */
	mdrv_format fmt;
	uint32_t fourcc;
	unsigned n_requested;
	mapped_buffer bufs[MAX_BUFFERS];
	unsigned n_bufs;
	bool streaming;
	bool gone; /* the device was unplugged */
	bool have_seq;
	uint32_t last_seq32;
	uint64_t seq;
	unsigned corrupt_frames;
	mdrv_host host;
};

/* The pixel formats this driver delivers, with their config names. */
static const struct {
	const char *name;
	uint32_t fourcc;
	mc_pixfmt fmt;
} formats[] = {
	{"YUYV", V4L2_PIX_FMT_YUYV, MC_PIXFMT_YUYV},
	{"MJPEG", V4L2_PIX_FMT_MJPEG, MC_PIXFMT_MJPEG},
	{"GREY", V4L2_PIX_FMT_GREY, MC_PIXFMT_GRAY8},
	{"JPEG", V4L2_PIX_FMT_JPEG, MC_PIXFMT_MJPEG}, /* some webcams call MJPEG this */
};
#define N_FORMATS (int)(sizeof formats / sizeof formats[0])

static int format_index(uint32_t fourcc)
{
	for (int i = 0; i < N_FORMATS; i++)
		if (formats[i].fourcc == fourcc)
			return i;
	return -1;
}

static void fourcc_str(uint32_t f, char out[5])
{
	for (int i = 0; i < 4; i++) {
		char c = (char)((f >> (8 * i)) & 0xff);
		out[i] = isprint((unsigned char)c) ? c : '?';
	}
	out[4] = 0;
}

/* ioctl that retries when a signal interrupts it. */
static int xioctl(int fd, unsigned long req, void *arg)
{
	int r;
	do
		r = ioctl(fd, req, arg);
	while (r < 0 && errno == EINTR);
	return r;
}

/* The status for a failed system call: a vanished device is NODEV. */
static int errno_status(int e)
{
	return e == ENODEV || e == ENXIO || e == ENOENT ? MDRV_ERR_NODEV : MDRV_ERR_IO;
}

/* ---- settings from the config ---- */

int drv_v4l2_read_settings(const mdrv_host *host, const char *drv, drv_v4l2_settings *s, char *err,
			   size_t errlen)
{
	memset(s, 0, sizeof *s);
	s->buffers = 4;
	static const char *const names[] = {"YUYV", "MJPEG", "GREY", "GRAY"};
	static const uint32_t fourccs[] = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_GREY,
					   V4L2_PIX_FMT_GREY};
	int choice = -1, st;
	if ((st = drv_cfg_choice(host, drv, "pixel_format", names, 4, &choice, err, errlen)) ||
	    (st = drv_cfg_uint(host, drv, "width", 1, 16384, &s->width, err, errlen)) ||
	    (st = drv_cfg_uint(host, drv, "height", 1, 16384, &s->height, err, errlen)) ||
	    (st = drv_cfg_double(host, drv, "fps", 0.01, 10000, &s->fps, err, errlen)) ||
	    (st = drv_cfg_uint(host, drv, "buffers", 2, MAX_BUFFERS, &s->buffers, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, drv, "exposure", 1e-5, 100, &s->exposure, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, drv, "gain", -1e9, 1e9, &s->gain, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, drv, "white_balance", 1000, 20000, &s->white_balance, err, errlen)))
		return st;
	if (choice >= 0)
		s->fourcc = fourccs[choice];
	if ((s->width == 0) != (s->height == 0))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config keys 'width' and 'height' go together",
				drv);
	return MDRV_OK;
}

/* ---- describing modes ---- */

static void appendf(char *buf, size_t n, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void appendf(char *buf, size_t n, const char *fmt, ...)
{
	size_t len = strlen(buf);
	if (len + 1 >= n)
		return;
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(buf + len, n - len, fmt, ap);
	va_end(ap);
}

/* Appends "@30,15" for the discrete intervals of one size. */
static void describe_intervals(int fd, uint32_t fourcc, uint32_t w, uint32_t h, char *buf, size_t n)
{
	struct v4l2_frmivalenum iv;
	memset(&iv, 0, sizeof iv);
	iv.pixel_format = fourcc;
	iv.width = w;
	iv.height = h;
	for (iv.index = 0; xioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &iv) == 0; iv.index++) {
		if (iv.type == V4L2_FRMIVAL_TYPE_DISCRETE) {
			double fps = iv.discrete.numerator ? (double)iv.discrete.denominator / iv.discrete.numerator
							   : 0;
			appendf(buf, n, "%s%.4g", iv.index ? "," : "@", fps);
		} else {
			double lo = (double)iv.stepwise.max.denominator / iv.stepwise.max.numerator;
			double hi = (double)iv.stepwise.min.denominator / iv.stepwise.min.numerator;
			appendf(buf, n, "@%.4g-%.4g", lo, hi);
			break;
		}
	}
}

void drv_v4l2_describe_modes(int fd, char *buf, size_t n)
{
	buf[0] = 0;
	char others[256] = "";
	struct v4l2_fmtdesc desc;
	memset(&desc, 0, sizeof desc);
	desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	int listed = 0;
	for (desc.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &desc) == 0; desc.index++) {
		int fi = format_index(desc.pixelformat);
		if (fi < 0) {
			char cc[5];
			fourcc_str(desc.pixelformat, cc);
			appendf(others, sizeof others, " %s", cc);
			continue;
		}
		appendf(buf, n, "%s%s", listed++ ? "; " : "", formats[fi].name);
		struct v4l2_frmsizeenum fs;
		memset(&fs, 0, sizeof fs);
		fs.pixel_format = desc.pixelformat;
		for (fs.index = 0; xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &fs) == 0; fs.index++) {
			if (fs.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
				appendf(buf, n, " %ux%u", fs.discrete.width, fs.discrete.height);
				describe_intervals(fd, fs.pixel_format, fs.discrete.width, fs.discrete.height, buf, n);
			} else {
				appendf(buf, n, " %ux%u-%ux%u", fs.stepwise.min_width, fs.stepwise.min_height,
					fs.stepwise.max_width, fs.stepwise.max_height);
				break;
			}
		}
	}
	if (!listed)
		appendf(buf, n, "no format mocapd takes (YUYV, MJPEG, GREY)");
	if (others[0])
		appendf(buf, n, "; formats mocapd does not take:%s", others);
}

/* ---- format negotiation ---- */

static int mode_error(drv_v4l2 *v, int status, char *err, size_t errlen, const char *what)
{
	char modes[1024];
	drv_v4l2_describe_modes(v->fd, modes, sizeof modes);
	return drv_errf(err, errlen, status, "%s: %s (%s): %s; it offers: %s", v->drv, v->path, v->card, what,
			modes);
}

/* Chooses the pixel format: the configured one, else the current one if
 * this driver takes it, else the first the device lists that it takes. */
static int choose_fourcc(drv_v4l2 *v, const drv_v4l2_settings *s, uint32_t current, uint32_t *out, char *err,
			 size_t errlen)
{
	struct v4l2_fmtdesc d;
	memset(&d, 0, sizeof d);
	d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	uint32_t first_supported = 0;
	bool offered = false;
	for (d.index = 0; xioctl(v->fd, VIDIOC_ENUM_FMT, &d) == 0; d.index++) {
		if (s->fourcc && (d.pixelformat == s->fourcc ||
				  (s->fourcc == V4L2_PIX_FMT_MJPEG && d.pixelformat == V4L2_PIX_FMT_JPEG))) {
			*out = d.pixelformat;
			offered = true;
		}
		if (!first_supported && format_index(d.pixelformat) >= 0)
			first_supported = d.pixelformat;
	}
	if (s->fourcc) {
		if (!offered) {
			char what[96], cc[5];
			fourcc_str(s->fourcc, cc);
			snprintf(what, sizeof what, "pixel_format %s is not offered", cc);
			return mode_error(v, MDRV_ERR_FORMAT, err, errlen, what);
		}
		return MDRV_OK;
	}
	if (format_index(current) >= 0) {
		*out = current;
		return MDRV_OK;
	}
	if (!first_supported)
		return mode_error(v, MDRV_ERR_FORMAT, err, errlen, "no pixel format mocapd can take (YUYV, MJPEG, GREY)");
	*out = first_supported;
	return MDRV_OK;
}

static int negotiate_format(drv_v4l2 *v, const drv_v4l2_settings *s, char *err, size_t errlen)
{
	struct v4l2_format f;
	memset(&f, 0, sizeof f);
	f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	if (xioctl(v->fd, VIDIOC_G_FMT, &f) < 0)
		return drv_errf(err, errlen, errno_status(errno), "%s: %s: VIDIOC_G_FMT: %s", v->drv, v->path,
				strerror(errno));
	uint32_t fourcc = 0;
	int st = choose_fourcc(v, s, f.fmt.pix.pixelformat, &fourcc, err, errlen);
	if (st)
		return st;
	uint32_t want_w = s->width ? s->width : f.fmt.pix.width;
	uint32_t want_h = s->height ? s->height : f.fmt.pix.height;
	f.fmt.pix.pixelformat = fourcc;
	f.fmt.pix.width = want_w;
	f.fmt.pix.height = want_h;
	f.fmt.pix.field = V4L2_FIELD_NONE;
	f.fmt.pix.bytesperline = 0;
	if (xioctl(v->fd, VIDIOC_S_FMT, &f) < 0) {
		if (errno == EBUSY)
			return drv_errf(err, errlen, MDRV_ERR_IO,
					"%s: %s: the device is busy (another program is streaming from it)", v->drv,
					v->path);
		return drv_errf(err, errlen, errno_status(errno), "%s: %s: VIDIOC_S_FMT: %s", v->drv, v->path,
				strerror(errno));
	}
	if (f.fmt.pix.pixelformat != fourcc || (s->width && (f.fmt.pix.width != want_w || f.fmt.pix.height != want_h))) {
		char what[128];
		snprintf(what, sizeof what, "asked for %ux%u, the device gives %ux%u", want_w, want_h,
			 f.fmt.pix.width, f.fmt.pix.height);
		return mode_error(v, MDRV_ERR_FORMAT, err, errlen, what);
	}
	v->fourcc = fourcc;
	v->fmt.pixfmt = formats[format_index(fourcc)].fmt;
	v->fmt.width = f.fmt.pix.width;
	v->fmt.height = f.fmt.pix.height;
	bool compressed = v->fmt.pixfmt == MC_PIXFMT_MJPEG;
	unsigned bpp = v->fmt.pixfmt == MC_PIXFMT_YUYV ? 2 : 1;
	v->fmt.stride = compressed ? 0 : (f.fmt.pix.bytesperline ? f.fmt.pix.bytesperline : v->fmt.width * bpp);
	v->fmt.max_bytes = f.fmt.pix.sizeimage;
	if (!compressed && v->fmt.max_bytes < (size_t)v->fmt.stride * v->fmt.height)
		v->fmt.max_bytes = (size_t)v->fmt.stride * v->fmt.height;
	return MDRV_OK;
}

static int negotiate_frame_rate(drv_v4l2 *v, const drv_v4l2_settings *s, char *err, size_t errlen)
{
	struct v4l2_streamparm p;
	memset(&p, 0, sizeof p);
	p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	bool can_set = xioctl(v->fd, VIDIOC_G_PARM, &p) == 0 && (p.parm.capture.capability & V4L2_CAP_TIMEPERFRAME);
	if (s->fps > 0) {
		if (!can_set)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG,
					"%s: %s (%s): config key 'fps': the device's frame rate cannot be set", v->drv,
					v->path, v->card);
		memset(&p, 0, sizeof p);
		p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
		p.parm.capture.timeperframe.numerator = 1000;
		p.parm.capture.timeperframe.denominator = (uint32_t)lround(s->fps * 1000);
		if (xioctl(v->fd, VIDIOC_S_PARM, &p) < 0)
			return drv_errf(err, errlen, errno_status(errno), "%s: %s: VIDIOC_S_PARM: %s", v->drv, v->path,
					strerror(errno));
		struct v4l2_fract t = p.parm.capture.timeperframe;
		double got = t.numerator ? (double)t.denominator / t.numerator : 0;
		if (fabs(got - s->fps) > 0.01 * s->fps) {
			char what[128];
			snprintf(what, sizeof what, "asked for %g fps at %ux%u, the device gives %g", s->fps,
				 v->fmt.width, v->fmt.height, got);
			return mode_error(v, MDRV_ERR_FORMAT, err, errlen, what);
		}
	}
	memset(&p, 0, sizeof p);
	p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	if (xioctl(v->fd, VIDIOC_G_PARM, &p) == 0 && p.parm.capture.timeperframe.numerator)
		v->fmt.fps = (double)p.parm.capture.timeperframe.denominator / p.parm.capture.timeperframe.numerator;
	return MDRV_OK;
}

/* ---- controls ---- */

/* Looks a control up; 0 if the device has it enabled. */
static int query_ctrl(int fd, uint32_t id, struct v4l2_queryctrl *q)
{
	memset(q, 0, sizeof *q);
	q->id = id;
	if (xioctl(fd, VIDIOC_QUERYCTRL, q) < 0 || (q->flags & V4L2_CTRL_FLAG_DISABLED))
		return -1;
	return 0;
}

static int set_ctrl(drv_v4l2 *v, const struct v4l2_queryctrl *q, int64_t value, const char *key, char *err,
		    size_t errlen)
{
	if (value < q->minimum || value > q->maximum)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: %s (%s): config key '%s': %lld outside the control's range [%d, %d]", v->drv,
				v->path, v->card, key, (long long)value, q->minimum, q->maximum);
	struct v4l2_control c = {.id = q->id, .value = (int32_t)value};
	if (xioctl(v->fd, VIDIOC_S_CTRL, &c) < 0)
		return drv_errf(err, errlen, errno == EACCES || errno == EBUSY ? MDRV_ERR_CONFIG : errno_status(errno),
				"%s: %s (%s): config key '%s': setting control '%s' to %lld: %s", v->drv, v->path,
				v->card, key, (const char *)q->name, (long long)value, strerror(errno));
	return MDRV_OK;
}

/* Sets control `id` if the device has it; missing and required is an error. */
static int set_ctrl_id(drv_v4l2 *v, uint32_t id, int64_t value, bool required, const char *key, const char *what,
		       char *err, size_t errlen)
{
	struct v4l2_queryctrl q;
	if (query_ctrl(v->fd, id, &q) != 0) {
		if (!required)
			return MDRV_OK;
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: %s (%s): config key '%s': the device has no %s control",
				v->drv, v->path, v->card, key, what);
	}
	return set_ctrl(v, &q, value, key, err, errlen);
}

/* True if menu control `id` has entry `value`. */
static bool menu_has(int fd, uint32_t id, int value)
{
	struct v4l2_querymenu m;
	memset(&m, 0, sizeof m);
	m.id = id;
	m.index = (uint32_t)value;
	return xioctl(fd, VIDIOC_QUERYMENU, &m) == 0;
}

static int apply_exposure(drv_v4l2 *v, const drv_auto_value *e, char *err, size_t errlen)
{
	if (!e->present)
		return MDRV_OK;
	if (e->is_auto) {
		/* webcams usually offer aperture priority as their "auto" */
		int mode = menu_has(v->fd, V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_APERTURE_PRIORITY)
				   ? V4L2_EXPOSURE_APERTURE_PRIORITY
				   : V4L2_EXPOSURE_AUTO;
		return set_ctrl_id(v, V4L2_CID_EXPOSURE_AUTO, mode, true, "exposure", "automatic exposure", err, errlen);
	}
	int st = set_ctrl_id(v, V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL, false, "exposure", "", err, errlen);
	if (st)
		return st;
	/* V4L2_CID_EXPOSURE_ABSOLUTE counts 100 microsecond units */
	return set_ctrl_id(v, V4L2_CID_EXPOSURE_ABSOLUTE, llround(e->value * 1e4), true, "exposure",
			   "absolute exposure", err, errlen);
}

static int apply_gain(drv_v4l2 *v, const drv_auto_value *g, char *err, size_t errlen)
{
	if (!g->present)
		return MDRV_OK;
	if (g->is_auto)
		return set_ctrl_id(v, V4L2_CID_AUTOGAIN, 1, true, "gain", "automatic gain", err, errlen);
	int st = set_ctrl_id(v, V4L2_CID_AUTOGAIN, 0, false, "gain", "", err, errlen);
	return st ? st : set_ctrl_id(v, V4L2_CID_GAIN, llround(g->value), true, "gain", "gain", err, errlen);
}

static int apply_white_balance(drv_v4l2 *v, const drv_auto_value *w, char *err, size_t errlen)
{
	if (!w->present)
		return MDRV_OK;
	if (w->is_auto)
		return set_ctrl_id(v, V4L2_CID_AUTO_WHITE_BALANCE, 1, true, "white_balance", "automatic white balance",
				   err, errlen);
	int st = set_ctrl_id(v, V4L2_CID_AUTO_WHITE_BALANCE, 0, false, "white_balance", "", err, errlen);
	return st ? st
		  : set_ctrl_id(v, V4L2_CID_WHITE_BALANCE_TEMPERATURE, llround(w->value), true, "white_balance",
				"white balance temperature", err, errlen);
}

/* "White Balance Temperature, Auto" -> "white_balance_temperature_auto" */
static void control_key(const char *name, char *out, size_t n)
{
	size_t j = snprintf(out, n, "ctrl.");
	bool sep = false;
	for (const char *p = name; *p && j + 1 < n; p++) {
		if (isalnum((unsigned char)*p)) {
			if (sep && j > 5)
				out[j++] = '_';
			if (j + 1 < n)
				out[j++] = (char)tolower((unsigned char)*p);
			sep = false;
		} else {
			sep = true;
		}
	}
	out[j] = 0;
}

/* Parses a ctrl.* value: an integer, true/false for booleans, or a menu
 * entry's name. */
static int parse_control_value(drv_v4l2 *v, const struct v4l2_queryctrl *q, const char *key, const char *val,
			       int64_t *out, char *err, size_t errlen)
{
	char *end;
	errno = 0;
	long long n = strtoll(val, &end, 0);
	if (!errno && end != val && !*end) {
		*out = n;
		return MDRV_OK;
	}
	if (q->type == V4L2_CTRL_TYPE_BOOLEAN) {
		if (!strcasecmp(val, "true") || !strcasecmp(val, "on") || !strcasecmp(val, "yes")) {
			*out = 1;
			return MDRV_OK;
		}
		if (!strcasecmp(val, "false") || !strcasecmp(val, "off") || !strcasecmp(val, "no")) {
			*out = 0;
			return MDRV_OK;
		}
	}
	if (q->type == V4L2_CTRL_TYPE_MENU) {
		struct v4l2_querymenu m;
		for (int i = q->minimum; i <= q->maximum; i++) {
			memset(&m, 0, sizeof m);
			m.id = q->id;
			m.index = (uint32_t)i;
			if (xioctl(v->fd, VIDIOC_QUERYMENU, &m) == 0 && !strcasecmp((const char *)m.name, val)) {
				*out = i;
				return MDRV_OK;
			}
		}
	}
	return drv_errf(err, errlen, MDRV_ERR_CONFIG,
			"%s: %s (%s): config key '%s': '%s' is not a value of control '%s'", v->drv, v->path, v->card,
			key, val, (const char *)q->name);
}

/* Applies every ctrl.NAME key that names one of the device's controls. */
static int apply_named_controls(drv_v4l2 *v, char *err, size_t errlen)
{
	struct v4l2_queryctrl q;
	memset(&q, 0, sizeof q);
	q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
	while (xioctl(v->fd, VIDIOC_QUERYCTRL, &q) == 0) {
		uint32_t id = q.id;
		bool settable = q.type == V4L2_CTRL_TYPE_INTEGER || q.type == V4L2_CTRL_TYPE_BOOLEAN ||
				q.type == V4L2_CTRL_TYPE_MENU || q.type == V4L2_CTRL_TYPE_INTEGER_MENU;
		if (settable && !(q.flags & (V4L2_CTRL_FLAG_DISABLED | V4L2_CTRL_FLAG_READ_ONLY))) {
			char key[64];
			control_key((const char *)q.name, key, sizeof key);
			const char *val = drv_cfg_str(&v->host, key);
			if (val) {
				int64_t value = 0;
				int st = parse_control_value(v, &q, key, val, &value, err, errlen);
				if (st || (st = set_ctrl(v, &q, value, key, err, errlen)))
					return st;
				drv_logf(&v->host, MDRV_LOG_DEBUG, "%s: %s: %s = %lld", v->drv, v->path, key,
					 (long long)value);
			}
		}
		memset(&q, 0, sizeof q);
		q.id = id | V4L2_CTRL_FLAG_NEXT_CTRL;
	}
	return MDRV_OK;
}

/* ---- open / stream / close ---- */

drv_v4l2 *drv_v4l2_open(const char *path, const drv_v4l2_settings *s, const mdrv_host *host, const char *drv,
			int *status, char *err, size_t errlen)
{
	drv_v4l2 *v = calloc(1, sizeof *v);
	if (!v) {
		*status = drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", drv);
		return NULL;
	}
	v->drv = drv;
	v->host = *host;
	v->n_requested = s->buffers ? s->buffers : 4;
	drv_strlcpy(v->path, path, sizeof v->path);
	v->fd = open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
	if (v->fd < 0) {
		int e = errno;
		*status = drv_errf(err, errlen, errno_status(e), "%s: cannot open %s: %s%s", drv, path, strerror(e),
				   e == EACCES ? " (is the user in the 'video' group?)" : "");
		free(v);
		return NULL;
	}
	struct v4l2_capability cap;
	memset(&cap, 0, sizeof cap);
	if (xioctl(v->fd, VIDIOC_QUERYCAP, &cap) < 0) {
		*status = drv_errf(err, errlen, errno == ENOTTY ? MDRV_ERR_CONFIG : errno_status(errno),
				   "%s: %s is not a V4L2 device: %s", drv, path, strerror(errno));
		goto fail;
	}
	drv_strlcpy(v->card, (const char *)cap.card, sizeof v->card);
	uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
	if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
		*status = drv_errf(err, errlen, MDRV_ERR_CONFIG,
				   "%s: %s (%s) is not a video capture node with streaming (capabilities 0x%08x)",
				   drv, path, v->card, caps);
		goto fail;
	}
	if ((*status = negotiate_format(v, s, err, errlen)) || (*status = negotiate_frame_rate(v, s, err, errlen)) ||
	    (*status = apply_exposure(v, &s->exposure, err, errlen)) ||
	    (*status = apply_gain(v, &s->gain, err, errlen)) ||
	    (*status = apply_white_balance(v, &s->white_balance, err, errlen)) ||
	    (*status = apply_named_controls(v, err, errlen)))
		goto fail;
	char modes[1024];
	drv_v4l2_describe_modes(v->fd, modes, sizeof modes);
	drv_logf(host, MDRV_LOG_DEBUG, "%s: %s (%s, %s) offers %s", drv, path, v->card, (const char *)cap.bus_info,
		 modes);
	drv_logf(host, MDRV_LOG_INFO, "%s: opened %s (%s): %s %ux%u, %.4g fps", drv, path, v->card,
		 mc_pixfmt_name(v->fmt.pixfmt), v->fmt.width, v->fmt.height, v->fmt.fps);
	*status = MDRV_OK;
	return v;
fail:
	close(v->fd);
	free(v);
	return NULL;
}

void drv_v4l2_get_format(const drv_v4l2 *v, mdrv_format *fmt)
{
	*fmt = v->fmt;
}

static void unmap_buffers(drv_v4l2 *v)
{
	for (unsigned i = 0; i < v->n_bufs; i++)
		if (v->bufs[i].start != MAP_FAILED && v->bufs[i].start)
			munmap(v->bufs[i].start, v->bufs[i].length);
	v->n_bufs = 0;
	if (!v->gone) {
		struct v4l2_requestbuffers rb = {.count = 0, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
		xioctl(v->fd, VIDIOC_REQBUFS, &rb);
	}
}

int drv_v4l2_start(drv_v4l2 *v, char *err, size_t errlen)
{
	if (v->streaming)
		return MDRV_OK;
	if (v->gone)
		return drv_errf(err, errlen, MDRV_ERR_NODEV, "%s: %s (%s) was unplugged", v->drv, v->path, v->card);
	struct v4l2_requestbuffers rb = {.count = v->n_requested, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE,
					 .memory = V4L2_MEMORY_MMAP};
	if (xioctl(v->fd, VIDIOC_REQBUFS, &rb) < 0)
		return drv_errf(err, errlen, errno_status(errno), "%s: %s: VIDIOC_REQBUFS: %s", v->drv, v->path,
				strerror(errno));
	if (rb.count < 2 || rb.count > MAX_BUFFERS)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s: the driver granted %u buffers", v->drv, v->path,
				rb.count);
	for (unsigned i = 0; i < rb.count; i++) {
		struct v4l2_buffer b = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
		if (xioctl(v->fd, VIDIOC_QUERYBUF, &b) < 0)
			goto io_error;
		v->bufs[i].length = b.length;
		v->bufs[i].start = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, v->fd, b.m.offset);
		v->n_bufs = i + 1;
		if (v->bufs[i].start == MAP_FAILED)
			goto io_error;
		if (xioctl(v->fd, VIDIOC_QBUF, &b) < 0)
			goto io_error;
	}
	enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	if (xioctl(v->fd, VIDIOC_STREAMON, &type) < 0)
		goto io_error;
	v->streaming = true;
	v->have_seq = false;
	return MDRV_OK;
io_error:;
	int e = errno;
	unmap_buffers(v);
	return drv_errf(err, errlen, errno_status(e), "%s: %s: starting the stream: %s", v->drv, v->path, strerror(e));
}

static int gone_error(drv_v4l2 *v, char *err, size_t errlen)
{
	v->gone = true;
	return drv_errf(err, errlen, MDRV_ERR_NODEV, "%s: %s (%s) was unplugged", v->drv, v->path, v->card);
}

/* Extends the driver's 32-bit frame counter to 64 bits, strictly
 * increasing: a device that repeats or restarts its count (vivid does when
 * its thread falls behind) advances it by one, so that readers never see a
 * sequence number go backwards; real gaps still show as jumps. */
static uint64_t extend_sequence(drv_v4l2 *v, uint32_t seq32)
{
	if (!v->have_seq) {
		v->have_seq = true;
		v->seq = seq32;
	} else {
		uint32_t step = seq32 - v->last_seq32;
		v->seq += (step == 0 || step > 0x80000000u) ? 1 : step;
	}
	v->last_seq32 = seq32;
	return v->seq;
}

int drv_v4l2_next_frame(drv_v4l2 *v, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	if (v->gone)
		return gone_error(v, err, errlen);
	if (!v->streaming)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s: next_frame before start", v->drv, v->path);
	struct pollfd p = {.fd = v->fd, .events = POLLIN};
	uint64_t deadline = mc_now_ns() + (uint64_t)(timeout_ms > 0 ? timeout_ms : 0) * 1000000u;
	for (;;) {
		uint64_t now = mc_now_ns();
		int wait_ms = now >= deadline ? 0 : (int)((deadline - now + 999999) / 1000000);
		int r = poll(&p, 1, wait_ms);
		if (r < 0 && errno == EINTR)
			continue;
		if (r < 0)
			return drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s: poll: %s", v->drv, v->path, strerror(errno));
		if (r == 0)
			return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, "%s: %s: no frame within %d ms", v->drv, v->path,
					timeout_ms);
		if (p.revents & POLLHUP)
			return gone_error(v, err, errlen);
		break; /* readable, or POLLERR: DQBUF says which */
	}
	struct v4l2_buffer b = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
	if (xioctl(v->fd, VIDIOC_DQBUF, &b) < 0) {
		int e = errno;
		if (e == EAGAIN)
			return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, "%s: %s: no frame ready", v->drv, v->path);
		if (e == ENODEV || e == ENXIO)
			return gone_error(v, err, errlen);
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s: VIDIOC_DQBUF: %s", v->drv, v->path, strerror(e));
	}
	uint64_t dequeued_ns = mc_now_ns();
	int status = MDRV_OK;
	size_t used = b.bytesused ? b.bytesused : (b.index < v->n_bufs ? v->bufs[b.index].length : 0);
	if (b.index >= v->n_bufs || used > v->bufs[b.index].length) {
		status = drv_errf(err, errlen, MDRV_ERR_IO, "%s: %s: the driver returned a bad buffer", v->drv,
				  v->path);
	} else if (used > slot->capacity) {
		status = drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: %s: frame of %zu bytes, slot holds %zu", v->drv,
				  v->path, used, slot->capacity);
	} else {
		memcpy(slot->data, v->bufs[b.index].start, used);
		slot->bytesused = used;
		slot->format = v->fmt;
		slot->flags = 0;
		if (b.flags & V4L2_BUF_FLAG_ERROR) {
			slot->flags |= MDRV_FRAME_CORRUPT;
			if (v->corrupt_frames++ % 100 == 0)
				drv_logf(&v->host, MDRV_LOG_WARN, "%s: %s: the driver flagged a damaged frame", v->drv,
					 v->path);
		}
		if (v->fmt.stride && used < (size_t)v->fmt.stride * v->fmt.height)
			slot->flags |= MDRV_FRAME_SHORT;
		if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC)
			slot->timestamp_ns = (uint64_t)b.timestamp.tv_sec * 1000000000u +
					     (uint64_t)b.timestamp.tv_usec * 1000u;
		else
			slot->timestamp_ns = dequeued_ns;
		slot->sequence = extend_sequence(v, b.sequence);
	}
	if (xioctl(v->fd, VIDIOC_QBUF, &b) < 0 && status == MDRV_OK) {
		int e = errno;
		if (e == ENODEV || e == ENXIO)
			return gone_error(v, err, errlen);
		/* the frame is good; the lost buffer shows up later as a stall */
		drv_logf(&v->host, MDRV_LOG_WARN, "%s: %s: VIDIOC_QBUF: %s", v->drv, v->path, strerror(e));
	}
	return status;
}

void drv_v4l2_stop(drv_v4l2 *v)
{
	if (!v->streaming)
		return;
	enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	if (!v->gone)
		xioctl(v->fd, VIDIOC_STREAMOFF, &type);
	unmap_buffers(v);
	v->streaming = false;
}

void drv_v4l2_close(drv_v4l2 *v)
{
	if (!v)
		return;
	drv_v4l2_stop(v);
	close(v->fd);
	free(v);
}

/* ---- enumeration ---- */

static int node_number(const char *name)
{
	if (strncmp(name, "video", 5) != 0 || !isdigit((unsigned char)name[5]))
		return -1;
	char *end;
	long n = strtol(name + 5, &end, 10);
	return *end ? -1 : (int)n;
}

static int cmp_int(const void *a, const void *b)
{
	return *(const int *)a - *(const int *)b;
}

int drv_v4l2_list(const char *dev_dir, const char *sysfs_root, drv_v4l2_node *out, int max)
{
	DIR *d = opendir(dev_dir);
	if (!d)
		return 0;
	int nums[256], n_nums = 0;
	struct dirent *e;
	while ((e = readdir(d)) && n_nums < 256) {
		int num = node_number(e->d_name);
		if (num >= 0)
			nums[n_nums++] = num;
	}
	closedir(d);
	qsort(nums, (size_t)n_nums, sizeof nums[0], cmp_int);
	int found = 0;
	for (int i = 0; i < n_nums && found < max; i++) {
		char path[64];
		snprintf(path, sizeof path, "%s/video%d", dev_dir, nums[i]);
		int fd = open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
		if (fd < 0)
			continue;
		struct v4l2_capability cap;
		memset(&cap, 0, sizeof cap);
		int ok = xioctl(fd, VIDIOC_QUERYCAP, &cap) == 0;
		close(fd);
		uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
		if (!ok || !(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING))
			continue;
		drv_v4l2_node *o = &out[found++];
		memset(o, 0, sizeof *o);
		drv_strlcpy(o->path, path, sizeof o->path);
		drv_strlcpy(o->card, (const char *)cap.card, sizeof o->card);
		drv_strlcpy(o->driver, (const char *)cap.driver, sizeof o->driver);
		drv_strlcpy(o->bus_info, (const char *)cap.bus_info, sizeof o->bus_info);
		char node[32];
		snprintf(node, sizeof node, "video%d", nums[i]);
		drv_usb_video_info usb;
		if (drv_sysfs_video_usb_info(sysfs_root, node, &usb) == 0)
			drv_strlcpy(o->serial, usb.serial, sizeof o->serial);
	}
	return found;
}
