/* mc_motion_graph: motion graph, Essential graph, parametric nodes
 * (mc_motion_graph.h).  The file format is in mc_motion_graph_io.c. */
#include "motion/mc_motion_graph.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A transition u -> v exists when some window pair fits and it jumps. */
static bool transition_ok(const mc_motion_db *db, const mc_cost_matrix *m, int lmax, int u, int v)
{
	if (!isfinite(m->t[(size_t)u * m->n + v].D))
		return false;
	return db->clip_of[u] != db->clip_of[v] || abs(v - u) > lmax;
}

static bool original_ok(const mc_motion_db *db, int u, int v)
{
	return v == u + 1 && v < db->nframes && db->clip_of[u] == db->clip_of[v];
}

static double tr_weight(const mc_cost_matrix *m, double alpha, int u, int v)
{
	const mc_transition *t = &m->t[(size_t)u * m->n + v];
	return t->D + alpha * t->L;
}

/* ---- threads over source nodes ---- */

typedef struct {
	const mc_motion_db *db;
	const mc_cost_matrix *m;
	int lmax;
	double alpha;
	uint8_t *keep;          /* essential: written; stats: read */
	const int *start, *adj; /* stats: CSR of the graph */
	const float *w;         /* stats: edge weights along adj */
	const float *W;         /* essential: n x n transition weights, INFINITY for none */
	void (*progress)(void *ctx, const char *stage, int done, int total);
	void *progress_ctx;
	int done;
	pthread_mutex_t lock;
	int next;
	int failed;
	double sum, sum2;
	long count, unreachable;
} sp_job;

static int next_source(sp_job *jb)
{
	pthread_mutex_lock(&jb->lock);
	int u = jb->next < jb->db->nframes ? jb->next++ : -1;
	pthread_mutex_unlock(&jb->lock);
	return u;
}

static void add_stats(sp_job *jb, int u, const double *dist)
{
	double s = 0, s2 = 0;
	long c = 0, un = 0;
	for (int v = 0; v < jb->db->nframes; v++) {
		if (v == u)
			continue;
		if (isfinite(dist[v])) {
			s += dist[v];
			s2 += dist[v] * dist[v];
			c++;
		} else {
			un++;
		}
	}
	pthread_mutex_lock(&jb->lock);
	jb->sum += s;
	jb->sum2 += s2;
	jb->count += c;
	jb->unreachable += un;
	jb->done++;
	if (jb->progress)
		jb->progress(jb->progress_ctx, "shortest paths", jb->done, jb->db->nframes);
	pthread_mutex_unlock(&jb->lock);
}

/* Dijkstra over the complete digraph from u: O(n^2), no heap needed; one
 * pass per settled node both relaxes its edges (row a of W, the weights,
 * INFINITY where there is no transition) and finds the next node. */
static void dense_dijkstra(sp_job *jb, int u, double *dist, uint8_t *done)
{
	const int n = jb->db->nframes;
	for (int v = 0; v < n; v++) {
		dist[v] = INFINITY;
		done[v] = 0;
	}
	dist[u] = 0;
	for (int a = u; a >= 0;) {
		done[a] = 1;
		double da = dist[a];
		if (original_ok(jb->db, a, a + 1) && da + jb->alpha < dist[a + 1])
			dist[a + 1] = da + jb->alpha;
		const float *w = jb->W + (size_t)a * n;
		int next = -1;
		double best = INFINITY;
		for (int v = 0; v < n; v++) {
			if (done[v])
				continue;
			double d = da + w[v];
			if (d < dist[v])
				dist[v] = d;
			if (dist[v] < best) {
				best = dist[v];
				next = v;
			}
		}
		a = next;
	}
}

static void *essential_worker(void *arg)
{
	sp_job *jb = arg;
	const int n = jb->db->nframes;
	double *dist = malloc(sizeof(double) * (size_t)n);
	uint8_t *done = malloc((size_t)n);
	if (!dist || !done) {
		jb->failed = 1;
	} else {
		for (int u; (u = next_source(jb)) >= 0;) {
			dense_dijkstra(jb, u, dist, done);
			/* u -> v is on a shortest path iff its weight is the
			 * distance from u to v (positive weights). */
			const float *w = jb->W + (size_t)u * n;
			for (int v = 0; v < n; v++)
				jb->keep[(size_t)u * n + v] = isfinite(w[v]) && w[v] <= dist[v] * (1 + 1e-9);
			add_stats(jb, u, dist);
		}
	}
	free(dist);
	free(done);
	return NULL;
}

/* ---- Dijkstra on a sparse graph, with a binary heap ---- */

typedef struct {
	double *key;
	int *heap, *pos, size;
} heap;

static void heap_swap(heap *h, int a, int b)
{
	int t = h->heap[a];
	h->heap[a] = h->heap[b];
	h->heap[b] = t;
	h->pos[h->heap[a]] = a;
	h->pos[h->heap[b]] = b;
}

static void heap_up(heap *h, int i)
{
	while (i > 0 && h->key[h->heap[(i - 1) / 2]] > h->key[h->heap[i]]) {
		heap_swap(h, i, (i - 1) / 2);
		i = (i - 1) / 2;
	}
}

static void heap_down(heap *h, int i)
{
	for (;;) {
		int l = 2 * i + 1, r = l + 1, s = i;
		if (l < h->size && h->key[h->heap[l]] < h->key[h->heap[s]])
			s = l;
		if (r < h->size && h->key[h->heap[r]] < h->key[h->heap[s]])
			s = r;
		if (s == i)
			return;
		heap_swap(h, i, s);
		i = s;
	}
}

static void sparse_dijkstra(const int *start, const int *adj, const float *w, int n, int u, double *dist, heap *h)
{
	for (int v = 0; v < n; v++) {
		dist[v] = INFINITY;
		h->pos[v] = -1;
	}
	h->key = dist;
	h->size = 0;
	dist[u] = 0;
	h->heap[h->size] = u;
	h->pos[u] = h->size++;
	while (h->size > 0) {
		int a = h->heap[0];
		heap_swap(h, 0, --h->size);
		h->pos[a] = -2; /* settled */
		heap_down(h, 0);
		for (int e = start[a]; e < start[a + 1]; e++) {
			int v = adj[e];
			double d = dist[a] + w[e];
			if (h->pos[v] == -2 || d >= dist[v])
				continue;
			dist[v] = d;
			if (h->pos[v] < 0) {
				h->heap[h->size] = v;
				h->pos[v] = h->size++;
			}
			heap_up(h, h->pos[v]);
		}
	}
}

static void *stats_worker(void *arg)
{
	sp_job *jb = arg;
	const int n = jb->db->nframes;
	double *dist = malloc(sizeof(double) * (size_t)n);
	heap h = {NULL, malloc(sizeof(int) * (size_t)n), malloc(sizeof(int) * (size_t)n), 0};
	if (!dist || !h.heap || !h.pos) {
		jb->failed = 1;
	} else {
		for (int u; (u = next_source(jb)) >= 0;) {
			sparse_dijkstra(jb->start, jb->adj, jb->w, n, u, dist, &h);
			add_stats(jb, u, dist);
		}
	}
	free(dist);
	free(h.heap);
	free(h.pos);
	return NULL;
}

static int run_threads(sp_job *jb, void *(*fn)(void *), int threads, mc_err *err)
{
	int nt = mc_motion_threads(threads);
	pthread_t *th = calloc((size_t)nt, sizeof(*th));
	if (!th)
		return mc_err_set(err, "out of memory");
	int started = 0;
	while (started < nt && pthread_create(&th[started], NULL, fn, jb) == 0)
		started++;
	if (started == 0)
		fn(jb);
	for (int k = 0; k < started; k++)
		pthread_join(th[k], NULL);
	free(th);
	return jb->failed ? mc_err_set(err, "out of memory in a shortest-path thread") : 0;
}

static void finish_stats(const sp_job *jb, mc_graph_stats *st)
{
	st->mean = jb->count ? jb->sum / (double)jb->count : NAN;
	st->var = jb->count ? jb->sum2 / (double)jb->count - st->mean * st->mean : NAN;
	if (st->var < 0)
		st->var = 0;
	double pairs = (double)jb->db->nframes * (jb->db->nframes - 1);
	st->unreachable = pairs > 0 ? (double)jb->unreachable / pairs : 0;
}

static long count_edges(const mc_motion_db *db, const uint8_t *keep)
{
	size_t n = (size_t)db->nframes;
	long e = 0;
	for (size_t i = 0; i < n * n; i++)
		e += keep[i] != 0;
	for (int u = 0; u + 1 < db->nframes; u++)
		e += original_ok(db, u, u + 1);
	return e;
}

static void set_density(const mc_motion_db *db, const uint8_t *keep, mc_graph_stats *st)
{
	st->edges = count_edges(db, keep);
	double n = db->nframes;
	st->density = n > 1 ? (double)st->edges / (n * (n - 1)) : 0;
}

static int essential(const mc_motion_db *db, const mc_cost_matrix *m, int lmax, double alpha, const mc_cost_params *p,
		     uint8_t *keep, mc_graph_stats *st, mc_err *err)
{
	if (!(alpha > 0))
		return mc_err_set(err, "alpha %g: must be positive (weights must be positive)", alpha);
	const int n = db->nframes;
	float *W = malloc(sizeof(float) * (size_t)n * n);
	if (!W)
		return mc_err_set(err, "out of memory for %d x %d weights", n, n);
	for (int a = 0; a < n; a++)
		for (int v = 0; v < n; v++)
			W[(size_t)a * n + v] =
				transition_ok(db, m, lmax, a, v) ? (float)tr_weight(m, alpha, a, v) : (float)INFINITY;
	sp_job jb = {.db = db, .m = m, .lmax = lmax, .alpha = alpha, .keep = keep, .W = W, .progress = p->progress,
		     .progress_ctx = p->progress_ctx};
	pthread_mutex_init(&jb.lock, NULL);
	int rc = run_threads(&jb, essential_worker, p->threads, err);
	pthread_mutex_destroy(&jb.lock);
	free(W);
	if (rc)
		return -1;
	if (st) {
		finish_stats(&jb, st);
		set_density(db, keep, st);
	}
	return 0;
}

int mc_graph_essential(const mc_motion_db *db, const mc_cost_matrix *m, int lmax, double alpha, int threads,
		       uint8_t *keep, mc_graph_stats *st, mc_err *err)
{
	mc_cost_params p = {.threads = threads};
	return essential(db, m, lmax, alpha, &p, keep, st, err);
}

void mc_graph_motion(const mc_motion_db *db, const mc_cost_matrix *m, int lmax, uint8_t *keep)
{
	const int n = db->nframes;
	memset(keep, 0, (size_t)n * n);
	for (int u = 0; u < n; u++)
		for (int v = 0; v < n; v++) {
			if (!transition_ok(db, m, lmax, u, v))
				continue;
			/* a local minimum of its clip pair's matrix */
			double d = m->t[(size_t)u * n + v].D;
			bool min = true;
			for (int du = -1; du <= 1 && min; du++)
				for (int dv = -1; dv <= 1 && min; dv++) {
					int a = u + du, b = v + dv;
					if ((du == 0 && dv == 0) || a < 0 || b < 0 || a >= n || b >= n ||
					    db->clip_of[a] != db->clip_of[u] || db->clip_of[b] != db->clip_of[v] ||
					    !transition_ok(db, m, lmax, a, b))
						continue;
					double o = m->t[(size_t)a * n + b].D;
					/* ties go to the first in scan order */
					if (o < d || (o == d && (du < 0 || (du == 0 && dv < 0))))
						min = false;
				}
			keep[(size_t)u * n + v] = min;
		}
}

int mc_graph_stats_of(const mc_motion_db *db, const mc_cost_matrix *m, double alpha, const uint8_t *keep, int threads,
		      mc_graph_stats *st, mc_err *err)
{
	const int n = db->nframes;
	set_density(db, keep, st);
	int *start = calloc((size_t)n + 1, sizeof(int));
	int *adj = malloc(sizeof(int) * (size_t)(st->edges > 0 ? st->edges : 1));
	float *w = malloc(sizeof(float) * (size_t)(st->edges > 0 ? st->edges : 1));
	int rc = -1;
	if (!start || !adj || !w) {
		mc_err_set(err, "out of memory for %ld edges", st->edges);
		goto out;
	}
	int e = 0;
	for (int u = 0; u < n; u++) {
		start[u] = e;
		if (original_ok(db, u, u + 1)) {
			adj[e] = u + 1;
			w[e++] = (float)alpha;
		}
		for (int v = 0; v < n; v++)
			if (keep[(size_t)u * n + v]) {
				adj[e] = v;
				w[e++] = (float)tr_weight(m, alpha, u, v);
			}
	}
	start[n] = e;
	sp_job jb = {.db = db, .m = m, .alpha = alpha, .start = start, .adj = adj, .w = w};
	pthread_mutex_init(&jb.lock, NULL);
	rc = run_threads(&jb, stats_worker, threads, err);
	pthread_mutex_destroy(&jb.lock);
	if (!rc)
		finish_stats(&jb, st);
out:
	free(start);
	free(adj);
	free(w);
	return rc;
}

/* ---- the graph ---- */

int mc_graph_build(mc_motion_db *db, const mc_cost_matrix *m, const mc_cost_params *p, double alpha,
		   mc_motion_graph *g, mc_graph_stats *stats_ess, mc_err *err)
{
	memset(g, 0, sizeof(*g));
	const int n = db->nframes;
	uint8_t *ess = calloc((size_t)n * n, 1), *mg = malloc((size_t)n * n);
	mc_graph_stats st;
	int rc = -1;
	if (!ess || !mg) {
		mc_err_set(err, "out of memory for %d x %d edge flags", n, n);
		goto out;
	}
	if (essential(db, m, p->lmax, alpha, p, ess, &st, err))
		goto out;
	if (stats_ess)
		*stats_ess = st;
	mc_graph_motion(db, m, p->lmax, mg);
	long ne = 0;
	for (size_t i = 0; i < (size_t)n * n; i++)
		ne += ess[i] || mg[i];
	for (int u = 0; u + 1 < n; u++)
		ne += original_ok(db, u, u + 1);
	g->edges = malloc(sizeof(mc_edge) * (size_t)(ne > 0 ? ne : 1));
	if (!g->edges) {
		mc_err_set(err, "out of memory for %ld edges", ne);
		goto out;
	}
	for (int u = 0; u < n; u++)
		for (int v = 0; v < n; v++) {
			size_t i = (size_t)u * n + v;
			uint8_t flags = (uint8_t)((original_ok(db, u, v) ? MC_EDGE_ORIGINAL : 0) |
						  (mg[i] ? MC_EDGE_MOTION : 0) | (ess[i] ? MC_EDGE_ESSENTIAL : 0));
			if (!flags)
				continue;
			mc_edge *e = &g->edges[g->nedges++];
			e->from = (uint32_t)u;
			e->to = (uint32_t)v;
			if (flags & MC_EDGE_ORIGINAL) {
				e->D = 0;
				e->L = 1;
				e->li = e->lj = 0;
			} else {
				e->D = m->t[i].D;
				e->L = m->t[i].L;
				e->li = m->t[i].li;
				e->lj = m->t[i].lj;
			}
			e->E = (float)(e->D + alpha * e->L);
			e->flags = flags;
		}
	g->alpha = alpha;
	g->tau = p->tau;
	g->lmin = p->lmin;
	g->lmax = p->lmax;
	g->lstep = p->lstep;
	g->db = *db;
	memset(db, 0, sizeof(*db));
	rc = mc_graph_param_nodes(g, err);
out:
	free(ess);
	free(mg);
	if (rc) /* the database goes with it once moved */
		mc_graph_free(g);
	return rc;
}

void mc_graph_free(mc_motion_graph *g)
{
	mc_motion_db_free(&g->db);
	free(g->edges);
	free(g->params);
	free(g->param_edges);
	memset(g, 0, sizeof(*g));
}

/* ---- parametric nodes (Casas et al. 2013) ---- */

void mc_clip_params(const mc_motion_db *db, int clip, float *speed, float *turn)
{
	const mc_motion_clip *c = &db->clips[clip];
	double dist = 0, dturn = 0;
	for (int k = 1; k < c->nframes; k++) {
		const mc_vec3 *a = mc_motion_frame(db, c->first + k - 1), *b = mc_motion_frame(db, c->first + k);
		dist += hypot(b[0].x - a[0].x, b[0].y - a[0].y);
		double dh = mc_motion_floor_frame(b).heading - mc_motion_floor_frame(a).heading;
		dturn += remainder(dh, 2 * M_PI);
	}
	double T = (c->nframes - 1) / db->fps;
	*speed = T > 0 ? (float)(dist / T) : 0;
	*turn = T > 0 ? (float)(dturn / T * 180 / M_PI) : 0;
}

int mc_graph_param_nodes(mc_motion_graph *g, mc_err *err)
{
	const mc_motion_db *db = &g->db;
	free(g->params);
	free(g->param_edges);
	g->params = calloc((size_t)(db->nclips > 0 ? db->nclips : 1), sizeof(mc_param_node));
	g->param_edges = NULL;
	g->nparams = g->nparam_edges = 0;
	if (!g->params)
		return mc_err_set(err, "out of memory");
	for (int c = 0; c < db->nclips; c++) {
		if (!db->clips[c].cls[0])
			continue;
		int k = 0;
		while (k < g->nparams && strcmp(g->params[k].cls, db->clips[c].cls) != 0)
			k++;
		mc_param_node *pn = &g->params[k];
		if (k == g->nparams) {
			snprintf(pn->cls, sizeof(pn->cls), "%s", db->clips[c].cls);
			g->nparams++;
		}
		if (pn->nmembers == MC_PARAM_MAX_MEMBERS)
			continue;
		pn->clip[pn->nmembers] = c;
		mc_clip_params(db, c, &pn->speed[pn->nmembers], &pn->turn[pn->nmembers]);
		pn->nmembers++;
	}
	/* a class of one clip has nothing to blend: drop it */
	int kept = 0;
	for (int k = 0; k < g->nparams; k++)
		if (g->params[k].nmembers >= 2)
			g->params[kept++] = g->params[k];
	g->nparams = kept;
	/* between nodes: the cheapest kept transition from a member to a member */
	if (kept == 0)
		return 0;
	g->param_edges = calloc((size_t)kept * kept, sizeof(mc_param_edge));
	if (!g->param_edges)
		return mc_err_set(err, "out of memory");
	int *node_of_clip = malloc(sizeof(int) * (size_t)db->nclips);
	if (!node_of_clip)
		return mc_err_set(err, "out of memory");
	for (int c = 0; c < db->nclips; c++)
		node_of_clip[c] = -1;
	for (int k = 0; k < kept; k++)
		for (int i = 0; i < g->params[k].nmembers; i++)
			node_of_clip[g->params[k].clip[i]] = k;
	for (int a = 0; a < kept; a++)
		for (int b = 0; b < kept; b++)
			g->param_edges[a * kept + b] = (mc_param_edge){(uint32_t)a, (uint32_t)b, 0, 0, INFINITY};
	for (int i = 0; i < g->nedges; i++) {
		const mc_edge *e = &g->edges[i];
		if (e->flags & MC_EDGE_ORIGINAL)
			continue;
		int a = node_of_clip[db->clip_of[e->from]], b = node_of_clip[db->clip_of[e->to]];
		if (a < 0 || b < 0 || a == b)
			continue;
		mc_param_edge *pe = &g->param_edges[a * kept + b];
		if (e->E < pe->E) {
			pe->from = e->from;
			pe->to = e->to;
			pe->E = e->E;
		}
	}
	/* keep the pairs that have one */
	int ne = 0;
	for (int i = 0; i < kept * kept; i++)
		if (isfinite(g->param_edges[i].E))
			g->param_edges[ne++] = g->param_edges[i];
	g->nparam_edges = ne;
	free(node_of_clip);
	return 0;
}

/* ---- adjacency and the largest strongly connected component ---- */

static int largest_scc(mc_graph_adj *a, const mc_motion_graph *g, mc_err *err)
{
	/* Tarjan's algorithm, iterative (graphs of many thousand nodes). */
	const int n = a->n;
	int *index = malloc(sizeof(int) * (size_t)n), *low = malloc(sizeof(int) * (size_t)n);
	int *stack = malloc(sizeof(int) * (size_t)n), *call = malloc(sizeof(int) * (size_t)n);
	int *iter = malloc(sizeof(int) * (size_t)n), *comp = malloc(sizeof(int) * (size_t)n);
	uint8_t *on = calloc((size_t)n, 1);
	int rc = -1;
	if (!index || !low || !stack || !call || !iter || !comp || !on) {
		mc_err_set(err, "out of memory");
		goto out;
	}
	for (int v = 0; v < n; v++)
		index[v] = -1;
	int counter = 0, sp = 0, ncomp = 0, best = -1, best_size = 0;
	for (int root = 0; root < n; root++) {
		if (index[root] >= 0)
			continue;
		int cp = 0;
		call[cp++] = root;
		index[root] = low[root] = counter++;
		iter[root] = a->start[root];
		stack[sp++] = root;
		on[root] = 1;
		while (cp > 0) {
			int v = call[cp - 1];
			if (iter[v] < a->start[v + 1]) {
				int w = (int)g->edges[a->edge[iter[v]++]].to;
				if (index[w] < 0) {
					index[w] = low[w] = counter++;
					iter[w] = a->start[w];
					stack[sp++] = w;
					on[w] = 1;
					call[cp++] = w;
				} else if (on[w] && index[w] < low[v]) {
					low[v] = index[w];
				}
				continue;
			}
			cp--;
			if (cp > 0 && low[v] < low[call[cp - 1]])
				low[call[cp - 1]] = low[v];
			if (low[v] == index[v]) {
				int size = 0, w;
				do {
					w = stack[--sp];
					on[w] = 0;
					comp[w] = ncomp;
					size++;
				} while (w != v);
				if (size > best_size) {
					best_size = size;
					best = ncomp;
				}
				ncomp++;
			}
		}
	}
	for (int v = 0; v < n; v++)
		a->in_scc[v] = comp[v] == best;
	rc = 0;
out:
	free(index);
	free(low);
	free(stack);
	free(call);
	free(iter);
	free(comp);
	free(on);
	return rc;
}

int mc_graph_adj_build(const mc_motion_graph *g, int mask, mc_graph_adj *a, mc_err *err)
{
	memset(a, 0, sizeof(*a));
	mask |= MC_EDGE_ORIGINAL;
	a->n = g->db.nframes;
	a->start = calloc((size_t)a->n + 1, sizeof(int));
	a->edge = malloc(sizeof(int) * (size_t)(g->nedges > 0 ? g->nedges : 1));
	a->in_scc = calloc((size_t)(a->n > 0 ? a->n : 1), 1);
	if (!a->start || !a->edge || !a->in_scc) {
		mc_graph_adj_free(a);
		return mc_err_set(err, "out of memory");
	}
	int k = 0;
	for (int i = 0, u = 0; u <= a->n; u++) {
		a->start[u] = k;
		for (; i < g->nedges && (int)g->edges[i].from == u; i++)
			if (g->edges[i].flags & mask)
				a->edge[k++] = i;
	}
	if (a->n > 0 && largest_scc(a, g, err)) {
		mc_graph_adj_free(a);
		return -1;
	}
	return 0;
}

void mc_graph_adj_free(mc_graph_adj *a)
{
	free(a->start);
	free(a->edge);
	free(a->in_scc);
	memset(a, 0, sizeof(*a));
}
