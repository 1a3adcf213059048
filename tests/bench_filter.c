/* bench_filter: what mocapd's output filter ([output] filter = one_euro,
 * core/track/mc_skeleton_filter) does to the tracker's real poses.  Reads
 * an evaluation clip's ground truth and the tracker's estimates for it
 * (`mocap-bench --clip DIR --out FILE`: JSON lines, joints in the same
 * frame as gt.json), filters the estimates as the daemon would (frame k at
 * k / fps seconds), and prints for the raw and the filtered poses:
 *   - MPJPE (cm) over the joints both have;
 *   - the mean joint velocity error (m/s) and the ratio of the estimate's
 *     mean joint acceleration to the truth's (frame differences);
 *   - the error (cm) of the pose block's prediction 40 ms ahead (from the
 *     two newest poses, as mocap_predict does) against the truth there.
 *
 *   bench_filter CLIP_DIR ESTIMATES [MIN_CUTOFF_HZ BETA D_CUTOFF_HZ]
 *
 * `make bench-filter` runs it on every evaluation clip. */
#include "eval/mc_gt.h"
#include "track/mc_skeleton_filter.h"

#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define AHEAD_S 0.04

typedef struct {
	int nframes, njoints;
	mc_vec3 *p;  /* nframes * njoints, from the estimates, in gt's joint order */
	bool *have;  /* per frame: a tracked estimate (ok or uncertain) */
	bool *known; /* per joint: the estimates name it */
} estimates;

/* One JSON line of mocap-bench --out into frame `index` of e. */
static void read_line(const char *line, const mc_gt *gt, estimates *e)
{
	json_t *root = json_loads(line, 0, NULL);
	json_t *joints = root ? json_object_get(root, "joints") : NULL;
	int k = root ? (int)json_integer_value(json_object_get(root, "index")) : -1;
	const char *state = root ? json_string_value(json_object_get(root, "state")) : NULL;
	if (joints && k >= 0 && k < e->nframes && state) {
		e->have[k] = strcmp(state, "ok") == 0 || strcmp(state, "uncertain") == 0;
		for (int j = 0; j < gt->njoints; j++) {
			json_t *v = json_object_get(joints, gt->joint_names[j]);
			if (json_array_size(v) != 3)
				continue;
			e->p[k * e->njoints + j] = mc_v3(json_number_value(json_array_get(v, 0)),
							  json_number_value(json_array_get(v, 1)),
							  json_number_value(json_array_get(v, 2)));
			e->known[j] = true;
		}
	}
	json_decref(root);
}

static bool load_estimates(const char *path, const mc_gt *gt, estimates *e)
{
	FILE *f = fopen(path, "r");
	if (!f) {
		fprintf(stderr, "bench_filter: %s: cannot open\n", path);
		return false;
	}
	e->nframes = gt->nframes, e->njoints = gt->njoints;
	e->p = calloc((size_t)e->nframes * (size_t)e->njoints, sizeof(*e->p));
	e->have = calloc((size_t)e->nframes, sizeof(*e->have));
	e->known = calloc((size_t)e->njoints, sizeof(*e->known));
	static char line[1 << 16];
	while (e->p && e->have && e->known && fgets(line, sizeof(line), f))
		read_line(line, gt, e);
	fclose(f);
	return e->p && e->have && e->known;
}

static void free_estimates(estimates *e)
{
	free(e->p);
	free(e->have);
	free(e->known);
}

/* Filters the estimates in place, frame by frame, as the publishing thread
 * does (an untracked frame is a gap; the filter's own gap rule applies). */
static void filter_estimates(estimates *e, const mc_gt *gt, const mc_one_euro_params *params)
{
	mc_skeleton_filter *f = malloc(sizeof(*f));
	mc_skeleton *sk = calloc(1, sizeof(*sk));
	if (!f || !sk)
		goto out;
	mc_skeleton_filter_init(f, params, 0.2);
	for (int k = 0; k < e->nframes; k++) {
		if (!e->have[k])
			continue;
		sk->timestamp_ns = (uint64_t)llround(1e9 * k / gt->fps);
		sk->state = MC_TRACK_OK;
		sk->njoints = e->njoints;
		for (int j = 0; j < e->njoints; j++) {
			sk->joints[j].parent = -1; /* mocap-bench's file has no parents: positions only */
			sk->joints[j].orientation = mc_quat_identity();
			sk->joints[j].position = e->p[k * e->njoints + j];
		}
		mc_skeleton_filter_apply(f, sk);
		for (int j = 0; j < e->njoints; j++)
			e->p[k * e->njoints + j] = sk->joints[j].position;
	}
out:
	free(f);
	free(sk);
}

typedef struct {
	double mpjpe_cm, vel_err_ms, accel_ratio, predict_cm;
} scores;

/* Whether frames k-2..k are all tracked. */
static bool run_of_three(const estimates *e, int k)
{
	return k >= 2 && e->have[k] && e->have[k - 1] && e->have[k - 2];
}

static scores score(const estimates *e, const mc_gt *gt)
{
	double err = 0, vel = 0, acc = 0, acc_gt = 0, pred = 0, fps = gt->fps;
	long n_err = 0, n_run = 0, n_pred = 0;
	int ahead_frames = (int)floor(AHEAD_S * fps), last = e->nframes - ahead_frames - 2;
	double frac = AHEAD_S * fps - ahead_frames; /* the truth between two frames, linearly */
	for (int k = 0; k < e->nframes; k++)
		for (int j = 0; j < e->njoints && e->have[k]; j++) {
			if (!e->known[j])
				continue;
			mc_vec3 x0 = e->p[k * e->njoints + j], g0 = mc_gt_at(gt, k, j);
			err += mc_v3_norm(mc_v3_sub(x0, g0)), n_err++;
			if (!run_of_three(e, k))
				continue;
			mc_vec3 x1 = e->p[(k - 1) * e->njoints + j], x2 = e->p[(k - 2) * e->njoints + j];
			mc_vec3 g1 = mc_gt_at(gt, k - 1, j), g2 = mc_gt_at(gt, k - 2, j);
			vel += mc_v3_norm(mc_v3_sub(mc_v3_sub(x0, x1), mc_v3_sub(g0, g1))) * fps;
			acc += mc_v3_norm(mc_v3_add(mc_v3_sub(x0, mc_v3_scale(x1, 2)), x2));
			acc_gt += mc_v3_norm(mc_v3_add(mc_v3_sub(g0, mc_v3_scale(g1, 2)), g2));
			n_run++;
			if (k > last)
				continue;
			mc_vec3 predicted = mc_v3_axpy(AHEAD_S * fps, mc_v3_sub(x0, x1), x0);
			mc_vec3 ga = mc_gt_at(gt, k + ahead_frames, j), gb = mc_gt_at(gt, k + ahead_frames + 1, j);
			mc_vec3 truth = mc_v3_axpy(frac, mc_v3_sub(gb, ga), ga);
			pred += mc_v3_norm(mc_v3_sub(predicted, truth)), n_pred++;
		}
	scores s = {n_err ? 100 * err / n_err : NAN, n_run ? vel / n_run : NAN, acc_gt > 0 ? acc / acc_gt : NAN,
		    n_pred ? 100 * pred / n_pred : NAN};
	return s;
}

static const char *clip_name(const char *dir)
{
	static char name[256];
	snprintf(name, sizeof(name), "%s", dir);
	size_t n = strlen(name);
	while (n > 1 && name[n - 1] == '/')
		name[--n] = 0;
	const char *slash = strrchr(name, '/');
	return slash ? slash + 1 : name;
}

/* The ground truth's key: joints_left_cam (head-mounted) or joints_world. */
static int load_gt(const char *dir, mc_gt *gt)
{
	char path[4200];
	snprintf(path, sizeof(path), "%s/gt.json", dir);
	mc_err err;
	if (mc_gt_load(path, "joints_left_cam", gt, &err) == 0 || mc_gt_load(path, "joints_world", gt, &err) == 0)
		return 0;
	fprintf(stderr, "bench_filter: %s\n", err.msg);
	return -1;
}

int main(int argc, char **argv)
{
	if (argc != 3 && argc != 6) {
		fprintf(stderr, "usage: bench_filter CLIP_DIR ESTIMATES [MIN_CUTOFF_HZ BETA D_CUTOFF_HZ]\n");
		return 2;
	}
	mc_one_euro_params params;
	mc_one_euro_params_default(&params);
	if (argc == 6)
		params = (mc_one_euro_params){atof(argv[3]), atof(argv[4]), atof(argv[5])};
	mc_gt gt = {0};
	estimates e = {0};
	if (load_gt(argv[1], &gt) || !load_estimates(argv[2], &gt, &e)) {
		mc_gt_free(&gt);
		free_estimates(&e);
		return 1;
	}
	scores raw = score(&e, &gt);
	filter_estimates(&e, &gt, &params);
	scores filt = score(&e, &gt);
	const char *name = clip_name(argv[1]);
	printf("FILTER clip=%s min_cutoff_hz=%g beta=%g d_cutoff_hz=%g\n", name, params.min_cutoff_hz, params.beta,
	       params.d_cutoff_hz);
	const scores *s[2] = {&raw, &filt};
	for (int i = 0; i < 2; i++)
		printf("  %-8s MPJPE %.2f cm, velocity error %.3f m/s, acceleration %.2fx the truth's, "
		       "prediction 40 ms ahead %.2f cm off\n",
		       i ? "filtered" : "raw", s[i]->mpjpe_cm, s[i]->vel_err_ms, s[i]->accel_ratio, s[i]->predict_cm);
	mc_gt_free(&gt);
	free_estimates(&e);
	return 0;
}
