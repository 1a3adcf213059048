/* Tests of the energy terms as functions of the pose of the default body
 * model (config/models/default.json), seen by an egocentric stereo fisheye
 * rig like the evaluation data's (thesis ch. 6): analytic gradients through
 * mc_model_backprop against central finite differences in random poses and
 * in poses with self-occlusion, and E_color's minimum at the pose an image
 * was rendered from. */
#include "energy/mc_energy.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "test_util.h"

#include <string.h>
#include <sys/stat.h>

#define MODEL_PATH "config/models/default.json"

static double urand(unsigned long long *rng, double lo, double hi)
{
	return lo + (hi - lo) * mc_test_rand(rng);
}

/* ---- the rig: two 180-degree equidistant fisheyes 0.30 m apart, looking
 * down at the wearer, as in ../shared/data/ego (the rig frame is the left
 * camera's) ---- */

static void fisheye(mc_camera *cam, const char *name, double x)
{
	memset(cam, 0, sizeof(*cam));
	snprintf(cam->name, sizeof(cam->name), "%s", name);
	cam->model = MC_CAM_EQUIDISTANT;
	cam->width = cam->height = 256;
	cam->fx = cam->fy = 128 / (M_PI / 2);
	cam->cx = cam->cy = 127.5;
	cam->max_theta = M_PI / 2;
	cam->rig_from_cam = mc_xform_identity();
	cam->rig_from_cam.t = mc_v3(x, 0, 0);
}

typedef struct {
	mc_raytable rt[2];
	float *hsv[2];
	mc_view view[2];
} stereo;

static int stereo_init(stereo *st, int w, mc_err *err)
{
	memset(st, 0, sizeof(*st));
	mc_camera cam[2];
	fisheye(&cam[0], "left", 0);
	fisheye(&cam[1], "right", 0.30);
	for (int c = 0; c < 2; c++) {
		if (mc_raytable_build(&cam[c], w, w, &st->rt[c], err))
			return -1;
		st->hsv[c] = calloc((size_t)3 * w * w, sizeof(float));
		if (!st->hsv[c])
			return mc_err_set(err, "out of memory");
		st->view[c] = (mc_view){&st->rt[c], st->hsv[c]};
	}
	return 0;
}

static void stereo_free(stereo *st)
{
	for (int c = 0; c < 2; c++) {
		mc_raytable_free(&st->rt[c]);
		free(st->hsv[c]);
	}
}

/* ---- energies as functions of the pose ---- */

typedef struct {
	const mc_model *model;
	const stereo *st;
	const int *pixels[2]; /* sampled pixel subsets */
	int npixels[2];
	mc_detection_ray det[8];
	int ndet;
	const double *pred; /* E_smooth's prediction */
} problem;

typedef enum { TERM_COLOR, TERM_DETECTION, TERM_POSE, TERM_SMOOTH, TERMS } term;
static const char *term_name[TERMS] = {"color", "detection", "pose", "smooth"};

/* Energy term `t` at `pose`; adds dE/dpose into grad (may be NULL). */
static double energy(const problem *pb, term t, const double *pose, double *grad)
{
	const mc_model *m = pb->model;
	if (t == TERM_POSE)
		return mc_energy_pose(m, pose, 0.1, 1e-4, grad);
	if (t == TERM_SMOOTH)
		return mc_energy_smooth(m->ndof, pose, pb->pred, 0.1, grad);
	mc_fk fk;
	mc_model_fk(m, pose, &fk);
	mc_scene scene;
	mc_scene_from_model(m, &fk, &scene);
	mc_vec3 dmu[MC_MAX_GAUSSIANS] = {{0, 0, 0}};
	mc_vec3 *g = grad ? dmu : NULL;
	double e = 0;
	if (t == TERM_COLOR) {
		for (int c = 0; c < 2; c++)
			e += mc_energy_color(&scene, &pb->st->view[c], pb->pixels[c], pb->npixels[c], g, NULL);
	} else {
		/* the detection rays are fixed; the Gaussians move */
		e = mc_energy_detection(&scene, pb->det, pb->ndet, 1.0 / 3, g, NULL);
	}
	if (grad)
		mc_model_backprop(m, pose, &fk, dmu, grad);
	return e;
}

static double max_rel_seen;
static int entries_checked, entries_negligible;

/* Five-point central differences in every pose dof, h = 1e-4 rad.  An
 * entry is negligible below 1e-6 of the largest (finite-difference noise,
 * see test_energy.c). */
static void check_pose_gradient(const problem *pb, term t, const double *pose0, const char *label)
{
	int nd = pb->model->ndof;
	double grad[MC_MAX_DOF] = {0}, pose[MC_MAX_DOF];
	energy(pb, t, pose0, grad);
	double scale = 0;
	for (int k = 0; k < nd; k++)
		scale = fmax(scale, fabs(grad[k]));
	CHECK_MSG(scale > 0, "%s, %s: gradient is zero everywhere", term_name[t], label);
	memcpy(pose, pose0, sizeof(double) * nd);
	const double h = 1e-4, off[4] = {-2, -1, 1, 2};
	for (int k = 0; k < nd; k++) {
		double e[4];
		for (int j = 0; j < 4; j++) {
			pose[k] = pose0[k] + off[j] * h;
			e[j] = energy(pb, t, pose, NULL);
		}
		pose[k] = pose0[k];
		double fd = (8 * (e[2] - e[1]) - (e[3] - e[0])) / (12 * h), an = grad[k];
		double mag = fmax(fabs(fd), fabs(an));
		char dof[64];
		mc_model_dof_name(pb->model, k, dof, sizeof(dof));
		if (mag <= 1e-6 * scale) {
			entries_negligible++;
			CHECK_MSG(fabs(fd - an) <= 1e-6 * scale, "%s, %s, %s: analytic %.6g fd %.6g", term_name[t],
				  label, dof, an, fd);
			continue;
		}
		double rel = fabs(fd - an) / mag;
		entries_checked++;
		max_rel_seen = fmax(max_rel_seen, rel);
		CHECK_MSG(rel < 1e-4, "%s, %s, %s: analytic %.10g fd %.10g rel %.3g", term_name[t], label, dof, an, fd,
			  rel);
	}
}

/* ---- poses ---- */

/* A pose within `spread` radians of the rest pose in every dof, strictly
 * inside the limits (E_pose is only C1 at a limit, where finite
 * differences would disagree with the one-sided derivative). */
static void random_pose(const mc_model *m, unsigned long long *rng, double spread, double *pose)
{
	double lo[MC_MAX_DOF], hi[MC_MAX_DOF];
	mc_model_dof_limits(m, lo, hi);
	mc_model_rest_pose(m, pose);
	for (int k = 0; k < m->ndof; k++) {
		double a = fmax(lo[k] + 0.01, pose[k] - spread), b = fmin(hi[k] - 0.01, pose[k] + spread);
		pose[k] = urand(rng, a, b);
	}
}

/* Pixels of the left camera where the left arm occludes the rest of the
 * body: some other Gaussian with visibility > 0.2 without the arm keeps
 * less than half of it with the arm.  Returns their count (at most cap
 * indices written to out). */
static int arm_occlusion_pixels(const mc_model *m, const double *pose, const stereo *st, int *out, int cap)
{
	bool arm[MC_MAX_JOINTS] = {0};
	mc_model_subtree(m, mc_model_find_joint(m, "left_shoulder"), arm);
	mc_fk fk;
	mc_model_fk(m, pose, &fk);
	mc_scene scene, no_arm;
	mc_scene_from_model(m, &fk, &scene);
	no_arm = scene;
	for (int q = 0; q < scene.n; q++)
		if (arm[m->gauss[q].joint])
			no_arm.c[q] = 0;
	const mc_raytable *rt = &st->rt[0];
	int count = 0;
	for (int p = 0; p < rt->width * rt->height; p++) {
		if (!rt->valid[p])
			continue;
		double v[MC_MAX_GAUSSIANS], v0[MC_MAX_GAUSSIANS], b;
		mc_ray_visibility(&scene, rt->origin, rt->dir[p], v, &b);
		mc_ray_visibility(&no_arm, rt->origin, rt->dir[p], v0, &b);
		for (int q = 0; q < scene.n; q++)
			if (!arm[m->gauss[q].joint] && v0[q] > 0.2 && v[q] < 0.5 * v0[q]) {
				if (count < cap)
					out[count] = p;
				count++;
				break;
			}
	}
	return count;
}

/* A pose with the left arm raised in front of the body, as the cameras see
 * it: the most occluding of a few candidate arm poses. */
static int self_occlusion_pose(const mc_model *m, const stereo *st, double *pose)
{
	int sh = mc_model_find_joint(m, "left_shoulder"), el = mc_model_find_joint(m, "left_elbow");
	if (sh < 0 || el < 0 || m->joints[sh].ndof < 3 || m->joints[el].ndof < 1)
		return 0;
	const double deg = M_PI / 180;
	int best = 0, pix[1];
	double cand[MC_MAX_DOF];
	for (double flex = 60; flex <= 90; flex += 30)
		for (double rot = -30; rot <= 30; rot += 30)
			for (double bend = 60; bend <= 120; bend += 30) {
				mc_model_rest_pose(m, cand);
				cand[m->joints[sh].dof0] = flex * deg;
				cand[m->joints[sh].dof0 + 2] = rot * deg;
				cand[m->joints[el].dof0] = bend * deg;
				mc_model_clamp_pose(m, cand);
				int n = arm_occlusion_pixels(m, cand, st, pix, 0);
				if (n > best) {
					best = n;
					memcpy(pose, cand, sizeof(double) * m->ndof);
				}
			}
	return best;
}

/* ---- tests ---- */

/* Image colours for the gradient checks: random, so that every Gaussian
 * sees both similar and dissimilar pixels. */
static void random_images(stereo *st, unsigned long long *rng)
{
	for (int c = 0; c < 2; c++)
		for (int k = 0; k < 3 * st->rt[c].width * st->rt[c].height; k++)
			st->hsv[c][k] = (float)mc_test_rand(rng);
}

/* Up to cap pixels of the view near the body (within 3 sigma of some
 * Gaussian's centre), spread evenly over all such pixels. */
static int pixels_near_body(const mc_raytable *rt, const mc_scene *s, int *out, int cap)
{
	int total = rt->width * rt->height, near = 0;
	int *all = malloc(sizeof(int) * total);
	if (!all)
		return 0;
	for (int p = 0; p < total; p++) {
		if (!rt->valid[p])
			continue;
		for (int q = 0; q < s->n; q++) {
			mc_vec3 d = mc_v3_sub(s->mu[q], rt->origin);
			double m = mc_v3_dot(d, rt->dir[p]), r2 = mc_v3_norm2(d) - m * m;
			if (r2 < 9 * s->sigma[q] * s->sigma[q]) {
				all[near++] = p;
				break;
			}
		}
	}
	int n = near < cap ? near : cap;
	for (int i = 0; i < n; i++)
		out[i] = all[(long)i * near / n];
	free(all);
	return n;
}

static void detections_for_pose(const mc_model *m, const double *pose, const stereo *st, unsigned long long *rng,
				problem *pb)
{
	static const char *parts[] = {"left_wrist", "right_wrist", "left_knee", "right_ankle", "left_elbow", "spine"};
	mc_fk fk;
	mc_model_fk(m, pose, &fk);
	pb->ndet = 0;
	for (int i = 0; i < 6; i++) {
		int j = mc_model_find_joint(m, parts[i]);
		int q = -1;
		for (int g = 0; g < m->ngauss && q < 0; g++)
			if (m->gauss[g].joint == j)
				q = g;
		if (q < 0)
			continue;
		const mc_raytable *rt = &st->rt[i % 2];
		/* a detection a little off the Gaussian's centre */
		mc_vec3 target = mc_v3_add(fk.mu[q], mc_v3(urand(rng, -0.03, 0.03), urand(rng, -0.03, 0.03), 0));
		pb->det[pb->ndet++] = (mc_detection_ray){q, rt->origin, mc_v3_normalize(mc_v3_sub(target, rt->origin)),
							 urand(rng, 0.3, 1)};
	}
}

#define GRAD_RES 48     /* working resolution of the gradient checks */
#define GRAD_PIXELS 100 /* pixels per camera checked */

static void test_gradients(const mc_model *m)
{
	stereo st;
	mc_err err;
	if (stereo_init(&st, GRAD_RES, &err)) {
		CHECK_MSG(0, "%s", err.msg);
		stereo_free(&st);
		return;
	}
	unsigned long long rng = 99;
	random_images(&st, &rng);
	double poses[4][MC_MAX_DOF];
	const char *labels[4] = {"random pose 1", "random pose 2", "random pose 3", "self-occlusion"};
	for (int i = 0; i < 3; i++)
		random_pose(m, &rng, 0.6, poses[i]);
	int occluded = self_occlusion_pose(m, &st, poses[3]);
	printf("self-occlusion pose: the left arm hides part of the body in %d of %d pixels\n", occluded,
	       st.rt[0].nvalid);
	CHECK(occluded >= 20);
	for (int i = 0; i < 4; i++) {
		problem pb = {.model = m, .st = &st};
		mc_fk fk;
		mc_model_fk(m, poses[i], &fk);
		mc_scene s;
		mc_scene_from_model(m, &fk, &s);
		int pix[2][GRAD_PIXELS];
		for (int c = 0; c < 2; c++) {
			pb.npixels[c] = pixels_near_body(&st.rt[c], &s, pix[c], GRAD_PIXELS);
			pb.pixels[c] = pix[c];
			CHECK(pb.npixels[c] == GRAD_PIXELS);
		}
		if (i == 3) /* make sure the occluded pixels are among those checked */
			arm_occlusion_pixels(m, poses[i], &st, pix[0], GRAD_PIXELS / 2);
		detections_for_pose(m, poses[i], &st, &rng, &pb);
		double pred[MC_MAX_DOF];
		for (int k = 0; k < m->ndof; k++)
			pred[k] = poses[i][k] + urand(&rng, -0.3, 0.3);
		pb.pred = pred;
		for (int t = 0; t < TERMS; t++)
			check_pose_gradient(&pb, t, poses[i], labels[i]);
	}
	stereo_free(&st);
}

/* Renders both views at `pose` into HSV images.  translucent: the model's
 * own image formation, mc_ray_render_rgb (eq. 4.9 plus B times the
 * background); otherwise opaque: each pixel takes the albedo of its most
 * visible Gaussian, or the background where B is larger (what a camera
 * sees of solid, uniformly coloured parts). */
static void render(const mc_model *m, const double *pose, const double bg[3], bool translucent, stereo *st)
{
	mc_fk fk;
	mc_model_fk(m, pose, &fk);
	mc_scene s;
	mc_scene_from_model(m, &fk, &s);
	double albedo[MC_MAX_GAUSSIANS][3];
	for (int q = 0; q < m->ngauss; q++)
		memcpy(albedo[q], m->gauss[q].rgb, sizeof(albedo[q]));
	for (int c = 0; c < 2; c++) {
		const mc_raytable *rt = &st->rt[c];
		for (int p = 0; p < rt->width * rt->height; p++) {
			double rgb[3] = {0, 0, 0}, hsv[3];
			if (rt->valid[p] && translucent) {
				mc_ray_render_rgb(&s, (const double(*)[3])albedo, rt->origin, rt->dir[p], bg, rgb);
			} else if (rt->valid[p]) {
				double vis[MC_MAX_GAUSSIANS], b;
				mc_ray_visibility(&s, rt->origin, rt->dir[p], vis, &b);
				const double *best = bg;
				for (int q = 0; q < s.n; q++)
					if (vis[q] > b)
						b = vis[q], best = albedo[q];
				memcpy(rgb, best, sizeof(rgb));
			}
			for (int ch = 0; ch < 3; ch++)
				rgb[ch] = fmin(1, rgb[ch]); /* a camera saturates */
			mc_rgb_to_hsv(rgb, hsv);
			for (int ch = 0; ch < 3; ch++)
				st->hsv[c][3 * p + ch] = (float)hsv[ch];
		}
	}
}

/* E_color of an image rendered at a known pose, there and at random
 * perturbations of every dof by +-deg.  Returns the share of perturbations
 * that raise the energy. */
static double share_raised(const mc_model *m, stereo *st, const double *truth, double deg, int n,
			   unsigned long long *rng, double *min_rise, double *mean_rise)
{
	problem pb = {.model = m, .st = st};
	double e_true = energy(&pb, TERM_COLOR, truth, NULL), pose[MC_MAX_DOF], lo[MC_MAX_DOF], hi[MC_MAX_DOF];
	mc_model_dof_limits(m, lo, hi);
	int raised = 0;
	*min_rise = INFINITY;
	*mean_rise = 0;
	for (int i = 0; i < n; i++) {
		for (int k = 0; k < m->ndof; k++) {
			double step = (mc_test_rand(rng) < 0.5 ? -1 : 1) * deg * M_PI / 180;
			pose[k] = truth[k] + step;
			if (pose[k] > hi[k] || pose[k] < lo[k])
				pose[k] = truth[k] - step; /* stay inside the limits */
		}
		double rise = energy(&pb, TERM_COLOR, pose, NULL) - e_true;
		raised += rise > 0;
		*min_rise = fmin(*min_rise, rise);
		*mean_rise += rise / n;
	}
	return (double)raised / n;
}

/* E_color is not a photo-consistency energy: it rewards a Gaussian's
 * visibility wherever the image is similar to its colour (two-sided d),
 * so its minimum need not sit exactly at the pose an image was rendered
 * from (docs/ENERGY.md, "What E_color prefers").  Checked here: random
 * perturbations of a few degrees in every dof raise E_color in nearly all
 * cases, for opaque renders and for the model's own translucent renders. */
static void test_rendered_minimum(const mc_model *m)
{
	stereo st;
	mc_err err;
	if (stereo_init(&st, 32, &err)) {
		CHECK_MSG(0, "%s", err.msg);
		stereo_free(&st);
		return;
	}
	unsigned long long rng = 123;
	const double bg[3] = {0.2, 0.8, 0.2}; /* a green floor */
	for (int trial = 0; trial < 3; trial++) {
		double truth[MC_MAX_DOF];
		random_pose(m, &rng, 0.3, truth);
		for (int translucent = 0; translucent < 2; translucent++) {
			double least, mean;
			render(m, truth, bg, translucent, &st);
			double share = share_raised(m, &st, truth, 5, 20, &rng, &least, &mean);
			printf("pose %d, %s render: 5 degree perturbations raise E_color in %.0f%% (mean rise %.2f, "
			       "least %.2f)\n",
			       trial, translucent ? "translucent" : "opaque", 100 * share, mean, least);
			CHECK(mean > 0);
			CHECK(share >= (translucent ? 0.6 : 0.8));
		}
	}
	stereo_free(&st);
}

int main(void)
{
	struct stat sb;
	if (stat(MODEL_PATH, &sb) != 0)
		TEST_SKIP("%s not found (run from the repository root)", MODEL_PATH);
	static mc_model model;
	mc_err err;
	if (mc_model_load(MODEL_PATH, &model, &err)) {
		fprintf(stderr, "%s\n", err.msg);
		return 1;
	}
	test_gradients(&model);
	test_rendered_minimum(&model);
	printf("pose gradients: %d entries checked (max relative error %.3g), %d negligible\n", entries_checked,
	       max_rel_seen, entries_negligible);
	CHECK(entries_checked > 50);
	return mc_test_finish("test_energy_pose");
}
