/* mocap-export: a recorded take (docs/RECORDING.md) as BVH, CSV or JSON
 * joint positions, or one camera's frames as image files.
 *
 *   mocap-export --bvh OUT.bvh TAKE_DIR
 *   mocap-export --csv OUT.csv TAKE_DIR
 *   mocap-export --json OUT.json TAKE_DIR
 *   mocap-export --frames OUT_DIR --camera NAME TAKE_DIR
 *   mocap-export --video OUT.mkv --camera NAME TAKE_DIR
 *
 * Only whole records are read: a take cut by a crash exports up to its last
 * whole frame (and says so). */
#include "base/mc_file.h"
#include "base/mc_math.h"
#include "image/mc_image.h"
#include "image/mc_pixfmt.h"
#include "mc_install_paths.h" /* generated: MC_VERSION */
#include "take.h"

#include <errno.h>
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/pixfmt.h>
#include <getopt.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define fail(code, ...) mc_fail_exit("mocap-export", code, __VA_ARGS__)

static void usage(FILE *f)
{
	fprintf(f, "usage: mocap-export (--bvh OUT.bvh | --csv OUT.csv | --json OUT.json |\n"
		   "                     --frames OUT_DIR --camera NAME | --video OUT.mkv --camera NAME) TAKE_DIR\n"
		   "Exports a take recorded by mocapd (docs/RECORDING.md).\n"
		   "\n"
		   "  --bvh FILE       the skeleton as BVH: the HIERARCHY from the take's skeleton\n"
		   "                   (centimetres), one line of rotations per pose\n"
		   "  --csv FILE       joint positions (metres) and confidences, a row per pose\n"
		   "  --json FILE      the same as JSON\n"
		   "  --frames DIR     one camera's frames as image files (JPEG as recorded,\n"
		   "                   other formats encoded as JPEG), named by sequence\n"
		   "  --video FILE     one camera's frames as a Matroska video, nothing re-encoded\n"
		   "                   (JPEG as MJPEG, raw formats as uncompressed video)\n"
		   "  --camera NAME    the camera for --frames and --video\n"
		   "  --track NAME     the skeletons of mocap-track's poses-NAME.mcr instead of\n"
		   "                   those tracked live\n"
		   "  -h, --help       this text\n"
		   "  -V, --version    the version\n");
}

/* ---- BVH ---- */

static double frame_time(const take_poses *t)
{
	if (t->nposes < 2)
		return 1.0 / 30;
	double span = (double)(t->poses[t->nposes - 1].capture_ns - t->poses[0].capture_ns) * 1e-9;
	return span > 0 ? span / (t->nposes - 1) : 1.0 / 30;
}

static void export_bvh(const take_poses *t, const char *path)
{
	FILE *f = mc_file_create_or_exit("mocap-export", path);
	take_bvh_write_hierarchy(f, &t->def);
	take_bvh_write_motion(f, t->nposes, frame_time(t));
	for (int i = 0; i < t->nposes; i++)
		take_bvh_write_pose(f, &t->def, &t->poses[i]);
	mc_file_close_or_exit("mocap-export", f, path);
}

/* ---- CSV and JSON ----
 * Joint names come from the take as recorded: mocapd's model loader allows
 * only A-Z a-z 0-9 _ - . (docs/MODEL_FORMAT.md), but a crafted or older
 * take may hold anything, so they are escaped here (issue 34). */

/* One CSV header field, name then suffix, quoted (RFC 4180) when the name
 * holds a comma, a quote or a line break. */
static void csv_field(FILE *f, const char *name, const char *suffix)
{
	if (!strpbrk(name, ",\"\r\n")) {
		fprintf(f, ",%s%s", name, suffix);
		return;
	}
	fputs(",\"", f);
	for (const char *c = name; *c; c++) {
		if (*c == '"')
			fputc('"', f);
		fputc(*c, f);
	}
	fprintf(f, "%s\"", suffix);
}

/* A JSON string: quotes, backslashes and every byte outside printable
 * ASCII escaped, so that any name gives valid JSON. */
static void json_string_out(FILE *f, const char *s)
{
	fputc('"', f);
	for (const unsigned char *c = (const unsigned char *)s; *c; c++) {
		if (*c == '"' || *c == '\\')
			fprintf(f, "\\%c", *c);
		else if (*c < 0x20 || *c >= 0x7f)
			fprintf(f, "\\u%04x", *c);
		else
			fputc(*c, f);
	}
	fputc('"', f);
}

static void export_csv(const take_poses *t, const char *path)
{
	FILE *f = mc_file_create_or_exit("mocap-export", path);
	fprintf(f, "seq,capture_ns,realtime_ns,state");
	static const char *const suffix[4] = {"_x", "_y", "_z", "_confidence"};
	for (int j = 0; j < t->def.njoints; j++)
		for (int k = 0; k < 4; k++)
			csv_field(f, t->def.joints[j].name, suffix[k]);
	fputc('\n', f);
	for (int i = 0; i < t->nposes; i++) {
		const take_pose *p = &t->poses[i];
		fprintf(f, "%llu,%llu,%llu,%d", (unsigned long long)p->seq, (unsigned long long)p->capture_ns,
			(unsigned long long)p->realtime_ns, p->state);
		for (int j = 0; j < p->njoints; j++)
			fprintf(f, ",%.6f,%.6f,%.6f,%.3f", p->joints[j].position[0], p->joints[j].position[1],
				p->joints[j].position[2], p->joints[j].confidence);
		fputc('\n', f);
	}
	mc_file_close_or_exit("mocap-export", f, path);
}

static void export_json(const take_poses *t, const char *path)
{
	FILE *f = mc_file_create_or_exit("mocap-export", path);
	fprintf(f, "{\"joints\": [");
	for (int j = 0; j < t->def.njoints; j++) {
		fprintf(f, "%s{\"name\": ", j ? ", " : "");
		json_string_out(f, t->def.joints[j].name);
		fprintf(f, ", \"parent\": %d}", t->def.joints[j].parent);
	}
	fprintf(f, "],\n \"poses\": [\n");
	for (int i = 0; i < t->nposes; i++) {
		const take_pose *p = &t->poses[i];
		fprintf(f, "  {\"seq\": %llu, \"capture_ns\": %llu, \"realtime_ns\": %llu, \"state\": %d, \"positions\": [",
			(unsigned long long)p->seq, (unsigned long long)p->capture_ns, (unsigned long long)p->realtime_ns,
			p->state);
		for (int j = 0; j < p->njoints; j++)
			fprintf(f, "%s[%.6f, %.6f, %.6f]", j ? ", " : "", p->joints[j].position[0], p->joints[j].position[1],
				p->joints[j].position[2]);
		fprintf(f, "], \"confidence\": [");
		for (int j = 0; j < p->njoints; j++)
			fprintf(f, "%s%.3f", j ? ", " : "", p->joints[j].confidence);
		fprintf(f, "]}%s\n", i + 1 < t->nposes ? "," : "");
	}
	fprintf(f, " ],\n \"gap_frames\": %llu}\n", (unsigned long long)t->gap_frames);
	mc_file_close_or_exit("mocap-export", f, path);
}

/* ---- frames ----
 * A bad frame ends the export with a message; the error paths free what
 * they hold first (a frame's buffers, the converter, the reader), so that
 * only the exit is left (LSan found seven that leaked, issue 34). */

/* Writes a whole file; -1 with err naming it. */
static int write_file(const char *path, const void *data, size_t n, mc_err *err)
{
	FILE *f = fopen(path, "wb");
	if (!f)
		return mc_err_set(err, "%s: %s", path, strerror(errno));
	bool bad = fwrite(data, 1, n, f) != n;
	bad |= fclose(f) != 0;
	return bad ? mc_err_set(err, "%s: write error", path) : 0;
}

/* The record file of one camera of the take; exits when there is none. */
static void open_camera(const char *take, const char *camera, take_reader *r)
{
	char path[4300];
	snprintf(path, sizeof(path), "%s/cam-%s.mcr", take, camera);
	mc_err err = {""};
	if (take_reader_open(r, path, &err) < 0)
		fail(1, "%s%s%s%s", err.msg, strstr(err.msg, "No such file") ? " (is '" : "",
		     strstr(err.msg, "No such file") ? camera : "",
		     strstr(err.msg, "No such file") ? "' one of the take's cameras? take.json lists them)" : "");
}

/* One frame as a JPEG file: JPEG as recorded, a raw format (its meta
 * checked before anything is allocated from it) converted and encoded. */
static int export_frame(mc_image_conv *conv, const take_frame_meta *m, const uint8_t *bytes, size_t nbytes,
			const char *path, mc_err *err)
{
	if (m->pixfmt == MC_PIXFMT_MJPEG)
		return write_file(path, bytes, nbytes, err);
	if (take_frame_check_raw(m, nbytes, err) < 0)
		return -1;
	size_t rgb_bytes = (size_t)m->width * m->height * 3, jpeg_bytes = 0;
	uint8_t *rgb = malloc(rgb_bytes), *jpeg = NULL;
	mc_image_frame fr = {.pixfmt = m->pixfmt, .width = m->width, .height = m->height, .stride = m->stride,
			     .data = bytes, .bytes = nbytes};
	int rc = !rgb ? mc_err_set(err, "out of memory (%zu bytes)", rgb_bytes)
		      : mc_image_to_rgb24(conv, &fr, rgb, rgb_bytes, err);
	if (rc == 0)
		rc = mc_image_encode_jpeg(conv, rgb, (int)m->width, (int)m->height, 95, &jpeg, &jpeg_bytes, err);
	if (rc == 0)
		rc = write_file(path, jpeg, jpeg_bytes, err);
	free(rgb);
	free(jpeg);
	return rc;
}

static int export_frames(const char *take, const char *camera, const char *dir)
{
	char path[4300];
	take_reader r;
	mc_err err = {""};
	open_camera(take, camera, &r);
	if (mkdir(dir, 0755) < 0 && errno != EEXIST) {
		take_reader_close(&r);
		fail(1, "%s: %s", dir, strerror(errno));
	}
	mc_image_conv *conv = mc_image_conv_new(&err);
	if (!conv) {
		take_reader_close(&r);
		fail(1, "%s", err.msg);
	}
	take_frame_meta m;
	const uint8_t *bytes;
	size_t nbytes;
	int count = 0;
	while (take_reader_next_frame(&r, &m, &bytes, &nbytes) == 1) {
		snprintf(path, sizeof(path), "%s/%s_%08llu.jpg", dir, camera, (unsigned long long)m.sequence);
		if (export_frame(conv, &m, bytes, nbytes, path, &err) < 0) {
			mc_image_conv_free(conv);
			take_reader_close(&r);
			fail(1, "%s/cam-%s.mcr: frame %llu: %s", take, camera, (unsigned long long)m.sequence, err.msg);
		}
		count++;
	}
	if (r.torn)
		fprintf(stderr, "mocap-export: %s/cam-%s.mcr ends in a torn record (the take was cut): %d whole frames\n",
			take, camera, count);
	printf("mocap-export: %d frames of %s into %s\n", count, camera, dir);
	mc_image_conv_free(conv);
	take_reader_close(&r);
	return 0;
}

/* ---- video ---- */

/* The pixel format libav calls a raw format; AV_PIX_FMT_NONE: not one. */
static enum AVPixelFormat av_format_of(uint32_t pixfmt)
{
	switch (pixfmt) {
	case MC_PIXFMT_RGB24: return AV_PIX_FMT_RGB24;
	case MC_PIXFMT_GRAY8: return AV_PIX_FMT_GRAY8;
	case MC_PIXFMT_YUYV: return AV_PIX_FMT_YUYV422;
	case MC_PIXFMT_BAYER_RGGB8: return AV_PIX_FMT_BAYER_RGGB8;
	case MC_PIXFMT_BAYER_GRBG8: return AV_PIX_FMT_BAYER_GRBG8;
	case MC_PIXFMT_BAYER_GBRG8: return AV_PIX_FMT_BAYER_GBRG8;
	case MC_PIXFMT_BAYER_BGGR8: return AV_PIX_FMT_BAYER_BGGR8;
	case MC_PIXFMT_DEPTH16: return AV_PIX_FMT_GRAY16LE;
	default: return AV_PIX_FMT_NONE;
	}
}

/* The video stream for the first frame: JPEG as MJPEG, raw formats as
 * uncompressed video (both stored as recorded, nothing re-encoded). */
static AVFormatContext *open_video(const char *out, const take_frame_meta *m)
{
	AVFormatContext *oc = NULL;
	if (avformat_alloc_output_context2(&oc, NULL, "matroska", out) < 0 || !oc)
		fail(1, "%s: cannot make a Matroska file", out);
	AVStream *st = avformat_new_stream(oc, NULL);
	if (!st)
		fail(1, "%s: out of memory", out);
	AVCodecParameters *cp = st->codecpar;
	cp->codec_type = AVMEDIA_TYPE_VIDEO;
	cp->width = (int)m->width;
	cp->height = (int)m->height;
	if (m->pixfmt == MC_PIXFMT_MJPEG) {
		cp->codec_id = AV_CODEC_ID_MJPEG;
	} else {
		enum AVPixelFormat f = av_format_of(m->pixfmt);
		if (f == AV_PIX_FMT_NONE)
			fail(1, "%s: pixel format %u has no uncompressed video counterpart", out, m->pixfmt);
		cp->codec_id = AV_CODEC_ID_RAWVIDEO;
		cp->format = f;
		cp->codec_tag = avcodec_pix_fmt_to_codec_tag(f);
	}
	st->time_base = (AVRational){1, 1000000000};
	if (avio_open(&oc->pb, out, AVIO_FLAG_WRITE) < 0)
		fail(1, "%s: %s", out, strerror(errno));
	if (avformat_write_header(oc, NULL) < 0)
		fail(1, "%s: cannot write the Matroska header", out);
	return oc;
}

/* Rows of a raw frame packed (the ring may pad them to `stride`). */
static size_t packed_copy(const take_frame_meta *m, const uint8_t *src, size_t n, uint8_t *dst)
{
	int bpp = m->pixfmt == MC_PIXFMT_MJPEG ? 0 : mc_image_bytes_per_pixel(m->pixfmt);
	size_t row = (size_t)m->width * (size_t)bpp;
	if (!bpp || !m->stride || m->stride == row) {
		memcpy(dst, src, n);
		return n;
	}
	for (uint32_t y = 0; y < m->height && (size_t)(y + 1) * m->stride <= n + m->stride - row; y++)
		memcpy(dst + y * row, src + (size_t)y * m->stride, row);
	return row * m->height;
}

/* A frame the video stream (made for the first frame) can take: the
 * first frame's format and size, and for a raw format as many bytes as
 * that size needs (a GRAY8 frame claiming 8x100 in 64 bytes made the
 * packet 800 bytes long: a heap overflow read, found with issue 34's
 * shapes).  -1 with err. */
static int video_frame_ok(const take_frame_meta *first, const take_frame_meta *m, size_t bytes, mc_err *err)
{
	if (m->pixfmt != first->pixfmt || m->width != first->width || m->height != first->height)
		return mc_err_set(err, "%ux%u %s, where the video is %ux%u %s", m->width, m->height,
				  mc_pixfmt_name(m->pixfmt), first->width, first->height, mc_pixfmt_name(first->pixfmt));
	return m->pixfmt == MC_PIXFMT_MJPEG ? 0 : take_frame_check_raw(m, bytes, err);
}

/* One frame as a packet at its capture time; -1 with err. */
static int write_packet(AVFormatContext *oc, const take_frame_meta *m, const uint8_t *frame, size_t bytes,
			uint64_t t0, mc_err *err)
{
	AVPacket *pkt = av_packet_alloc();
	if (!pkt || av_new_packet(pkt, (int)bytes) < 0) {
		av_packet_free(&pkt);
		return mc_err_set(err, "out of memory");
	}
	pkt->size = (int)packed_copy(m, frame, bytes, pkt->data);
	pkt->pts = pkt->dts = av_rescale_q((int64_t)(m->capture_ns - t0), (AVRational){1, 1000000000},
					   oc->streams[0]->time_base);
	pkt->flags |= AV_PKT_FLAG_KEY;
	int rc = av_write_frame(oc, pkt) < 0 ? mc_err_set(err, "cannot write it") : 0;
	av_packet_free(&pkt);
	return rc;
}

static void export_video(const char *take, const char *camera, const char *out)
{
	take_reader r;
	open_camera(take, camera, &r);
	AVFormatContext *oc = NULL;
	int count = 0;
	take_frame_meta first = {0}, m;
	const uint8_t *frame;
	size_t bytes;
	mc_err err = {""};
	while (take_reader_next_frame(&r, &m, &frame, &bytes) == 1) {
		if (!oc && (video_frame_ok(&m, &m, bytes, &err) < 0 || !(oc = open_video(out, &m))))
			break;
		if (count == 0)
			first = m;
		if (video_frame_ok(&first, &m, bytes, &err) < 0 || write_packet(oc, &m, frame, bytes, first.capture_ns, &err) < 0)
			break;
		count++;
	}
	take_reader_close(&r);
	if (err.msg[0]) {
		if (oc)
			avio_closep(&oc->pb);
		avformat_free_context(oc);
		fail(1, "%s/cam-%s.mcr: frame %llu: %s", take, camera, (unsigned long long)m.sequence, err.msg);
	}
	if (!oc)
		fail(1, "%s/cam-%s.mcr: no whole frame", take, camera);
	if (av_write_trailer(oc) < 0 || avio_closep(&oc->pb) < 0)
		fail(1, "%s: write error", out);
	avformat_free_context(oc);
	printf("mocap-export: %d frames of %s into %s\n", count, camera, out);
}

int main(int argc, char **argv)
{
	const char *bvh = NULL, *csv = NULL, *json = NULL, *frames = NULL, *camera = NULL, *track = NULL, *video = NULL;
	static const struct option opts[] = {
		{"bvh", required_argument, NULL, 'b'},    {"csv", required_argument, NULL, 'c'},
		{"json", required_argument, NULL, 'j'},   {"frames", required_argument, NULL, 'f'},
		{"camera", required_argument, NULL, 'C'}, {"track", required_argument, NULL, 't'},
		{"video", required_argument, NULL, 'v'},
		{"help", no_argument, NULL, 'h'},
		{"version", no_argument, NULL, 'V'},      {NULL, 0, NULL, 0},
	};
	int o;
	while ((o = getopt_long(argc, argv, "hV", opts, NULL)) != -1) {
		switch (o) {
		case 'b': bvh = optarg; break;
		case 'c': csv = optarg; break;
		case 'j': json = optarg; break;
		case 'f': frames = optarg; break;
		case 'C': camera = optarg; break;
		case 't': track = optarg; break;
		case 'v': video = optarg; break;
		case 'h': usage(stdout); return 0;
		case 'V': printf("mocap-export %s\n", MC_VERSION); return 0;
		default: usage(stderr); return 2;
		}
	}
	if (optind + 1 != argc || (!bvh && !csv && !json && !frames && !video) || ((frames || video) && !camera)) {
		usage(stderr);
		return 2;
	}
	const char *take = argv[optind];
	mc_err err = {""};
	take_info info;
	if (take_info_read(take, &info, &err) < 0)
		fail(1, "%s", err.msg);
	if (frames)
		export_frames(take, camera, frames);
	if (video)
		export_video(take, camera, video);
	if (!bvh && !csv && !json)
		return 0;
	take_poses t;
	if (take_poses_load(take, track, &t, &err) < 0)
		fail(1, "%s", err.msg);
	if (t.torn)
		fprintf(stderr, "mocap-export: %s/poses.mcr ends in a torn record (the take was cut): %d whole poses\n",
			take, t.nposes);
	if (bvh)
		export_bvh(&t, bvh);
	if (csv)
		export_csv(&t, csv);
	if (json)
		export_json(&t, json);
	if (t.gap_frames == UINT64_MAX) /* take_poses_load saturates the sum */
		printf("mocap-export: %d poses (gap records claim 2^64 or more missed: damaged) of %s%s\n", t.nposes, take,
		       info.complete ? "" : " (not stopped cleanly)");
	else
		printf("mocap-export: %d poses (%llu missed by the recorder) of %s%s\n", t.nposes,
		       (unsigned long long)t.gap_frames, take, info.complete ? "" : " (not stopped cleanly)");
	take_poses_free(&t);
	return 0;
}
