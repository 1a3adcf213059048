/* bench_predict: how far libmocap's mocap_predict misses, on the
 * evaluation clips' ground truth played as skeletons.  Each clip's joints
 * (gt.json: joints_left_cam for head-mounted clips, joints_world for
 * outside-in ones; 30 fps) become frames; from frames k-1 and k the pose
 * is predicted 10, 20 and 40 ms past frame k and compared with the truth
 * there (linear between the two ground-truth frames around that time).
 * Holding frame k (no prediction) is the baseline.  Positions only: the
 * ground truth has no joint orientations.
 *
 *   bench_predict CLIP_DIR...        (e.g. ../shared/data/ego/walk_131_01) */
#include "base/mc_stats.h"
#include "mocap.h"

#include <jansson.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_FRAMES 4000
#define NJ 32

typedef struct {
	int nframes, njoints;
	double fps;
	double p[MAX_FRAMES][NJ][3];
} clip;

/* Reads the clip's ground truth; false (with a message) when it cannot. */
static bool load_clip(const char *dir, clip *c)
{
	char path[4200];
	snprintf(path, sizeof(path), "%s/gt.json", dir);
	json_error_t e;
	json_t *root = json_load_file(path, 0, &e);
	if (!root) {
		fprintf(stderr, "bench_predict: %s:%d: %s\n", path, e.line, e.text);
		return false;
	}
	json_t *names = json_object_get(root, "joint_names"), *frames = json_object_get(root, "frames");
	c->fps = json_number_value(json_object_get(root, "fps"));
	c->njoints = (int)json_array_size(names);
	c->nframes = (int)json_array_size(frames);
	if (c->njoints > NJ || c->nframes > MAX_FRAMES || !(c->fps > 0)) {
		fprintf(stderr, "bench_predict: %s: %d joints, %d frames, fps %g: out of this program's range\n", path,
			c->njoints, c->nframes, c->fps);
		json_decref(root);
		return false;
	}
	for (int k = 0; k < c->nframes; k++) {
		json_t *f = json_array_get(frames, (size_t)k);
		json_t *joints = json_object_get(f, "joints_world");
		if (!joints)
			joints = json_object_get(f, "joints_left_cam");
		for (int j = 0; j < c->njoints; j++) {
			json_t *v = json_object_get(joints, json_string_value(json_array_get(names, (size_t)j)));
			for (int i = 0; i < 3; i++)
				c->p[k][j][i] = json_number_value(json_array_get(v, (size_t)i));
		}
	}
	json_decref(root);
	return true;
}

static void to_frame(const clip *c, int k, mocap_skeleton_frame *f)
{
	memset(f, 0, sizeof(*f));
	f->capture_ns = (uint64_t)llround(k * 1e9 / c->fps);
	f->skeleton_id = 1;
	f->njoints = c->njoints;
	for (int j = 0; j < c->njoints; j++) {
		memcpy(f->joints[j].position, c->p[k][j], sizeof(f->joints[j].position));
		f->joints[j].orientation[0] = 1;
	}
}

/* The truth at time t (s), linear between the frames around it. */
static void truth_at(const clip *c, double t, int j, double out[3])
{
	double x = t * c->fps;
	int k = (int)floor(x);
	double a = x - k;
	for (int i = 0; i < 3; i++)
		out[i] = (1 - a) * c->p[k][j][i] + a * c->p[k + 1][j][i];
}

static double dist_mm(const double a[3], const double b[3])
{
	return 1000 * sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

static void report(const char *name, const clip *c)
{
	static const int ahead_ms[] = {10, 20, 40};
	static mocap_skeleton_frame older, newer, out;
	size_t cap = (size_t)c->nframes * (size_t)c->njoints;
	double *pred = malloc(sizeof(double) * cap), *hold = malloc(sizeof(double) * cap);
	for (int h = 0; h < 3; h++) {
		size_t n = 0;
		double ahead = ahead_ms[h] / 1000.0, sum_p = 0, sum_h = 0;
		for (int k = 1; (k + ahead * c->fps) + 1 < c->nframes; k++) {
			to_frame(c, k - 1, &older);
			to_frame(c, k, &newer);
			mocap_predict(&older, &newer, newer.capture_ns + (uint64_t)(ahead * 1e9), &out);
			for (int j = 0; j < c->njoints; j++, n++) {
				double truth[3];
				truth_at(c, k / c->fps + ahead, j, truth);
				pred[n] = dist_mm(out.joints[j].position, truth);
				hold[n] = dist_mm(newer.joints[j].position, truth);
				sum_p += pred[n];
				sum_h += hold[n];
			}
		}
		mc_stats_sort(pred, n);
		mc_stats_sort(hold, n);
		printf("  %-22s +%2d ms   predicted %6.1f mm mean, %6.1f p95   held %6.1f mean, %6.1f p95\n", name,
		       ahead_ms[h], sum_p / (double)n, mc_stats_percentile(pred, n, 95), sum_h / (double)n,
		       mc_stats_percentile(hold, n, 95));
	}
	free(pred);
	free(hold);
}

int main(int argc, char **argv)
{
	if (argc < 2) {
		fprintf(stderr, "usage: bench_predict CLIP_DIR...\n");
		return 2;
	}
	clip *c = malloc(sizeof(*c));
	printf("bench_predict: joint position error of mocap_predict (constant velocity from the two newest poses) "
	       "against holding the newest pose, every joint of every frame\n");
	for (int i = 1; i < argc; i++) {
		if (!load_clip(argv[i], c))
			continue;
		const char *base = strrchr(argv[i], '/');
		char name[256];
		snprintf(name, sizeof(name), "%s", argv[i]);
		if (base && !base[1]) /* a trailing slash */
			name[strlen(name) - 1] = 0;
		/* "ego/walk_131_01": the clip's folder and its parent's name. */
		char *last = strrchr(name, '/');
		if (last) {
			*last = 0;
			char *parent = strrchr(name, '/');
			*last = '/';
			memmove(name, parent ? parent + 1 : name, strlen(parent ? parent + 1 : name) + 1);
		}
		report(name, c);
	}
	free(c);
	return 0;
}
