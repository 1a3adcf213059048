/* The take format without a daemon: records read back as written; a file
 * cut at any byte, or with a flipped byte, reads up to its last whole
 * record and says it is torn; a full disk fails the append with the
 * reason and leaves whole records; take.json round-trips; and mocap-export's
 * BVH, read back with the core's BVH reader and forward kinematics,
 * reproduces the recorded joint positions of mocapd's default model at
 * random poses within 1 mm (within 1e-5 m: printed precision). */
#include "base/mc_file.h"
#include "image/mc_pixfmt.h"
#include "body/mc_bvh.h"
#include "body/mc_model.h"
#include "take.h"
#include "test_util.h"

#include <fcntl.h>
#include <jansson.h>
#include <libavformat/avformat.h>
#include <limits.h>
#include <string.h>
#include <unistd.h>

static char dir[] = "/tmp/test-take-XXXXXX";

static void write_poses(const char *take, const take_def *def, const take_pose *poses, int n)
{
	char path[256];
	snprintf(path, sizeof(path), "%s/poses.mcr", take);
	take_file f;
	mc_err err = {""};
	static uint8_t buf[64 + 64 * TAKE_MAX_JOINTS];
	CHECK_MSG(take_file_create(&f, path, &err) == 0, "%s", err.msg);
	size_t k = take_encode_def(def, buf, sizeof(buf));
	CHECK(k > 0 && take_file_append(&f, TAKE_DEF, buf, k, NULL, 0, 1, &err) == 0);
	for (int i = 0; i < n; i++) {
		if (i == 3) { /* two poses the recorder missed */
			size_t g = take_encode_gap(poses[i - 1].seq + 1, 2, buf, sizeof(buf));
			CHECK(take_file_append(&f, TAKE_GAP, buf, g, NULL, 0, 2, &err) == 0);
		}
		k = take_encode_pose(&poses[i], buf, sizeof(buf));
		CHECK(k > 0 && take_file_append(&f, TAKE_SKELETON, buf, k, NULL, 0, 3, &err) == 0);
		if (i == 1) { /* the keypoints pose 1 was tracked with */
			take_keypoint kp[2] = {{0, 5, 100.5f, 200.25f, 0.9f}, {1, 17, 3.f, 4.f, 0.25f}};
			k = take_encode_keypoints(poses[i].seq, poses[i].capture_ns, kp, 2, buf, sizeof(buf));
			CHECK(k > 0 && take_file_append(&f, TAKE_KEYPOINTS, buf, k, NULL, 0, 3, &err) == 0);
		}
	}
	CHECK(take_file_sync(&f, &err) == 0);
	take_file_close(&f);
}

static void pose_from_fk(const mc_model *model, const double *dofs, uint64_t seq, take_pose *p)
{
	mc_fk fk;
	mc_model_fk(model, dofs, &fk);
	memset(p, 0, sizeof(*p));
	p->seq = seq;
	p->capture_ns = 1000000000ull + seq * 33333333ull;
	p->def_id = 1;
	p->njoints = model->njoints;
	for (int j = 0; j < model->njoints; j++) {
		mc_quat q = mc_quat_from_m3(fk.rig_from_joint[j].R);
		p->joints[j].position[0] = fk.rig_from_joint[j].t.x;
		p->joints[j].position[1] = fk.rig_from_joint[j].t.y;
		p->joints[j].position[2] = fk.rig_from_joint[j].t.z;
		p->joints[j].orientation[0] = q.w;
		p->joints[j].orientation[1] = q.x;
		p->joints[j].orientation[2] = q.y;
		p->joints[j].orientation[3] = q.z;
		p->joints[j].confidence = 0.5f;
	}
}

/* Whole records survive any cut and any flipped byte in a later one. */
static void check_torn(const char *take, int nrecords)
{
	char path[256], cut[256];
	snprintf(path, sizeof(path), "%s/poses.mcr", take);
	snprintf(cut, sizeof(cut), "%s/cut.mcr", take);
	uint8_t *data = NULL;
	size_t size = 0;
	mc_err err = {""};
	CHECK(mc_file_read(path, 1 << 24, &data, &size, &err) == 0);
	/* where each record ends */
	take_reader r;
	CHECK(take_reader_open(&r, path, &err) == 0);
	size_t ends[64];
	int n = 0;
	take_record_type type;
	const uint8_t *p;
	size_t k;
	while (take_reader_next(&r, &type, &p, &k, NULL) == 1 && n < 64)
		ends[n++] = r.pos;
	CHECK(n == nrecords && !r.torn && ends[n - 1] == size);
	take_reader_close(&r);
	int bad = 0;
	for (size_t len = 0; len < size; len += 7) {
		int fd = open(cut, O_WRONLY | O_CREAT | O_TRUNC, 0644);
		CHECK(fd >= 0 && write(fd, data, len) == (ssize_t)len);
		close(fd);
		int whole = 0;
		while (whole < n && ends[whole] <= len)
			whole++;
		CHECK(take_reader_open(&r, cut, &err) == 0);
		int got = 0;
		while (take_reader_next(&r, &type, &p, &k, NULL) == 1)
			got++;
		bool torn_expected = whole == 0 ? len > 0 : ends[whole - 1] != len;
		bad += got != whole || r.torn != torn_expected || r.valid_end != (whole ? ends[whole - 1] : 0);
		take_reader_close(&r);
	}
	CHECK_MSG(bad == 0, "%d cuts read wrong", bad);
	/* A flipped byte in the payload of record 5: records 0..4 only. */
	data[ends[4] + TAKE_HEADER_SIZE + 3] ^= 0x40;
	int fd = open(cut, O_WRONLY | O_CREAT | O_TRUNC, 0644);
	CHECK(fd >= 0 && write(fd, data, size) == (ssize_t)size);
	close(fd);
	CHECK(take_reader_open(&r, cut, &err) == 0);
	int got = 0;
	while (take_reader_next(&r, &type, &p, &k, NULL) == 1)
		got++;
	CHECK_MSG(got == 5 && r.torn, "flipped byte: %d records, torn %d", got, r.torn);
	take_reader_close(&r);
	free(data);
	unlink(cut);
}

/* The keypoints record reads back, tied to its pose. */
static void check_keypoints(const char *take, const take_pose *pose)
{
	char path[256];
	snprintf(path, sizeof(path), "%s/poses.mcr", take);
	take_reader r;
	mc_err err = {""};
	CHECK(take_reader_open(&r, path, &err) == 0);
	take_record_type type;
	const uint8_t *p;
	size_t n;
	int found = 0;
	while (take_reader_next(&r, &type, &p, &n, NULL) == 1) {
		if (type != TAKE_KEYPOINTS)
			continue;
		take_keypoint kp[4];
		uint64_t seq, t;
		int k;
		CHECK(take_decode_keypoints(p, n, &seq, &t, kp, 4, &k) == 0 && k == 2);
		CHECK(seq == pose->seq && t == pose->capture_ns);
		CHECK(kp[0].cam == 0 && kp[0].joint == 5 && kp[0].u == 100.5f && kp[0].v == 200.25f && kp[0].confidence == 0.9f);
		CHECK(kp[1].cam == 1 && kp[1].joint == 17 && kp[1].confidence == 0.25f);
		CHECK(take_decode_keypoints(p, n - 1, &seq, &t, kp, 4, &k) < 0);
		found++;
	}
	CHECK(found == 1);
	take_reader_close(&r);
}

/* A full disk: the append fails, saying so; what is there stays whole. */
static void check_disk_full(void)
{
	take_file f;
	mc_err err = {""};
	memset(&f, 0, sizeof(f));
	snprintf(f.path, sizeof(f.path), "/dev/full");
	f.fd = open("/dev/full", O_WRONLY);
	if (f.fd < 0) {
		printf("SKIP part: no /dev/full here\n");
		return;
	}
	uint8_t payload[100] = {1};
	CHECK(take_file_append(&f, TAKE_GAP, payload, sizeof(payload), NULL, 0, 1, &err) < 0);
	CHECK_MSG(strstr(err.msg, "/dev/full: No space left on device"), "%s", err.msg);
	CHECK(f.bytes == 0);
	take_file_close(&f);
}

static void check_info(const char *take)
{
	take_info t = {.start_realtime_ns = 5, .start_monotonic_ns = 6, .stop_realtime_ns = 7, .complete = true,
		       .ncams = 2, .poses = 40, .pose_gaps = 2, .bytes = 12345};
	snprintf(t.name, sizeof(t.name), "walk-1");
	snprintf(t.stop_reason, sizeof(t.stop_reason), "limit: [record] max_mb = 1 reached");
	snprintf(t.cams[0], sizeof(t.cams[0]), "left");
	snprintf(t.cams[1], sizeof(t.cams[1]), "right");
	t.frames[1] = 90;
	t.frame_drops[1] = 3;
	mc_err err = {""};
	CHECK_MSG(take_info_write(take, &t, &err) == 0, "%s", err.msg);
	take_info u;
	CHECK_MSG(take_info_read(take, &u, &err) == 0, "%s", err.msg);
	CHECK(strcmp(u.name, "walk-1") == 0 && u.complete && u.poses == 40 && u.pose_gaps == 2 && u.ncams == 2);
	CHECK(strcmp(u.cams[1], "right") == 0 && u.frames[1] == 90 && u.frame_drops[1] == 3);
	CHECK(strcmp(u.stop_reason, t.stop_reason) == 0 && u.bytes == 12345 && u.stop_realtime_ns == 7);
	CHECK(take_info_read("/nonexistent", &u, &err) < 0 && strstr(err.msg, "/nonexistent/take.json"));
}

/* Blender's own BVH importer (record/tests/blender_bvh.py) puts every bone
 * head where the take has the joint, within 1 mm; skipped without
 * Blender (`make deps-train`). */
static void check_blender(const char *bvh_path, const mc_model *model, const take_pose *poses, int n)
{
	char cmd[1024], out[8192], json_path[300];
	if (mc_test_run("command -v blender 2>&1", out, sizeof(out)) != 0) {
		printf("SKIP part: Blender is not installed (make deps-train): the BVH is not imported into Blender\n");
		return;
	}
	snprintf(json_path, sizeof(json_path), "%s.json", bvh_path);
	snprintf(cmd, sizeof(cmd), "blender -b --factory-startup --python record/tests/blender_bvh.py -- %s %s 2>&1",
		 bvh_path, json_path);
	int rc = mc_test_run(cmd, out, sizeof(out));
	json_error_t je;
	json_t *frames = json_load_file(json_path, 0, &je);
	if (rc != 0 || !json_is_array(frames)) {
		CHECK_MSG(false, "blender: exit %d, %s: %s\n%s", rc, json_path, je.text, out);
		json_decref(frames);
		return;
	}
	CHECK_MSG((int)json_array_size(frames) == n, "Blender has %zu frames, the take %d", json_array_size(frames), n);
	double worst = 0;
	int compared = 0;
	for (int i = 0; i < n && i < (int)json_array_size(frames); i++)
		for (int j = 0; j < model->njoints; j++) {
			json_t *head = json_object_get(json_array_get(frames, (size_t)i), model->joints[j].name);
			if (!json_is_array(head))
				continue; /* a joint Blender made no bone of */
			const double *want = poses[i].joints[j].position;
			mc_vec3 got = mc_v3(json_number_value(json_array_get(head, 0)), json_number_value(json_array_get(head, 1)),
					    json_number_value(json_array_get(head, 2)));
			double e = mc_v3_norm(mc_v3_sub(got, mc_v3(want[0], want[1], want[2])));
			worst = e > worst ? e : worst;
			compared++;
		}
	printf("Blender BVH import: %d joint positions compared, largest miss %.2e m\n", compared, worst);
	CHECK_MSG(compared >= n * (model->njoints - 2) && worst < 1e-3, "%d compared, worst %.3g m", compared, worst);
	json_decref(frames);
}

/* mocap-export --bvh, read back with mc_bvh: the joints where recorded. */
static void check_bvh(const char *take, const mc_model *model, const take_pose *poses, int n)
{
	char build[PATH_MAX], cmd[PATH_MAX * 2 + 300], out[4096], bvh_path[256];
	if (!mc_test_build_dir(3, build, sizeof(build))) { /* <build>/record/tests/test_take */
		printf("SKIP part: no build folder\n");
		return;
	}
	snprintf(bvh_path, sizeof(bvh_path), "%s/out.bvh", take);
	snprintf(cmd, sizeof(cmd), "%s/bin/mocap-export --bvh %s --csv %s/out.csv %s 2>&1", build, bvh_path, take, take);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "8 poses (2 missed by the recorder)"), "exit %d: %s", rc, out);
	mc_bvh bvh;
	mc_err err = {""};
	if (mc_bvh_load(bvh_path, &bvh, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return;
	}
	CHECK(bvh.nframes == n && mc_bvh_count_joints(&bvh) == model->njoints);
	double worst = 0;
	mc_xform *w = calloc((size_t)bvh.njoints, sizeof(*w));
	for (int i = 0; i < n; i++) {
		mc_bvh_fk(&bvh, i, w);
		for (int j = 0; j < model->njoints; j++) {
			int b = mc_bvh_find(&bvh, model->joints[j].name);
			CHECK(b >= 0);
			if (b < 0)
				continue;
			mc_vec3 got = mc_v3_scale(w[b].t, 0.01); /* centimetres */
			const double *want = poses[i].joints[j].position;
			double e = mc_v3_norm(mc_v3_sub(got, mc_v3(want[0], want[1], want[2])));
			worst = e > worst ? e : worst;
		}
	}
	printf("BVH export: %d poses, largest joint miss %.2e m\n", n, worst);
	CHECK_MSG(worst < 1e-5, "BVH joints %.3g m from the recorded ones", worst);
	free(w);
	mc_bvh_free(&bvh);
	check_blender(bvh_path, model, poses, n);
	/* CSV: a header and a row per pose */
	char csv[256];
	snprintf(csv, sizeof(csv), "%s/out.csv", take);
	uint8_t *text = NULL;
	size_t len = 0;
	CHECK(mc_file_read(csv, 1 << 20, &text, &len, &err) == 0);
	int lines = 0;
	for (size_t k = 0; k < len; k++)
		lines += text[k] == '\n';
	CHECK(lines == n + 1 && text && strncmp((char *)text, "seq,capture_ns,realtime_ns,state,head_x", 39) == 0);
	free(text);
}

/* A camera of raw YUYV frames (8x4, rows padded to 20 bytes) exported
 * with --video: libavformat reads back an uncompressed YUYV Matroska
 * stream with every frame, rows packed, in order, timed as captured. */
static void check_video(const char *take, const char *bin)
{
	char path[256];
	snprintf(path, sizeof(path), "%s/cam-x.mcr", take);
	take_file f;
	mc_err err = {""};
	CHECK(take_file_create(&f, path, &err) == 0);
	uint8_t frame[3][4 * 20];
	for (int k = 0; k < 3; k++) {
		for (int i = 0; i < 4 * 20; i++)
			frame[k][i] = (uint8_t)(k * 50 + i);
		take_frame_meta m = {.sequence = (uint64_t)k, .capture_ns = 1000000000ull + (uint64_t)k * 40000000ull,
				     .pixfmt = MC_PIXFMT_YUYV, .width = 8, .height = 4, .stride = 20};
		uint8_t head[TAKE_FRAME_META_SIZE];
		take_encode_frame_meta(&m, head);
		CHECK(take_file_append(&f, TAKE_FRAME, head, sizeof(head), frame[k], sizeof(frame[k]), 1, &err) == 0);
	}
	take_file_close(&f);
	take_info t = {.ncams = 1};
	snprintf(t.cams[0], sizeof(t.cams[0]), "x");
	CHECK(take_info_write(take, &t, &err) == 0);
	char cmd[PATH_MAX + 600], out[2048], mkv[256];
	snprintf(mkv, sizeof(mkv), "%s/x.mkv", take);
	snprintf(cmd, sizeof(cmd), "%s/bin/mocap-export --video %s --camera x %s 2>&1", bin, mkv, take);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "3 frames of x"), "exit %d: %s", rc, out);
	AVFormatContext *ic = NULL;
	if (avformat_open_input(&ic, mkv, NULL, NULL) < 0 || avformat_find_stream_info(ic, NULL) < 0) {
		CHECK_MSG(false, "libavformat cannot open %s", mkv);
		return;
	}
	const AVCodecParameters *cp = ic->streams[0]->codecpar;
	CHECK(ic->nb_streams == 1 && cp->codec_id == AV_CODEC_ID_RAWVIDEO && cp->format == AV_PIX_FMT_YUYV422 &&
	      cp->width == 8 && cp->height == 4);
	AVPacket *pkt = av_packet_alloc();
	int n = 0;
	double last_s = -1;
	while (pkt && av_read_frame(ic, pkt) == 0) {
		bool packed = pkt->size == 4 * 16;
		for (int y = 0; packed && y < 4 && n < 3; y++)
			packed = memcmp(pkt->data + y * 16, frame[n] + y * 20, 16) == 0;
		CHECK_MSG(packed, "packet %d is not frame %d with its rows packed", n, n);
		double s = (double)pkt->pts * av_q2d(ic->streams[0]->time_base);
		CHECK_MSG(fabs(s - 0.04 * n) < 0.002, "packet %d at %.3f s", n, s);
		last_s = s;
		n++;
		av_packet_unref(pkt);
	}
	CHECK_MSG(n == 3 && last_s > 0, "%d packets", n);
	av_packet_free(&pkt);
	avformat_close_input(&ic);
}

int main(void)
{
	const char *model_path = "config/models/default.json";
	if (access(model_path, R_OK) != 0)
		TEST_SKIP("run from the repository root (%s not found)", model_path);
	if (!mkdtemp(dir))
		TEST_SKIP("cannot create a scratch directory");
	mc_model model;
	mc_err err = {""};
	if (mc_model_load(model_path, &model, &err) < 0) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	model.bone_scale[4] = 1.1; /* an actor's longer upper arm: the take keeps scaled offsets */
	take_def def = {.id = 1, .njoints = model.njoints};
	for (int j = 0; j < model.njoints; j++) {
		snprintf(def.joints[j].name, sizeof(def.joints[j].name), "%s", model.joints[j].name);
		def.joints[j].parent = model.joints[j].parent;
		double s = model.bone_scale[j] > 0 ? model.bone_scale[j] : 1;
		def.joints[j].offset[0] = model.joints[j].offset.x * s;
		def.joints[j].offset[1] = model.joints[j].offset.y * s;
		def.joints[j].offset[2] = model.joints[j].offset.z * s;
	}
	static take_pose poses[8];
	double lo[MC_MAX_DOF], hi[MC_MAX_DOF], dofs[MC_MAX_DOF];
	mc_model_dof_limits(&model, lo, hi);
	uint64_t rng = 11;
	for (int i = 0; i < 8; i++) {
		for (int k = 0; k < model.ndof; k++)
			dofs[k] = lo[k] + (hi[k] - lo[k]) * mc_rng_uniform(&rng);
		pose_from_fk(&model, dofs, (uint64_t)(i < 3 ? i + 1 : i + 3), &poses[i]);
	}
	write_poses(dir, &def, poses, 8);
	take_poses t;
	CHECK_MSG(take_poses_load(dir, NULL, &t, &err) == 0, "%s", err.msg);
	CHECK(t.nposes == 8 && t.gap_frames == 2 && !t.torn && t.def.njoints == model.njoints);
	CHECK(strcmp(t.def.joints[4].name, model.joints[4].name) == 0);
	CHECK_NEAR(t.def.joints[4].offset[1], model.joints[4].offset.y * 1.1, 1e-12);
	CHECK(t.nposes == 8 && memcmp(&t.poses[5].joints[3], &poses[5].joints[3], sizeof(take_joint)) == 0 &&
	      t.poses[7].seq == 10);
	take_poses_free(&t);

	check_torn(dir, 11);
	check_keypoints(dir, &poses[1]);
	check_disk_full();
	check_info(dir);
	check_bvh(dir, &model, poses, 8);
	char build[PATH_MAX];
	if (mc_test_build_dir(3, build, sizeof(build)))
		check_video(dir, build);
	char cmd[64];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	CHECK(system(cmd) == 0);
	return mc_test_finish("test_take");
}
