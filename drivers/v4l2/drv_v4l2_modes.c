/* drv_v4l2_modes: the modes of a V4L2 capture node as mdrv_mode entries,
 * for mocapd --probe (mdrv_driver.modes).  Only the formats this driver
 * delivers are listed, by the name its `pixel_format` key takes, so that
 * what --probe prints can be pasted into the config as it is.  A separate
 * file from drv_v4l2.c, which negotiates and streams. */
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <string.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include "drv_v4l2.h"

static const struct {
	uint32_t fourcc;
	const char *key; /* the pixel_format value */
	uint32_t pixfmt;
} taken[] = {
	{V4L2_PIX_FMT_YUYV, "YUYV", MC_PIXFMT_YUYV},
	{V4L2_PIX_FMT_MJPEG, "MJPEG", MC_PIXFMT_MJPEG},
	{V4L2_PIX_FMT_JPEG, "MJPEG", MC_PIXFMT_MJPEG},
	{V4L2_PIX_FMT_GREY, "GREY", MC_PIXFMT_GRAY8},
};

static int ioctl_retry(int fd, unsigned long req, void *arg)
{
	int r;
	do
		r = ioctl(fd, req, arg);
	while (r < 0 && errno == EINTR);
	return r;
}

static double interval_fps(const struct v4l2_fract *f)
{
	return f->numerator ? (double)f->denominator / f->numerator : 0;
}

/* The rates of one size into m: discrete ones, or a continuous range. */
static void fill_rates(int fd, uint32_t fourcc, mdrv_mode *m)
{
	struct v4l2_frmivalenum iv;
	memset(&iv, 0, sizeof iv);
	iv.pixel_format = fourcc;
	iv.width = m->width;
	iv.height = m->height;
	for (iv.index = 0; ioctl_retry(fd, VIDIOC_ENUM_FRAMEINTERVALS, &iv) == 0; iv.index++) {
		if (iv.type != V4L2_FRMIVAL_TYPE_DISCRETE) {
			m->nfps = 0;
			m->fps_min = interval_fps(&iv.stepwise.max);
			m->fps_max = interval_fps(&iv.stepwise.min);
			return;
		}
		if (m->nfps >= MDRV_MODE_RATES)
			break;
		/* Kept highest first: devices list intervals shortest first,
		 * but not all of them. */
		double fps = interval_fps(&iv.discrete);
		uint32_t k = m->nfps++;
		while (k > 0 && m->fps[k - 1] < fps) {
			m->fps[k] = m->fps[k - 1];
			k--;
		}
		m->fps[k] = fps;
	}
}

/* Appends the sizes of one format; returns the new count. */
static int add_sizes(int fd, int f, mdrv_mode *out, int n, int max)
{
	struct v4l2_frmsizeenum fs;
	memset(&fs, 0, sizeof fs);
	fs.pixel_format = taken[f].fourcc;
	for (fs.index = 0; n < max && ioctl_retry(fd, VIDIOC_ENUM_FRAMESIZES, &fs) == 0; fs.index++) {
		mdrv_mode *m = &out[n++];
		memset(m, 0, sizeof *m);
		drv_strlcpy(m->pixel_format, taken[f].key, sizeof m->pixel_format);
		m->pixfmt = taken[f].pixfmt;
		if (fs.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
			m->width = fs.discrete.width;
			m->height = fs.discrete.height;
		} else { /* stepwise or continuous: the largest size stands for them */
			m->width = fs.stepwise.max_width;
			m->height = fs.stepwise.max_height;
		}
		fill_rates(fd, fs.pixel_format, m);
		if (fs.type != V4L2_FRMSIZE_TYPE_DISCRETE)
			break;
	}
	return n;
}

int drv_v4l2_modes(const char *path, const char *drv, mdrv_mode *out, int max, char *err, size_t errlen)
{
	int fd = open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
	if (fd < 0)
		return drv_errf(err, errlen, errno == ENOENT ? MDRV_ERR_NODEV : MDRV_ERR_IO, "%s: %s: %s", drv, path,
				strerror(errno));
	int n = 0;
	struct v4l2_fmtdesc desc;
	memset(&desc, 0, sizeof desc);
	desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
	for (desc.index = 0; n < max && ioctl_retry(fd, VIDIOC_ENUM_FMT, &desc) == 0; desc.index++)
		for (int f = 0; f < (int)(sizeof taken / sizeof taken[0]); f++)
			if (taken[f].fourcc == desc.pixelformat)
				n = add_sizes(fd, f, out, n, max);
	close(fd);
	return n;
}
