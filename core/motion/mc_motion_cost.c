/* mc_motion_cost: frame distances, DTW and transition costs
 * (mc_motion_cost.h has the formulas). */
#include "motion/mc_motion_cost.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void mc_cost_params_default(mc_cost_params *p, double fps)
{
	memset(p, 0, sizeof(*p));
	p->tau = 0.1;
	p->lmin = (int)lround(fps / 3);
	if (p->lmin < 2)
		p->lmin = 2;
	p->lmax = (int)lround(fps);
	if (p->lmax < p->lmin)
		p->lmax = p->lmin;
	p->lstep = (p->lmax - p->lmin) / 2;
	if (p->lstep < 1)
		p->lstep = 1;
}

/* ---- features ---- */

int mc_motion_features(const mc_motion_db *db, mc_vec3 **features, mc_err *err)
{
	const int J = MC_MOTION_JOINTS;
	mc_vec3 *F = malloc(sizeof(*F) * (size_t)db->nframes * 2 * J);
	if (!F)
		return mc_err_set(err, "out of memory for the features of %d frames", db->nframes);
	for (int c = 0; c < db->nclips; c++) {
		const mc_motion_clip *cl = &db->clips[c];
		for (int k = 0; k < cl->nframes; k++) {
			int f = cl->first + k;
			int a = k > 0 ? f - 1 : f, b = k + 1 < cl->nframes ? f + 1 : f;
			double rate = b > a ? db->fps / (b - a) : 0;
			const mc_vec3 *x = mc_motion_frame(db, f), *xa = mc_motion_frame(db, a), *xb = mc_motion_frame(db, b);
			mc_floor_frame ff = mc_motion_floor_frame(x);
			mc_vec3 *q = F + (size_t)f * 2 * J, *v = q + J;
			for (int j = 0; j < J; j++) {
				q[j] = mc_floor_from_world(ff, x[j]);
				/* a velocity is a direction: rotate it only */
				mc_floor_frame rot = {0, 0, ff.heading};
				v[j] = mc_v3_scale(mc_floor_from_world(rot, mc_v3_sub(xb[j], xa[j])), rate);
			}
		}
	}
	*features = F;
	return 0;
}

double mc_frame_distance(const mc_vec3 *fa, const mc_vec3 *fb, double tau)
{
	const int J = MC_MOTION_JOINTS;
	double s = 0;
	for (int j = 0; j < J; j++)
		s += mc_v3_norm2(mc_v3_sub(fa[j], fb[j])) + tau * tau * mc_v3_norm2(mc_v3_sub(fa[J + j], fb[J + j]));
	return sqrt(s / J);
}

/* ---- DTW with a slope constraint ----
 * States of a cell: 0 arrived diagonally, 1..R after 1..R horizontal steps
 * in a row (the target advances), R+1..2R after vertical ones (the source
 * advances). */
#define NSTATE (1 + 2 * MC_DTW_MAX_RUN)
#define CELLS (MC_DTW_MAX_WINDOW * MC_DTW_MAX_WINDOW * NSTATE)

struct mc_dtw_ws {
	int ls, lt;
	double acc[CELLS];
	int16_t len[CELLS];
	int8_t from[CELLS]; /* predecessor state, -1: none (start or unreachable) */
};

mc_dtw_ws *mc_dtw_ws_new(void) { return malloc(sizeof(mc_dtw_ws)); }
void mc_dtw_ws_free(mc_dtw_ws *ws) { free(ws); }

static inline int cell(const mc_dtw_ws *ws, int s, int t, int k) { return (s * ws->lt + t) * NSTATE + k; }

/* Relaxes state k of (s, t) from state kp of cell (ps, pt). */
static void relax(mc_dtw_ws *ws, int s, int t, int k, int ps, int pt, int kp, double w)
{
	int p = cell(ws, ps, pt, kp), c = cell(ws, s, t, k);
	if (!isfinite(ws->acc[p]))
		return;
	double a = ws->acc[p] + w;
	if (a < ws->acc[c]) {
		ws->acc[c] = a;
		ws->len[c] = (int16_t)(ws->len[p] + 1);
		ws->from[c] = (int8_t)kp;
	}
}

void mc_dtw_fill(mc_dtw_ws *ws, const float *w, int ls, int lt)
{
	const int R = MC_DTW_MAX_RUN;
	ws->ls = ls;
	ws->lt = lt;
	for (int i = 0; i < ls * lt * NSTATE; i++) {
		ws->acc[i] = INFINITY;
		ws->len[i] = 0;
		ws->from[i] = -1;
	}
	ws->acc[0] = w[0];
	ws->len[0] = 1;
	for (int s = 0; s < ls; s++)
		for (int t = 0; t < lt; t++) {
			double x = w[s * lt + t];
			if (s > 0 && t > 0)
				for (int kp = 0; kp < NSTATE; kp++)
					relax(ws, s, t, 0, s - 1, t - 1, kp, x);
			if (t > 0) { /* horizontal */
				relax(ws, s, t, 1, s, t - 1, 0, x);
				for (int r = 1; r <= R; r++)
					relax(ws, s, t, 1, s, t - 1, R + r, x);
				for (int r = 1; r < R; r++)
					relax(ws, s, t, 1 + r, s, t - 1, r, x);
			}
			if (s > 0) { /* vertical */
				relax(ws, s, t, R + 1, s - 1, t, 0, x);
				for (int r = 1; r <= R; r++)
					relax(ws, s, t, R + 1, s - 1, t, r, x);
				for (int r = 1; r < R; r++)
					relax(ws, s, t, R + 1 + r, s - 1, t, R + r, x);
			}
		}
}

static int best_state(const mc_dtw_ws *ws, int s, int t)
{
	int best = -1;
	for (int k = 0; k < NSTATE; k++)
		if (isfinite(ws->acc[cell(ws, s, t, k)]) && (best < 0 || ws->acc[cell(ws, s, t, k)] < ws->acc[cell(ws, s, t, best)]))
			best = k;
	return best;
}

int mc_dtw_end(const mc_dtw_ws *ws, int li, double *sum)
{
	int k = best_state(ws, li - 1, ws->lt - 1);
	if (k < 0)
		return -1;
	int c = cell(ws, li - 1, ws->lt - 1, k);
	*sum = ws->acc[c];
	return ws->len[c];
}

int mc_dtw_path(const mc_dtw_ws *ws, int li, uint8_t (*path)[2])
{
	const int R = MC_DTW_MAX_RUN;
	int s = li - 1, t = ws->lt - 1, k = best_state(ws, s, t);
	if (k < 0)
		return -1;
	int n = ws->len[cell(ws, s, t, k)];
	for (int i = n - 1; i >= 0; i--) {
		path[i][0] = (uint8_t)s;
		path[i][1] = (uint8_t)t;
		int kp = ws->from[cell(ws, s, t, k)];
		if (k == 0) {
			s--;
			t--;
		} else if (k <= R) {
			t--;
		} else {
			s--;
		}
		k = kp;
	}
	return n;
}

/* ---- the cost matrix ---- */

typedef struct {
	const mc_motion_db *db;
	const mc_cost_params *p;
	const mc_vec3 *features;
	mc_cost_matrix *m;
	pthread_mutex_t lock;
	int next_row, rows_done, phase; /* phase 0: distances, 1: transitions */
	int failed;
} job;

static int take_row(job *jb)
{
	pthread_mutex_lock(&jb->lock);
	int r = jb->next_row < jb->m->n ? jb->next_row++ : -1;
	pthread_mutex_unlock(&jb->lock);
	return r;
}

static void row_done(job *jb)
{
	pthread_mutex_lock(&jb->lock);
	jb->rows_done++;
	if (jb->p->progress)
		jb->p->progress(jb->p->progress_ctx, "costs", jb->rows_done, 2 * jb->m->n);
	pthread_mutex_unlock(&jb->lock);
}

static void distance_row(job *jb, int a)
{
	const int n = jb->m->n;
	const mc_vec3 *fa = jb->features + (size_t)a * 2 * MC_MOTION_JOINTS;
	for (int b = 0; b < n; b++)
		jb->m->d[(size_t)a * n + b] =
			(float)mc_frame_distance(fa, jb->features + (size_t)b * 2 * MC_MOTION_JOINTS, jb->p->tau);
}

/* Best windows for transition (i, j); w is scratch for lmax * lmax. */
static mc_transition transition(job *jb, mc_dtw_ws *ws, float *w, int i, int j)
{
	const mc_motion_db *db = jb->db;
	const mc_cost_params *p = jb->p;
	const int n = jb->m->n;
	const mc_motion_clip *ci = &db->clips[db->clip_of[i]], *cj = &db->clips[db->clip_of[j]];
	int ls = ci->first + ci->nframes - i; /* source frames left from i */
	if (ls > p->lmax)
		ls = p->lmax;
	int tmax = j - cj->first + 1;         /* target frames up to j */
	mc_transition best = {INFINITY, 0, 0, 0, 0};
	for (int lj = p->lmin; lj <= p->lmax && lj <= tmax; lj += p->lstep) {
		if (ls < p->lmin)
			break;
		int t0 = j - lj + 1;
		for (int s = 0; s < ls; s++)
			for (int t = 0; t < lj; t++)
				w[s * lj + t] = jb->m->d[(size_t)(i + s) * n + t0 + t];
		mc_dtw_fill(ws, w, ls, lj);
		for (int li = p->lmin; li <= ls; li += p->lstep) {
			double sum;
			int len = mc_dtw_end(ws, li, &sum);
			if (len > 0 && sum / len < best.D) {
				best.D = (float)(sum / len);
				best.L = (uint8_t)len;
				best.li = (uint8_t)li;
				best.lj = (uint8_t)lj;
			}
		}
	}
	return best;
}

static void *worker(void *arg)
{
	job *jb = arg;
	mc_dtw_ws *ws = jb->phase ? mc_dtw_ws_new() : NULL;
	float *w = jb->phase ? malloc(sizeof(float) * MC_DTW_MAX_WINDOW * MC_DTW_MAX_WINDOW) : NULL;
	if (jb->phase && (!ws || !w)) {
		pthread_mutex_lock(&jb->lock);
		jb->failed = 1;
		pthread_mutex_unlock(&jb->lock);
	} else {
		for (int r; (r = take_row(jb)) >= 0; row_done(jb)) {
			if (!jb->phase) {
				distance_row(jb, r);
				continue;
			}
			for (int j = 0; j < jb->m->n; j++)
				jb->m->t[(size_t)r * jb->m->n + j] = transition(jb, ws, w, r, j);
		}
	}
	mc_dtw_ws_free(ws);
	free(w);
	return NULL;
}

int mc_motion_threads(int requested)
{
	if (requested > 0)
		return requested;
	long n = sysconf(_SC_NPROCESSORS_ONLN);
	return n > 0 ? (int)n : 1;
}

static int run_phase(job *jb, int phase, int nthreads, mc_err *err)
{
	jb->phase = phase;
	jb->next_row = 0;
	pthread_t *th = calloc((size_t)nthreads, sizeof(*th));
	if (!th)
		return mc_err_set(err, "out of memory");
	int started = 0;
	for (; started < nthreads; started++)
		if (pthread_create(&th[started], NULL, worker, jb) != 0)
			break;
	if (started == 0)
		worker(jb);
	for (int k = 0; k < started; k++)
		pthread_join(th[k], NULL);
	free(th);
	if (jb->failed)
		return mc_err_set(err, "out of memory in a cost thread");
	return 0;
}

int mc_cost_matrix_build(const mc_motion_db *db, const mc_cost_params *p, mc_cost_matrix *m, mc_err *err)
{
	memset(m, 0, sizeof(*m));
	if (p->lmin < 1 || p->lmax < p->lmin || p->lstep < 1 || p->lmax > MC_DTW_MAX_WINDOW || p->lmax > 255)
		return mc_err_set(err, "window lengths %d..%d step %d: need 1 <= min <= max <= %d, step >= 1", p->lmin,
				  p->lmax, p->lstep, MC_DTW_MAX_WINDOW);
	size_t n = (size_t)db->nframes;
	m->n = db->nframes;
	m->d = malloc(sizeof(float) * n * n);
	m->t = malloc(sizeof(mc_transition) * n * n);
	mc_vec3 *features = NULL;
	if (!m->d || !m->t) {
		mc_cost_matrix_free(m);
		return mc_err_set(err, "out of memory for the %zu x %zu cost matrix", n, n);
	}
	if (mc_motion_features(db, &features, err)) {
		mc_cost_matrix_free(m);
		return -1;
	}
	job jb = {.db = db, .p = p, .features = features, .m = m};
	pthread_mutex_init(&jb.lock, NULL);
	int nthreads = mc_motion_threads(p->threads);
	int rc = run_phase(&jb, 0, nthreads, err);
	if (!rc)
		rc = run_phase(&jb, 1, nthreads, err);
	pthread_mutex_destroy(&jb.lock);
	free(features);
	if (rc)
		mc_cost_matrix_free(m);
	return rc;
}

void mc_cost_matrix_free(mc_cost_matrix *m)
{
	free(m->d);
	free(m->t);
	memset(m, 0, sizeof(*m));
}
