/* mc_image: camera frames to packed RGB24, and area-averaging downscale.
 *
 * Formats (mc_pixfmt, image/mc_pixfmt.h):
 *   RGB24, GRAY8            copied / replicated;
 *   YUYV                    BT.601 limited range (Y 16..235, Cb Cr 16..240),
 *                           what UVC and V4L2 cameras deliver;
 *   MJPEG                   one JPEG per frame, decoded with libturbojpeg;
 *   BAYER_{RGGB,GRBG,GBRG,BGGR}8  bilinear demosaic (the mean of the same
 *                           colour's pixels in the 3x3 neighbourhood);
 *   DEPTH16                 grey for display: near bright, far dark, over
 *                           the frame's own range of valid readings; 0
 *                           (no reading) is black.
 * `stride` is the bytes per row of uncompressed formats; 0 means tightly
 * packed.  A frame shorter than its format needs, a JPEG that does not
 * decode or whose size disagrees with the declared size, is rejected with an
 * error naming the format and the sizes; nothing is read out of bounds.
 *
 * Whole image files (JPEG, PNG, binary PPM/PGM) decode with mc_image_decode.
 *
 * A converter holds the JPEG decoder; use one per thread. */
#ifndef MC_IMAGE_H
#define MC_IMAGE_H

#include "base/mc_error.h"

#include <stddef.h>
#include <stdint.h>

typedef struct mc_image_conv mc_image_conv;

/* A frame as it comes from a driver or a ring slot. */
typedef struct {
	uint32_t pixfmt;  /* mc_pixfmt */
	uint32_t width, height;
	uint32_t stride;  /* 0: packed */
	const uint8_t *data;
	size_t bytes;     /* bytes used */
} mc_image_frame;

mc_image_conv *mc_image_conv_new(mc_err *err);
void mc_image_conv_free(mc_image_conv *conv);

/* Bytes per pixel of an uncompressed format, 0 for MJPEG or unknown. */
int mc_image_bytes_per_pixel(uint32_t pixfmt);

/* Width and height of a JPEG image from its header. */
int mc_image_jpeg_size(mc_image_conv *conv, const uint8_t *jpeg, size_t bytes, int *width, int *height,
		       mc_err *err);

/* Converts to width*height*3 bytes of packed RGB at dst (dst_bytes long).
 * For MJPEG a declared width/height of 0 accepts the JPEG's own size (read
 * it first with mc_image_jpeg_size to size dst). */
int mc_image_to_rgb24(mc_image_conv *conv, const mc_image_frame *frame, uint8_t *dst, size_t dst_bytes, mc_err *err);

/* Area-averaging resize of packed RGB24: every destination pixel is the mean
 * of the source area it covers, weighted by overlap.  Meant for shrinking
 * (it also enlarges, as nearest-neighbour-like boxes). */
int mc_image_resize_rgb24(const uint8_t *src, int src_w, int src_h, uint8_t *dst, int dst_w, int dst_h, mc_err *err);

/* Image files, recognised by their first bytes. */
typedef enum {
	MC_IMAGE_FILE_UNKNOWN = 0,
	MC_IMAGE_FILE_JPEG,
	MC_IMAGE_FILE_PNG,
	MC_IMAGE_FILE_PNM, /* binary PPM (P6) or PGM (P5) */
} mc_image_file_kind;

mc_image_file_kind mc_image_file_kind_of(const uint8_t *data, size_t bytes);

/* Decodes a JPEG, PNG or binary PPM/PGM (maxval up to 255) held in memory
 * into packed RGB24 in a buffer allocated with malloc (*rgb; free() it).
 * `origin` (e.g. the file name) starts every error message. */
int mc_image_decode(mc_image_conv *conv, const uint8_t *data, size_t bytes, const char *origin, uint8_t **rgb,
		    int *width, int *height, mc_err *err);
/* Reads a whole image file into a malloc'd buffer (*data, *bytes):
 * mc_file_read, refusing anything but a regular file of at most
 * MC_IMAGE_MAX_FILE_BYTES. */
#define MC_IMAGE_MAX_FILE_BYTES (64u << 20)
int mc_image_read_file(const char *path, uint8_t **data, size_t *bytes, mc_err *err);
/* mc_image_read_file + mc_image_decode. */
int mc_image_load(mc_image_conv *conv, const char *path, uint8_t **rgb, int *width, int *height, mc_err *err);

/* Encodes packed RGB24 as a JPEG (quality 1..100) into a buffer allocated
 * with malloc (*jpeg, *bytes; free it with free()).  Used by tools and tests
 * to make MJPEG frames. */
int mc_image_encode_jpeg(mc_image_conv *conv, const uint8_t *rgb, int width, int height, int quality,
			 uint8_t **jpeg, size_t *bytes, mc_err *err);

#endif
