/* Pixel formats of camera frames: what a driver delivers, what a frame ring
 * slot holds and what core/image converts to RGB.  A header of its own,
 * without dependencies, so that the driver ABI (drivers/mdrv.h), the core
 * and the daemon share it without the core including the driver ABI. */
#ifndef MC_PIXFMT_H
#define MC_PIXFMT_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
	MC_PIXFMT_NONE = 0,
	MC_PIXFMT_RGB24 = 1,   /* packed R, G, B bytes */
	MC_PIXFMT_GRAY8 = 2,
	MC_PIXFMT_YUYV = 3,    /* YUV 4:2:2, Y0 U Y1 V */
	MC_PIXFMT_MJPEG = 4,   /* one JPEG image per frame, bytesused is its size */
	MC_PIXFMT_BAYER_RGGB8 = 5,
	MC_PIXFMT_BAYER_GRBG8 = 6,
	MC_PIXFMT_BAYER_GBRG8 = 7,
	MC_PIXFMT_BAYER_BGGR8 = 8,
	MC_PIXFMT_DEPTH16 = 9, /* uint16 millimetres, 0 = no reading */
} mc_pixfmt;

static inline const char *mc_pixfmt_name(uint32_t pixfmt)
{
	static const char *const names[] = {"none", "RGB24", "GRAY8", "YUYV", "MJPEG", "BAYER_RGGB8",
					    "BAYER_GRBG8", "BAYER_GBRG8", "BAYER_BGGR8", "DEPTH16"};
	return pixfmt < sizeof(names) / sizeof(names[0]) ? names[pixfmt] : "unknown";
}

#ifdef __cplusplus
}
#endif

#endif
