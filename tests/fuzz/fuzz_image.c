/* libFuzzer target: decoding image files and MJPEG frames
 * (core/image/mc_image.c): mc_image_decode, which the files driver runs
 * on every JPEG, PNG or binary PPM/PGM it reads; a JPEG takes the path of
 * an MJPEG camera's frames (mc_image_jpeg_size, then mc_image_to_rgb24
 * into a buffer of that size).  The size limits against
 * decompression bombs stay in force: libFuzzer's -rss_limit_mb catches an
 * input that gets past them.  A refused image gets a message that starts
 * with its name; an accepted one has a size within the limits. */
#include "fuzz_util.h"

#include "image/mc_image.h"

#include <stdlib.h>

#define ORIGIN "fuzz.img"

static mc_image_conv *conv; /* holds the JPEG decoder, as a capture thread's */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	mc_err err = {{0}};
	if (!conv && !(conv = mc_image_conv_new(&err)))
		abort();
	uint8_t *rgb = NULL;
	int w = 0, h = 0;
	if (mc_image_decode(conv, data, size, ORIGIN, &rgb, &w, &h, &err) != 0) {
		fuzz_check_refusal("fuzz_image", ORIGIN, &err);
		if (rgb)
			fuzz_fail("fuzz_image", "a refused image left a buffer", &err);
	} else {
		if (w < 1 || h < 1 || w > 32768 || h > 32768 || (long long)w * h > 8192ll * 8192ll)
			fuzz_fail("fuzz_image", "accepted an image of a size out of the limits", NULL);
		free(rgb);
	}
	return 0;
}
