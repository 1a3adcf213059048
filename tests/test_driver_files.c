/* Tests of the files driver plugin (drivers/files), loaded with dlopen as the
 * daemon loads it, on the bundled demo clip tests/data/ego_demo and on
 * small folders made here.  The host and the plugin's location: see
 * tests/drivers/plugin_host.h. */
#include "image/mc_image.h"
#include "mdrv.h"
#include "test_util.h"
#include "drivers/plugin_host.h"

#include <limits.h>
#include <stdint.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define DEMO "tests/data/ego_demo"

static int file_equals(const char *path, const uint8_t *data, size_t n)
{
	FILE *fp = fopen(path, "rb");
	if (!fp)
		return 0;
	uint8_t *tmp = malloc(n + 1);
	size_t got = fread(tmp, 1, n + 1, fp);
	fclose(fp);
	int same = got == n && memcmp(tmp, data, n) == 0;
	free(tmp);
	return same;
}

/* ---- tests ---- */

static void test_entry_and_config(void)
{
	CHECK(drv->abi_version == MDRV_ABI_VERSION);
	CHECK(strcmp(drv->name, "files") == 0);
	config c = {0};
	mdrv_host h = host_for(&c);
	mdrv_device_info info[4];
	CHECK(drv->probe(&h, info, 4, err, sizeof(err)) == 0);

	expect_open_fails(&c, "'path' is required");
	cfg_set(&c, "path", "/nonexistent/folder/left");
	expect_open_fails(&c, "/nonexistent/folder/left");
	expect_open_fails(&c, "No such file");
	cfg_set(&c, "path", DEMO "/left");
	cfg_set(&c, "rate", "-1");
	expect_open_fails(&c, "'rate'");
	/* check(), for mocapd --check, finds the same without opening */
	mdrv_host hc = host_for(&c);
	CHECK(drv->check && drv->check(&hc, err, sizeof(err)) == MDRV_ERR_CONFIG && strstr(err, "'rate'"));
	cfg_set(&c, "rate", "0");
	cfg_set(&c, "loop", "maybe");
	expect_open_fails(&c, "'loop'");
	cfg_set(&c, "loop", "false");
	cfg_set(&c, "format", "bmp");
	expect_open_fails(&c, "'format'");
	cfg_set(&c, "format", "mjpeg");
	cfg_set(&c, "epoch", "soon");
	expect_open_fails(&c, "'epoch'");
	cfg_set(&c, "epoch", "0");
	cfg_set(&c, "start", "1000");
	expect_open_fails(&c, "from frame 1000");
	cfg_set(&c, "path", DEMO); /* a folder without numbered images */
	cfg_set(&c, "start", "0");
	expect_open_fails(&c, "no numbered");
}

static void test_mjpeg(void)
{
	config c = {0};
	cfg_setv(&c, "path", DEMO "/left", "rate", "0", "start", "3", "count", "5", NULL);
	mdrv_format fmt;
	void *dev = open_checked(&c, &fmt);
	if (!dev)
		return;
	CHECK(fmt.pixfmt == MC_PIXFMT_MJPEG && fmt.width == 256 && fmt.height == 256 && fmt.stride == 0);
	CHECK(fmt.max_bytes > 1000 && fmt.max_bytes < 100000);
	uint64_t frames = 0; /* start 3, count 5: the offline progress's total */
	CHECK(drv->frame_count && drv->frame_count(dev, &frames) == MDRV_OK && frames == 5);
	uint8_t *buf = malloc(fmt.max_bytes);
	mdrv_frame f;
	uint64_t last_ts = 0;
	for (int k = 0; k < 5; k++) {
		int rc = pull(dev, &f, buf, fmt.max_bytes, 1000);
		CHECK_MSG(rc == MDRV_OK, "frame %d: %s", k, err);
		char path[256];
		snprintf(path, sizeof(path), DEMO "/left/%05d.jpg", 3 + k);
		CHECK_MSG(file_equals(path, buf, f.bytesused), "frame %d is not %s", k, path);
		CHECK(f.sequence == (uint64_t)k && f.format.pixfmt == MC_PIXFMT_MJPEG && f.format.width == 256);
		CHECK(f.timestamp_ns >= last_ts && f.timestamp_ns > 0);
		last_ts = f.timestamp_ns;
	}
	CHECK(pull(dev, &f, buf, fmt.max_bytes, 1000) == MDRV_ERR_END);
	CHECK(strstr(err, "end of"));
	CHECK(pull(dev, &f, buf, fmt.max_bytes, 1000) == MDRV_ERR_END);
	/* A slot that is too small. */
	drv->stop(dev);
	CHECK(pull(dev, &f, buf, fmt.max_bytes, 0) != MDRV_OK); /* stopped */
	CHECK(drv->start(dev, err, sizeof(err)) == MDRV_OK);
	CHECK(pull(dev, &f, buf, 100, 1000) == MDRV_ERR_NOSPACE);
	CHECK(strstr(err, "00003.jpg"));
	free(buf);
	drv->close(dev);
}

static void test_rgb24(void)
{
	config c = {0};
	cfg_setv(&c, "path", DEMO "/right", "rate", "0", "count", "2", "format", "rgb24", NULL);
	void *dev = open_checked(&c, NULL);
	if (!dev)
		return;
	mdrv_format fmt;
	drv->get_format(dev, &fmt, err, sizeof(err));
	CHECK(fmt.pixfmt == MC_PIXFMT_RGB24 && fmt.stride == 256 * 3 && fmt.max_bytes == 256 * 256 * 3);
	uint8_t *buf = malloc(fmt.max_bytes);
	mdrv_frame f;
	mc_err e;
	mc_image_conv *conv = mc_image_conv_new(&e);
	for (int k = 0; k < 2; k++) {
		CHECK(pull(dev, &f, buf, fmt.max_bytes, 1000) == MDRV_OK);
		char path[256];
		snprintf(path, sizeof(path), DEMO "/right/%05d.jpg", k);
		uint8_t *want = NULL;
		int w, hh;
		CHECK(mc_image_load(conv, path, &want, &w, &hh, &e) == 0);
		CHECK(f.bytesused == fmt.max_bytes && want && memcmp(want, buf, f.bytesused) == 0);
		free(want);
	}
	CHECK(pull(dev, &f, buf, fmt.max_bytes, 1000) == MDRV_ERR_END);
	mc_image_conv_free(conv);
	free(buf);
	drv->close(dev);
}

/* Pacing at a rate, shared epoch across two cameras, and timeouts. */
static void test_pacing(void)
{
	config cl = {0}, cr = {0};
	uint64_t epoch = mc_now_ns() + 20 * 1000000ull;
	char es[32];
	snprintf(es, sizeof(es), "%llu", (unsigned long long)epoch);
	cfg_set(&cl, "path", DEMO "/left");
	cfg_set(&cr, "path", DEMO "/right");
	for (config *c = &cl; c; c = c == &cl ? &cr : NULL)
		cfg_setv(c, "rate", "50", "count", "6", "epoch", es, NULL);
	void *l = open_start(&cl), *r = open_start(&cr);
	CHECK(l && r);
	if (!l || !r) {
		if (l)
			drv->close(l);
		if (r)
			drv->close(r);
		return;
	}
	uint8_t *buf = malloc(1 << 20);
	mdrv_frame fl, fr;
	uint64_t first = 0, last = 0;
	for (int k = 0; k < 6; k++) {
		CHECK(pull(l, &fl, buf, 1 << 20, 1000) == MDRV_OK);
		uint64_t t = mc_now_ns();
		CHECK(pull(r, &fr, buf, 1 << 20, 1000) == MDRV_OK);
		CHECK(fl.timestamp_ns == epoch + (uint64_t)k * 20000000ull);
		CHECK(fl.timestamp_ns == fr.timestamp_ns); /* same frame, same time */
		CHECK(t >= fl.timestamp_ns);              /* never delivered early */
		if (k == 0)
			first = t;
		last = t;
	}
	double span = (double)(last - first) * 1e-9;
	CHECK_MSG(span > 0.09 && span < 0.5, "6 frames at 50 fps took %.3f s", span);
	drv->close(l);
	drv->close(r);

	/* A frame due in 10 s: next_frame times out after about timeout_ms. */
	config c = {0};
	snprintf(es, sizeof(es), "%llu", (unsigned long long)(mc_now_ns() + 10000000000ull));
	cfg_setv(&c, "path", DEMO "/left", "rate", "30", "epoch", es, NULL);
	void *dev = open_start(&c);
	CHECK(dev != NULL);
	if (dev) {
		uint64_t t0 = mc_now_ns();
		CHECK(pull(dev, &fl, buf, 1 << 20, 30) == MDRV_ERR_TIMEOUT);
		double waited = (double)(mc_now_ns() - t0) * 1e-9;
		CHECK_MSG(waited > 0.025 && waited < 1.0, "waited %.3f s", waited);
		drv->close(dev);
	}
	free(buf);
}

static void test_loop(void)
{
	config c = {0};
	cfg_setv(&c, "path", DEMO "/left", "rate", "0", "count", "3", "loop", "true", NULL);
	void *dev = open_start(&c);
	CHECK(dev != NULL);
	if (!dev)
		return;
	uint64_t frames = 0;
	CHECK(drv->frame_count(dev, &frames) != MDRV_OK); /* a loop never ends */
	uint8_t *buf = malloc(1 << 20);
	mdrv_frame f;
	for (int k = 0; k < 7; k++) {
		CHECK(pull(dev, &f, buf, 1 << 20, 1000) == MDRV_OK);
		char path[256];
		snprintf(path, sizeof(path), DEMO "/left/%05d.jpg", k % 3);
		CHECK_MSG(file_equals(path, buf, f.bytesused), "frame %d is not %s", k, path);
		CHECK(f.sequence == (uint64_t)k);
	}
	free(buf);
	drv->close(dev);
}

/* A folder of PNG and PPM files with other files around, and a bad JPEG. */
static void test_other_files(void)
{
	char dir[] = "/tmp/mocap-files-test-XXXXXX";
	CHECK(mkdtemp(dir) != NULL);
	char path[PATH_MAX];
	mc_err e;
	mc_image_conv *conv = mc_image_conv_new(&e);
	uint8_t *jpeg;
	size_t jn;
	enum { W = 8, H = 6 };
	uint8_t rgb[W * H * 3];
	for (int i = 0; i < W * H * 3; i++)
		rgb[i] = (uint8_t)(i * 5);
	/* frame_2.ppm, frame_10.ppm (numeric order, not name order), notes.txt, cover.ppm */
	int numbers[2] = {10, 2};
	for (int i = 0; i < 2; i++) {
		snprintf(path, sizeof(path), "%s/frame_%d.ppm", dir, numbers[i]);
		FILE *fp = fopen(path, "wb");
		fprintf(fp, "P6\n%d %d\n255\n", W, H);
		rgb[0] = (uint8_t)numbers[i];
		fwrite(rgb, 1, sizeof(rgb), fp);
		fclose(fp);
	}
	snprintf(path, sizeof(path), "%s/notes.txt", dir);
	FILE *fp = fopen(path, "w");
	fputs("frame 7\n", fp);
	fclose(fp);
	snprintf(path, sizeof(path), "%s/cover.ppm", dir);
	fp = fopen(path, "w");
	fputs("P6\n", fp);
	fclose(fp);

	config c = {0};
	cfg_setv(&c, "path", dir, "rate", "0", "format", "mjpeg", NULL);
	expect_open_fails(&c, "mjpeg needs JPEG files");
	cfg_set(&c, "format", "rgb24");
	void *dev = open_checked(&c, NULL);
	uint8_t *buf = malloc(W * H * 3);
	mdrv_frame f;
	if (dev) {
		CHECK(pull(dev, &f, buf, W * H * 3, 1000) == MDRV_OK && buf[0] == 2 && buf[1] == rgb[1]);
		CHECK(pull(dev, &f, buf, W * H * 3, 1000) == MDRV_OK && buf[0] == 10);
		CHECK(pull(dev, &f, buf, W * H * 3, 1000) == MDRV_ERR_END);
		drv->close(dev);
	}

	/* JPEGs: 0 good, 1 garbage, 2 good: the bad one is an error that names
	 * it, and playback goes on. */
	char jdir[] = "/tmp/mocap-files-jpeg-XXXXXX";
	CHECK(mkdtemp(jdir) != NULL);
	CHECK(mc_image_encode_jpeg(conv, rgb, W, H, 90, &jpeg, &jn, &e) == 0);
	for (int i = 0; i < 3; i++) {
		snprintf(path, sizeof(path), "%s/%d.jpg", jdir, i);
		fp = fopen(path, "wb");
		fwrite(jpeg, 1, i == 1 ? jn / 2 : jn, fp);
		fclose(fp);
	}
	config cj = {0};
	cfg_setv(&cj, "path", jdir, "rate", "0", "format", "rgb24", NULL);
	dev = open_checked(&cj, NULL);
	if (dev) {
		CHECK(pull(dev, &f, buf, W * H * 3, 1000) == MDRV_OK && f.sequence == 0);
		CHECK(pull(dev, &f, buf, W * H * 3, 1000) == MDRV_ERR_IO);
		CHECK_MSG(strstr(err, "1.jpg") != NULL, "%s", err);
		CHECK(pull(dev, &f, buf, W * H * 3, 1000) == MDRV_OK && f.sequence == 2);
		CHECK(pull(dev, &f, buf, W * H * 3, 1000) == MDRV_ERR_END);
		drv->close(dev);
	}
	/* Default format for all-JPEG folders is mjpeg, bytes as in the file. */
	config cd = {0};
	cfg_setv(&cd, "path", jdir, "rate", "0", NULL);
	dev = open_start(&cd);
	CHECK(dev != NULL);
	if (dev) {
		uint8_t *jb = malloc(jn);
		CHECK(pull(dev, &f, jb, jn, 1000) == MDRV_OK && f.format.pixfmt == MC_PIXFMT_MJPEG);
		CHECK(f.bytesused == jn && memcmp(jb, jpeg, jn) == 0);
		free(jb);
		drv->close(dev);
	}
	/* One file far larger than an 8x6 JPEG can be (issue 20, defect 3: a
	 * 50 MB photo among the frames sized every slot of the ring): the
	 * slots keep the frames' size and that file alone is refused. */
	char bdir[] = "/tmp/mocap-files-big-XXXXXX";
	CHECK(mkdtemp(bdir) != NULL);
	for (int i = 0; i < 3; i++) {
		snprintf(path, sizeof(path), "%s/%d.jpg", bdir, i);
		fp = fopen(path, "wb");
		fwrite(jpeg, 1, jn, fp);
		for (int pad = 0; i == 1 && pad < 200000; pad++)
			fputc(0, fp); /* after the JPEG's end: still decodes */
		fclose(fp);
	}
	config cb = {0};
	cfg_setv(&cb, "path", bdir, "rate", "0", NULL);
	mdrv_format bf;
	dev = open_checked(&cb, &bf);
	if (dev) {
		CHECK_MSG(bf.max_bytes == jn, "slots of %zu bytes for %zu-byte frames", bf.max_bytes, jn);
		uint8_t *jb = malloc(bf.max_bytes);
		CHECK(pull(dev, &f, jb, bf.max_bytes, 1000) == MDRV_OK && f.sequence == 0);
		CHECK(pull(dev, &f, jb, bf.max_bytes, 1000) == MDRV_ERR_NOSPACE);
		CHECK_MSG(strstr(err, "1.jpg") != NULL, "%s", err);
		CHECK(pull(dev, &f, jb, bf.max_bytes, 1000) == MDRV_OK && f.sequence == 2);
		free(jb);
		drv->close(dev);
	}
	free(jpeg);
	free(buf);
	mc_image_conv_free(conv);
	char cmd[PATH_MAX * 3 + 16];
	snprintf(cmd, sizeof(cmd), "rm -rf '%s' '%s' '%s'", dir, jdir, bdir);
	CHECK(system(cmd) == 0);
}

int main(void)
{
	if (access(DEMO "/left/00000.jpg", R_OK) != 0)
		TEST_SKIP("the demo clip %s is missing (run from the repository root)", DEMO);
	void *dl = NULL;
	drv = load_plugin("files", &dl);
	CHECK_MSG(drv != NULL, "cannot load mocap-driver-files.so (set MOCAP_DRIVER_DIR)");
	if (!drv)
		return mc_test_finish("test_driver_files");
	test_entry_and_config();
	test_mjpeg();
	test_rgb24();
	test_pacing();
	test_loop();
	test_other_files();
	dlclose(dl);
	return mc_test_finish("test_driver_files");
}
