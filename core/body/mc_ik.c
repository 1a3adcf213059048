#include "body/mc_ik.h"
#include "geom/mc_ray.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

void mc_ik_options_default(mc_ik_options *o)
{
	o->iterations = 100;
	o->pose_prior = 1e-4;
	o->prior_pose = NULL;
	o->fit_bone_scale = true;
	o->fit_root = true;
	o->restarts = true;
	o->ray_near = 0;
}

static bool is_ray(const mc_ik_target *t)
{
	return mc_v3_norm2(t->dir) > 0;
}

/* The residual of a joint at offset v from a target's position: a ray
 * target's mc_ray_offset, a point target's v itself (its dir is 0). */
static mc_vec3 target_residual(const mc_ik_target *t, double near, mc_vec3 v)
{
	return is_ray(t) ? mc_ray_offset(v, t->dir, near) : v;
}

/* The residual's change for the joint's move dv. */
static mc_vec3 target_residual_move(const mc_ik_target *t, double near, mc_vec3 v, mc_vec3 dv)
{
	return is_ray(t) ? mc_ray_offset_move(v, t->dir, near, dv) : dv;
}

static int compare_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

const mc_ik_target *mc_ik_find_target(const mc_ik_target *t, int n, int joint)
{
	for (int i = 0; i < n; i++)
		if (t[i].joint == joint)
			return &t[i];
	return NULL;
}

void mc_ik_fit_bone_scale(mc_model *model, const mc_ik_target *targets, int n)
{
	double scales[MC_MAX_JOINTS];
	bool known[MC_MAX_JOINTS] = {false};
	int nscales = 0;
	for (int j = 0; j < model->njoints; j++) {
		int parent = model->joints[j].parent;
		double rest = mc_v3_norm(model->joints[j].offset);
		const mc_ik_target *a = mc_ik_find_target(targets, n, j);
		const mc_ik_target *b = parent >= 0 ? mc_ik_find_target(targets, n, parent) : NULL;
		if (!a || !b || rest < 1e-3)
			continue;
		model->bone_scale[j] = mc_v3_norm(mc_v3_sub(a->position, b->position)) / rest;
		known[j] = true;
		scales[nscales++] = model->bone_scale[j];
	}
	double median = 1.0;
	if (nscales) {
		double sorted[MC_MAX_JOINTS];
		memcpy(sorted, scales, sizeof(double) * nscales);
		qsort(sorted, nscales, sizeof(double), compare_double);
		median = sorted[nscales / 2];
	}
	for (int j = 0; j < model->njoints; j++)
		if (!known[j])
			model->bone_scale[j] = median;
}

/* A dof's offset from where the pose prior pulls it. */
static double prior_offset(const double *p, const double *p0, int k)
{
	return p0 ? p[k] - p0[k] : p[k];
}

static double ik_cost(const mc_model *m, const double *p, const mc_ik_target *t, int n, const mc_ik_options *o,
		      int first_joint_dof)
{
	double prior = o->pose_prior;
	const double *p0 = o->prior_pose;
	mc_fk fk;
	mc_model_fk(m, p, &fk);
	double c = 0;
	for (int i = 0; i < n; i++) {
		mc_vec3 r = target_residual(&t[i], o->ray_near, mc_v3_sub(fk.rig_from_joint[t[i].joint].t, t[i].position));
		c += t[i].weight * mc_v3_norm2(r);
	}
	for (int k = first_joint_dof; k < m->ndof; k++)
		c += prior * prior_offset(p, p0, k) * prior_offset(p, p0, k);
	return c;
}

/* One Levenberg-Marquardt step: solves (J^T W J + mu D + prior) d = -g. */
static bool ik_step(const mc_model *m, const double *p, const mc_ik_target *t, int n, const mc_ik_options *o,
		    double mu, int first_joint_dof, int nfrozen, double *step, mc_vec3 *J)
{
	double prior = o->pose_prior;
	const double *p0 = o->prior_pose;
	int nd = m->ndof;
	double A[MC_MAX_DOF * MC_MAX_DOF];
	double *g = step;
	mc_fk fk;
	mc_model_fk(m, p, &fk);
	mc_model_joint_jacobian(m, p, &fk, J);
	memset(A, 0, sizeof(double) * nd * nd);
	memset(g, 0, sizeof(double) * nd);
	for (int i = 0; i < n; i++) {
		const mc_vec3 *Jj = &J[t[i].joint * nd];
		mc_vec3 Ji[MC_MAX_DOF];
		mc_vec3 v = mc_v3_sub(fk.rig_from_joint[t[i].joint].t, t[i].position);
		for (int a = 0; a < nd; a++)
			Ji[a] = target_residual_move(&t[i], o->ray_near, v, Jj[a]);
		mc_vec3 r = target_residual(&t[i], o->ray_near, v);
		for (int a = 0; a < nd; a++) {
			g[a] += t[i].weight * mc_v3_dot(Ji[a], r);
			for (int b = a; b < nd; b++)
				A[a * nd + b] += t[i].weight * mc_v3_dot(Ji[a], Ji[b]);
		}
	}
	for (int a = 0; a < nd; a++) {
		for (int b = 0; b < a; b++)
			A[a * nd + b] = A[b * nd + a];
		double reg = a >= first_joint_dof ? prior : 0.0;
		g[a] = -(g[a] + reg * prior_offset(p, p0, a));
		A[a * nd + a] += reg + mu * (A[a * nd + a] + 1e-6);
	}
	for (int a = 0; a < nfrozen; a++) { /* frozen dofs: zero step */
		for (int b = 0; b < nd; b++)
			A[a * nd + b] = A[b * nd + a] = 0;
		A[a * nd + a] = 1;
		g[a] = 0;
	}
	return mc_la_cholesky_solve(A, g, nd);
}

static double lm_solve(const mc_model *m, double *p, const mc_ik_target *t, int n, const mc_ik_options *o,
		       int first_joint_dof, int nfrozen)
{
	mc_vec3 *J = malloc(sizeof(mc_vec3) * MC_MAX_JOINTS * MC_MAX_DOF);
	double step[MC_MAX_DOF], trial[MC_MAX_DOF];
	double mu = 1e-3, cost = ik_cost(m, p, t, n, o, first_joint_dof);
	for (int it = 0; it < o->iterations && J; it++) {
		if (!ik_step(m, p, t, n, o, mu, first_joint_dof, nfrozen, step, J)) {
			mu *= 10;
			continue;
		}
		for (int k = 0; k < m->ndof; k++)
			trial[k] = p[k] + step[k];
		mc_model_clamp_pose(m, trial);
		double c = ik_cost(m, trial, t, n, o, first_joint_dof);
		if (c < cost) {
			double gain = cost - c;
			memcpy(p, trial, sizeof(double) * m->ndof);
			cost = c;
			mu = fmax(mu * 0.3, 1e-9);
			if (gain < 1e-14)
				break;
		} else {
			mu *= 10;
			if (mu > 1e8)
				break;
		}
	}
	free(J);
	return cost;
}

/* Levenberg-Marquardt from the given start, and, while the fit is worse
 * than IK_GOOD_RMS, from other starts: the joint dofs at the middle of
 * their limits, then at deterministic pseudo-random points inside them
 * (the root dofs keep the given start).  Limb poses far from the start can
 * otherwise end in a local minimum (an arm folded the wrong way). */
#define IK_GOOD_RMS 0.002
#define IK_RESTARTS 6

static void restart_pose(const mc_model *m, int attempt, int first_joint_dof, const double *start, double *p)
{
	uint64_t state = 0x9e3779b97f4a7c15ull * (uint64_t)(attempt + 1);
	memcpy(p, start, sizeof(double) * m->ndof);
	for (int j = 0; j < m->njoints; j++)
		for (int d = 0; d < m->joints[j].ndof; d++) {
			const mc_joint *jt = &m->joints[j];
			int k = jt->dof0 + d;
			if (k < first_joint_dof)
				continue;
			state ^= state << 13, state ^= state >> 7, state ^= state << 17;
			double u = attempt == 1 ? 0.5 : (double)(state >> 11) / 9007199254740992.0;
			p[k] = jt->lower[d] + u * (jt->upper[d] - jt->lower[d]);
		}
}

void mc_ik_place_free_root(const mc_model *m, double *p, const int *joint, const mc_vec3 *position,
			   const double *weight, int n)
{
	if (!m->root_free || n < 3)
		return;
	mc_fk fk;
	mc_model_fk(m, p, &fk);
	mc_vec3 from[MC_IK_PLACE_MAX];
	for (int i = 0; i < n && i < MC_IK_PLACE_MAX; i++)
		from[i] = fk.rig_from_joint[joint[i]].t;
	mc_xform fit = mc_xform_fit_rigid(from, position, weight, n < MC_IK_PLACE_MAX ? n : MC_IK_PLACE_MAX);
	mc_xform root = {mc_m3_from_rotvec(mc_v3(p[3], p[4], p[5])), mc_v3(p[0], p[1], p[2])};
	root = mc_xform_compose(fit, root);
	mc_vec3 r = mc_m3_to_rotvec(root.R);
	double v[MC_ROOT_FREE_DOFS] = {root.t.x, root.t.y, root.t.z, r.x, r.y, r.z};
	memcpy(p, v, sizeof(v));
}

/* A free root starts from the rigid fit of the pose's joints to the point
 * targets, so that the solve starts in the right place, facing the right
 * way, whatever the root's previous value (e.g. the origin of a lab). */
static void align_free_root(const mc_model *m, double *p, const mc_ik_target *t, int n)
{
	int joint[MC_IK_PLACE_MAX], k = 0;
	mc_vec3 to[MC_IK_PLACE_MAX];
	double w[MC_IK_PLACE_MAX];
	for (int i = 0; i < n && k < MC_IK_PLACE_MAX; i++)
		if (mc_v3_norm2(t[i].dir) == 0 && t[i].weight > 0) {
			joint[k] = t[i].joint;
			to[k] = t[i].position;
			w[k++] = t[i].weight;
		}
	mc_ik_place_free_root(m, p, joint, to, w, k);
}

static double solve_with_restarts(const mc_model *m, double *p, const mc_ik_target *t, int n,
				  const mc_ik_options *o, int first_joint_dof, int nfrozen, double wsum)
{
	double start[MC_MAX_DOF], best[MC_MAX_DOF], trial[MC_MAX_DOF];
	memcpy(start, p, sizeof(double) * m->ndof);
	memcpy(best, p, sizeof(double) * m->ndof);
	double best_cost = lm_solve(m, best, t, n, o, first_joint_dof, nfrozen);
	for (int a = 1; o->restarts && a <= IK_RESTARTS && sqrt(best_cost / wsum) > IK_GOOD_RMS; a++) {
		restart_pose(m, a, first_joint_dof, start, trial);
		double c = lm_solve(m, trial, t, n, o, first_joint_dof, nfrozen);
		if (c < best_cost) {
			best_cost = c;
			memcpy(best, trial, sizeof(double) * m->ndof);
		}
	}
	memcpy(p, best, sizeof(double) * m->ndof);
	return best_cost;
}

double mc_ik_solve(mc_model *model, double *pose, const mc_ik_target *targets, int n, const mc_ik_options *o,
		   mc_err *err)
{
	double wsum = 0, spread = 0;
	for (int i = 0; i < n; i++) {
		if (targets[i].joint < 0 || targets[i].joint >= model->njoints || !mc_v3_isfinite(targets[i].position))
			return mc_err_set(err, "ik target %d: invalid joint or position", i);
		mc_vec3 p = targets[i].position;
		if (fabs(p.x) > MC_IK_TARGET_MAX_M || fabs(p.y) > MC_IK_TARGET_MAX_M || fabs(p.z) > MC_IK_TARGET_MAX_M)
			return mc_err_set(err, "ik target %d ('%s'): (%g, %g, %g) m is more than %g m from the rig", i,
					  model->joints[targets[i].joint].name, p.x, p.y, p.z, MC_IK_TARGET_MAX_M);
		if (mc_v3_norm2(targets[i].dir) == 0) /* point targets must span a body, not one point */
			spread = fmax(spread, mc_v3_norm(mc_v3_sub(p, targets[0].position)));
		wsum += targets[i].weight;
	}
	if (n < 3 || !(wsum > 0))
		return mc_err_set(err, "ik: need at least 3 weighted joint targets, got %d", n);
	if (mc_v3_norm2(targets[0].dir) == 0 && spread < MC_IK_MIN_SPREAD_M)
		return mc_err_set(err, "ik: the %d joint positions lie within %g m of each other: not a body", n,
				  MC_IK_MIN_SPREAD_M);
	if (o->fit_bone_scale)
		mc_ik_fit_bone_scale(model, targets, n);

	bool solve_root = o->fit_root && !model->root_free;
	mc_model work = *model;
	double p[MC_MAX_DOF] = {0};
	if (solve_root) {
		/* A fixed-root model is solved as a free-root one, so that the
		 * root placement becomes six ordinary pose parameters. */
		work.root_free = true;
		if (mc_model_finalize(&work, err) < 0)
			return -1;
		p[0] = model->rig_from_root.t.x;
		p[1] = model->rig_from_root.t.y;
		p[2] = model->rig_from_root.t.z;
		mc_vec3 w = mc_m3_to_rotvec(model->rig_from_root.R);
		p[3] = w.x;
		p[4] = w.y;
		p[5] = w.z;
		memcpy(p + 6, pose, sizeof(double) * model->ndof);
	} else {
		memcpy(p, pose, sizeof(double) * model->ndof);
	}
	if (model->root_free && o->fit_root)
		align_free_root(&work, p, targets, n);
	int first_joint_dof = work.root_free ? 6 : 0;
	int nfrozen = (work.root_free && !o->fit_root) ? 6 : 0;
	/* the prior's pose in the solved vector (after the six root dofs when
	 * a fixed root is solved for) */
	mc_ik_options solve = *o;
	double p0[MC_MAX_DOF] = {0};
	if (o->prior_pose && solve_root) {
		memcpy(p0 + 6, o->prior_pose, sizeof(double) * model->ndof);
		solve.prior_pose = p0;
	}
	double cost = solve_with_restarts(&work, p, targets, n, &solve, first_joint_dof, nfrozen, wsum);
	if (solve_root) {
		model->rig_from_root.t = mc_v3(p[0], p[1], p[2]);
		model->rig_from_root.R = mc_m3_from_rotvec(mc_v3(p[3], p[4], p[5]));
		memcpy(pose, p + 6, sizeof(double) * model->ndof);
	} else {
		memcpy(pose, p, sizeof(double) * model->ndof);
	}
	return sqrt(cost / wsum);
}
