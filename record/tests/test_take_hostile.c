/* Takes that are damaged or crafted (issue 34), with valid CRCs, against
 * the offline tools and the take driver:
 *   - skeletons with more joints than their definition: mocap-track
 *     crashed (item 3); fewer: the BVH export read memory never written
 *     (item 5).  Both are refused now, naming the skeleton.
 *   - joint names with quotes, commas, spaces, braces and line breaks:
 *     the JSON export parses, the CSV header has its columns, the BVH
 *     reads back with every joint (item 4).
 *   - raw frames that claim sizes their record does not hold: refused
 *     before anything is allocated from them (item 6).
 *   - a FIFO as a camera file or take.json: refused, not waited on; a
 *     frame 10^18 ns after the previous one: replayed at once (item 7).
 *   - gap counts that would wrap (the "Also" list). */
#include "base/mc_file.h"
#include "image/mc_pixfmt.h"
#include "take.h"
#include "test_util.h"
#include "drivers/plugin_host.h"
#include "body/mc_bvh.h"

#include <fcntl.h>
#include <jansson.h>
#include <limits.h>
#include <sys/stat.h>

static char dir[] = "/tmp/test-take-hostile-XXXXXX";
static char bin[PATH_MAX];

/* TAKE/take.json naming camera "left". */
static void make_take_json(const char *take)
{
	mc_err err = {""};
	take_info t = {.ncams = 1, .complete = true};
	snprintf(t.cams[0], sizeof(t.cams[0]), "left");
	CHECK_MSG(take_info_write(take, &t, &err) == 0, "%s", err.msg);
}

/* A take TAKE (under dir) with camera "left" named in take.json. */
static void make_take(const char *take)
{
	CHECK(mkdir(take, 0755) == 0);
	make_take_json(take);
}

/* poses.mcr: a definition of ndef joints named by names (NULL: jN), then
 * nposes skeletons of npose joints each, and gap records of gaps[]. */
static void write_poses(const char *take, int ndef, const char *const *names, int npose, int nposes,
			const uint64_t *gaps, int ngaps)
{
	char path[PATH_MAX];
	snprintf(path, sizeof(path), "%s/poses.mcr", take);
	static take_def def;
	static take_pose p;
	static uint8_t buf[64 + 64 * TAKE_MAX_JOINTS + 8 * TAKE_MAX_DOF];
	memset(&def, 0, sizeof(def));
	def.id = 1;
	def.njoints = ndef;
	for (int j = 0; j < ndef; j++) {
		if (names)
			snprintf(def.joints[j].name, sizeof(def.joints[j].name), "%s", names[j]);
		else
			snprintf(def.joints[j].name, sizeof(def.joints[j].name), "j%d", j);
		def.joints[j].parent = j - 1;
		def.joints[j].offset[1] = j ? 0.1 : 0;
	}
	take_file f;
	mc_err err = {""};
	CHECK_MSG(take_file_create(&f, path, &err) == 0, "%s", err.msg);
	size_t n = take_encode_def(&def, buf, sizeof(buf));
	CHECK(n > 0 && take_file_append(&f, TAKE_DEF, buf, n, NULL, 0, 1, &err) == 0);
	for (int i = 0; i < nposes; i++) {
		memset(&p, 0, sizeof(p));
		p.seq = (uint64_t)i + 1;
		p.capture_ns = 1000000000ull + (uint64_t)i * 33333333ull;
		p.def_id = 1;
		p.njoints = npose;
		for (int j = 0; j < npose; j++) {
			p.joints[j].position[1] = 0.1 * j;
			p.joints[j].orientation[0] = 1;
			p.joints[j].confidence = 1;
		}
		n = take_encode_pose(&p, buf, sizeof(buf));
		CHECK(n > 0 && take_file_append(&f, TAKE_SKELETON, buf, n, NULL, 0, 2, &err) == 0);
	}
	for (int g = 0; g < ngaps; g++) {
		n = take_encode_gap(100 + (uint64_t)g, gaps[g], buf, sizeof(buf));
		CHECK(take_file_append(&f, TAKE_GAP, buf, n, NULL, 0, 3, &err) == 0);
	}
	take_file_close(&f);
}

/* cam-left.mcr with n frames of meta m (capture times from times[]) and
 * nbytes bytes each. */
static void write_frames(const char *take, take_frame_meta m, const uint64_t *times, int n, size_t nbytes)
{
	char path[PATH_MAX];
	snprintf(path, sizeof(path), "%s/cam-left.mcr", take);
	take_file f;
	mc_err err = {""};
	CHECK_MSG(take_file_create(&f, path, &err) == 0, "%s", err.msg);
	static uint8_t data[4096];
	for (int k = 0; k < n; k++) {
		uint8_t head[TAKE_FRAME_META_SIZE];
		m.sequence = (uint64_t)k;
		m.capture_ns = times[k];
		take_encode_frame_meta(&m, head);
		CHECK(nbytes <= sizeof(data) &&
		      take_file_append(&f, TAKE_FRAME, head, sizeof(head), data, nbytes, 1, &err) == 0);
	}
	take_file_close(&f);
}

/* Runs BIN/bin/TOOL ARGS under a 20 s timeout; its exit status (124:
 * timed out, -1: killed by a signal) and output. */
static int tool(const char *name, const char *args, char *out, size_t cap)
{
	char cmd[2 * PATH_MAX + 512];
	snprintf(cmd, sizeof(cmd), "timeout 20 %s/bin/%s %s 2>&1", bin, name, args);
	int rc = mc_test_run(cmd, out, cap);
	printf("%s %s: exit %d: %s", name, args, rc, out);
	return rc;
}

/* Items 3 and 5: joint counts that disagree with the definition. */
static void check_joint_counts(void)
{
	char take[PATH_MAX], args[PATH_MAX + 64], out[8192];
	/* A take mocap-track gets as far as the tracker with: the rig and the
	 * model of the bundled demo, a camera with a frame. */
	snprintf(take, sizeof(take), "%s/more", dir);
	make_take(take);
	write_poses(take, 3, NULL, 19, 2, NULL, 0);
	mc_err err = {""};
	CHECK(take_copy_file("config/rigs/ego_stereo.json", take, "rig.json", &err) == 0);
	CHECK(take_copy_file("config/models/default.json", take, "model.json", &err) == 0);
	take_frame_meta m = {.pixfmt = MC_PIXFMT_GRAY8, .width = 8, .height = 8};
	uint64_t times[1] = {1000000000ull};
	write_frames(take, m, times, 1, 64);
	take_info t = {.ncams = 1, .complete = true, .frames = {1}};
	snprintf(t.cams[0], sizeof(t.cams[0]), "left");
	CHECK(take_info_write(take, &t, &err) == 0);
	snprintf(args, sizeof(args), "--quiet %s", take);
	int rc = tool("mocap-track", args, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "skeleton 1 (seq 1): 19 joints, the skeleton definition has 3"),
		  "more joints than the definition: exit %d", rc);

	snprintf(take, sizeof(take), "%s/fewer", dir);
	make_take(take);
	write_poses(take, 6, NULL, 3, 2, NULL, 0);
	snprintf(args, sizeof(args), "--bvh %s/fewer.bvh %s", dir, take);
	rc = tool("mocap-export", args, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "skeleton 1 (seq 1): 3 joints, the skeleton definition has 6"),
		  "fewer joints than the definition: exit %d", rc);
}

/* Counts the fields of one CSV line (RFC 4180 quoting). */
static int csv_fields(const char *line)
{
	int n = 1;
	bool quoted = false;
	for (const char *c = line; *c && (quoted || *c != '\n'); c++) {
		if (*c == '"')
			quoted = !quoted; /* a doubled quote toggles twice */
		else if (*c == ',' && !quoted)
			n++;
	}
	return n;
}

/* Item 4: hostile joint names come out escaped. */
static void check_names(void)
{
	static const char *const names[4] = {"root", "x\"},\n{\"evil", "a,b\"c", "MOTION {\nFrames: 9"};
	char take[PATH_MAX], args[PATH_MAX * 2 + 64], out[8192], path[PATH_MAX + 32];
	snprintf(take, sizeof(take), "%s/names", dir);
	make_take(take);
	write_poses(take, 4, names, 4, 3, NULL, 0);
	snprintf(args, sizeof(args), "--json %s/n.json --csv %s/n.csv --bvh %s/n.bvh %s", dir, dir, dir, take);
	int rc = tool("mocap-export", args, out, sizeof(out));
	CHECK_MSG(rc == 0, "exit %d", rc);
	/* JSON: parses, and the names come back as they were. */
	snprintf(path, sizeof(path), "%s/n.json", dir);
	json_error_t je;
	json_t *root = json_load_file(path, 0, &je);
	CHECK_MSG(root != NULL, "%s: %s (line %d)", path, je.text, je.line);
	json_t *joints = json_object_get(root, "joints");
	CHECK(json_array_size(joints) == 4 && json_object_size(root) == 3);
	for (size_t j = 0; j < json_array_size(joints); j++) {
		const char *got = json_string_value(json_object_get(json_array_get(joints, j), "name"));
		CHECK_MSG(got && strcmp(got, names[j]) == 0, "joint %zu: %s", j, got ? got : "(none)");
	}
	CHECK(json_array_size(json_object_get(root, "poses")) == 3);
	json_decref(root);
	/* CSV: 4 + 4 per joint columns in the header, as in each row. */
	uint8_t *text = NULL;
	size_t len = 0;
	mc_err err = {""};
	snprintf(path, sizeof(path), "%s/n.csv", dir);
	CHECK(mc_file_read(path, 1 << 20, &text, &len, &err) == 0);
	CHECK_MSG(text && csv_fields((char *)text) == 4 + 4 * 4, "CSV header: %d fields",
		  text ? csv_fields((char *)text) : -1);
	free(text);
	/* BVH: every joint and every frame read back. */
	snprintf(path, sizeof(path), "%s/n.bvh", dir);
	mc_bvh bvh;
	if (mc_bvh_load(path, &bvh, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return;
	}
	CHECK_MSG(bvh.nframes == 3 && mc_bvh_count_joints(&bvh) == 4, "BVH: %d frames, %d joints", bvh.nframes,
		  mc_bvh_count_joints(&bvh));
	mc_bvh_free(&bvh);
}

/* Item 6: raw frames whose size their record does not hold. */
static void check_frame_sizes(void)
{
	static const struct {
		uint32_t w, h, stride;
		const char *want;
	} cases[] = {
		{0xffffffffu, 0xffffffffu, 0, "width x height: 4294967295x4294967295, not within 1..16384"},
		{65535, 65535, 0, "width x height: 65535x65535, not within 1..16384"},
		{4096, 4096, 0, "4096x4096 GRAY8 needs 16777216 bytes, the record holds 64"},
		{8, 8, 4, "stride: 4 bytes"},
	};
	char take[PATH_MAX], args[PATH_MAX * 2 + 64], out[8192];
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		snprintf(take, sizeof(take), "%s/size%zu", dir, i);
		make_take(take);
		take_frame_meta m = {.pixfmt = MC_PIXFMT_GRAY8, .width = 8, .height = 8};
		uint64_t times[2] = {1000000000ull, 1033333333ull};
		write_frames(take, m, times, 1, 64); /* a good frame first: its buffers are freed */
		char path[PATH_MAX + 32];
		snprintf(path, sizeof(path), "%s/cam-left.mcr", take);
		take_file f = {.fd = open(path, O_WRONLY | O_APPEND)};
		snprintf(f.path, sizeof(f.path), "%.4000s", path);
		m = (take_frame_meta){.sequence = 1, .capture_ns = times[1], .pixfmt = MC_PIXFMT_GRAY8,
				      .width = cases[i].w, .height = cases[i].h, .stride = cases[i].stride};
		uint8_t head[TAKE_FRAME_META_SIZE], data[64] = {0};
		take_encode_frame_meta(&m, head);
		mc_err err = {""};
		CHECK(f.fd >= 0 && take_file_append(&f, TAKE_FRAME, head, sizeof(head), data, sizeof(data), 1, &err) == 0);
		take_file_close(&f);
		snprintf(args, sizeof(args), "--frames %s/frames%zu --camera left %s", dir, i, take);
		int rc = tool("mocap-export", args, out, sizeof(out));
		/* exit 1 exactly: under ASan a leak on the way out makes it 23 */
		CHECK_MSG(rc == 1 && strstr(out, "cam-left.mcr: frame 1: ") && strstr(out, cases[i].want),
			  "case %zu: exit %d, wanted '%s'", i, rc, cases[i].want);
	}
}

/* --video: frames the stream cannot take are refused (a GRAY8 frame
 * claiming 8x100 in 64 bytes made an 800-byte packet of a 64-byte buffer:
 * a heap overflow read under ASan). */
static void check_video_sizes(void)
{
	static const struct {
		uint32_t h0, h1;
		const char *want;
	} cases[] = {
		{4, 100, "cam-left.mcr: frame 1: 8x100 GRAY8, where the video is 8x4 GRAY8"},
		{100, 100, "cam-left.mcr: frame 0: 8x100 GRAY8 needs 1592 bytes, the record holds 64"},
	};
	char take[PATH_MAX], args[PATH_MAX * 2 + 64], out[8192];
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		snprintf(take, sizeof(take), "%s/video%zu", dir, i);
		make_take(take);
		char path[PATH_MAX + 32];
		snprintf(path, sizeof(path), "%s/cam-left.mcr", take);
		take_file f;
		mc_err err = {""};
		CHECK(take_file_create(&f, path, &err) == 0);
		uint8_t data[64] = {0};
		for (int k = 0; k < 2; k++) {
			take_frame_meta m = {.sequence = (uint64_t)k, .capture_ns = 1000000000ull + (uint64_t)k * 33333333ull,
					     .pixfmt = MC_PIXFMT_GRAY8, .width = 8, .height = k ? cases[i].h1 : cases[i].h0,
					     .stride = 16};
			uint8_t head[TAKE_FRAME_META_SIZE];
			take_encode_frame_meta(&m, head);
			CHECK(take_file_append(&f, TAKE_FRAME, head, sizeof(head), data, sizeof(data), 1, &err) == 0);
		}
		take_file_close(&f);
		snprintf(args, sizeof(args), "--video %s/v%zu.mkv --camera left %s", dir, i, take);
		int rc = tool("mocap-export", args, out, sizeof(out));
		CHECK_MSG(rc == 1 && strstr(out, cases[i].want), "case %zu: exit %d, wanted '%s'", i, rc, cases[i].want);
	}
}

/* Item 7: FIFOs are refused at once, not waited on. */
static void check_fifos(void)
{
	char take[PATH_MAX], path[PATH_MAX + 32], args[PATH_MAX * 2 + 64], out[8192];
	snprintf(take, sizeof(take), "%s/fifo", dir);
	make_take(take);
	snprintf(path, sizeof(path), "%s/cam-left.mcr", take);
	CHECK(mkfifo(path, 0644) == 0);
	snprintf(args, sizeof(args), "--frames %s/fifo-frames --camera left %s", dir, take);
	int rc = tool("mocap-export", args, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "cam-left.mcr: not a regular file (a FIFO)"), "camera FIFO: exit %d", rc);
	snprintf(path, sizeof(path), "%s/take.json", take);
	CHECK(unlink(path) == 0 && mkfifo(path, 0644) == 0);
	snprintf(args, sizeof(args), "--json %s/fifo.json %s", dir, take);
	rc = tool("mocap-export", args, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "take.json: not a regular file (a FIFO)"), "take.json FIFO: exit %d", rc);
}

/* Item 7: the take driver replays a take with a frame 10^18 ns after the
 * previous one (and one that goes back in time) without waiting for it. */
static void check_driver_gaps(void)
{
	char take[PATH_MAX];
	snprintf(take, sizeof(take), "%s/gaps", dir);
	make_take(take);
	take_frame_meta m = {.pixfmt = MC_PIXFMT_GRAY8, .width = 8, .height = 8};
	uint64_t t0 = 1000000000ull;
	uint64_t times[5] = {t0, t0 + 33333333ull, t0 + 1000000000000000000ull, t0 + 1000000000033333333ull, t0};
	write_frames(take, m, times, 5, 64);
	char drivers[PATH_MAX + 16];
	snprintf(drivers, sizeof(drivers), "%s/drivers", bin);
	setenv("MOCAP_DRIVER_DIR", drivers, 1);
	void *dl = NULL;
	if (!(drv = load_plugin("take", &dl))) {
		CHECK_MSG(false, "mocap-driver-take.so does not load from %s", drivers);
		return;
	}
	static config c;
	cfg_setv(&c, "take", take, "camera", "left", NULL);
	void *dev = open_start(&c);
	CHECK_MSG(dev != NULL, "%s", err);
	static uint8_t data[4096];
	mdrv_frame slot = {.data = data, .capacity = sizeof(data)};
	int got = 0;
	uint64_t start = mc_now_ns();
	while (dev && mc_now_ns() - start < 3000000000ull) {
		int rc = drv->next_frame(dev, &slot, 100, err, sizeof(err));
		if (rc == MDRV_ERR_END)
			break;
		got += rc == MDRV_OK;
	}
	double secs = (double)(mc_now_ns() - start) * 1e-9;
	printf("take driver: %d of 5 frames in %.2f s\n", got, secs);
	CHECK_MSG(got == 5 && secs < 2, "%d of 5 frames in %.2f s (a gap of 10^18 ns was waited for)", got, secs);
	if (dev)
		drv->close(dev);
	/* mocapd --check runs the driver's check: a FIFO as the camera file
	 * is refused at once, where opening it waited for a writer for ever. */
	snprintf(take, sizeof(take), "%s/fifo", dir); /* check_fifos made it */
	static config cf;
	cfg_setv(&cf, "take", take, "camera", "left", NULL);
	cf.host = host_for(&cf);
	char path[PATH_MAX + 32];
	snprintf(path, sizeof(path), "%s/take.json", take);
	unlink(path);
	make_take_json(take);
	err[0] = 0;
	int rc = drv->check ? drv->check(&cf.host, err, sizeof(err)) : MDRV_OK;
	printf("take driver check on a FIFO: %d: %s\n", rc, err);
	CHECK_MSG(rc == MDRV_ERR_CONFIG && strstr(err, "cam-left.mcr: not a regular file (a FIFO)"), "check: %d: %s", rc,
		  err);
	dlclose(dl);
}

/* Gap counts add up without wrapping. */
static void check_gap_counts(void)
{
	char take[PATH_MAX], args[PATH_MAX * 2 + 64], out[8192];
	snprintf(take, sizeof(take), "%s/gapcount", dir);
	make_take(take);
	uint64_t gaps[2] = {UINT64_MAX - 1, 2};
	write_poses(take, 2, NULL, 2, 2, gaps, 2);
	snprintf(args, sizeof(args), "--csv %s/g.csv %s", dir, take);
	int rc = tool("mocap-export", args, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "gap records claim 2^64 or more missed: damaged"), "exit %d", rc);
}

int main(void)
{
	if (access("config/models/default.json", R_OK) != 0)
		TEST_SKIP("run from the repository root");
	if (!mc_test_build_dir(3, bin, sizeof(bin))) /* <build>/record/tests/test_take_hostile */
		TEST_SKIP("no build folder");
	if (!mkdtemp(dir))
		TEST_SKIP("cannot create a scratch directory");
	check_joint_counts();
	check_names();
	check_frame_sizes();
	check_video_sizes();
	check_fifos();
	check_driver_gaps();
	check_gap_counts();
	char cmd[128];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	CHECK(system(cmd) == 0);
	return mc_test_finish("test_take_hostile");
}
