/* Runs tools/mocap-render (built next to this test, in BUILD/bin) on the
 * shipped rig and model: renders, an overlay, and bad command lines.  The
 * images are read back and checked against the geometry computed here. */
#include "geom/mc_camera.h"
#include "image/mc_image.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "test_util.h"

#include <stdint.h>
#include <string.h>
#include <unistd.h>

static char tool[4096], tmpdir[64];

/* Runs the tool with `args`; returns its exit status and its output
 * (stdout and stderr) in out. */
static int run_tool(const char *args, char *out, size_t cap)
{
	char cmd[8192];
	snprintf(cmd, sizeof(cmd), "%s %s 2>&1", tool, args);
	return mc_test_run(cmd, out, cap);
}

static uint8_t *load_png(const char *path, int *w, int *h)
{
	mc_err err = {0};
	mc_image_conv *conv = mc_image_conv_new(&err);
	uint8_t *rgb = NULL;
	if (!conv || mc_image_load(conv, path, &rgb, w, h, &err)) {
		CHECK_MSG(0, "%s", err.msg);
		rgb = NULL;
	}
	mc_image_conv_free(conv);
	return rgb;
}

static const uint8_t *pixel(const uint8_t *rgb, int w, int x, int y)
{
	return rgb + ((size_t)y * w + x) * 3;
}

static bool near_color(const uint8_t *p, int r, int g, int b, int tol)
{
	return abs(p[0] - r) <= tol && abs(p[1] - g) <= tol && abs(p[2] - b) <= tol;
}

/* Projects a rig-frame point to a pixel of a w x h image of camera cam. */
static bool project(const mc_camera *cam, mc_vec3 p_rig, int w, int h, int *x, int *y)
{
	double u, v;
	if (!mc_camera_project_rig(cam, p_rig, &u, &v))
		return false;
	*x = (int)lround((u + 0.5) * w / cam->width - 0.5);
	*y = (int)lround((v + 0.5) * h / cam->height - 0.5);
	return true;
}

static void test_render(const mc_rig *rig, const mc_model *model, const mc_fk *fk)
{
	char out[4096], args[1024], path[256];
	snprintf(args, sizeof(args),
		 "--rig config/rigs/ego_stereo.json --model config/models/default.json --rest --width 64 --height 64 "
		 "--out %s/r",
		 tmpdir);
	int rc = run_tool(args, out, sizeof(out));
	CHECK_MSG(rc == 0, "exit %d: %s", rc, out);
	uint8_t *img[2] = {NULL, NULL};
	for (int c = 0; c < 2; c++) {
		int w = 0, h = 0;
		snprintf(path, sizeof(path), "%s/r_%s.png", tmpdir, rig->cams[c].name);
		img[c] = load_png(path, &w, &h);
		if (!img[c])
			continue;
		CHECK(w == 64 && h == 64);
		/* outside the 180-degree circle: black; inside, grey background
		 * where no body is seen, and the body somewhere */
		CHECK(near_color(pixel(img[c], 64, 0, 0), 0, 0, 0, 0));
		CHECK(near_color(pixel(img[c], 64, 63, 63), 0, 0, 0, 0));
		CHECK(near_color(pixel(img[c], 64, 32, 2), 128, 128, 128, 2));
		int body = 0;
		for (int k = 0; k < 64 * 64; k++) {
			const uint8_t *p = img[c] + k * 3;
			body += !near_color(p, 0, 0, 0, 0) && !near_color(p, 128, 128, 128, 8);
		}
		CHECK_MSG(body > 200, "%s: only %d body pixels", rig->cams[c].name, body);
		/* where the rest-pose torso projects, the torso's colour is seen */
		int spine = mc_model_find_joint(model, "spine"), q = 0;
		while (q < model->ngauss && model->gauss[q].joint != spine)
			q++;
		int x, y;
		CHECK(q < model->ngauss && project(&rig->cams[c], fk->mu[q], 64, 64, &x, &y));
		const double *a = model->gauss[q].rgb;
		const uint8_t *p = pixel(img[c], 64, x, y);
		CHECK_MSG(near_color(p, (int)(a[0] * 255), (int)(a[1] * 255), (int)(a[2] * 255), 40),
			  "%s: torso pixel (%d, %d) is %d %d %d", rig->cams[c].name, x, y, p[0], p[1], p[2]);
	}
	/* two viewpoints, two different images */
	if (img[0] && img[1])
		CHECK(memcmp(img[0], img[1], 64 * 64 * 3) != 0);
	free(img[0]);
	free(img[1]);
	for (int c = 0; c < 2; c++) {
		snprintf(path, sizeof(path), "%s/r_%s.png", tmpdir, rig->cams[c].name);
		unlink(path);
	}
}

static void test_overlay(const mc_rig *rig, const mc_model *model, const mc_fk *fk)
{
	/* a black 128x128 JPEG stands in for a camera frame at half resolution */
	char img_path[256], out[4096], args[1024], path[256];
	mc_err err = {0};
	uint8_t *black = calloc(128 * 128, 3), *jpeg = NULL;
	size_t bytes = 0;
	mc_image_conv *conv = mc_image_conv_new(&err);
	CHECK(conv && mc_image_encode_jpeg(conv, black, 128, 128, 95, &jpeg, &bytes, &err) == 0);
	mc_image_conv_free(conv);
	free(black);
	snprintf(img_path, sizeof(img_path), "%s/frame.jpg", tmpdir);
	FILE *f = fopen(img_path, "wb");
	if (!f || !jpeg) {
		CHECK_MSG(0, "cannot write %s", img_path);
		free(jpeg);
		if (f)
			fclose(f);
		return;
	}
	fwrite(jpeg, 1, bytes, f);
	fclose(f);
	free(jpeg);
	snprintf(args, sizeof(args),
		 "--rig config/rigs/ego_stereo.json --model config/models/default.json --rest --cam right "
		 "--overlay %s --out %s/o",
		 img_path, tmpdir);
	int rc = run_tool(args, out, sizeof(out));
	CHECK_MSG(rc == 0, "exit %d: %s", rc, out);
	snprintf(path, sizeof(path), "%s/o_right_overlay.png", tmpdir);
	int w = 0, h = 0;
	uint8_t *rgb = load_png(path, &w, &h);
	if (rgb) {
		CHECK(w == 128 && h == 128);
		/* each projected joint has a coloured disc on it */
		int seen = 0, drawn = 0;
		for (int j = 0; j < model->njoints; j++) {
			int x, y;
			if (!project(&rig->cams[1], fk->rig_from_joint[j].t, 128, 128, &x, &y))
				continue;
			seen++;
			const uint8_t *p = pixel(rgb, 128, x, y);
			drawn += p[0] + p[1] + p[2] > 150;
		}
		CHECK(seen >= 10);
		CHECK_MSG(drawn == seen, "%d of %d joints drawn", drawn, seen);
		/* and far from the skeleton the frame is untouched */
		CHECK(near_color(pixel(rgb, 128, 5, 64), 0, 0, 0, 8));
		free(rgb);
	}
	unlink(path);
	unlink(img_path);
}

static void test_bad_command_lines(void)
{
	{
		char o[4096];
		CHECK(run_tool("-h", o, sizeof(o)) == 0 && strstr(o, "usage: mocap-render"));
		CHECK(run_tool("-V", o, sizeof(o)) == 0 && strstr(o, "mocap-render "));
	}
	char out[4096];
	CHECK(run_tool("--model config/models/default.json --out /tmp/x", out, sizeof(out)) == 2);
	CHECK(strstr(out, "--rig is required") != NULL);
	CHECK(run_tool("--rig config/rigs/ego_stereo.json --model config/models/default.json --width 0 --height 9 "
		       "--out /tmp/x",
		       out, sizeof(out)) == 2);
	CHECK(strstr(out, "--width: expected an integer 1..4096, got '0'") != NULL);
	CHECK(run_tool("--rig tests/data/rigs/nan_string.json --model config/models/default.json --out /tmp/x", out,
		       sizeof(out)) == 1);
	CHECK_MSG(strstr(out, "tests/data/rigs/nan_string.json: cameras[0].cx: expected a number") != NULL, "%s", out);
	CHECK(run_tool("--rig config/rigs/ego_stereo.json --model config/models/default.json --cam middle --out /tmp/x",
		       out, sizeof(out)) == 1);
	CHECK(strstr(out, "config/rigs/ego_stereo.json: no camera named 'middle'") != NULL);
	CHECK(run_tool("--rig config/rigs/ego_stereo.json --model config/models/default.json --overlay x.jpg --out /tmp/x",
		       out, sizeof(out)) == 2);
	CHECK(strstr(out, "--overlay needs --cam") != NULL);
	/* a pose naming a dof the model does not have */
	char pose[256], args[1024];
	snprintf(pose, sizeof(pose), "%s/pose.json", tmpdir);
	FILE *f = fopen(pose, "w");
	if (f) {
		fputs("{\"dofs\": {\"left_elbow.x\": 40, \"left_elbw.x\": 3}}", f);
		fclose(f);
		snprintf(args, sizeof(args),
			 "--rig config/rigs/ego_stereo.json --model config/models/default.json --pose %s --out %s/p",
			 pose, tmpdir);
		CHECK(run_tool(args, out, sizeof(out)) == 1);
		CHECK_MSG(strstr(out, ": dofs.left_elbw.x: no such dof in the model") != NULL, "%s", out);
		unlink(pose);
	}
	/* the output folder must exist */
	CHECK(run_tool("--rig config/rigs/ego_stereo.json --model config/models/default.json --width 8 --height 8 "
		       "--out /nonexistent-dir/r",
		       out, sizeof(out)) == 1);
	CHECK(strstr(out, "/nonexistent-dir/r_left.png: cannot create") != NULL);
}

int main(int argc, char **argv)
{
	(void)argc;
	mc_test_find_tool(argv[0], "mocap-render", tool, sizeof(tool));
	mc_rig rig;
	static mc_model model;
	static mc_fk fk;
	double pose[MC_MAX_DOF];
	mc_err err = {0};
	if (mc_rig_load("config/rigs/ego_stereo.json", &rig, &err) ||
	    mc_model_load("config/models/default.json", &model, &err)) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	mc_model_rest_pose(&model, pose);
	mc_model_fk(&model, pose, &fk);
	snprintf(tmpdir, sizeof(tmpdir), "/tmp/mocap-test-render-XXXXXX");
	if (!mkdtemp(tmpdir)) {
		fprintf(stderr, "mkdtemp failed\n");
		return 1;
	}
	test_render(&rig, &model, &fk);
	test_overlay(&rig, &model, &fk);
	test_bad_command_lines();
	rmdir(tmpdir);
	return mc_test_finish("test_render_tool");
}
