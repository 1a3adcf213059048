/* Tests of the sim driver plugin (drivers/sim), loaded with dlopen: renders
 * the default body model driven by shared/data/mocap/131_01.bvh through the
 * left camera of config/rigs/ego_stereo.json.
 *
 * The check of content: the mapped joints of the same BVH frame, put in the
 * rig frame and projected with the rig camera, land on body pixels (not the
 * green background) of the rendered frame; pixels outside the fisheye circle
 * are black; the image changes with the motion.
 *
 * The host and the plugin's location: see tests/drivers/plugin_host.h. */
#include "body/mc_bvh.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "mdrv.h"
#include "test_util.h"
#include "drivers/plugin_host.h"

#include <limits.h>
#include <stdint.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define W 96
#define H 96

static char bvh_path[PATH_MAX];

static void base_config(config *c)
{
	memset(c, 0, sizeof(*c));
	cfg_setv(c, "bvh", bvh_path, "rig", "config/rigs/ego_stereo.json", "model", "config/models/default.json",
		 "camera", "left", "width", "96", "height", "96", "rate", "0", "background", "#00ff00", NULL);
}

static void test_config_errors(void)
{
	/* one key of the base config changed, and what the error names */
	static const char *const bad[][3] = {
		{"bvh", "/nonexistent.bvh", "/nonexistent.bvh"},
		{"rig", "/nonexistent-rig.json", "'rig'"},
		{"camera", "middle", "no camera 'middle'"},
		{"background", "green", "'background'"},
		{"height_m", "7", "'height_m'"},
	};
	config c;
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		base_config(&c);
		cfg_set(&c, bad[i][0], bad[i][1]);
		expect_open_fails(&c, bad[i][2]);
	}
	config empty = {0};
	expect_open_fails(&empty, "'bvh' is required");
}

static int is_green(const uint8_t *p) { return p[0] < 30 && p[1] > 225 && p[2] < 30; }

/* Joints of BVH frame f projected into the rendered image must be on the body. */
static void check_joints_on_body(const mc_bvh *bvh, const int *idx, double mpu, const mc_model *model,
				 const mc_camera *cam, int f, const uint8_t *img, int *on_body, int *visible)
{
	mc_vec3 head[MC_BVH_CMU_JOINTS];
	mc_bvh_joints_in_head(bvh, idx, f, mpu, head);
	mc_xform cam_from_rig = mc_xform_inverse(cam->rig_from_cam);
	/* Joints the head hides or that the lens sees at grazing angles are
	 * left out: pelvis, hips, knees, ankles. */
	static const char *const names[] = {"pelvis", "left_hip", "right_hip", "left_knee", "right_knee",
					    "left_ankle", "right_ankle"};
	for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
		int j = 0;
		while (strcmp(mc_bvh_cmu_joint_name(j), names[i]) != 0)
			j++;
		mc_vec3 p = mc_xform_apply(cam_from_rig, mc_xform_apply(model->rig_from_root, head[j]));
		double u, v;
		if (!mc_camera_project(cam, p, &u, &v))
			continue;
		/* working pixel of native (u, v) */
		int x = (int)floor((u + 0.5) * W / cam->width), y = (int)floor((v + 0.5) * H / cam->height);
		if (x < 0 || y < 0 || x >= W || y >= H)
			continue;
		(*visible)++;
		*on_body += !is_green(img + ((size_t)y * W + (size_t)x) * 3);
	}
}

static void test_render(void)
{
	config c;
	base_config(&c);
	mdrv_format fmt;
	void *dev = open_checked(&c, &fmt);
	if (!dev)
		return;
	CHECK(fmt.pixfmt == MC_PIXFMT_RGB24 && fmt.width == W && fmt.height == H && fmt.stride == W * 3);
	CHECK(fmt.max_bytes == W * H * 3);

	mc_bvh bvh;
	mc_rig rig;
	mc_model model;
	mc_err e;
	int idx[MC_BVH_CMU_JOINTS];
	CHECK(mc_bvh_load(bvh_path, &bvh, &e) == 0 && mc_bvh_map_cmu(&bvh, idx, &e) == 0);
	CHECK(mc_rig_load("config/rigs/ego_stereo.json", &rig, &e) == 0);
	CHECK(mc_model_load("config/models/default.json", &model, &e) == 0);
	double mpu = 1.75 / mc_bvh_rest_height(&bvh);

	static uint8_t img[W * H * 3], first[W * H * 3];
	mdrv_frame f;
	int on_body = 0, visible = 0;
	uint64_t t0 = mc_now_ns();
	/* rate 0: frame k shows motion time k / 30 s = BVH frame 4k. */
	for (int k = 0; k < 8; k++) {
		int rc = pull(dev, &f, img, sizeof(img), 5000);
		CHECK_MSG(rc == MDRV_OK, "frame %d: %s", k, err);
		if (rc != MDRV_OK)
			break;
		CHECK(f.sequence == (uint64_t)k && f.bytesused == sizeof(img) && f.format.pixfmt == MC_PIXFMT_RGB24);
		if (k == 0)
			memcpy(first, img, sizeof(img));
		check_joints_on_body(&bvh, idx, mpu, &model, &rig.cams[0], 4 * k, img, &on_body, &visible);
		/* Corners are outside the 180-degree circle: black. */
		CHECK(img[0] == 0 && img[1] == 0 && img[2] == 0);
		/* Some background, some body. */
		int green = 0;
		for (int i = 0; i < W * H; i++)
			green += is_green(img + 3 * i);
		CHECK_MSG(green > W * H / 10 && green < W * H * 7 / 10, "frame %d: %d green pixels", k, green);
	}
	double per_frame = (double)(mc_now_ns() - t0) * 1e-9 / 8;
	printf("sim: %dx%d frame in %.3f s; %d of %d projected joints on the body\n", W, H, per_frame, on_body,
	       visible);
	CHECK(visible >= 30);
	CHECK_MSG(on_body >= visible * 9 / 10, "%d of %d joints on body pixels", on_body, visible);
	size_t changed = 0;
	for (size_t i = 0; i < sizeof(img); i++)
		changed += img[i] != first[i];
	CHECK(changed > 100); /* the actor moved */
	CHECK(pull(dev, &f, img, 100, 1000) == MDRV_ERR_NOSPACE);
	drv->close(dev);
	mc_bvh_free(&bvh);
}

/* Pacing, timestamps from a shared epoch, end of the motion, loop. */
static void test_timing(void)
{
	config c;
	base_config(&c);
	uint64_t epoch = mc_now_ns() + 10000000ull;
	char es[32];
	snprintf(es, sizeof(es), "%llu", (unsigned long long)epoch);
	/* 131_01 lasts 994 / 120 = 8.28 s */
	cfg_setv(&c, "width", "16", "height", "16", "rate", "40", "epoch", es, "start", "8.2", NULL);
	void *dev = open_checked(&c, NULL);
	if (!dev)
		return;
	uint8_t img[16 * 16 * 3];
	mdrv_frame f;
	int n = 0;
	int rc;
	while ((rc = pull(dev, &f, img, sizeof(img), 1000)) == MDRV_OK) {
		CHECK(f.timestamp_ns == epoch + (uint64_t)n * 25000000ull);
		CHECK(mc_now_ns() >= f.timestamp_ns);
		n++;
	}
	CHECK_MSG(rc == MDRV_ERR_END, "rc %d: %s", rc, err);
	CHECK_MSG(n == 3 || n == 4, "%d frames before the end", n);
	drv->close(dev);

	/* Looping from 8.2 s wraps around the end of the motion. */
	cfg_setv(&c, "loop", "true", "rate", "0", NULL);
	dev = open_start(&c);
	CHECK(dev != NULL);
	if (dev) {
		for (int k = 0; k < 10; k++)
			CHECK(pull(dev, &f, img, sizeof(img), 1000) == MDRV_OK && f.sequence == (uint64_t)k);
		drv->close(dev);
	}
}

int main(void)
{
	const char *data = mc_test_data_dir();
	if (!data)
		TEST_SKIP("no evaluation data for the BVH file");
	snprintf(bvh_path, sizeof(bvh_path), "%s/mocap/131_01.bvh", data);
	if (access("config/models/default.json", R_OK) != 0 || access("config/rigs/ego_stereo.json", R_OK) != 0)
		TEST_SKIP("config/models/default.json or config/rigs/ego_stereo.json missing (run from the repository root)");
	void *dl = NULL;
	drv = load_plugin("sim", &dl);
	CHECK_MSG(drv != NULL, "cannot load mocap-driver-sim.so (set MOCAP_DRIVER_DIR)");
	if (!drv)
		return mc_test_finish("test_driver_sim");
	CHECK(drv->abi_version == MDRV_ABI_VERSION && strcmp(drv->name, "sim") == 0);
	test_config_errors();
	test_render();
	test_timing();
	dlclose(dl);
	return mc_test_finish("test_driver_sim");
}
