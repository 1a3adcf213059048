/* mc_pose_prior: the Gaussian-mixture prior over joint angles (see the
 * header; the file format is in docs/MODEL_FORMAT.md, "Pose prior"). */
#include "body/mc_pose_prior.h"

#include "base/mc_json.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
	double log_c; /* log w_k + log det L_k */
	double mean[MC_MAX_DOF];
	double L[MC_MAX_DOF * MC_MAX_DOF]; /* lower triangle, row-major, d x d */
} component;

struct mc_pose_prior {
	int d, k;
	int dof[MC_MAX_DOF]; /* the model's pose index of each covered dof */
	double log_c_max;
	component comp[MC_PRIOR_MAX_COMPONENTS];
};

static int map_dofs(mc_pose_prior *p, const json_t *root, const char *origin, const mc_model *model, mc_err *err)
{
	size_t n;
	json_t *dofs = json_object_get(root, "dofs");
	if (!json_is_array(dofs) || (n = json_array_size(dofs)) == 0 || n > MC_MAX_DOF)
		return mc_err_set(err, "%s: dofs: expected an array of 1 to %d dof names", origin, MC_MAX_DOF);
	p->d = (int)n;
	for (size_t i = 0; i < n; i++) {
		const char *want = json_string_value(json_array_get(dofs, i));
		p->dof[i] = -1;
		for (int k = 0; want && k < model->ndof; k++) {
			char name[64];
			mc_model_dof_name(model, k, name, sizeof(name));
			if (strcmp(name, want) == 0)
				p->dof[i] = k;
		}
		if (!want)
			return mc_err_set(err, "%s: dofs[%zu]: expected a string", origin, i);
		if (p->dof[i] < 0)
			return mc_err_set(err, "%s: dofs[%zu]: the model has no dof '%s'", origin, i, want);
	}
	return 0;
}

/* Row i of the precision's Cholesky factor holds i + 1 numbers, the diagonal
 * last and positive. */
static int parse_chol(component *c, const json_t *rows, const char *where, int d, mc_err *err)
{
	if (!json_is_array(rows) || (int)json_array_size(rows) != d)
		return mc_err_set(err, "%s.precision_chol: expected %d rows", where, d);
	double log_det = 0;
	for (int i = 0; i < d; i++) {
		const json_t *row = json_array_get(rows, (size_t)i);
		if (!json_is_array(row) || (int)json_array_size(row) != i + 1)
			return mc_err_set(err, "%s.precision_chol[%d]: expected %d numbers", where, i, i + 1);
		for (int j = 0; j <= i; j++) {
			const json_t *v = json_array_get(row, (size_t)j);
			if (!json_is_number(v) || !isfinite(json_number_value(v)))
				return mc_err_set(err, "%s.precision_chol[%d][%d]: expected a number", where, i, j);
			c->L[i * d + j] = json_number_value(v);
		}
		if (!(c->L[i * d + i] > 0))
			return mc_err_set(err, "%s.precision_chol[%d][%d]: the diagonal must be > 0", where, i, i);
		log_det += log(c->L[i * d + i]);
	}
	c->log_c += log_det;
	return 0;
}

static int parse_component(mc_pose_prior *p, const json_t *j, const char *where, component *c, mc_err *err)
{
	double w;
	if (!json_is_object(j))
		return mc_err_set(err, "%s: expected an object", where);
	if (mc_json_number_range(j, "weight", where, DBL_MIN, 1.0, &w, true, err) < 0 ||
	    mc_json_numbers(j, "mean", where, c->mean, (size_t)p->d, true, err) < 0)
		return -1;
	c->log_c = log(w);
	return parse_chol(c, json_object_get(j, "precision_chol"), where, p->d, err);
}

static int parse_prior(mc_pose_prior *p, const json_t *root, const char *origin, const mc_model *model, mc_err *err)
{
	if (map_dofs(p, root, origin, model, err) < 0)
		return -1;
	const json_t *comps = json_object_get(root, "components");
	size_t n = json_array_size(comps);
	if (!json_is_array(comps) || n == 0 || n > MC_PRIOR_MAX_COMPONENTS)
		return mc_err_set(err, "%s: components: expected an array of 1 to %d components", origin,
				  MC_PRIOR_MAX_COMPONENTS);
	p->k = (int)n;
	p->log_c_max = -INFINITY;
	for (size_t i = 0; i < n; i++) {
		char where[256];
		mc_json_path_index(where, sizeof(where), origin, "components", i);
		if (parse_component(p, json_array_get(comps, i), where, &p->comp[i], err) < 0)
			return -1;
		p->log_c_max = fmax(p->log_c_max, p->comp[i].log_c);
	}
	return 0;
}

static mc_pose_prior *finish(json_t *root, const char *origin, const mc_model *model, mc_err *err)
{
	mc_pose_prior *p = calloc(1, sizeof(*p));
	if (!p) {
		mc_err_set(err, "%s: out of memory", origin);
	} else if (parse_prior(p, root, origin, model, err) < 0) {
		free(p);
		p = NULL;
	}
	json_decref(root);
	return p;
}

mc_pose_prior *mc_pose_prior_load(const char *path, const mc_model *model, mc_err *err)
{
	json_t *root;
	if (mc_json_load_file(path, &root, err))
		return NULL;
	return finish(root, path, model, err);
}

mc_pose_prior *mc_pose_prior_parse(const char *json_text, const char *origin, const mc_model *model, mc_err *err)
{
	json_t *root;
	if (mc_json_load_text(json_text, origin, &root, err))
		return NULL;
	return finish(root, origin, model, err);
}

void mc_pose_prior_free(mc_pose_prior *p)
{
	free(p);
}

int mc_pose_prior_ndofs(const mc_pose_prior *p)
{
	return p->d;
}

int mc_pose_prior_ncomponents(const mc_pose_prior *p)
{
	return p->k;
}

/* z = L^T (x - mean); returns log_c - |z|^2 / 2. */
static double component_log(const component *c, const double *x, int d, double *z)
{
	double diff[MC_MAX_DOF];
	for (int i = 0; i < d; i++)
		diff[i] = x[i] - c->mean[i];
	double q = 0;
	for (int j = 0; j < d; j++) {
		double s = 0;
		for (int i = j; i < d; i++)
			s += c->L[i * d + j] * diff[i];
		z[j] = s;
		q += s * s;
	}
	return c->log_c - 0.5 * q;
}

double mc_pose_prior_energy(const mc_pose_prior *p, const double *pose, double lambda, double *grad)
{
	const int d = p->d;
	double x[MC_MAX_DOF], a[MC_PRIOR_MAX_COMPONENTS], amax = -INFINITY;
	double z[MC_PRIOR_MAX_COMPONENTS][MC_MAX_DOF];
	for (int i = 0; i < d; i++)
		x[i] = pose[p->dof[i]];
	for (int k = 0; k < p->k; k++) {
		a[k] = component_log(&p->comp[k], x, d, z[k]);
		amax = fmax(amax, a[k]);
	}
	double sum = 0;
	for (int k = 0; k < p->k; k++)
		sum += exp(a[k] - amax);
	double nll = p->log_c_max - (amax + log(sum));
	/* The robust form and its slope: c log(1 + nll / c). */
	const double c = MC_PRIOR_ROBUST_NATS;
	double E = nll > 0 ? c * log1p(nll / c) : nll, slope = nll > 0 ? lambda / (1.0 + nll / c) : lambda;
	if (grad) /* dnll/dx = sum_k r_k L_k z_k, r_k the responsibilities */
		for (int k = 0; k < p->k; k++) {
			double r = exp(a[k] - amax) / sum;
			const component *c = &p->comp[k];
			for (int i = 0; i < d; i++) {
				double s = 0;
				for (int j = 0; j <= i; j++)
					s += c->L[i * d + j] * z[k][j];
				grad[p->dof[i]] += slope * r * s;
			}
		}
	return lambda * E;
}
