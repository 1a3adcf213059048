/* mc_simdet, the simulated detector's gross errors: each mode happens at
 * its rate (within a few binomial standard errors over thousands of draws
 * on tests/data/outside_demo) and does what it says, judged from the
 * keypoints against the ground truth's projections, not from the module's
 * own counts; zero rates give the plain noisy projections; the occlusion
 * test on a constructed pose; the same seed gives the same keypoints. */
#include "eval/mc_simdet.h"
#include "test_util.h"

#define NJ 15
#define REPEATS 12
static const char *const joints[NJ] = {
	"neck",      "left_shoulder", "left_elbow",     "left_wrist",  "left_hip",    "left_knee",
	"left_ankle", "left_toe",     "right_shoulder", "right_elbow", "right_wrist", "right_hip",
	"right_knee", "right_ankle",  "right_toe",
};

static mc_clip clip;
static mc_model model;

/* One frame set's keypoints by camera and evaluated joint. */
typedef struct {
	bool have[MC_MAX_CAMERAS][NJ];
	double u[MC_MAX_CAMERAS][NJ], v[MC_MAX_CAMERAS][NJ], conf[MC_MAX_CAMERAS][NJ];
	double tu[MC_MAX_CAMERAS][NJ], tv[MC_MAX_CAMERAS][NJ]; /* the truth's projection */
} frame_kp;

static int joint_index(const char *name)
{
	for (int e = 0; e < NJ; e++)
		if (!strcmp(joints[e], name))
			return e;
	return -1;
}

static void simulate(int k, const mc_simdet *sd, uint64_t *rng, frame_kp *f, mc_simdet_stats *st)
{
	mc_keypoint kp[MC_MAX_CAMERAS * NJ];
	memset(f, 0, sizeof(*f));
	int n = mc_simdet_keypoints(&clip, &model, joints, NJ, k, sd, rng, kp, MC_MAX_CAMERAS * NJ, st);
	for (int i = 0; i < n; i++) {
		int e = joint_index(model.joints[kp[i].joint].name), c = kp[i].cam;
		CHECK(e >= 0 && !f->have[c][e]);
		f->have[c][e] = true;
		f->u[c][e] = kp[i].u;
		f->v[c][e] = kp[i].v;
		f->conf[c][e] = kp[i].conf;
	}
	for (int c = 0; c < clip.rig.ncams; c++)
		for (int e = 0; e < NJ; e++) {
			const mc_camera *cam = &clip.rig.cams[c];
			mc_vec3 p = mc_clip_gt(&clip, k, mc_clip_joint(&clip, joints[e]));
			if (!mc_camera_project_rig(cam, p, &f->tu[c][e],
					       &f->tv[c][e]))
				f->tu[c][e] = f->tv[c][e] = -1e9; /* not in the image */
		}
}

static bool at(const frame_kp *f, int c, int e, int truth_of)
{
	return fabs(f->u[c][e] - f->tu[c][truth_of]) < 1e-9 && fabs(f->v[c][e] - f->tv[c][truth_of]) < 1e-9;
}

static int partner(int e)
{
	return e == 0 ? -1 : (e <= 7 ? e + 7 : e - 7);
}

/* Calls visit for every keypoint of `repeats` passes over the clip's frame
 * sets (k, camera c, evaluated joint e, and the frame set's keypoints). */
typedef void keypoint_visit(const frame_kp *f, int k, int c, int e, void *ctx);
static void visit_keypoints(const mc_simdet *sd, uint64_t *rng, int repeats, mc_simdet_stats *st,
			    keypoint_visit *visit, void *ctx)
{
	for (int r = 0; r < repeats; r++)
		for (int k = 0; k < clip.gt.nframes; k++) {
			frame_kp f;
			simulate(k, sd, rng, &f, st);
			for (int c = 0; c < clip.rig.ncams; c++)
				for (int e = 0; e < NJ; e++)
					if (f.have[c][e])
						visit(&f, k, c, e, ctx);
		}
}

/* Within 4 binomial standard errors of the rate. */
static void check_rate(const char *what, long hits, long n, double rate)
{
	double got = n ? (double)hits / n : -1, tol = 4 * sqrt(rate * (1 - rate) / (n ? n : 1)) + 1e-9;
	printf("%s: %ld of %ld = %.4f, rate %.2f (tolerance %.4f)\n", what, hits, n, got, rate, tol);
	CHECK_MSG(n > 500 && fabs(got - rate) <= tol, "%s: %.4f against %.2f", what, got, rate);
}

/* The original simulation (before the gross errors), as it was: the
 * zero-rate simulation must give its keypoints draw for draw, so that
 * figures measured with it stay reproducible. */
static double legacy_gauss(uint64_t *rng)
{
	double u1 = ((mc_rng_next(rng) >> 11) + 0.5) * 0x1.0p-53, u2 = mc_rng_uniform(rng);
	return sqrt(-2 * log(u1)) * cos(2 * M_PI * u2);
}

static int legacy(int k, double noise_px, uint64_t *rng, mc_keypoint *kp, int cap)
{
	int n = 0;
	for (int e = 0; e < NJ; e++) {
		int g = mc_clip_joint(&clip, joints[e]), j = mc_model_find_joint(&model, joints[e]);
		for (int c = 0; c < clip.rig.ncams && g >= 0 && j >= 0 && n < cap; c++) {
			const mc_camera *cam = &clip.rig.cams[c];
			double u, v;
			if (!mc_camera_project_rig(cam, mc_clip_gt(&clip, k, g), &u, &v) || mc_rng_uniform(rng) < MC_CLIP_SIMULATED_MISS)
				continue;
			double du = noise_px * legacy_gauss(rng), dv = noise_px * legacy_gauss(rng);
			kp[n++] = (mc_keypoint){c, j, u + du, v + dv, 1.0};
		}
	}
	return n;
}

/* No gross error: the original keypoints, and without noise every one is
 * its truth, confidence 1, MC_CLIP_SIMULATED_MISS of them missing. */
static void test_plain(void)
{
	mc_simdet sd = {.noise_px = 3};
	uint64_t rng = 7, rng_legacy = 7;
	for (int k = 0; k < clip.gt.nframes; k++) {
		mc_keypoint a[MC_MAX_CAMERAS * NJ], b[MC_MAX_CAMERAS * NJ];
		int na = mc_simdet_keypoints(&clip, &model, joints, NJ, k, &sd, &rng, a, MC_MAX_CAMERAS * NJ, NULL);
		int nb = legacy(k, 3, &rng_legacy, b, MC_MAX_CAMERAS * NJ);
		CHECK_MSG(na == nb && !memcmp(a, b, sizeof(mc_keypoint) * na) && rng == rng_legacy,
			  "frame set %d: not the original keypoints", k);
		nb = mc_clip_simulated_keypoints(&clip, &model, joints, NJ, k, 3, &rng_legacy, b, MC_MAX_CAMERAS * NJ);
		na = mc_simdet_keypoints(&clip, &model, joints, NJ, k, &sd, &rng, a, MC_MAX_CAMERAS * NJ, NULL);
		CHECK(na == nb && !memcmp(a, b, sizeof(mc_keypoint) * na));
	}
	sd.noise_px = 0;
	long kept = 0, seen = 0;
	for (int r = 0; r < REPEATS; r++)
		for (int k = 0; k < clip.gt.nframes; k++) {
			frame_kp f;
			simulate(k, &sd, &rng, &f, NULL);
			for (int c = 0; c < clip.rig.ncams; c++)
				for (int e = 0; e < NJ; e++) {
					seen += f.tu[c][e] > -1e8;
					kept += f.have[c][e];
					CHECK(!f.have[c][e] || (at(&f, c, e, e) && f.conf[c][e] == 1));
				}
		}
	check_rate("kept (1 - miss)", kept, seen, 1 - MC_CLIP_SIMULATED_MISS);
}

/* Pairs with both keypoints: collapsed ones have both at one side's truth,
 * swapped ones each at the other's; no keypoint is anywhere else. */
static void test_pairs(double collapse, double swap)
{
	mc_simdet sd = {.collapse = collapse, .swap = swap};
	mc_simdet_stats st = {0};
	uint64_t rng = 11;
	long pairs = 0, collapsed = 0, swapped = 0, left_side = 0;
	for (int r = 0; r < REPEATS; r++)
		for (int k = 0; k < clip.gt.nframes; k++) {
			frame_kp f;
			simulate(k, &sd, &rng, &f, &st);
			for (int c = 0; c < clip.rig.ncams; c++)
				for (int a = 1; a <= 7; a++) {
					int b = partner(a);
					if (!f.have[c][a] || !f.have[c][b])
						continue;
					pairs++;
					bool on_a = at(&f, c, a, a) && at(&f, c, b, a), on_b = at(&f, c, a, b) && at(&f, c, b, b);
					bool crossed = at(&f, c, a, b) && at(&f, c, b, a), right = at(&f, c, a, a) && at(&f, c, b, b);
					CHECK_MSG(on_a || on_b || crossed || right, "camera %d, %s: keypoints of neither truth", c,
						  joints[a]);
					collapsed += on_a || on_b;
					left_side += on_a;
					swapped += crossed;
				}
		}
	CHECK(st.pairs == pairs && st.collapsed == collapsed && st.swapped == swapped);
	check_rate("collapsed pairs", collapsed, pairs, collapse);
	check_rate("swapped pairs", swapped, pairs, swap);
	if (collapse > 0)
		check_rate("collapsed onto the left limb", left_side, collapsed, 0.5);
}

/* Outliers: more than 1.5 times the far threshold off, at most 5 times,
 * at their rate; everything else exact (no noise). */
typedef struct {
	long n, off;
} outlier_count;

static void count_outlier(const frame_kp *f, int k, int c, int e, void *ctx)
{
	(void)k;
	outlier_count *oc = ctx;
	double d = hypot(f->u[c][e] - f->tu[c][e], f->v[c][e] - f->tv[c][e]), far = mc_simdet_far_px(&clip, c);
	CHECK_MSG(d < 1e-9 || (d > 1.5 * far - 1e-9 && d < 5 * far + 1e-9), "%.2f px off", d);
	oc->n++;
	oc->off += d > far;
}

static void test_outliers(double rate)
{
	mc_simdet sd = {.outlier = rate};
	mc_simdet_stats st = {0};
	uint64_t rng = 13;
	outlier_count oc = {0, 0};
	visit_keypoints(&sd, &rng, REPEATS, &st, count_outlier, &oc);
	CHECK(st.keypoints == oc.n && st.far == oc.off && st.outliers == oc.off);
	check_rate("outliers", oc.off, oc.n, rate);
}

/* Runs of outlier keypoints (a camera's joint over consecutive frame sets
 * that report it) and whether consecutive outliers keep their offset. */
typedef struct {
	long n, off, runs, pairs, same_pairs;
	bool was[MC_MAX_CAMERAS][NJ];
	double du[MC_MAX_CAMERAS][NJ], dv[MC_MAX_CAMERAS][NJ];
} outlier_runs;

static void count_run(const frame_kp *f, int k, int c, int e, void *ctx)
{
	(void)k;
	outlier_runs *r = ctx;
	double u = f->u[c][e] - f->tu[c][e], v = f->v[c][e] - f->tv[c][e];
	bool is = hypot(u, v) > 1e-9;
	r->n++;
	r->off += is;
	r->runs += is && !r->was[c][e];
	if (is && r->was[c][e]) {
		r->pairs++;
		r->same_pairs += fabs(u - r->du[c][e]) < 1e-9 && fabs(v - r->dv[c][e]) < 1e-9;
	}
	r->was[c][e] = is;
	r->du[c][e] = u;
	r->dv[c][e] = v;
}

/* Mean run length over `seeds` seeds (one pass each); the share of outlier
 * keypoints in *rate, of consecutive outlier pairs with one offset in *same. */
static double outlier_run_length(int persist, int seeds, double *rate, double *same)
{
	static outlier_runs total, r;
	memset(&total, 0, sizeof(total));
	for (int seed = 1; seed <= seeds; seed++) {
		mc_simdet sd = {.outlier = 0.2, .persist = persist, .seed = (uint64_t)seed};
		uint64_t rng = (uint64_t)seed;
		memset(&r, 0, sizeof(r));
		visit_keypoints(&sd, &rng, 1, NULL, count_run, &r);
		total.n += r.n, total.off += r.off, total.runs += r.runs;
		total.pairs += r.pairs, total.same_pairs += r.same_pairs;
	}
	*rate = total.n ? (double)total.off / total.n : 0;
	*same = total.pairs ? (double)total.same_pairs / total.pairs : 0;
	return total.runs ? (double)total.off / total.runs : 0;
}

/* Persistent outliers (persist N): the same rate, in runs about N frame
 * sets long with one offset each; drawn afresh (persist 0), runs of about
 * 1 / (1 - rate) and offsets that change. */
static void test_persistent_outliers(void)
{
	double rate, same, fresh_rate, fresh_same;
	double len = outlier_run_length(8, 12, &rate, &same);
	double fresh = outlier_run_length(0, 12, &fresh_rate, &fresh_same);
	printf("outlier runs: persist 8: mean %.2f frame sets, rate %.3f, same offset %.2f; afresh: %.2f, %.3f, %.2f\n",
	       len, rate, same, fresh, fresh_rate, fresh_same);
	CHECK(len > 4 && fresh < 2);
	CHECK(fabs(rate - 0.2) < 0.06 && fabs(fresh_rate - 0.2) < 0.03);
	CHECK(same > 0.8 && fresh_same < 0.05);
}

/* Occluded keypoints of paired joints go to the other limb's truth at
 * their rate; visible ones never move. */
static void test_occluded(double rate)
{
	mc_simdet sd = {.occluded_wrong = rate};
	uint64_t rng = 17;
	long occluded = 0, wrong = 0, visible = 0;
	for (int r = 0; r < REPEATS; r++)
		for (int k = 0; k < clip.gt.nframes; k++) {
			frame_kp f;
			simulate(k, &sd, &rng, &f, NULL);
			for (int c = 0; c < clip.rig.ncams; c++)
				for (int e = 1; e < NJ; e++) {
					int p = partner(e);
					if (!f.have[c][e] || f.tu[c][p] < -1e8)
						continue;
					bool hidden = mc_simdet_occluded(&clip, k, c, mc_clip_joint(&clip, joints[e]));
					CHECK_MSG(at(&f, c, e, e) || (hidden && at(&f, c, e, p)), "camera %d %s moved", c, joints[e]);
					occluded += hidden;
					wrong += hidden && !at(&f, c, e, e);
					visible += !hidden;
				}
		}
	printf("occluded %ld, visible %ld keypoints of paired joints\n", occluded, visible);
	CHECK(visible > occluded / 4);
	check_rate("occluded on the wrong limb", wrong, occluded, rate);
}

/* Blind confidences: uniform in [0.3, 1] whether the keypoint is good or an
 * outlier (the same mean), so they cannot tell one from the other. */
typedef struct {
	double sum[2], sum2;
	long n[2];
} confidence_sums;

static void add_confidence(const frame_kp *f, int k, int c, int e, void *ctx)
{
	(void)k;
	confidence_sums *cs = ctx;
	double conf = f->conf[c][e];
	int bad = hypot(f->u[c][e] - f->tu[c][e], f->v[c][e] - f->tv[c][e]) > mc_simdet_far_px(&clip, c);
	CHECK_MSG(conf >= 0.3 && conf <= 1, "confidence %g", conf);
	cs->sum[bad] += conf;
	cs->sum2 += conf * conf;
	cs->n[bad]++;
}

static void test_blind_confidence(void)
{
	mc_simdet sd = {.noise_px = 1, .outlier = 0.3, .blind_confidence = true};
	uint64_t rng = 19;
	confidence_sums cs = {{0, 0}, 0, {0, 0}};
	visit_keypoints(&sd, &rng, REPEATS, NULL, add_confidence, &cs);
	long all_n = cs.n[0] + cs.n[1];
	double good = cs.sum[0] / cs.n[0], bad = cs.sum[1] / cs.n[1], all = (cs.sum[0] + cs.sum[1]) / all_n;
	double sd_all = sqrt(cs.sum2 / all_n - all * all);
	printf("confidence: good %.4f (%ld), wrong %.4f (%ld), sd %.4f\n", good, cs.n[0], bad, cs.n[1], sd_all);
	CHECK(cs.n[1] > 500 && fabs(good - 0.65) < 0.01 && fabs(bad - 0.65) < 0.015);
	CHECK_NEAR(sd_all, 0.7 / sqrt(12), 0.01); /* uniform over [0.3, 1] */
}

/* The occlusion test on a pose placed by hand: the torso put on the line
 * between camera 0 and the left ankle hides it; moved 1 m aside it does
 * not; the foot pointing at the camera does not hide its own ankle. */
static void test_occlusion_geometry(void)
{
	int ankle = mc_clip_joint(&clip, "left_ankle"), neck = mc_clip_joint(&clip, "neck");
	int pelvis = mc_clip_joint(&clip, "pelvis"), toe = mc_clip_joint(&clip, "left_toe");
	mc_vec3 *g = clip.gt.joints, o = clip.rig.cams[0].rig_from_cam.t, a = g[ankle];
	mc_vec3 saved[MC_GT_MAX_JOINTS];
	memcpy(saved, g, sizeof(mc_vec3) * clip.gt.njoints);
	mc_vec3 mid = mc_v3_add(o, mc_v3_scale(mc_v3_sub(a, o), 0.5));
	/* every other joint 100 m above: their bones are far from the ray,
	 * and the one to the neck (head) points straight up */
	for (int j = 0; j < clip.gt.njoints; j++)
		if (j != ankle)
			g[j] = mc_v3_add(mid, mc_v3(0, 0, 100));
	g[neck] = mc_v3_add(mid, mc_v3(0, 0, 0.3));
	g[pelvis] = mc_v3_add(mid, mc_v3(0, 0, -0.3));
	CHECK(mc_simdet_occluded(&clip, 0, 0, ankle));
	CHECK(!mc_simdet_occluded(&clip, 0, 0, neck)); /* its own bones only */
	g[neck] = mc_v3_add(g[neck], mc_v3(1, 1, 0));
	g[pelvis] = mc_v3_add(g[pelvis], mc_v3(1, 1, 0));
	CHECK(!mc_simdet_occluded(&clip, 0, 0, ankle));
	g[toe] = mc_v3_add(a, mc_v3_scale(mc_v3_sub(o, a), 0.1));
	CHECK(!mc_simdet_occluded(&clip, 0, 0, ankle));
	memcpy(g, saved, sizeof(mc_vec3) * clip.gt.njoints);
}

/* The same seed, the same keypoints (with every mode on). */
static void test_deterministic(void)
{
	mc_simdet sd;
	CHECK(mc_simdet_preset("outside", &sd) && sd.collapse > 0.9 && sd.blind_confidence);
	CHECK(mc_simdet_preset("ego", &sd) && sd.collapse > 0 && sd.swap > 0 && sd.outlier > 0 && sd.occluded_wrong > 0);
	CHECK(!mc_simdet_preset("bogus", &sd));
	sd.noise_px = 4;
	for (int k = 0; k < 5; k++) {
		mc_keypoint a[MC_MAX_CAMERAS * NJ], b[MC_MAX_CAMERAS * NJ];
		uint64_t r1 = 23 + k, r2 = 23 + k;
		int na = mc_simdet_keypoints(&clip, &model, joints, NJ, k, &sd, &r1, a, MC_MAX_CAMERAS * NJ, NULL);
		int nb = mc_simdet_keypoints(&clip, &model, joints, NJ, k, &sd, &r2, b, MC_MAX_CAMERAS * NJ, NULL);
		CHECK(na > 0 && na == nb && !memcmp(a, b, sizeof(mc_keypoint) * na));
	}
}

int main(void)
{
	mc_err err = {{0}};
	if (mc_clip_open("tests/data/outside_demo", false, &clip, &err) < 0)
		TEST_SKIP("run from the repository root: %s", err.msg);
	if (mc_model_load("config/models/default.json", &model, &err) < 0) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	test_plain();
	test_pairs(0.4, 0);
	test_pairs(0, 0.3);
	test_pairs(0.5, 0.3);
	test_outliers(0.2);
	test_persistent_outliers();
	test_occluded(0.5);
	test_blind_confidence();
	test_occlusion_geometry();
	test_deterministic();
	mc_clip_close(&clip);
	return mc_test_finish("test_simdet");
}
