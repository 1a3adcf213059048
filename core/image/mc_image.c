/* mc_image: pixel-format conversion to RGB24 and area-averaging resize. */
#include "image/mc_image.h"

#include "image/mc_pixfmt.h"
#include "base/mc_file.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <png.h>
#include <stdio.h>
#include <sys/stat.h>
#include <turbojpeg.h>

#define MAX_SIDE 32768 /* larger images are refused: sizes come from foreign input */
/* Nor more pixels than this (8192 x 8192, twice 8K UHD): a 14 KB JPEG may
 * claim 32768 x 32768, which would be a 3 GB buffer and seconds of CPU
 * per frame (issue 20, defect 3). */
#define MAX_PIXELS (8192ll * 8192ll)

/* Whether a size from foreign input is one to decode. */
static bool decodable_size(long long w, long long h)
{
	return w > 0 && h > 0 && w <= MAX_SIDE && h <= MAX_SIDE && w * h <= MAX_PIXELS;
}

struct mc_image_conv {
	tjhandle dec; /* created on first use */
	tjhandle enc;
};

mc_image_conv *mc_image_conv_new(mc_err *err)
{
	mc_image_conv *c = calloc(1, sizeof(*c));
	if (!c)
		mc_err_set(err, "image converter: out of memory");
	return c;
}

void mc_image_conv_free(mc_image_conv *conv)
{
	if (!conv)
		return;
	if (conv->dec)
		tjDestroy(conv->dec);
	if (conv->enc)
		tjDestroy(conv->enc);
	free(conv);
}

int mc_image_bytes_per_pixel(uint32_t pixfmt)
{
	switch (pixfmt) {
	case MC_PIXFMT_RGB24:
		return 3;
	case MC_PIXFMT_YUYV:
	case MC_PIXFMT_DEPTH16:
		return 2;
	case MC_PIXFMT_GRAY8:
	case MC_PIXFMT_BAYER_RGGB8:
	case MC_PIXFMT_BAYER_GRBG8:
	case MC_PIXFMT_BAYER_GBRG8:
	case MC_PIXFMT_BAYER_BGGR8:
		return 1;
	default:
		return 0;
	}
}

static uint8_t clamp_u8(int v) { return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v); }

/* ---- JPEG ---- */

static tjhandle decoder(mc_image_conv *conv, mc_err *err)
{
	if (!conv->dec && !(conv->dec = tjInitDecompress()))
		mc_err_set(err, "MJPEG: cannot create a decoder: %s", tjGetErrorStr2(NULL));
	return conv->dec;
}

/* After a failed decode the handle can keep state that breaks the next
 * image (seen with libjpeg-turbo 2.1): start over with a fresh one. */
static void reset_decoder(mc_image_conv *conv)
{
	tjDestroy(conv->dec);
	conv->dec = NULL;
}

int mc_image_jpeg_size(mc_image_conv *conv, const uint8_t *jpeg, size_t bytes, int *width, int *height, mc_err *err)
{
	tjhandle h = decoder(conv, err);
	if (!h)
		return -1;
	if (bytes < 4 || jpeg[0] != 0xFF || jpeg[1] != 0xD8)
		return mc_err_set(err, "MJPEG: %zu bytes: not a JPEG image (no SOI marker)", bytes);
	if (bytes > ULONG_MAX)
		return mc_err_set(err, "MJPEG: %zu bytes: too large", bytes);
	int subsamp, colorspace;
	/* A tables-only JPEG, or one cut before its SOF, passes the header
	 * call without setting the size: start from 0 so that it is refused
	 * below, not read as whatever was on the stack. */
	*width = *height = 0;
	if (tjDecompressHeader3(h, jpeg, (unsigned long)bytes, width, height, &subsamp, &colorspace) != 0) {
		mc_err_set(err, "MJPEG: %zu bytes: bad header: %s", bytes, tjGetErrorStr2(h));
		reset_decoder(conv);
		return -1;
	}
	if (!decodable_size(*width, *height))
		return mc_err_set(err, "MJPEG: image size %dx%d out of range", *width, *height);
	return 0;
}

static int jpeg_to_rgb(mc_image_conv *conv, const mc_image_frame *f, uint8_t *dst, size_t dst_bytes, mc_err *err)
{
	int w, h;
	if (mc_image_jpeg_size(conv, f->data, f->bytes, &w, &h, err) != 0)
		return -1;
	if ((f->width || f->height) && ((uint32_t)w != f->width || (uint32_t)h != f->height))
		return mc_err_set(err, "MJPEG: the JPEG is %dx%d, the frame is declared %ux%u", w, h, f->width,
				  f->height);
	if ((size_t)w * (size_t)h * 3 > dst_bytes)
		return mc_err_set(err, "MJPEG: %dx%d RGB needs %zu bytes, the buffer holds %zu", w, h,
				  (size_t)w * (size_t)h * 3, dst_bytes);
	/* Any warning (a truncated or damaged stream) rejects the frame: a
	 * half-grey image would mislead the tracker. */
	if (tjDecompress2(conv->dec, f->data, (unsigned long)f->bytes, dst, w, 0, h, TJPF_RGB, 0) != 0) {
		mc_err_set(err, "MJPEG: %zu-byte %dx%d image does not decode: %s", f->bytes, w, h,
			   tjGetErrorStr2(conv->dec));
		reset_decoder(conv);
		return -1;
	}
	return 0;
}

int mc_image_encode_jpeg(mc_image_conv *conv, const uint8_t *rgb, int width, int height, int quality,
			 uint8_t **jpeg, size_t *bytes, mc_err *err)
{
	if (width <= 0 || height <= 0 || width > MAX_SIDE || height > MAX_SIDE || quality < 1 || quality > 100)
		return mc_err_set(err, "JPEG encode: bad size %dx%d or quality %d", width, height, quality);
	if (!conv->enc && !(conv->enc = tjInitCompress()))
		return mc_err_set(err, "JPEG encode: cannot create an encoder: %s", tjGetErrorStr2(NULL));
	unsigned char *out = NULL;
	unsigned long n = 0;
	if (tjCompress2(conv->enc, rgb, width, 0, height, TJPF_RGB, &out, &n, TJSAMP_444, quality, 0) != 0) {
		tjFree(out);
		return mc_err_set(err, "JPEG encode: %s", tjGetErrorStr2(conv->enc));
	}
	*jpeg = malloc(n);
	if (!*jpeg) {
		tjFree(out);
		return mc_err_set(err, "JPEG encode: out of memory");
	}
	memcpy(*jpeg, out, n);
	*bytes = n;
	tjFree(out);
	return 0;
}

/* ---- uncompressed formats ---- */

static void gray_to_rgb(const mc_image_frame *f, size_t stride, uint8_t *dst)
{
	for (uint32_t y = 0; y < f->height; y++) {
		const uint8_t *s = f->data + y * stride;
		uint8_t *d = dst + (size_t)y * f->width * 3;
		for (uint32_t x = 0; x < f->width; x++, d += 3)
			d[0] = d[1] = d[2] = s[x];
	}
}

static void rgb_copy(const mc_image_frame *f, size_t stride, uint8_t *dst)
{
	size_t row = (size_t)f->width * 3;
	for (uint32_t y = 0; y < f->height; y++)
		memcpy(dst + y * row, f->data + y * stride, row);
}

/* BT.601 limited range, 8-bit fixed point (coefficients * 256). The bias
 * keeps the shifted value non-negative. */
static void yuv_to_rgb(int y, int u, int v, uint8_t *d)
{
	int c = 298 * (y - 16) + 128 + (256 << 8), du = u - 128, dv = v - 128;
	d[0] = clamp_u8(((c + 409 * dv) >> 8) - 256);
	d[1] = clamp_u8(((c - 100 * du - 208 * dv) >> 8) - 256);
	d[2] = clamp_u8(((c + 516 * du) >> 8) - 256);
}

static void yuyv_to_rgb(const mc_image_frame *f, size_t stride, uint8_t *dst)
{
	for (uint32_t y = 0; y < f->height; y++) {
		const uint8_t *s = f->data + y * stride;
		uint8_t *d = dst + (size_t)y * f->width * 3;
		for (uint32_t x = 0; x < f->width; x += 2, s += 4, d += 6) {
			yuv_to_rgb(s[0], s[1], s[3], d);
			yuv_to_rgb(s[2], s[1], s[3], d + 3);
		}
	}
}

static void depth_to_rgb(const mc_image_frame *f, size_t stride, uint8_t *dst)
{
	uint16_t lo = UINT16_MAX, hi = 0;
	for (uint32_t y = 0; y < f->height; y++) {
		const uint8_t *s = f->data + y * stride;
		for (uint32_t x = 0; x < f->width; x++) {
			uint16_t d;
			memcpy(&d, s + 2 * x, 2);
			if (d) {
				lo = d < lo ? d : lo;
				hi = d > hi ? d : hi;
			}
		}
	}
	int range = hi > lo ? hi - lo : 1;
	for (uint32_t y = 0; y < f->height; y++) {
		const uint8_t *s = f->data + y * stride;
		uint8_t *o = dst + (size_t)y * f->width * 3;
		for (uint32_t x = 0; x < f->width; x++, o += 3) {
			uint16_t d;
			memcpy(&d, s + 2 * x, 2);
			/* near = 255, far = 32, no reading = 0 */
			uint8_t g = d ? (uint8_t)(32 + (hi - d) * 223 / range) : 0;
			o[0] = o[1] = o[2] = g;
		}
	}
}

/* Colour (0 R, 1 G, 2 B) of the Bayer cell at row parity r, column parity c. */
static const uint8_t bayer_cells[4][2][2] = {
	{{0, 1}, {1, 2}}, /* RGGB */
	{{1, 0}, {2, 1}}, /* GRBG */
	{{1, 2}, {0, 1}}, /* GBRG */
	{{2, 1}, {1, 0}}, /* BGGR */
};

/* Bilinear demosaic: a pixel keeps its own colour; each other colour is the
 * mean of that colour's pixels in the 3x3 neighbourhood (inside the image).
 * This is the general form, used along the border. */
static void bayer_pixel(const mc_image_frame *f, size_t stride, const uint8_t (*cell)[2], int x, int y, uint8_t *o)
{
	int w = (int)f->width, h = (int)f->height;
	int y0 = y > 0 ? y - 1 : y, y1 = y < h - 1 ? y + 1 : y;
	int x0 = x > 0 ? x - 1 : x, x1 = x < w - 1 ? x + 1 : x;
	int sum[3] = {0, 0, 0}, cnt[3] = {0, 0, 0};
	for (int yy = y0; yy <= y1; yy++) {
		const uint8_t *row = f->data + (size_t)yy * stride;
		for (int xx = x0; xx <= x1; xx++) {
			int c = cell[yy & 1][xx & 1];
			sum[c] += row[xx];
			cnt[c]++;
		}
	}
	int own = cell[y & 1][x & 1];
	for (int c = 0; c < 3; c++)
		o[c] = c == own ? f->data[(size_t)y * stride + (size_t)x]
				: (uint8_t)(cnt[c] ? (sum[c] + cnt[c] / 2) / cnt[c] : 0);
}

/* The same means inside the image, where every neighbour exists: at a green
 * pixel the other two colours are the horizontal and the vertical pair; at a
 * red or blue one green is the cross and the other colour the diagonals. */
static void bayer_interior_row(const uint8_t *up, const uint8_t *mid, const uint8_t *down, const uint8_t (*cell)[2],
			       int y, int w, uint8_t *o)
{
	for (int x = 1; x < w - 1; x++) {
		uint8_t *p = o + (size_t)x * 3;
		int own = cell[y & 1][x & 1];
		if (own == 1) {
			int horiz = cell[y & 1][(x + 1) & 1];
			p[1] = mid[x];
			p[horiz] = (uint8_t)((mid[x - 1] + mid[x + 1] + 1) / 2);
			p[2 - horiz] = (uint8_t)((up[x] + down[x] + 1) / 2);
		} else {
			p[own] = mid[x];
			p[1] = (uint8_t)((up[x] + down[x] + mid[x - 1] + mid[x + 1] + 2) / 4);
			p[2 - own] = (uint8_t)((up[x - 1] + up[x + 1] + down[x - 1] + down[x + 1] + 2) / 4);
		}
	}
}

static void bayer_to_rgb(const mc_image_frame *f, size_t stride, uint8_t *dst)
{
	const uint8_t(*cell)[2] = bayer_cells[f->pixfmt - MC_PIXFMT_BAYER_RGGB8];
	int w = (int)f->width, h = (int)f->height;
	for (int y = 0; y < h; y++) {
		uint8_t *o = dst + (size_t)y * (size_t)w * 3;
		if (y == 0 || y == h - 1 || w < 3) {
			for (int x = 0; x < w; x++)
				bayer_pixel(f, stride, cell, x, y, o + (size_t)x * 3);
			continue;
		}
		const uint8_t *mid = f->data + (size_t)y * stride;
		bayer_interior_row(mid - stride, mid, mid + stride, cell, y, w, o);
		bayer_pixel(f, stride, cell, 0, y, o);
		bayer_pixel(f, stride, cell, w - 1, y, o + (size_t)(w - 1) * 3);
	}
}

/* Checks sizes and returns the row stride, or 0 with err set. */
static size_t check_raw(const mc_image_frame *f, int bpp, size_t dst_bytes, mc_err *err)
{
	const char *name = mc_pixfmt_name(f->pixfmt);
	if (f->width == 0 || f->height == 0 || f->width > MAX_SIDE || f->height > MAX_SIDE) {
		mc_err_set(err, "%s: frame size %ux%u out of range", name, f->width, f->height);
		return 0;
	}
	if (f->pixfmt == MC_PIXFMT_YUYV && (f->width & 1)) {
		mc_err_set(err, "YUYV: width %u is odd (pixels come in pairs)", f->width);
		return 0;
	}
	size_t row = (size_t)f->width * (size_t)bpp;
	size_t stride = f->stride ? f->stride : row;
	if (stride < row) {
		mc_err_set(err, "%s: stride %u is less than a %u-pixel row (%zu bytes)", name, f->stride, f->width, row);
		return 0;
	}
	size_t need = stride * (f->height - 1) + row;
	if (!f->data || f->bytes < need) {
		mc_err_set(err, "%s: %ux%u frame needs %zu bytes, got %zu (short frame)", name, f->width, f->height,
			   need, f->bytes);
		return 0;
	}
	size_t out = (size_t)f->width * f->height * 3;
	if (dst_bytes < out) {
		mc_err_set(err, "%s: %ux%u RGB needs %zu bytes, the buffer holds %zu", name, f->width, f->height, out,
			   dst_bytes);
		return 0;
	}
	return stride;
}

int mc_image_to_rgb24(mc_image_conv *conv, const mc_image_frame *f, uint8_t *dst, size_t dst_bytes, mc_err *err)
{
	if (f->pixfmt == MC_PIXFMT_MJPEG) {
		if (!f->data)
			return mc_err_set(err, "MJPEG: no data");
		return jpeg_to_rgb(conv, f, dst, dst_bytes, err);
	}
	int bpp = mc_image_bytes_per_pixel(f->pixfmt);
	if (bpp == 0)
		return mc_err_set(err, "pixel format %u (%s) cannot be converted to RGB24", f->pixfmt,
				  mc_pixfmt_name(f->pixfmt));
	size_t stride = check_raw(f, bpp, dst_bytes, err);
	if (!stride)
		return -1;
	switch (f->pixfmt) {
	case MC_PIXFMT_RGB24:
		rgb_copy(f, stride, dst);
		break;
	case MC_PIXFMT_GRAY8:
		gray_to_rgb(f, stride, dst);
		break;
	case MC_PIXFMT_YUYV:
		yuyv_to_rgb(f, stride, dst);
		break;
	case MC_PIXFMT_DEPTH16:
		depth_to_rgb(f, stride, dst);
		break;
	default:
		bayer_to_rgb(f, stride, dst);
		break;
	}
	return 0;
}

/* ---- resize ---- */

/* For each destination index: the first source index it covers and the
 * overlap weights of the source indices from there (normalised to sum 1). */
typedef struct {
	int *first, *count;
	float *weight; /* max_taps per destination index */
	int max_taps;
} box_axis;

static int box_axis_init(box_axis *a, int src, int dst)
{
	double scale = (double)src / dst;
	a->max_taps = (int)scale + 2;
	a->first = malloc(sizeof(int) * (size_t)dst);
	a->count = malloc(sizeof(int) * (size_t)dst);
	a->weight = malloc(sizeof(float) * (size_t)dst * (size_t)a->max_taps);
	if (!a->first || !a->count || !a->weight)
		return -1;
	for (int i = 0; i < dst; i++) {
		double lo = i * scale, hi = (i + 1) * scale;
		int s0 = (int)lo, s1 = (int)ceil(hi);
		if (s1 > src)
			s1 = src;
		a->first[i] = s0;
		a->count[i] = s1 - s0;
		for (int s = s0; s < s1; s++) {
			double ov = fmin(hi, s + 1.0) - fmax(lo, (double)s);
			a->weight[(size_t)i * (size_t)a->max_taps + (size_t)(s - s0)] = (float)(ov / scale);
		}
	}
	return 0;
}

static void box_axis_free(box_axis *a)
{
	free(a->first);
	free(a->count);
	free(a->weight);
}

int mc_image_resize_rgb24(const uint8_t *src, int src_w, int src_h, uint8_t *dst, int dst_w, int dst_h, mc_err *err)
{
	if (src_w <= 0 || src_h <= 0 || dst_w <= 0 || dst_h <= 0 || src_w > MAX_SIDE || src_h > MAX_SIDE ||
	    dst_w > MAX_SIDE || dst_h > MAX_SIDE)
		return mc_err_set(err, "resize: sizes %dx%d -> %dx%d out of range", src_w, src_h, dst_w, dst_h);
	box_axis ax = {0}, ay = {0};
	float *tmp = malloc(sizeof(float) * (size_t)dst_w * (size_t)src_h * 3);
	int rc = 0;
	if (!tmp || box_axis_init(&ax, src_w, dst_w) != 0 || box_axis_init(&ay, src_h, dst_h) != 0) {
		rc = mc_err_set(err, "resize: out of memory");
		goto out;
	}
	/* Horizontal pass into floats, then vertical pass to bytes. */
	for (int y = 0; y < src_h; y++) {
		const uint8_t *row = src + (size_t)y * (size_t)src_w * 3;
		float *t = tmp + (size_t)y * (size_t)dst_w * 3;
		for (int x = 0; x < dst_w; x++) {
			const float *wt = ax.weight + (size_t)x * (size_t)ax.max_taps;
			float acc[3] = {0, 0, 0};
			for (int k = 0; k < ax.count[x]; k++) {
				const uint8_t *p = row + (size_t)(ax.first[x] + k) * 3;
				for (int c = 0; c < 3; c++)
					acc[c] += wt[k] * p[c];
			}
			for (int c = 0; c < 3; c++)
				t[x * 3 + c] = acc[c];
		}
	}
	for (int y = 0; y < dst_h; y++) {
		const float *wt = ay.weight + (size_t)y * (size_t)ay.max_taps;
		uint8_t *o = dst + (size_t)y * (size_t)dst_w * 3;
		for (int x = 0; x < dst_w * 3; x++) {
			float acc = 0;
			for (int k = 0; k < ay.count[y]; k++)
				acc += wt[k] * tmp[(size_t)(ay.first[y] + k) * (size_t)dst_w * 3 + (size_t)x];
			o[x] = clamp_u8((int)(acc + 0.5f));
		}
	}
out:
	box_axis_free(&ax);
	box_axis_free(&ay);
	free(tmp);
	return rc;
}

/* ---- image files ---- */

mc_image_file_kind mc_image_file_kind_of(const uint8_t *d, size_t n)
{
	if (n >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF)
		return MC_IMAGE_FILE_JPEG;
	if (n >= 8 && png_sig_cmp(d, 0, 8) == 0)
		return MC_IMAGE_FILE_PNG;
	if (n >= 2 && d[0] == 'P' && (d[1] == '6' || d[1] == '5'))
		return MC_IMAGE_FILE_PNM;
	return MC_IMAGE_FILE_UNKNOWN;
}

static int decode_png(const uint8_t *data, size_t n, const char *origin, uint8_t **rgb, int *w, int *h, mc_err *err)
{
	png_image img;
	memset(&img, 0, sizeof(img));
	img.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_memory(&img, data, n))
		return mc_err_set(err, "%s: PNG: %s", origin, img.message);
	if (!decodable_size(img.width, img.height)) {
		png_image_free(&img);
		return mc_err_set(err, "%s: PNG: size %ux%u out of range", origin, img.width, img.height);
	}
	img.format = PNG_FORMAT_RGB;
	uint8_t *buf = malloc(PNG_IMAGE_SIZE(img));
	if (!buf) {
		png_image_free(&img);
		return mc_err_set(err, "%s: PNG: out of memory", origin);
	}
	if (!png_image_finish_read(&img, NULL, buf, 0, NULL)) {
		free(buf);
		png_image_free(&img);
		return mc_err_set(err, "%s: PNG: %s", origin, img.message);
	}
	*rgb = buf;
	*w = (int)img.width;
	*h = (int)img.height;
	return 0;
}

/* Reads one header number of a PNM file, skipping whitespace and comments. */
static int pnm_number(const uint8_t *d, size_t n, size_t *pos, long *out)
{
	while (*pos < n) {
		if (d[*pos] == '#') {
			while (*pos < n && d[*pos] != '\n')
				(*pos)++;
		} else if (d[*pos] == ' ' || d[*pos] == '\t' || d[*pos] == '\r' || d[*pos] == '\n') {
			(*pos)++;
		} else {
			break;
		}
	}
	long v = 0;
	size_t start = *pos;
	while (*pos < n && d[*pos] >= '0' && d[*pos] <= '9' && v < 1000000)
		v = v * 10 + (d[(*pos)++] - '0');
	if (*pos == start)
		return -1;
	*out = v;
	return 0;
}

static int decode_pnm(const uint8_t *d, size_t n, const char *origin, uint8_t **rgb, int *w, int *h, mc_err *err)
{
	int channels = d[1] == '6' ? 3 : 1;
	size_t pos = 2;
	long width, height, maxval;
	if (pnm_number(d, n, &pos, &width) || pnm_number(d, n, &pos, &height) || pnm_number(d, n, &pos, &maxval))
		return mc_err_set(err, "%s: PNM: bad header", origin);
	if (!decodable_size(width, height))
		return mc_err_set(err, "%s: PNM: size %ldx%ld out of range", origin, width, height);
	if (maxval < 1 || maxval > 255)
		return mc_err_set(err, "%s: PNM: maxval %ld unsupported (8-bit only)", origin, maxval);
	pos++; /* the single whitespace before the pixels */
	size_t need = (size_t)width * (size_t)height * (size_t)channels;
	if (pos > n || n - pos < need)
		return mc_err_set(err, "%s: PNM: %ldx%ld needs %zu bytes of pixels, the file has %zu", origin, width,
				  height, need, pos > n ? 0 : n - pos);
	uint8_t *buf = malloc((size_t)width * (size_t)height * 3);
	if (!buf)
		return mc_err_set(err, "%s: PNM: out of memory", origin);
	const uint8_t *p = d + pos;
	for (size_t i = 0; i < (size_t)width * (size_t)height; i++)
		for (int c = 0; c < 3; c++)
			buf[3 * i + (size_t)c] = (uint8_t)(p[i * (size_t)channels + (channels == 3 ? (size_t)c : 0)] * 255 / maxval);
	*rgb = buf;
	*w = (int)width;
	*h = (int)height;
	return 0;
}

int mc_image_decode(mc_image_conv *conv, const uint8_t *data, size_t bytes, const char *origin, uint8_t **rgb,
		    int *width, int *height, mc_err *err)
{
	*rgb = NULL;
	switch (mc_image_file_kind_of(data, bytes)) {
	case MC_IMAGE_FILE_JPEG: {
		int w, h;
		if (mc_image_jpeg_size(conv, data, bytes, &w, &h, err) != 0)
			return mc_err_prefix(err, "%s", origin);
		uint8_t *buf = malloc((size_t)w * (size_t)h * 3);
		if (!buf)
			return mc_err_set(err, "%s: out of memory", origin);
		mc_image_frame f = {.pixfmt = MC_PIXFMT_MJPEG, .data = data, .bytes = bytes};
		if (mc_image_to_rgb24(conv, &f, buf, (size_t)w * (size_t)h * 3, err) != 0) {
			free(buf);
			return mc_err_prefix(err, "%s", origin);
		}
		*rgb = buf;
		*width = w;
		*height = h;
		return 0;
	}
	case MC_IMAGE_FILE_PNG:
		return decode_png(data, bytes, origin, rgb, width, height, err);
	case MC_IMAGE_FILE_PNM:
		return decode_pnm(data, bytes, origin, rgb, width, height, err);
	default:
		return mc_err_set(err, "%s: not a JPEG, PNG or binary PPM/PGM image", origin);
	}
}

int mc_image_read_file(const char *path, uint8_t **data, size_t *bytes, mc_err *err)
{
	return mc_file_read(path, MC_IMAGE_MAX_FILE_BYTES, data, bytes, err);
}

int mc_image_load(mc_image_conv *conv, const char *path, uint8_t **rgb, int *width, int *height, mc_err *err)
{
	uint8_t *data;
	size_t n;
	if (mc_image_read_file(path, &data, &n, err) != 0)
		return -1;
	int rc = mc_image_decode(conv, data, n, path, rgb, width, height, err);
	free(data);
	return rc;
}
