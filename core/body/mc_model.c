/* mc_model: forward kinematics, Jacobians, limits, model checks and the
 * sphere-to-Gaussian conversion of thesis 4.3.  The JSON format lives in
 * mc_model_io.c. */
#include "body/mc_model.h"

#include <stdio.h>
#include <string.h>

/* Offsets and Gaussian centres farther than this from their joint are
 * rejected: no body part is 10 m long, and it keeps FK far from overflow. */
#define MODEL_MAX_EXTENT 10.0

static const char AXIS_NAMES[3] = {'x', 'y', 'z'};

int mc_model_find_joint(const mc_model *model, const char *name)
{
	for (int j = 0; j < model->njoints; j++)
		if (strcmp(model->joints[j].name, name) == 0)
			return j;
	return -1;
}

int mc_joint_other_side_name(const char *name, char *out, size_t cap)
{
	int n;
	if (strncmp(name, "left_", 5) == 0)
		n = snprintf(out, cap, "right_%s", name + 5);
	else if (strncmp(name, "right_", 6) == 0)
		n = snprintf(out, cap, "left_%s", name + 6);
	else
		return 0;
	return n >= 0 && (size_t)n < cap ? 1 : -1;
}

int mc_model_other_side(const mc_model *model, int joint)
{
	char want[MC_JOINT_NAME_MAX + 8];
	if (joint < 0 || joint >= model->njoints ||
	    mc_joint_other_side_name(model->joints[joint].name, want, sizeof(want)) != 1)
		return -1;
	return mc_model_find_joint(model, want);
}

/* ---- kinematics ---- */

static mc_vec3 unit_axis(int axis)
{
	return mc_v3(axis == 0, axis == 1, axis == 2);
}

static mc_vec3 m3_column(mc_mat3 R, int i)
{
	return mc_v3(R.m[0][i], R.m[1][i], R.m[2][i]);
}

/* Left Jacobian of SO(3) at rotation vector w: d exp([w + e]x) / d e at e = 0
 * equals [J_l(w) e]x exp([w]x).  J_l = I + (1 - cos t)/t^2 [w]x + (t - sin t)/t^3 [w]x^2. */
static mc_mat3 so3_left_jacobian(mc_vec3 w)
{
	double t2 = mc_v3_norm2(w), t = sqrt(t2);
	double a, b;
	if (t < 1e-4) { /* Taylor series; the closed form loses digits here. */
		a = 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
		b = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;
	} else {
		a = (1.0 - cos(t)) / t2;
		b = (t - sin(t)) / (t2 * t);
	}
	mc_mat3 W = {{{0, -w.z, w.y}, {w.z, 0, -w.x}, {-w.y, w.x, 0}}};
	mc_mat3 W2 = mc_m3_mul(W, W);
	mc_mat3 J = mc_m3_identity();
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			J.m[i][j] += a * W.m[i][j] + b * W2.m[i][j];
	return J;
}

/* The root's parent frame; for a free root also its six dofs' axes. */
static mc_xform root_base(const mc_model *model, const double *pose, mc_fk *fk)
{
	if (!model->root_free)
		return model->rig_from_root;
	mc_vec3 t = mc_v3(pose[0], pose[1], pose[2]);
	mc_vec3 w = mc_v3(pose[3], pose[4], pose[5]);
	mc_xform base = {mc_m3_mul(mc_m3_from_rotvec(w), mc_m3_from_rotvec(model->root_base)), t};
	/* R(w) acts on the left of the base: its derivative is the left
	 * Jacobian at w, whatever the base. */
	mc_mat3 J = so3_left_jacobian(w);
	for (int i = 0; i < 3; i++) {
		fk->dof_axis[i] = unit_axis(i);
		fk->dof_pivot[i] = mc_v3(0, 0, 0);
		fk->dof_axis[3 + i] = m3_column(J, i);
		fk->dof_pivot[3 + i] = t;
	}
	return base;
}

void mc_model_fk(const mc_model *model, const double *pose, mc_fk *fk)
{
	mc_xform base = root_base(model, pose, fk);
	for (int j = 0; j < model->njoints; j++) {
		const mc_joint *jt = &model->joints[j];
		mc_xform parent = jt->parent < 0 ? base : fk->rig_from_joint[jt->parent];
		mc_xform f = {parent.R, mc_xform_apply(parent, mc_v3_scale(jt->offset, model->bone_scale[j]))};
		for (int a = 0; a < jt->ndof; a++) {
			int k = jt->dof0 + a;
			/* The axis of dof a is expressed after the rotations of dofs 0..a-1. */
			fk->dof_axis[k] = m3_column(f.R, jt->axis[a]);
			fk->dof_pivot[k] = f.t;
			f.R = mc_m3_mul(f.R, mc_m3_rot_axis(jt->axis[a], pose[k]));
		}
		fk->rig_from_joint[j] = f;
	}
	for (int q = 0; q < model->ngauss; q++) {
		const mc_gauss_def *g = &model->gauss[q];
		mc_vec3 local = mc_v3_scale(g->offset, model->bone_scale[g->scale_joint]);
		fk->mu[q] = mc_xform_apply(fk->rig_from_joint[g->joint], local);
	}
}

int mc_model_make_root_free(mc_model *model, mc_err *err)
{
	if (model->root_free)
		return 0;
	model->root_free = true;
	model->rig_from_root = mc_xform_identity();
	return mc_model_finalize(model, err);
}

/* Right-multiplies the root rotation R(p[3..5]) of every pose by M. */
static void turn_root_rotations(double *const *poses, int n, mc_mat3 M)
{
	for (int i = 0; i < n; i++) {
		double *p = poses[i];
		mc_vec3 w = mc_m3_to_rotvec(mc_m3_mul(mc_m3_from_rotvec(mc_v3(p[3], p[4], p[5])), M));
		p[3] = w.x, p[4] = w.y, p[5] = w.z;
	}
}

void mc_model_recentre_root(mc_model *model, double *const *poses, int n)
{
	if (!model->root_free || n < 1)
		return;
	mc_mat3 turn = mc_m3_from_rotvec(mc_v3(poses[0][3], poses[0][4], poses[0][5]));
	model->root_base = mc_m3_to_rotvec(mc_m3_mul(turn, mc_m3_from_rotvec(model->root_base)));
	turn_root_rotations(poses, n, mc_m3_transpose(turn));
}

void mc_model_fold_root_base(mc_model *model, double *const *poses, int n)
{
	if (!model->root_free)
		return;
	turn_root_rotations(poses, n, mc_m3_from_rotvec(model->root_base));
	model->root_base = mc_v3(0, 0, 0);
}

void mc_model_rest_pose(const mc_model *model, double *pose)
{
	for (int k = 0; k < model->ndof; k++)
		pose[k] = 0;
	mc_model_clamp_pose(model, pose);
}

void mc_model_copy_dofs(const mc_model *model, const bool *joints, const double *from, double *into)
{
	for (int j = 0; j < model->njoints; j++)
		for (int d = 0; joints[j] && d < model->joints[j].ndof; d++)
			into[model->joints[j].dof0 + d] = from[model->joints[j].dof0 + d];
}

/* d x / d p_k for a point x that moves rigidly with dof k. */
static mc_vec3 point_derivative(const mc_model *model, const mc_fk *fk, int k, mc_vec3 x)
{
	if (model->root_free && k < 3)
		return fk->dof_axis[k];
	return mc_v3_cross(fk->dof_axis[k], mc_v3_sub(x, fk->dof_pivot[k]));
}

/* Fills row[0..ndof) with d x / d p for a point x rigidly attached to `joint`:
 * only the dofs of the joint and its ancestors (and a free root) move it. */
static void point_jacobian_row(const mc_model *model, const mc_fk *fk, int joint, mc_vec3 x, mc_vec3 *row)
{
	for (int k = 0; k < model->ndof; k++)
		row[k] = mc_v3(0, 0, 0);
	if (model->root_free)
		for (int k = 0; k < MC_ROOT_FREE_DOFS; k++)
			row[k] = point_derivative(model, fk, k, x);
	for (int j = joint; j >= 0; j = model->joints[j].parent) {
		const mc_joint *jt = &model->joints[j];
		for (int a = 0; a < jt->ndof; a++)
			row[jt->dof0 + a] = point_derivative(model, fk, jt->dof0 + a, x);
	}
}

void mc_model_gauss_jacobian(const mc_model *model, const double *pose, const mc_fk *fk, mc_vec3 *J)
{
	(void)pose; /* everything needed is in fk */
	for (int q = 0; q < model->ngauss; q++)
		point_jacobian_row(model, fk, model->gauss[q].joint, fk->mu[q], J + (size_t)q * model->ndof);
}

void mc_model_joint_jacobian(const mc_model *model, const double *pose, const mc_fk *fk, mc_vec3 *J)
{
	(void)pose;
	for (int j = 0; j < model->njoints; j++)
		point_jacobian_row(model, fk, j, fk->rig_from_joint[j].t, J + (size_t)j * model->ndof);
}

/* dE/dp_k = sum_q g_q . (a_k x (mu_q - x_k)) = a_k . sum_q (mu_q - x_k) x g_q
 *         = a_k . (M - x_k x S), with S = sum g_q and M = sum mu_q x g_q over
 * the Gaussians below dof k's joint.  Accumulating S and M up the tree makes
 * the whole gradient O(Gaussians + dofs). */
void mc_model_backprop(const mc_model *model, const double *pose, const mc_fk *fk, const mc_vec3 *dE_dmu,
		       double *dE_dpose)
{
	(void)pose;
	mc_vec3 S[MC_MAX_JOINTS], M[MC_MAX_JOINTS];
	for (int j = 0; j < model->njoints; j++)
		S[j] = M[j] = mc_v3(0, 0, 0);
	for (int q = 0; q < model->ngauss; q++) {
		int j = model->gauss[q].joint;
		S[j] = mc_v3_add(S[j], dE_dmu[q]);
		M[j] = mc_v3_add(M[j], mc_v3_cross(fk->mu[q], dE_dmu[q]));
	}
	/* Children come after their parents: a reverse sweep sums subtrees. */
	for (int j = model->njoints - 1; j > 0; j--) {
		int p = model->joints[j].parent;
		S[p] = mc_v3_add(S[p], S[j]);
		M[p] = mc_v3_add(M[p], M[j]);
	}
	if (model->root_free) {
		for (int k = 0; k < 3; k++)
			dE_dpose[k] += mc_v3_dot(fk->dof_axis[k], S[0]);
		for (int k = 3; k < MC_ROOT_FREE_DOFS; k++)
			dE_dpose[k] += mc_v3_dot(fk->dof_axis[k], mc_v3_sub(M[0], mc_v3_cross(fk->dof_pivot[k], S[0])));
	}
	for (int j = 0; j < model->njoints; j++) {
		const mc_joint *jt = &model->joints[j];
		for (int a = 0; a < jt->ndof; a++) {
			int k = jt->dof0 + a;
			dE_dpose[k] += mc_v3_dot(fk->dof_axis[k], mc_v3_sub(M[j], mc_v3_cross(fk->dof_pivot[k], S[j])));
		}
	}
}

/* ---- limits and dof bookkeeping ---- */

static double clamp(double x, double lo, double hi)
{
	return x < lo ? lo : (x > hi ? hi : x);
}

void mc_model_clamp_pose(const mc_model *model, double *pose)
{
	for (int j = 0; j < model->njoints; j++) {
		const mc_joint *jt = &model->joints[j];
		for (int a = 0; a < jt->ndof; a++) {
			double *p = &pose[jt->dof0 + a];
			if (!isfinite(*p))
				*p = 0; /* then clamped: the rest value */
			*p = clamp(*p, jt->lower[a], jt->upper[a]);
		}
	}
}

void mc_model_dof_limits(const mc_model *model, double *lower, double *upper)
{
	int nroot = model->root_free ? MC_ROOT_FREE_DOFS : 0;
	for (int k = 0; k < nroot; k++) {
		lower[k] = -INFINITY;
		upper[k] = INFINITY;
	}
	for (int j = 0; j < model->njoints; j++) {
		const mc_joint *jt = &model->joints[j];
		for (int a = 0; a < jt->ndof; a++) {
			lower[jt->dof0 + a] = jt->lower[a];
			upper[jt->dof0 + a] = jt->upper[a];
		}
	}
}

int mc_model_subtree(const mc_model *model, int joint, bool *in_subtree)
{
	if (joint < 0 || joint >= model->njoints)
		return 0;
	int n = 0;
	for (int j = 0; j < model->njoints; j++) {
		/* Parents come first, so a parent's mark is final when read. */
		in_subtree[j] = j == joint || (j > joint && model->joints[j].parent >= 0 &&
					       in_subtree[model->joints[j].parent]);
		n += in_subtree[j];
	}
	return n;
}

int mc_model_dof_joint(const mc_model *model, int k)
{
	for (int j = 0; j < model->njoints; j++) {
		const mc_joint *jt = &model->joints[j];
		if (k >= jt->dof0 && k < jt->dof0 + jt->ndof)
			return j;
	}
	return -1;
}

void mc_model_dof_name(const mc_model *model, int k, char *buf, int cap)
{
	static const char *const root_names[MC_ROOT_FREE_DOFS] = {"tx", "ty", "tz", "rx", "ry", "rz"};
	if (cap <= 0)
		return;
	if (model->root_free && k >= 0 && k < MC_ROOT_FREE_DOFS) {
		snprintf(buf, (size_t)cap, "root.%s", root_names[k]);
		return;
	}
	int j = mc_model_dof_joint(model, k);
	if (j < 0) {
		snprintf(buf, (size_t)cap, "dof%d", k);
		return;
	}
	const mc_joint *jt = &model->joints[j];
	int a = k - jt->dof0;
	bool repeated = false;
	for (int b = 0; b < jt->ndof; b++)
		repeated |= b != a && jt->axis[b] == jt->axis[a];
	if (repeated)
		snprintf(buf, (size_t)cap, "%s.%c%d", jt->name, AXIS_NAMES[jt->axis[a]], a);
	else
		snprintf(buf, (size_t)cap, "%s.%c", jt->name, AXIS_NAMES[jt->axis[a]]);
}

/* ---- sphere to Gaussian (thesis 4.3) ---- */

/* A single Gaussian (sigma, c) seen by an orthographic ray at lateral
 * distance d, with the camera far in front of it: the ray Gaussian (eq. 4.4)
 * has c' = c exp(-d^2 / (2 sigma^2)); at the samples s_k = mu' + k sigma
 * (K = {-4..0}, eq. 4.10) the transmittance (eq. 4.6) is
 * exp(-sigma c' sqrt(pi/2) (1 + erf(k / sqrt 2))).  So V depends on d only
 * through a = sigma c':
 *   V = f(a) = sum_k a e^{-k^2/2} exp(-beta_k a),  beta_k = sqrt(pi/2) (1 + erf(k / sqrt 2)).
 * unit_visibility returns f and its first two derivatives. */
static void unit_visibility(double a, double *f, double *df, double *d2f)
{
	double v = 0, v1 = 0, v2 = 0;
	for (int k = -4; k <= 0; k++) {
		double w = exp(-0.5 * k * k);
		double beta = sqrt(M_PI / 2) * (1 + erf(k / sqrt(2.0)));
		double e = w * exp(-beta * a);
		v += a * e;
		v1 += e * (1 - beta * a);
		v2 += e * beta * (beta * a - 2);
	}
	*f = v;
	if (df)
		*df = v1;
	if (d2f)
		*d2f = v2;
}

static double unit_f(double a)
{
	double f;
	unit_visibility(a, &f, NULL, NULL);
	return f;
}

/* Bisection for a sign change of fn in [lo, hi] (fn(lo), fn(hi) of opposite
 * signs); the bracket shrinks to the last bit. */
static double bisect(double (*fn)(double, const void *), const void *ctx, double lo, double hi)
{
	double flo = fn(lo, ctx);
	for (int i = 0; i < 200 && hi - lo > 1e-15 * fmax(1.0, fabs(hi)); i++) {
		double mid = 0.5 * (lo + hi), fm = fn(mid, ctx);
		if ((fm > 0) == (flo > 0)) {
			lo = mid;
			flo = fm;
		} else {
			hi = mid;
		}
	}
	return 0.5 * (lo + hi);
}

static double centre_residual(double a, const void *ctx)
{
	return unit_f(a) - *(const double *)ctx;
}

/* V as a function of t = d / sigma for a = A e^{-t^2/2}:
 * V''(t) = a (t^2 (f'(a) + a f''(a)) - f'(a)), with the sign of its bracket. */
static double inflection_residual(double t, const void *ctx)
{
	double A = *(const double *)ctx, a = A * exp(-0.5 * t * t), f, df, d2f;
	unit_visibility(a, &f, &df, &d2f);
	return t * t * (df + a * d2f) - df;
}

/* |dV/dt| = |f'(a) a t|: the slope of the visibility profile. */
static double profile_slope(double A, double t)
{
	double a = A * exp(-0.5 * t * t), f, df;
	unit_visibility(a, &f, &df, NULL);
	return fabs(df * a * t);
}

/* Solves the unit problem: A = sigma c with f(A) = 1 - m on the rising
 * branch of f, and t* = r / sigma, the inflection point of V(t) of steepest
 * slope (the sharpest change of visibility, which the thesis aligns with the
 * sphere's outline). */
static int solve_unit_sphere(double m, double *A_out, double *t_out)
{
	if (!(m >= MC_SMOOTHNESS_MIN && m <= MC_SMOOTHNESS_MAX))
		return -1;
	/* f rises from 0 to about 0.998 near a = 3, then wanders (the five
	 * samples are a coarse quadrature): stop at the first maximum. */
	double a_peak = 0.01, f, df;
	for (;; a_peak += 0.01) {
		unit_visibility(a_peak, &f, &df, NULL);
		if (df <= 0 || a_peak > 100)
			break;
	}
	double target = 1 - m;
	if (!(unit_f(a_peak) > target))
		return -1;
	double A = bisect(centre_residual, &target, 0, a_peak);
	/* V(t) is flat at the centre and convex in the tail: scan for sign
	 * changes of V'' and keep the steepest inflection. */
	const double step = 0.005, t_max = 12;
	double best_t = -1, best_slope = -1;
	double prev = inflection_residual(step, &A);
	for (double t = 2 * step; t <= t_max; t += step) {
		double cur = inflection_residual(t, &A);
		if ((prev > 0) != (cur > 0)) {
			double root = bisect(inflection_residual, &A, t - step, t);
			double slope = profile_slope(A, root);
			if (slope > best_slope) {
				best_slope = slope;
				best_t = root;
			}
		}
		prev = cur;
	}
	if (best_t <= 0)
		return -1;
	*A_out = A;
	*t_out = best_t;
	return 0;
}

int mc_sphere_to_gaussian(double radius, double m, double *sigma, double *c)
{
	double A, t;
	if (!(radius > 0) || !isfinite(radius) || solve_unit_sphere(m, &A, &t))
		return -1;
	/* V depends on d / sigma and sigma c only: scale the unit solution. */
	*sigma = radius / t;
	*c = A / *sigma;
	return 0;
}

int mc_model_update_gaussians(mc_model *model, mc_err *err)
{
	double A, t;
	if (solve_unit_sphere(model->smoothness_m, &A, &t))
		return mc_err_set(err, "smoothness_m: %g is outside [%g, %g]", model->smoothness_m,
				  MC_SMOOTHNESS_MIN, MC_SMOOTHNESS_MAX);
	for (int q = 0; q < model->ngauss; q++) {
		mc_gauss_def *g = &model->gauss[q];
		if (!(g->radius > 0) || !isfinite(g->radius))
			return mc_err_set(err, "gaussians[%d].radius: must be a positive number, got %g", q, g->radius);
		g->sigma = g->radius / t;
		g->c = A / g->sigma;
	}
	return 0;
}

/* ---- model checks ---- */

static bool vec_in_extent(mc_vec3 v)
{
	return mc_v3_isfinite(v) && fabs(v.x) <= MODEL_MAX_EXTENT && fabs(v.y) <= MODEL_MAX_EXTENT &&
	       fabs(v.z) <= MODEL_MAX_EXTENT;
}

static bool is_rotation(mc_mat3 R)
{
	if (!mc_m3_isfinite(R))
		return false;
	mc_mat3 RtR = mc_m3_mul(mc_m3_transpose(R), R);
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			if (fabs(RtR.m[i][j] - (i == j)) > 1e-6)
				return false;
	double det = R.m[0][0] * (R.m[1][1] * R.m[2][2] - R.m[1][2] * R.m[2][1]) -
		     R.m[0][1] * (R.m[1][0] * R.m[2][2] - R.m[1][2] * R.m[2][0]) +
		     R.m[0][2] * (R.m[1][0] * R.m[2][1] - R.m[1][1] * R.m[2][0]);
	return det > 0;
}

static int check_joint(const mc_model *model, int j, mc_err *err)
{
	const mc_joint *jt = &model->joints[j];
	size_t len = strnlen(jt->name, MC_JOINT_NAME_MAX);
	if (len == 0 || len == MC_JOINT_NAME_MAX)
		return mc_err_set(err, "joints[%d].name: must be 1..%d characters", j, MC_JOINT_NAME_MAX - 1);
	for (int i = 0; i < j; i++)
		if (strcmp(model->joints[i].name, jt->name) == 0)
			return mc_err_set(err, "joints[%d].name: duplicate joint name '%s' (also joints[%d])", j,
					  jt->name, i);
	if (j == 0 && jt->parent != -1)
		return mc_err_set(err, "joints[0] '%s': the first joint must be the root (parent -1)", jt->name);
	if (j > 0 && (jt->parent < 0 || jt->parent >= j))
		return mc_err_set(err, "joints[%d] '%s': parent %d must be an earlier joint (0..%d)", j, jt->name,
				  jt->parent, j - 1);
	if (!vec_in_extent(jt->offset))
		return mc_err_set(err, "joints[%d] '%s': offset must be finite and within %g m", j, jt->name,
				  MODEL_MAX_EXTENT);
	if (!(model->bone_scale[j] > 0) || !isfinite(model->bone_scale[j]))
		return mc_err_set(err, "joints[%d] '%s': bone_scale must be a positive number, got %g", j, jt->name,
				  model->bone_scale[j]);
	if (jt->ndof < 0 || jt->ndof > 3)
		return mc_err_set(err, "joints[%d] '%s': %d dofs, at most 3", j, jt->name, jt->ndof);
	for (int a = 0; a < jt->ndof; a++) {
		if (jt->axis[a] < 0 || jt->axis[a] > 2)
			return mc_err_set(err, "joints[%d] '%s': dofs[%d].axis: %d is not 0, 1 or 2", j, jt->name, a,
					  jt->axis[a]);
		if (a > 0 && jt->axis[a] == jt->axis[a - 1])
			return mc_err_set(err, "joints[%d] '%s': dofs[%d].axis: same axis as dofs[%d] (redundant)", j,
					  jt->name, a, a - 1);
		if (!isfinite(jt->lower[a]) || !isfinite(jt->upper[a]) || jt->lower[a] > jt->upper[a])
			return mc_err_set(err, "joints[%d] '%s': dofs[%d]: limits [%g, %g] must be finite with min <= max",
					  j, jt->name, a, jt->lower[a], jt->upper[a]);
	}
	return 0;
}

static int check_gaussian(const mc_model *model, int q, mc_err *err)
{
	const mc_gauss_def *g = &model->gauss[q];
	if (g->joint < 0 || g->joint >= model->njoints)
		return mc_err_set(err, "gaussians[%d].joint: %d is not a joint (0..%d)", q, g->joint,
				  model->njoints - 1);
	if (g->scale_joint < 0 || g->scale_joint >= model->njoints)
		return mc_err_set(err, "gaussians[%d].bone: %d is not a joint (0..%d)", q, g->scale_joint,
				  model->njoints - 1);
	if (!vec_in_extent(g->offset))
		return mc_err_set(err, "gaussians[%d].offset: must be finite and within %g m", q, MODEL_MAX_EXTENT);
	if (!(g->radius > 0) || !(g->radius <= MODEL_MAX_EXTENT))
		return mc_err_set(err, "gaussians[%d].radius: must be in (0, %g] m, got %g", q, MODEL_MAX_EXTENT,
				  g->radius);
	for (int i = 0; i < 3; i++)
		if (!(g->rgb[i] >= 0 && g->rgb[i] <= 1))
			return mc_err_set(err, "gaussians[%d].color: components must be in [0, 1]", q);
	return 0;
}

/* The checks shared by validate and finalize; counts the dofs into *ndof. */
static int check_model(const mc_model *model, int *ndof, mc_err *err)
{
	if (model->njoints < 1 || model->njoints > MC_MAX_JOINTS)
		return mc_err_set(err, "joints: %d joints, expected 1..%d", model->njoints, MC_MAX_JOINTS);
	if (model->ngauss < 1 || model->ngauss > MC_MAX_GAUSSIANS)
		return mc_err_set(err, "gaussians: %d Gaussians, expected 1..%d", model->ngauss, MC_MAX_GAUSSIANS);
	if (strnlen(model->name, sizeof(model->name)) == sizeof(model->name))
		return mc_err_set(err, "name: longer than %zu characters", sizeof(model->name) - 1);
	if (!model->root_free && (!is_rotation(model->rig_from_root.R) || !mc_v3_isfinite(model->rig_from_root.t)))
		return mc_err_set(err, "rig_from_root: must be a rigid transform (orthonormal rotation, det +1)");
	if (!(model->smoothness_m >= MC_SMOOTHNESS_MIN && model->smoothness_m <= MC_SMOOTHNESS_MAX))
		return mc_err_set(err, "smoothness_m: %g is outside [%g, %g]", model->smoothness_m, MC_SMOOTHNESS_MIN,
				  MC_SMOOTHNESS_MAX);
	int n = model->root_free ? MC_ROOT_FREE_DOFS : 0;
	for (int j = 0; j < model->njoints; j++) {
		if (check_joint(model, j, err))
			return -1;
		n += model->joints[j].ndof;
		if (n > MC_MAX_DOF)
			return mc_err_set(err, "joints[%d] '%s': the model has more than %d degrees of freedom", j,
					  model->joints[j].name, MC_MAX_DOF);
	}
	for (int q = 0; q < model->ngauss; q++)
		if (check_gaussian(model, q, err))
			return -1;
	*ndof = n;
	return 0;
}

int mc_model_validate(const mc_model *model, mc_err *err)
{
	int ndof;
	if (check_model(model, &ndof, err))
		return -1;
	int k = model->root_free ? MC_ROOT_FREE_DOFS : 0;
	for (int j = 0; j < model->njoints; j++) {
		if (model->joints[j].dof0 != k)
			return mc_err_set(err, "joints[%d] '%s': dof0 is %d, expected %d", j, model->joints[j].name,
					  model->joints[j].dof0, k);
		k += model->joints[j].ndof;
	}
	if (model->ndof != ndof)
		return mc_err_set(err, "ndof is %d, the joints have %d", model->ndof, ndof);
	for (int q = 0; q < model->ngauss; q++) {
		const mc_gauss_def *g = &model->gauss[q];
		if (!(g->sigma > 0) || !isfinite(g->sigma) || !(g->c > 0) || !isfinite(g->c))
			return mc_err_set(err, "gaussians[%d]: sigma and c must be positive (call mc_model_finalize)", q);
	}
	return 0;
}

int mc_model_finalize(mc_model *model, mc_err *err)
{
	int ndof;
	if (check_model(model, &ndof, err))
		return -1;
	int k = model->root_free ? MC_ROOT_FREE_DOFS : 0;
	for (int j = 0; j < model->njoints; j++) {
		model->joints[j].dof0 = k;
		k += model->joints[j].ndof;
	}
	model->ndof = ndof;
	return mc_model_update_gaussians(model, err);
}
