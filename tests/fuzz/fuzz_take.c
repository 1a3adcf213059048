/* libFuzzer target: a take's record files (record/take.c), as
 * mocap-export, mocap-track and the take driver read them (issue 34).
 * Each input is read twice:
 *   - as poses.mcr, through take_poses_load (a directory made once holds
 *     poses.mcr, a link to the input's file): a refused take gets a
 *     message naming the file; an accepted one has skeletons with as many
 *     joints as its definition, and its BVH is written (to /dev/null) as
 *     mocap-export writes it;
 *   - as a camera file, every frame record: raw frames that
 *     take_frame_check_raw passes are converted to RGB in a buffer of
 *     their size, as mocap-export --frames and mocap-track do. */
#include "fuzz_util.h"

#include "image/mc_image.h"
#include "image/mc_pixfmt.h"
#include "take.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[] = "/tmp/fuzz-take-XXXXXX";
static char link_path[64];
static FILE *null_out;
static mc_image_conv *conv;

static void remove_dir(void)
{
	unlink(link_path);
	rmdir(dir);
}

/* The directory, its poses.mcr link to the input, /dev/null, a converter. */
static void setup(const char *input)
{
	mc_err err = {{0}};
	if (!mkdtemp(dir) || snprintf(link_path, sizeof(link_path), "%s/poses.mcr", dir) < 0 ||
	    symlink(input, link_path) != 0 || !(null_out = fopen("/dev/null", "w")) || !(conv = mc_image_conv_new(&err))) {
		perror("fuzz_take: setup");
		abort();
	}
	atexit(remove_dir);
}

static void poses(void)
{
	static take_poses t;
	mc_err err = {{0}};
	if (take_poses_load(dir, NULL, &t, &err) != 0) {
		fuzz_check_refusal("fuzz_take", link_path, &err);
		return;
	}
	take_bvh_write_hierarchy(null_out, &t.def);
	take_bvh_write_motion(null_out, t.nposes, 1.0 / 30);
	for (int i = 0; i < t.nposes; i++) {
		if (t.poses[i].njoints != t.def.njoints)
			fuzz_fail("fuzz_take", "a skeleton's joint count differs from its definition's", NULL);
		take_bvh_write_pose(null_out, &t.def, &t.poses[i]);
	}
	take_poses_free(&t);
}

static void frames(void)
{
	take_reader r;
	mc_err err = {{0}};
	if (take_reader_open(&r, link_path, &err) != 0)
		fuzz_fail("fuzz_take", "the input's file does not open", &err);
	take_frame_meta m;
	const uint8_t *bytes;
	size_t n;
	while (take_reader_next_frame(&r, &m, &bytes, &n) == 1) {
		if (m.pixfmt == MC_PIXFMT_MJPEG || take_frame_check_raw(&m, n, &err) != 0)
			continue;
		size_t rgb_bytes = (size_t)m.width * m.height * 3;
		uint8_t *rgb = malloc(rgb_bytes);
		if (!rgb)
			fuzz_fail("fuzz_take", "a checked frame's RGB buffer does not allocate", NULL);
		mc_image_frame f = {.pixfmt = m.pixfmt, .width = m.width, .height = m.height, .stride = m.stride,
				    .data = bytes, .bytes = n};
		mc_image_to_rgb24(conv, &f, rgb, rgb_bytes, &err);
		free(rgb);
	}
	take_reader_close(&r);
}

static int load(const char *path, void *ctx)
{
	(void)ctx;
	if (!conv)
		setup(path);
	poses();
	frames();
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	fuzz_load_from_file(data, size, load, NULL);
	return 0;
}
