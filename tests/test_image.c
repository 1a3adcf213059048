/* Tests of core/image/mc_image: every pixel format to RGB24, bad frames, resize. */
#include "image/mc_image.h"
#include "mdrv.h"
#include "test_util.h"

#include <png.h>
#include <stdint.h>
#include <string.h>

static mc_image_conv *conv;

static int max_abs_diff(const uint8_t *a, const uint8_t *b, size_t n)
{
	int m = 0;
	for (size_t i = 0; i < n; i++) {
		int d = abs((int)a[i] - (int)b[i]);
		m = d > m ? d : m;
	}
	return m;
}

/* A smooth test image with some structure. */
static void make_rgb(uint8_t *rgb, int w, int h)
{
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			uint8_t *p = rgb + ((size_t)y * w + x) * 3;
			p[0] = (uint8_t)(255 * x / (w - 1));
			p[1] = (uint8_t)(255 * y / (h - 1));
			p[2] = (uint8_t)(128 + 100 * sin(x * 0.05) * cos(y * 0.07));
		}
}

static int convert(uint32_t fmt, int w, int h, uint32_t stride, const uint8_t *data, size_t bytes, uint8_t *dst,
		   size_t dst_bytes, mc_err *err)
{
	mc_image_frame f = {.pixfmt = fmt, .width = (uint32_t)w, .height = (uint32_t)h, .stride = stride,
			    .data = data, .bytes = bytes};
	return mc_image_to_rgb24(conv, &f, dst, dst_bytes, err);
}

static void test_rgb_gray(void)
{
	mc_err err;
	enum { W = 5, H = 3, STRIDE = 20 };
	uint8_t src[STRIDE * H], out[W * H * 3], want[W * H * 3];
	memset(src, 0xEE, sizeof(src));
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W * 3; x++)
			src[y * STRIDE + x] = want[y * W * 3 + x] = (uint8_t)(y * 50 + x);
	CHECK(convert(MC_PIXFMT_RGB24, W, H, STRIDE, src, sizeof(src), out, sizeof(out), &err) == 0);
	CHECK(memcmp(out, want, sizeof(out)) == 0);
	/* The last row needs no padding. */
	CHECK(convert(MC_PIXFMT_RGB24, W, H, STRIDE, src, STRIDE * 2 + W * 3, out, sizeof(out), &err) == 0);
	CHECK(convert(MC_PIXFMT_RGB24, W, H, STRIDE, src, STRIDE * 2 + W * 3 - 1, out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "RGB24") && strstr(err.msg, "short frame"));
	CHECK(convert(MC_PIXFMT_RGB24, W, H, 14, src, sizeof(src), out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "stride 14"));
	CHECK(convert(MC_PIXFMT_RGB24, W, H, 0, src, sizeof(src), out, sizeof(out) - 1, &err) == -1);
	CHECK(strstr(err.msg, "buffer holds"));

	uint8_t g[W * H];
	for (int i = 0; i < W * H; i++)
		g[i] = (uint8_t)(i * 17);
	CHECK(convert(MC_PIXFMT_GRAY8, W, H, 0, g, sizeof(g), out, sizeof(out), &err) == 0);
	int ok = 1;
	for (int i = 0; i < W * H; i++)
		ok &= out[3 * i] == g[i] && out[3 * i + 1] == g[i] && out[3 * i + 2] == g[i];
	CHECK(ok);
	CHECK(convert(MC_PIXFMT_GRAY8, W, H, 0, g, sizeof(g) - 1, out, sizeof(out), &err) == -1);
	CHECK(convert(MC_PIXFMT_GRAY8, 0, H, 0, g, sizeof(g), out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "out of range"));
	CHECK(convert(MC_PIXFMT_GRAY8, W, H, 0, NULL, 0, out, sizeof(out), &err) == -1);
	CHECK(convert(77, W, H, 0, g, sizeof(g), out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "77"));
}

/* BT.601 limited range, the forward direction, in floating point. */
static void rgb_to_yuv(const int rgb[3], int yuv[3])
{
	double r = rgb[0] / 255.0, g = rgb[1] / 255.0, b = rgb[2] / 255.0;
	yuv[0] = (int)lround(16 + 65.481 * r + 128.553 * g + 24.966 * b);
	yuv[1] = (int)lround(128 - 37.797 * r - 74.203 * g + 112.0 * b);
	yuv[2] = (int)lround(128 + 112.0 * r - 93.786 * g - 18.214 * b);
}

static void test_yuyv(void)
{
	mc_err err;
	static const int colours[][3] = {{0, 0, 0},     {255, 255, 255}, {255, 0, 0},   {0, 255, 0},
					 {0, 0, 255},   {128, 128, 128}, {200, 120, 40}, {30, 160, 220}};
	enum { N = sizeof(colours) / sizeof(colours[0]) };
	/* One row, two pixels of the same colour per macropixel. */
	uint8_t src[N * 4], out[N * 2 * 3];
	for (int i = 0; i < N; i++) {
		int yuv[3];
		rgb_to_yuv(colours[i], yuv);
		src[4 * i + 0] = (uint8_t)yuv[0];
		src[4 * i + 1] = (uint8_t)yuv[1];
		src[4 * i + 2] = (uint8_t)yuv[0];
		src[4 * i + 3] = (uint8_t)yuv[2];
	}
	CHECK(convert(MC_PIXFMT_YUYV, N * 2, 1, 0, src, sizeof(src), out, sizeof(out), &err) == 0);
	for (int i = 0; i < N; i++)
		for (int p = 0; p < 2; p++)
			for (int c = 0; c < 3; c++)
				CHECK_MSG(abs(out[(2 * i + p) * 3 + c] - colours[i][c]) <= 2, "colour %d channel %d: %d vs %d",
					  i, c, out[(2 * i + p) * 3 + c], colours[i][c]);
	/* Y0 and Y1 differ: two greys sharing chroma. */
	uint8_t pair[4] = {16, 128, 235, 128};
	CHECK(convert(MC_PIXFMT_YUYV, 2, 1, 0, pair, 4, out, 6, &err) == 0);
	CHECK(out[0] == 0 && out[1] == 0 && out[2] == 0 && out[3] == 255 && out[4] == 255 && out[5] == 255);
	CHECK(convert(MC_PIXFMT_YUYV, 3, 1, 0, src, sizeof(src), out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "odd"));
	CHECK(convert(MC_PIXFMT_YUYV, N * 2, 1, 0, src, sizeof(src) - 1, out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "YUYV") && strstr(err.msg, "short"));
}

static void test_mjpeg(void)
{
	mc_err err;
	enum { W = 96, H = 64 };
	static uint8_t rgb[W * H * 3], out[W * H * 3];
	make_rgb(rgb, W, H);
	uint8_t *jpeg = NULL;
	size_t n = 0;
	CHECK(mc_image_encode_jpeg(conv, rgb, W, H, 95, &jpeg, &n, &err) == 0);
	if (!jpeg)
		return;
	int w = 0, h = 0;
	CHECK(mc_image_jpeg_size(conv, jpeg, n, &w, &h, &err) == 0 && w == W && h == H);
	/* A tables-only JPEG (SOI, EOI) and one cut before its SOF set no
	 * size: refused as 0x0 every time, never a size from the stack
	 * (issue 20, defect 2). */
	static const uint8_t tables_only[] = {0xFF, 0xD8, 0xFF, 0xD9};
	/* A small JPEG whose SOF claims 32768x32768 (a decompression bomb) is
	 * refused from its header, before any buffer (issue 20, defect 3). */
	uint8_t *bomb = malloc(n);
	if (bomb) {
		memcpy(bomb, jpeg, n);
		size_t sof = 0;
		for (size_t i = 2; i + 9 < n && !sof; i++)
			if (bomb[i] == 0xFF && bomb[i + 1] == 0xC0)
				sof = i;
		CHECK(sof > 0);
		if (sof) {
			bomb[sof + 5] = 0x80, bomb[sof + 6] = 0x00; /* height 32768 */
			bomb[sof + 7] = 0x80, bomb[sof + 8] = 0x00; /* width 32768 */
			CHECK(mc_image_jpeg_size(conv, bomb, n, &w, &h, &err) != 0);
			CHECK_MSG(strstr(err.msg, "32768x32768 out of range"), "%s", err.msg);
		}
		free(bomb);
	}
	for (int round = 0; round < 2; round++) {
		w = h = 12345;
		CHECK(mc_image_jpeg_size(conv, tables_only, sizeof(tables_only), &w, &h, &err) != 0);
		CHECK_MSG(w == 0 && h == 0 && (strstr(err.msg, "0x0") || strstr(err.msg, "bad header")),
			  "tables-only JPEG: %dx%d, %s", w, h, err.msg);
		w = h = 12345;
		CHECK(mc_image_jpeg_size(conv, jpeg, 20, &w, &h, &err) != 0);
		CHECK_MSG(w == 0 && h == 0, "JPEG cut before SOF: %dx%d, %s", w, h, err.msg);
	}
	CHECK(convert(MC_PIXFMT_MJPEG, W, H, 0, jpeg, n, out, sizeof(out), &err) == 0);
	double sum = 0;
	for (size_t i = 0; i < sizeof(out); i++)
		sum += abs((int)out[i] - (int)rgb[i]);
	CHECK_MSG(sum / sizeof(out) < 2.0, "mean JPEG error %.2f", sum / sizeof(out));
	/* Undeclared size: the JPEG's own is used. */
	CHECK(convert(MC_PIXFMT_MJPEG, 0, 0, 0, jpeg, n, out, sizeof(out), &err) == 0);
	/* Declared size disagrees. */
	CHECK(convert(MC_PIXFMT_MJPEG, W, H + 1, 0, jpeg, n, out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "96x64") && strstr(err.msg, "96x65"));
	CHECK(convert(MC_PIXFMT_MJPEG, W, H, 0, jpeg, n, out, sizeof(out) - 1, &err) == -1);

	/* Truncated at many places: always an error, never a crash. */
	int truncated_ok = 1;
	for (size_t cut = 0; cut < n; cut += n / 23 + 1) {
		uint8_t *part = malloc(cut ? cut : 1);
		memcpy(part, jpeg, cut);
		int rc = convert(MC_PIXFMT_MJPEG, W, H, 0, part, cut, out, sizeof(out), &err);
		if (rc != -1 || !strstr(err.msg, "MJPEG")) {
			fprintf(stderr, "cut at %zu: rc %d, '%s'\n", cut, rc, err.msg);
			truncated_ok = 0;
		}
		free(part);
	}
	CHECK(truncated_ok);
	/* Garbage. */
	uint8_t junk[4000];
	unsigned long long rng = 7;
	for (size_t i = 0; i < sizeof(junk); i++)
		junk[i] = (uint8_t)(mc_test_rand(&rng) * 256);
	CHECK(convert(MC_PIXFMT_MJPEG, W, H, 0, junk, sizeof(junk), out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "not a JPEG"));
	junk[0] = 0xFF;
	junk[1] = 0xD8;
	CHECK(convert(MC_PIXFMT_MJPEG, W, H, 0, junk, sizeof(junk), out, sizeof(out), &err) == -1);
	/* A damaged body (header intact): decodes or fails, but stays in bounds
	 * (ASan checks that in the SAN build). */
	uint8_t *bad = malloc(n);
	for (int trial = 0; trial < 20; trial++) {
		memcpy(bad, jpeg, n);
		for (int k = 0; k < 8; k++)
			bad[n / 3 + (size_t)(mc_test_rand(&rng) * (double)(n - n / 3 - 2))] = (uint8_t)(mc_test_rand(&rng) * 256);
		convert(MC_PIXFMT_MJPEG, W, H, 0, bad, n, out, sizeof(out), &err);
	}
	free(bad);
	free(jpeg);
}

static const uint8_t cells[4][2][2] = {{{0, 1}, {1, 2}}, {{1, 0}, {2, 1}}, {{1, 2}, {0, 1}}, {{2, 1}, {1, 0}}};

static void mosaic(const uint8_t *rgb, int w, int h, int order, uint8_t *raw)
{
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++)
			raw[y * w + x] = rgb[((size_t)y * w + x) * 3 + cells[order][y & 1][x & 1]];
}

static void test_bayer(void)
{
	mc_err err;
	enum { W = 40, H = 30 };
	static uint8_t rgb[W * H * 3], raw[W * H], out[W * H * 3];
	static const uint32_t fmts[4] = {MC_PIXFMT_BAYER_RGGB8, MC_PIXFMT_BAYER_GRBG8, MC_PIXFMT_BAYER_GBRG8,
					 MC_PIXFMT_BAYER_BGGR8};
	for (int o = 0; o < 4; o++) {
		/* A flat colour comes back exactly, in every order. */
		for (int i = 0; i < W * H; i++) {
			rgb[3 * i] = 200;
			rgb[3 * i + 1] = 100;
			rgb[3 * i + 2] = 30;
		}
		mosaic(rgb, W, H, o, raw);
		CHECK(convert(fmts[o], W, H, 0, raw, sizeof(raw), out, sizeof(out), &err) == 0);
		CHECK_MSG(max_abs_diff(out, rgb, sizeof(out)) == 0, "flat colour, order %d", o);
		/* The wrong order swaps or mixes channels. */
		CHECK(convert(fmts[(o + 1) % 4], W, H, 0, raw, sizeof(raw), out, sizeof(out), &err) == 0);
		CHECK(max_abs_diff(out, rgb, sizeof(out)) > 50);
		/* A linear ramp is reproduced by bilinear interpolation inside the image. */
		for (int y = 0; y < H; y++)
			for (int x = 0; x < W; x++) {
				uint8_t *p = rgb + ((size_t)y * W + x) * 3;
				p[0] = (uint8_t)(4 * x + 20);
				p[1] = (uint8_t)(6 * y + 10);
				p[2] = (uint8_t)(2 * x + 3 * y);
			}
		mosaic(rgb, W, H, o, raw);
		CHECK(convert(fmts[o], W, H, 0, raw, sizeof(raw), out, sizeof(out), &err) == 0);
		int worst = 0;
		for (int y = 1; y < H - 1; y++)
			for (int x = 1; x < W - 1; x++)
				for (int c = 0; c < 3; c++) {
					int d = abs(out[(y * W + x) * 3 + c] - rgb[(y * W + x) * 3 + c]);
					worst = d > worst ? d : worst;
				}
		CHECK_MSG(worst <= 1, "ramp, order %d: worst error %d", o, worst);
		CHECK(convert(fmts[o], W, H, 0, raw, sizeof(raw) - 1, out, sizeof(out), &err) == -1);
		CHECK(strstr(err.msg, "BAYER") && strstr(err.msg, "short"));
	}
	/* Random raw data against a plain implementation of the definition
	 * (own colour kept, others the mean of the 3x3 neighbours of that
	 * colour inside the image), odd sizes, every order. */
	enum { RW = 37, RH = 29 };
	static uint8_t rr[RW * RH], ro[RW * RH * 3];
	unsigned long long rng = 99;
	for (int i = 0; i < RW * RH; i++)
		rr[i] = (uint8_t)(mc_test_rand(&rng) * 256);
	for (int o = 0; o < 4; o++) {
		CHECK(convert(fmts[o], RW, RH, 0, rr, sizeof(rr), ro, sizeof(ro), &err) == 0);
		int mismatches = 0;
		for (int y = 0; y < RH; y++)
			for (int x = 0; x < RW; x++) {
				int sum[3] = {0, 0, 0}, cnt[3] = {0, 0, 0};
				for (int yy = y - 1; yy <= y + 1; yy++)
					for (int xx = x - 1; xx <= x + 1; xx++) {
						if (yy < 0 || xx < 0 || yy >= RH || xx >= RW)
							continue;
						int c = cells[o][yy & 1][xx & 1];
						sum[c] += rr[yy * RW + xx];
						cnt[c]++;
					}
				int own = cells[o][y & 1][x & 1];
				for (int c = 0; c < 3; c++) {
					int want = c == own ? rr[y * RW + x] : (sum[c] + cnt[c] / 2) / cnt[c];
					mismatches += ro[(y * RW + x) * 3 + c] != want;
				}
			}
		CHECK_MSG(mismatches == 0, "order %d: %d values differ from the definition", o, mismatches);
	}
	/* Tiny images: edges everywhere. */
	uint8_t one = 77;
	CHECK(convert(MC_PIXFMT_BAYER_RGGB8, 1, 1, 0, &one, 1, out, 3, &err) == 0);
	CHECK(out[0] == 77);
}

static void test_depth(void)
{
	mc_err err;
	uint16_t d[6] = {0, 1000, 2000, 3000, 1500, 0};
	uint8_t out[18];
	CHECK(convert(MC_PIXFMT_DEPTH16, 3, 2, 0, (uint8_t *)d, sizeof(d), out, sizeof(out), &err) == 0);
	CHECK(out[0] == 0 && out[15] == 0);                  /* no reading: black */
	CHECK(out[3] == 255 && out[4] == 255 && out[5] == 255); /* nearest */
	CHECK(out[9] == 32);                                 /* farthest */
	CHECK(out[6] < out[3] && out[6] > out[9] && out[12] > out[6]);
	CHECK(convert(MC_PIXFMT_DEPTH16, 3, 2, 0, (uint8_t *)d, sizeof(d) - 1, out, sizeof(out), &err) == -1);
	CHECK(strstr(err.msg, "DEPTH16"));
	/* An all-empty frame is all black. */
	uint16_t z[4] = {0, 0, 0, 0};
	CHECK(convert(MC_PIXFMT_DEPTH16, 2, 2, 0, (uint8_t *)z, sizeof(z), out, 12, &err) == 0);
	CHECK(out[0] == 0 && out[11] == 0);
}

static void test_resize(void)
{
	mc_err err;
	/* 4x4 -> 2x2: exact means of 2x2 blocks. */
	uint8_t src[4 * 4 * 3], out[2 * 2 * 3];
	for (int i = 0; i < 48; i++)
		src[i] = (uint8_t)(i * 5);
	CHECK(mc_image_resize_rgb24(src, 4, 4, out, 2, 2, &err) == 0);
	for (int y = 0; y < 2; y++)
		for (int x = 0; x < 2; x++)
			for (int c = 0; c < 3; c++) {
				int s = 0;
				for (int dy = 0; dy < 2; dy++)
					for (int dx = 0; dx < 2; dx++)
						s += src[((2 * y + dy) * 4 + 2 * x + dx) * 3 + c];
				CHECK(abs(out[(y * 2 + x) * 3 + c] - (s + 2) / 4) <= 1);
			}
	/* Non-integer ratio keeps a flat image flat and the mean of a ramp. */
	enum { SW = 257, SH = 131, DW = 100, DH = 37 };
	static uint8_t big[SW * SH * 3], small[DW * DH * 3];
	memset(big, 90, sizeof(big));
	CHECK(mc_image_resize_rgb24(big, SW, SH, small, DW, DH, &err) == 0);
	int flat = 1;
	for (size_t i = 0; i < sizeof(small); i++)
		flat &= small[i] == 90;
	CHECK(flat);
	make_rgb(big, SW, SH);
	CHECK(mc_image_resize_rgb24(big, SW, SH, small, DW, DH, &err) == 0);
	double ms = 0, md = 0;
	for (size_t i = 0; i < sizeof(big); i++)
		ms += big[i];
	for (size_t i = 0; i < sizeof(small); i++)
		md += small[i];
	CHECK_NEAR(ms / sizeof(big), md / sizeof(small), 0.6);
	/* Down to one pixel: the mean. */
	uint8_t px[3];
	CHECK(mc_image_resize_rgb24(src, 4, 4, px, 1, 1, &err) == 0);
	int s0 = 0;
	for (int i = 0; i < 16; i++)
		s0 += src[i * 3];
	CHECK(abs(px[0] - s0 / 16) <= 1);
	CHECK(mc_image_resize_rgb24(src, 4, 4, px, 0, 1, &err) == -1);
	CHECK(strstr(err.msg, "resize"));
}

static void test_decode_files(void)
{
	mc_err err;
	enum { W = 7, H = 5 };
	uint8_t rgb[W * H * 3];
	for (int i = 0; i < W * H * 3; i++)
		rgb[i] = (uint8_t)(i * 7 + 3);
	uint8_t *out = NULL;
	int w = 0, h = 0;

	/* PNG, written with libpng. */
	png_image img;
	memset(&img, 0, sizeof(img));
	img.version = PNG_IMAGE_VERSION;
	img.width = W;
	img.height = H;
	img.format = PNG_FORMAT_RGB;
	png_alloc_size_t pn = 0;
	CHECK(png_image_write_to_memory(&img, NULL, &pn, 0, rgb, 0, NULL));
	uint8_t *png = malloc(pn);
	CHECK(png_image_write_to_memory(&img, png, &pn, 0, rgb, 0, NULL));
	CHECK(mc_image_file_kind_of(png, pn) == MC_IMAGE_FILE_PNG);
	CHECK_MSG(mc_image_decode(conv, png, pn, "a.png", &out, &w, &h, &err) == 0, "%s", err.msg);
	CHECK(w == W && h == H && out && memcmp(out, rgb, sizeof(rgb)) == 0);
	free(out);
	CHECK(mc_image_decode(conv, png, pn / 2, "a.png", &out, &w, &h, &err) == -1);
	CHECK(strstr(err.msg, "a.png: PNG") && out == NULL);
	free(png);

	/* PPM (P6) with a comment, and PGM (P5) with maxval 15. */
	char hdr[64];
	int hn = snprintf(hdr, sizeof(hdr), "P6\n# made by a test\n%d %d\n255\n", W, H);
	uint8_t *ppm = malloc((size_t)hn + sizeof(rgb));
	memcpy(ppm, hdr, (size_t)hn);
	memcpy(ppm + hn, rgb, sizeof(rgb));
	CHECK(mc_image_decode(conv, ppm, (size_t)hn + sizeof(rgb), "a.ppm", &out, &w, &h, &err) == 0);
	CHECK(w == W && h == H && out && memcmp(out, rgb, sizeof(rgb)) == 0);
	free(out);
	CHECK(mc_image_decode(conv, ppm, (size_t)hn + sizeof(rgb) - 1, "a.ppm", &out, &w, &h, &err) == -1);
	CHECK(strstr(err.msg, "a.ppm: PNM") && strstr(err.msg, "needs"));
	free(ppm);
	const uint8_t pgm[] = {'P', '5', ' ', '2', ' ', '1', ' ', '1', '5', '\n', 0, 15};
	CHECK(mc_image_decode(conv, pgm, sizeof(pgm), "a.pgm", &out, &w, &h, &err) == 0);
	CHECK(w == 2 && h == 1 && out && out[0] == 0 && out[3] == 255 && out[4] == 255 && out[5] == 255);
	free(out);
	const uint8_t deep[] = "P5 2 1 65535\n\1\2\3\4";
	CHECK(mc_image_decode(conv, deep, sizeof(deep) - 1, "d.pgm", &out, &w, &h, &err) == -1);
	CHECK(strstr(err.msg, "maxval"));
	const uint8_t bad[] = "P6 x 1 255\n";
	CHECK(mc_image_decode(conv, bad, sizeof(bad) - 1, "b.ppm", &out, &w, &h, &err) == -1);
	CHECK(strstr(err.msg, "bad header"));

	/* JPEG through the same entry point; unknown bytes are refused. */
	uint8_t *jpeg;
	size_t jn;
	CHECK(mc_image_encode_jpeg(conv, rgb, W, H, 90, &jpeg, &jn, &err) == 0);
	CHECK_MSG(mc_image_decode(conv, jpeg, jn, "a.jpg", &out, &w, &h, &err) == 0 && w == W && h == H, "%s", err.msg);
	free(out);
	CHECK(mc_image_decode(conv, jpeg, jn / 3, "a.jpg", &out, &w, &h, &err) == -1);
	CHECK(strncmp(err.msg, "a.jpg: MJPEG", 12) == 0);
	free(jpeg);
	CHECK(mc_image_decode(conv, (const uint8_t *)"GIF89a", 6, "a.gif", &out, &w, &h, &err) == -1);
	CHECK(strstr(err.msg, "a.gif: not a JPEG"));
	CHECK(mc_image_load(conv, "/nonexistent.png", &out, &w, &h, &err) == -1);
	CHECK(strstr(err.msg, "/nonexistent.png"));
}

int main(void)
{
	mc_err err;
	conv = mc_image_conv_new(&err);
	CHECK(conv != NULL);
	if (!conv)
		return mc_test_finish("test_image");
	test_rgb_gray();
	test_yuyv();
	test_mjpeg();
	test_bayer();
	test_depth();
	test_resize();
	test_decode_files();
	mc_image_conv_free(conv);
	return mc_test_finish("test_image");
}
