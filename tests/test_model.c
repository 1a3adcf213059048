/* Tests of core/body/mc_model's kinematics: forward kinematics, Jacobians
 * and the chain rule against central finite differences (fixed and free
 * roots), joint limits, bone scaling, and the sphere-to-Gaussian
 * conversion of thesis 4.3.  The JSON format and the default model's
 * proportions are tested in test_model_io.c. */
#include "body/mc_model.h"
#include "model_fixture.h"
#include "test_util.h"

#include <stdio.h>
#include <string.h>

#define DEG (M_PI / 180.0)

/* A random pose: joint dofs anywhere within their limits, a free root
 * anywhere within a metre with any rotation up to 3 rad. */
static void random_pose(const mc_model *m, unsigned long long *rng, double *pose)
{
	if (m->root_free) {
		for (int k = 0; k < 3; k++)
			pose[k] = 2 * mc_test_rand(rng) - 1;
		mc_vec3 w = mc_v3(2 * mc_test_rand(rng) - 1, 2 * mc_test_rand(rng) - 1, 2 * mc_test_rand(rng) - 1);
		w = mc_v3_scale(mc_v3_normalize(w), 3.0 * mc_test_rand(rng));
		pose[3] = w.x;
		pose[4] = w.y;
		pose[5] = w.z;
	}
	for (int j = 0; j < m->njoints; j++) {
		const mc_joint *jt = &m->joints[j];
		for (int a = 0; a < jt->ndof; a++)
			pose[jt->dof0 + a] = jt->lower[a] + (jt->upper[a] - jt->lower[a]) * mc_test_rand(rng);
	}
}

static void random_bone_scales(mc_model *m, unsigned long long *rng)
{
	for (int j = 0; j < m->njoints; j++)
		m->bone_scale[j] = 0.8 + 0.45 * mc_test_rand(rng);
}

/* ---- forward kinematics ---- */

/* A planar two-link arm on a free root, checked against hand-computed values. */
static void test_fk_hand_computed(void)
{
	const char *text =
		"{\"name\": \"arm\", \"root\": \"free\", \"joints\": ["
		"{\"name\": \"base\"},"
		"{\"name\": \"a\", \"parent\": \"base\", \"offset\": [1, 0, 0], \"dofs\": [{\"axis\": \"z\", \"min_deg\": -180, \"max_deg\": 180}]},"
		"{\"name\": \"b\", \"parent\": \"a\", \"offset\": [1, 0, 0], \"dofs\": [{\"axis\": \"z\", \"min_deg\": -180, \"max_deg\": 180},"
		"                                                                  {\"axis\": \"x\", \"min_deg\": -180, \"max_deg\": 180}]}],"
		"\"gaussians\": [{\"joint\": \"b\", \"offset\": [1, 0, 0], \"radius\": 0.1, \"color\": \"#ffffff\"},"
		"               {\"joint\": \"b\", \"offset\": [0, 1, 0], \"radius\": 0.1, \"color\": \"#ffffff\"}]}";
	mc_model m;
	mc_err err;
	if (mc_model_parse(text, "arm.json", &m, &err)) {
		fprintf(stderr, "arm.json: %s\n", err.msg);
		mc_test_failures++;
		return;
	}
	CHECK(m.ndof == 6 + 3);
	CHECK(m.joints[1].dof0 == 6 && m.joints[2].dof0 == 7);
	double pose[9] = {0, 0, 0, 0, 0, 0, M_PI / 2, M_PI / 2, 0};
	mc_fk fk;
	mc_model_fk(&m, pose, &fk);
	/* a turns the rest of the arm by 90 degrees, b by another 90. */
	CHECK(vdist(fk.rig_from_joint[1].t, mc_v3(1, 0, 0)) < 1e-12);
	CHECK(vdist(fk.rig_from_joint[2].t, mc_v3(1, 1, 0)) < 1e-12);
	CHECK(vdist(fk.mu[0], mc_v3(0, 1, 0)) < 1e-12);
	/* b's second dof turns about b's x axis after its z rotation:
	 * offset (0,1,0) -> Rz(90) Rx(90) (0,1,0) = Rz(90) (0,0,1) = (0,0,1). */
	pose[8] = M_PI / 2;
	mc_model_fk(&m, pose, &fk);
	CHECK(vdist(fk.mu[1], mc_v3(1, 1, 1)) < 1e-12);
	CHECK(vdist(fk.mu[0], mc_v3(0, 1, 0)) < 1e-12);
	/* The free root moves and turns everything: 90 degrees about x, then +(0,0,2). */
	pose[0] = 0, pose[1] = 0, pose[2] = 2, pose[3] = M_PI / 2;
	mc_model_fk(&m, pose, &fk);
	CHECK(vdist(fk.rig_from_joint[2].t, mc_v3(1, 0, 3)) < 1e-12);
	CHECK(vdist(fk.mu[0], mc_v3(0, 0, 3)) < 1e-12);
	/* Bone scale of b doubles the a->b offset; the Gaussians' default bone
	 * (b has no child) is b's own, so their offsets double too. */
	CHECK(m.gauss[0].scale_joint == 2);
	m.bone_scale[2] = 2;
	pose[2] = 0, pose[3] = 0, pose[8] = 0;
	mc_model_fk(&m, pose, &fk);
	CHECK(vdist(fk.rig_from_joint[2].t, mc_v3(1, 2, 0)) < 1e-12);
	CHECK(vdist(fk.mu[0], mc_v3(-1, 2, 0)) < 1e-12);
	/* dof axes and pivots in the rig frame */
	CHECK(vdist(fk.dof_axis[6], mc_v3(0, 0, 1)) < 1e-12 && vdist(fk.dof_pivot[6], mc_v3(1, 0, 0)) < 1e-12);
	CHECK(vdist(fk.dof_axis[8], mc_v3(-1, 0, 0)) < 1e-12 && vdist(fk.dof_pivot[8], mc_v3(1, 2, 0)) < 1e-12);
}

/* ---- Jacobians against central differences ---- */

typedef struct {
	double worst_rel;   /* largest relative error over non-negligible entries */
	double worst_abs;   /* largest absolute error over negligible ones */
	int compared;
} fd_stats;

/* Relative error < 1e-6 where the derivative is not negligible (|fd| > 1e-4),
 * else absolute error < 1e-9. */
static void fd_compare(double analytic, double fd, fd_stats *s, const char *what, int row, int k)
{
	double e = fabs(analytic - fd);
	s->compared++;
	if (fabs(fd) > 1e-4) {
		double rel = e / fabs(fd);
		s->worst_rel = fmax(s->worst_rel, rel);
		CHECK_MSG(rel < 1e-6, "%s[%d][dof %d]: analytic %.12g, fd %.12g", what, row, k, analytic, fd);
	} else {
		s->worst_abs = fmax(s->worst_abs, e);
		CHECK_MSG(e < 1e-9, "%s[%d][dof %d]: analytic %.12g, fd %.12g", what, row, k, analytic, fd);
	}
}

static void fd_compare_vec(mc_vec3 a, mc_vec3 fd, fd_stats *s, const char *what, int row, int k)
{
	fd_compare(a.x, fd.x, s, what, row, k);
	fd_compare(a.y, fd.y, s, what, row, k);
	fd_compare(a.z, fd.z, s, what, row, k);
}

static void check_jacobians_at(const mc_model *m, const double *pose0, fd_stats *sg, fd_stats *sj, fd_stats *sb,
			       unsigned long long *rng)
{
	const double h = 1e-5; /* truncation ~h^2/6, rounding ~1e-16 / h */
	int n = m->ndof;
	static mc_vec3 Jg[MC_MAX_GAUSSIANS * MC_MAX_DOF], Jj[MC_MAX_JOINTS * MC_MAX_DOF];
	static mc_fk fk, fkp, fkm;
	double pose[MC_MAX_DOF];
	memcpy(pose, pose0, sizeof(double) * (size_t)n);
	mc_model_fk(m, pose, &fk);
	mc_model_gauss_jacobian(m, pose, &fk, Jg);
	mc_model_joint_jacobian(m, pose, &fk, Jj);

	/* A random linear energy E = sum_q g_q . mu_q for the chain rule. */
	mc_vec3 g[MC_MAX_GAUSSIANS];
	for (int q = 0; q < m->ngauss; q++)
		g[q] = mc_v3(2 * mc_test_rand(rng) - 1, 2 * mc_test_rand(rng) - 1, 2 * mc_test_rand(rng) - 1);
	double grad[MC_MAX_DOF];
	for (int k = 0; k < n; k++)
		grad[k] = 1.0; /* backprop adds: start from ones */
	mc_model_backprop(m, pose, &fk, g, grad);

	for (int k = 0; k < n; k++) {
		pose[k] = pose0[k] + h;
		mc_model_fk(m, pose, &fkp);
		pose[k] = pose0[k] - h;
		mc_model_fk(m, pose, &fkm);
		pose[k] = pose0[k];
		double e_fd = 0, e_jt = 0;
		for (int q = 0; q < m->ngauss; q++) {
			mc_vec3 d = mc_v3_scale(mc_v3_sub(fkp.mu[q], fkm.mu[q]), 0.5 / h);
			fd_compare_vec(Jg[q * n + k], d, sg, "gauss_jacobian", q, k);
			e_fd += mc_v3_dot(g[q], d);
			e_jt += mc_v3_dot(g[q], Jg[q * n + k]);
		}
		for (int j = 0; j < m->njoints; j++) {
			mc_vec3 d = mc_v3_scale(mc_v3_sub(fkp.rig_from_joint[j].t, fkm.rig_from_joint[j].t), 0.5 / h);
			fd_compare_vec(Jj[j * n + k], d, sj, "joint_jacobian", j, k);
		}
		fd_compare(grad[k] - 1.0, e_fd, sb, "backprop", 0, k);
		/* The O(n) chain rule equals J^T g to rounding. */
		CHECK_MSG(fabs(grad[k] - 1.0 - e_jt) <= 1e-12 * (1 + fabs(e_jt)), "backprop dof %d: %.15g vs J^T g %.15g",
			  k, grad[k] - 1.0, e_jt);
	}
}

static void test_jacobians(bool root_free)
{
	mc_model m;
	if (!load_default(&m))
		return;
	if (root_free) {
		mc_err err;
		m.root_free = true;
		if (mc_model_finalize(&m, &err)) {
			fprintf(stderr, "finalize: %s\n", err.msg);
			mc_test_failures++;
			return;
		}
		CHECK(m.ndof == 32 + 6 && m.joints[2].dof0 == 6);
	}
	unsigned long long rng = root_free ? 7 : 3;
	fd_stats sg = {0}, sj = {0}, sb = {0};
	double pose[MC_MAX_DOF];
	for (int trial = 0; trial < 6; trial++) {
		random_bone_scales(&m, &rng);
		random_pose(&m, &rng, pose);
		if (root_free && trial == 0)
			pose[3] = pose[4] = pose[5] = 0; /* rotation vector at exactly zero */
		if (root_free && trial == 1) {
			pose[3] = 0, pose[4] = 3.1, pose[5] = 0; /* close to pi */
		}
		if (root_free && trial == 2) {
			/* tiny angle: the left Jacobian's series branch */
			pose[3] = 6e-5, pose[4] = -5e-5, pose[5] = 4e-5;
		}
		check_jacobians_at(&m, pose, &sg, &sj, &sb, &rng);
	}
	printf("jacobians (%s root): %d/%d/%d entries, worst relative error gauss %.2g joint %.2g backprop %.2g, "
	       "worst absolute error on negligible entries %.2g\n",
	       root_free ? "free" : "fixed", sg.compared, sj.compared, sb.compared, sg.worst_rel, sj.worst_rel,
	       sb.worst_rel, fmax(sg.worst_abs, fmax(sj.worst_abs, sb.worst_abs)));
}

/* Entries of dofs that cannot move a point are exactly zero. */
static void test_jacobian_sparsity(void)
{
	mc_model m;
	if (!load_default(&m))
		return;
	static mc_vec3 J[MC_MAX_JOINTS * MC_MAX_DOF];
	double pose[MC_MAX_DOF];
	unsigned long long rng = 11;
	random_pose(&m, &rng, pose);
	mc_fk fk;
	mc_model_fk(&m, pose, &fk);
	mc_model_joint_jacobian(&m, pose, &fk, J);
	int lw = mc_model_find_joint(&m, "left_wrist"), rk = mc_model_find_joint(&m, "right_knee");
	int le = mc_model_find_joint(&m, "left_elbow");
	CHECK(lw >= 0 && rk >= 0 && le >= 0);
	/* The right knee's dof does not move the left wrist; the left elbow's does. */
	int k_rk = m.joints[rk].dof0, k_le = m.joints[le].dof0;
	CHECK(mc_v3_norm(J[lw * m.ndof + k_rk]) == 0);
	CHECK(mc_v3_norm(J[lw * m.ndof + k_le]) > 0.05);
	/* A joint's own rotation does not move its origin. */
	CHECK(mc_v3_norm(J[le * m.ndof + k_le]) < 1e-15);
}

/* ---- limits, bone scaling, helpers ---- */

static void test_limits(void)
{
	mc_model m;
	if (!load_default(&m))
		return;
	double pose[MC_MAX_DOF], rest[MC_MAX_DOF], lo[MC_MAX_DOF], hi[MC_MAX_DOF];
	mc_model_dof_limits(&m, lo, hi);
	mc_model_rest_pose(&m, rest);
	unsigned long long rng = 5;
	for (int trial = 0; trial < 200; trial++) {
		for (int k = 0; k < m.ndof; k++)
			pose[k] = (mc_test_rand(&rng) * 2 - 1) * 4.0; /* well beyond most limits */
		double before[MC_MAX_DOF];
		memcpy(before, pose, sizeof(pose));
		mc_model_clamp_pose(&m, pose);
		for (int k = 0; k < m.ndof; k++) {
			CHECK(pose[k] >= lo[k] && pose[k] <= hi[k]);
			/* Values inside the limits are kept; others go to the nearest limit. */
			if (before[k] >= lo[k] && before[k] <= hi[k])
				CHECK(pose[k] == before[k]);
			else
				CHECK(pose[k] == (before[k] < lo[k] ? lo[k] : hi[k]));
		}
	}
	/* The limits are the file's degrees. */
	int lk = mc_model_find_joint(&m, "left_knee");
	CHECK_NEAR(lo[m.joints[lk].dof0], -150 * DEG, 1e-12);
	CHECK_NEAR(hi[m.joints[lk].dof0], 5 * DEG, 1e-12);
	/* Non-finite values fall back to the rest value. */
	pose[m.joints[lk].dof0] = NAN;
	mc_model_clamp_pose(&m, pose);
	CHECK(pose[m.joints[lk].dof0] == rest[m.joints[lk].dof0]);
	/* A free root's dofs are unlimited and left alone. */
	mc_err err;
	m.root_free = true;
	CHECK(mc_model_finalize(&m, &err) == 0);
	mc_model_dof_limits(&m, lo, hi);
	CHECK(isinf(lo[0]) && lo[0] < 0 && isinf(hi[5]) && hi[5] > 0);
	for (int k = 0; k < m.ndof; k++)
		pose[k] = 10.0;
	mc_model_clamp_pose(&m, pose);
	CHECK(pose[0] == 10.0 && pose[5] == 10.0);
	CHECK(pose[m.joints[lk].dof0] == 5 * DEG);
	/* A rest pose whose zero lies outside a joint's limits is clamped. */
	m.joints[lk].lower[0] = 10 * DEG;
	m.joints[lk].upper[0] = 20 * DEG;
	mc_model_rest_pose(&m, pose);
	CHECK(pose[m.joints[lk].dof0] == 10 * DEG);
}

/* Scaling one bone moves every descendant joint by the scaled offset, and
 * only them; the Gaussians along that bone stretch with it. */
static void test_bone_scale(void)
{
	mc_model m;
	if (!load_default(&m))
		return;
	double pose[MC_MAX_DOF];
	unsigned long long rng = 9;
	random_pose(&m, &rng, pose);
	static mc_fk a, b;
	mc_model_fk(&m, pose, &a);
	int sh = mc_model_find_joint(&m, "left_shoulder"), el = mc_model_find_joint(&m, "left_elbow");
	double s = 1.2;
	m.bone_scale[el] = s;
	mc_model_fk(&m, pose, &b);
	bool below[MC_MAX_JOINTS];
	int n = mc_model_subtree(&m, el, below);
	CHECK(n == 2); /* elbow and wrist */
	/* The offset shoulder->elbow, in the rig frame, grows by (s - 1). */
	mc_vec3 shift = mc_m3_apply(a.rig_from_joint[sh].R, mc_v3_scale(m.joints[el].offset, s - 1));
	CHECK(mc_v3_norm(shift) > 0.05);
	for (int j = 0; j < m.njoints; j++) {
		mc_vec3 moved = mc_v3_sub(b.rig_from_joint[j].t, a.rig_from_joint[j].t);
		if (below[j])
			CHECK_MSG(vdist(moved, shift) < 1e-12, "joint %s", m.joints[j].name);
		else
			CHECK_MSG(mc_v3_norm(moved) < 1e-15, "joint %s", m.joints[j].name);
	}
	int stretched = 0;
	for (int q = 0; q < m.ngauss; q++) {
		const mc_gauss_def *g = &m.gauss[q];
		mc_vec3 moved = mc_v3_sub(b.mu[q], a.mu[q]);
		if (g->joint == sh) {
			/* Upper-arm Gaussians lie along the bone to the elbow: their
			 * offset is scaled by s. */
			CHECK(g->scale_joint == el);
			mc_vec3 expect = mc_m3_apply(a.rig_from_joint[sh].R, mc_v3_scale(g->offset, s - 1));
			CHECK(vdist(moved, expect) < 1e-12);
			stretched++;
		} else if (below[g->joint]) {
			CHECK(vdist(moved, shift) < 1e-12);
		} else {
			CHECK(mc_v3_norm(moved) < 1e-15);
		}
	}
	CHECK(stretched >= 3);
}

/* A fixed-root model made free keeps its joints' dofs after six root dofs;
 * re-centring its root base moves the rotation out of the pose and leaves
 * every skeleton where it was. */
static void test_free_root_recentre(void)
{
	mc_model m;
	mc_err err = {0};
	if (!load_default(&m))
		return;
	int fixed_ndof = m.ndof;
	CHECK_MSG(mc_model_make_root_free(&m, &err) == 0, "%s", err.msg);
	CHECK(m.root_free && m.ndof == fixed_ndof + MC_ROOT_FREE_DOFS);
	CHECK(m.joints[0].dof0 == MC_ROOT_FREE_DOFS);
	double a[MC_MAX_DOF] = {0}, b[MC_MAX_DOF] = {0};
	mc_model_rest_pose(&m, a);
	mc_model_rest_pose(&m, b);
	double ra[6] = {0.5, -1.0, 1.7, 0.3, 2.9, -0.4}, rb[6] = {0.6, -1.1, 1.6, 0.35, 2.8, -0.5};
	memcpy(a, ra, sizeof(ra));
	memcpy(b, rb, sizeof(rb));
	a[8] = 0.3;
	mc_fk fa, fb, ga, gb;
	mc_model_fk(&m, a, &fa);
	mc_model_fk(&m, b, &fb);
	double *poses[2] = {a, b};
	mc_model_recentre_root(&m, poses, 2);
	CHECK(fabs(a[3]) + fabs(a[4]) + fabs(a[5]) < 1e-12);
	CHECK(mc_v3_norm(mc_v3(b[3], b[4], b[5])) < 0.2); /* b is near a: its rotation vector is small */
	mc_model_fk(&m, a, &ga);
	mc_model_fk(&m, b, &gb);
	for (int j = 0; j < m.njoints; j++) {
		CHECK(mc_v3_norm(mc_v3_sub(fa.rig_from_joint[j].t, ga.rig_from_joint[j].t)) < 1e-9);
		CHECK(mc_v3_norm(mc_v3_sub(fb.rig_from_joint[j].t, gb.rig_from_joint[j].t)) < 1e-9);
	}
	/* folding the base back restores plain poses with the same skeletons */
	{
		double a2[MC_MAX_DOF], *pa[1] = {a2};
		memcpy(a2, a, sizeof(a2));
		mc_model m2 = m;
		mc_model_fold_root_base(&m2, pa, 1);
		CHECK(mc_v3_norm(m2.root_base) == 0);
		CHECK(mc_v3_norm(mc_v3_sub(mc_v3(a2[3], a2[4], a2[5]), mc_v3(ra[3], ra[4], ra[5]))) < 1e-9);
	}
	/* the root rotation's Jacobian still matches finite differences with a base */
	double p[MC_MAX_DOF];
	memcpy(p, b, sizeof(p));
	mc_vec3 J[MC_MAX_JOINTS * MC_MAX_DOF];
	mc_model_joint_jacobian(&m, p, &gb, J);
	for (int k = 3; k < 6; k++) {
		double h = 1e-6, save = p[k];
		mc_fk fp, fm;
		p[k] = save + h;
		mc_model_fk(&m, p, &fp);
		p[k] = save - h;
		mc_model_fk(&m, p, &fm);
		p[k] = save;
		int j = m.njoints - 1;
		mc_vec3 fd = mc_v3_scale(mc_v3_sub(fp.rig_from_joint[j].t, fm.rig_from_joint[j].t), 0.5 / h);
		CHECK_MSG(mc_v3_norm(mc_v3_sub(fd, J[j * m.ndof + k])) < 1e-6, "root dof %d", k);
	}
}

static void test_helpers(void)
{
	mc_model m;
	if (!load_default(&m))
		return;
	CHECK(mc_model_find_joint(&m, "head") == 0);
	CHECK(mc_model_find_joint(&m, "nose") == -1);
	bool in[MC_MAX_JOINTS];
	CHECK(mc_model_subtree(&m, 0, in) == m.njoints);
	CHECK(mc_model_subtree(&m, -1, in) == 0 && mc_model_subtree(&m, m.njoints, in) == 0);
	int pelvis = mc_model_find_joint(&m, "pelvis");
	CHECK(mc_model_subtree(&m, pelvis, in) == 9); /* pelvis + 2 x (hip, knee, ankle, toe) */
	CHECK(in[mc_model_find_joint(&m, "right_toe")] && !in[mc_model_find_joint(&m, "spine")]);
	int lk = mc_model_find_joint(&m, "left_knee"), rk = mc_model_find_joint(&m, "right_knee");
	CHECK(mc_model_other_side(&m, lk) == rk && mc_model_other_side(&m, rk) == lk);
	CHECK(mc_model_other_side(&m, pelvis) == -1);
	CHECK(mc_model_other_side(&m, -1) == -1 && mc_model_other_side(&m, m.njoints) == -1);
	char name[64];
	int le = mc_model_find_joint(&m, "left_elbow");
	CHECK(mc_model_dof_joint(&m, m.joints[le].dof0 + 1) == le);
	CHECK(mc_model_dof_joint(&m, m.ndof) == -1);
	mc_model_dof_name(&m, m.joints[le].dof0 + 1, name, sizeof(name));
	CHECK(strcmp(name, "left_elbow.y") == 0);
	mc_err err;
	m.root_free = true;
	CHECK(mc_model_finalize(&m, &err) == 0);
	CHECK(mc_model_dof_joint(&m, 4) == -1);
	mc_model_dof_name(&m, 4, name, sizeof(name));
	CHECK(strcmp(name, "root.ry") == 0);
	/* The in-memory checks catch what a hand-built model can get wrong. */
	mc_model bad = m;
	bad.joints[3].parent = 5;
	CHECK(mc_model_finalize(&bad, &err) == -1 && strstr(err.msg, "joints[3]") && strstr(err.msg, "parent"));
	bad = m;
	bad.joints[4].lower[0] = 1, bad.joints[4].upper[0] = 0;
	CHECK(mc_model_finalize(&bad, &err) == -1 && strstr(err.msg, "joints[4]") && strstr(err.msg, "limits"));
	bad = m;
	bad.gauss[2].radius = 0;
	CHECK(mc_model_finalize(&bad, &err) == -1 && strstr(err.msg, "gaussians[2].radius"));
	bad = m;
	bad.ndof++;
	CHECK(mc_model_validate(&bad, &err) == -1 && strstr(err.msg, "ndof"));
	CHECK(mc_model_validate(&m, &err) == 0);
}

/* ---- sphere to Gaussian (thesis 4.3) ---- */

/* Visibility (eq. 4.10, K = {-4..0}, lambda = sigma) of one Gaussian at
 * (0, 0, depth) for the orthographic ray o = (d, 0, 0), n = +z, with the
 * transmittance of eq. 4.6; written out independently of mc_model.c. */
static double single_visibility(double sigma, double c, double d)
{
	mc_vec3 mu = mc_v3(0, 0, 40 * sigma), o = mc_v3(d, 0, 0), n = mc_v3(0, 0, 1);
	mc_vec3 r = mc_v3_sub(mu, o);
	double mu1 = mc_v3_dot(r, n);
	double c1 = c * exp(-(mc_v3_norm2(r) - mu1 * mu1) / (2 * sigma * sigma));
	double v = 0;
	for (int k = -4; k <= 0; k++) {
		double s = mu1 + k * sigma;
		double T = exp(-sigma * c1 * sqrt(M_PI / 2) *
			       (erf((s - mu1) / (sqrt(2) * sigma)) - erf(-mu1 / (sqrt(2) * sigma))));
		double G = c1 * exp(-(s - mu1) * (s - mu1) / (2 * sigma * sigma));
		v += sigma * T * G;
	}
	return v;
}

static double visibility_d2(double sigma, double c, double d, double h)
{
	return (single_visibility(sigma, c, d + h) - 2 * single_visibility(sigma, c, d) +
		single_visibility(sigma, c, d - h)) /
	       (h * h);
}

static void test_sphere_to_gaussian(void)
{
	const double radii[] = {0.02, 0.05, 0.1, 0.3, 1.0};
	const double ms[] = {0.1, 0.1, 0.1, 0.1, 0.1, 0.05, 0.3, 0.6};
	for (size_t i = 0; i < sizeof(ms) / sizeof(ms[0]); i++) {
		double m = ms[i], r = i < 5 ? radii[i] : 0.1;
		double sigma = 0, c = 0;
		CHECK(mc_sphere_to_gaussian(r, m, &sigma, &c) == 0);
		/* 1 - V at the centre is m. */
		CHECK_NEAR(1 - single_visibility(sigma, c, 0), m, 1e-9);
		/* V'' changes sign at r: bisect the finite-difference V''. */
		double h = 1e-3 * r, lo = 0.8 * r, hi = 1.2 * r;
		double dlo = visibility_d2(sigma, c, lo, h);
		CHECK(dlo < 0 && visibility_d2(sigma, c, hi, h) > 0);
		for (int it = 0; it < 60; it++) {
			double mid = 0.5 * (lo + hi), dm = visibility_d2(sigma, c, mid, h);
			if ((dm < 0) == (dlo < 0))
				lo = mid;
			else
				hi = mid;
		}
		CHECK_NEAR(0.5 * (lo + hi) / r, 1.0, 1e-4);
		/* ... and it is where V falls fastest. */
		double slope_r = single_visibility(sigma, c, r - h) - single_visibility(sigma, c, r + h);
		for (double d = 0.05 * r; d < 4 * r; d += 0.05 * r)
			CHECK(single_visibility(sigma, c, d - h) - single_visibility(sigma, c, d + h) <= slope_r * (1 + 1e-6));
		if (i == 2)
			printf("sphere r = 0.1 m, m = 0.1: sigma = %.6f m, c = %.4f /m\n", sigma, c);
	}
	/* sigma is proportional to r, c to 1/r. */
	double s1 = 0, c1 = 0, s2 = 0, c2 = 0;
	CHECK(mc_sphere_to_gaussian(0.1, 0.1, &s1, &c1) == 0 && mc_sphere_to_gaussian(0.4, 0.1, &s2, &c2) == 0);
	CHECK_NEAR(s2 / s1, 4, 1e-12);
	CHECK_NEAR(c1 / c2, 4, 1e-12);
	/* bad arguments */
	CHECK(mc_sphere_to_gaussian(0, 0.1, &s1, &c1) == -1);
	CHECK(mc_sphere_to_gaussian(-1, 0.1, &s1, &c1) == -1);
	CHECK(mc_sphere_to_gaussian(NAN, 0.1, &s1, &c1) == -1);
	CHECK(mc_sphere_to_gaussian(0.1, 0, &s1, &c1) == -1);
	CHECK(mc_sphere_to_gaussian(0.1, 1, &s1, &c1) == -1);
	CHECK(mc_sphere_to_gaussian(0.1, NAN, &s1, &c1) == -1);
}

int main(void)
{
	test_fk_hand_computed();
	test_jacobians(false);
	test_jacobians(true);
	test_jacobian_sparsity();
	test_limits();
	test_bone_scale();
	test_helpers();
	test_free_root_recentre();
	test_sphere_to_gaussian();
	return mc_test_finish("test_model");
}
