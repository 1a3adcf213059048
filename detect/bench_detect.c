/* bench_detect: milliseconds per view of the detector runtime (resize,
 * network, decoding), over 200 runs after 10 warm-up runs, for a 128x128
 * view (the network's input size: no resize) and a 256x256 one (the
 * evaluation rig's native size).  The image is frame 0 of the bundled demo
 * clip when found, else a synthetic pattern.
 *
 *     bench_detect --model config/models/ego_detector.onnx [--runs 200] [--threads 1] */
#include "base/mc_stats.h"
#include "base/mc_time.h"
#include "image/mc_image.h"
#include "mc_detector.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void run(mc_detector *d, const uint8_t *rgb, int w, int h, int runs, int threads)
{
	mc_detection det[MC_DETECTOR_MAX_JOINTS];
	mc_err err = {{0}};
	double *ms = calloc((size_t)runs, sizeof(double));
	double infer = 0;
	int found = 0;
	if (!ms)
		return;
	for (int i = 0; i < 10; i++)
		mc_detector_detect(d, rgb, w, h, 0, det, MC_DETECTOR_MAX_JOINTS, &err);
	for (int i = 0; i < runs; i++) {
		uint64_t t0 = mc_now_ns();
		int n = mc_detector_detect(d, rgb, w, h, 0, det, MC_DETECTOR_MAX_JOINTS, &err);
		ms[i] = mc_ms_since(t0);
		if (n < 0) {
			fprintf(stderr, "bench_detect: %s\n", err.msg);
			free(ms);
			exit(1);
		}
		mc_detector_timing t;
		mc_detector_get_timing(d, &t);
		infer += t.last_infer_ms;
		found = n;
	}
	double sum = 0;
	for (int i = 0; i < runs; i++)
		sum += ms[i];
	mc_stats_sort(ms, (size_t)runs);
	printf("bench_detect: %dx%d view: %.3f ms mean, %.3f median, %.3f p90 (network %.3f ms), %d keypoints, "
	       "%d runs, %d thread%s\n",
	       w, h, sum / runs, mc_stats_percentile(ms, (size_t)runs, 50), mc_stats_percentile(ms, (size_t)runs, 90),
	       infer / runs, found, runs, threads, threads == 1 ? "" : "s");
	free(ms);
}

int main(int argc, char **argv)
{
	const char *model = NULL;
	int runs = 200, threads = 1;
	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--model") && i + 1 < argc)
			model = argv[++i];
		else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
			runs = atoi(argv[++i]);
		else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
			threads = atoi(argv[++i]);
		else {
			fprintf(stderr, "usage: bench_detect --model MODEL.onnx [--runs N] [--threads N]\n");
			return 2;
		}
	}
	if (!model || runs < 1 || threads < 1) {
		fprintf(stderr, "usage: bench_detect --model MODEL.onnx [--runs N] [--threads N]\n");
		return 2;
	}
	mc_err err = {{0}};
	mc_detector *d = mc_detector_load(model, &err);
	if (!d) {
		fprintf(stderr, "bench_detect: %s\n", err.msg);
		return 1;
	}
	mc_detector_set_threads(threads);
	int in_w, in_h, hm_w, hm_h;
	mc_detector_input_size(d, &in_w, &in_h);
	mc_detector_heatmap_size(d, &hm_w, &hm_h);
	printf("bench_detect: %s: input %dx%d, %d heatmaps of %dx%d\n", model, in_w, in_h, mc_detector_njoints(d),
	       hm_w, hm_h);

	/* A 256x256 frame: the demo clip's, else a pattern. */
	uint8_t *frame = NULL;
	int fw = 0, fh = 0;
	mc_image_conv *conv = mc_image_conv_new(&err);
	if (!conv || mc_image_load(conv, "tests/data/ego_demo/left/00000.jpg", &frame, &fw, &fh, &err) < 0 ||
	    fw != 256 || fh != 256) {
		free(frame);
		fw = fh = 256;
		frame = malloc((size_t)fw * (size_t)fh * 3);
		for (int i = 0; frame && i < fw * fh * 3; i++)
			frame[i] = (uint8_t)((i * 7) ^ (i >> 5));
	}
	mc_image_conv_free(conv);
	uint8_t *small = malloc((size_t)in_w * (size_t)in_h * 3);
	if (!frame || !small || mc_image_resize_rgb24(frame, fw, fh, small, in_w, in_h, &err) < 0) {
		fprintf(stderr, "bench_detect: cannot make the test image\n");
		return 1;
	}
	run(d, small, in_w, in_h, runs, threads);
	run(d, frame, fw, fh, runs, threads);
	free(small);
	free(frame);
	mc_detector_free(d);
	return 0;
}
