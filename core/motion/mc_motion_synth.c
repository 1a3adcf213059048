/* mc_motion_synth: graph walks as a skeleton stream (mc_motion_synth.h). */
#include "motion/mc_motion_synth.h"

#include <stdlib.h>
#include <string.h>

#define J MC_MOTION_JOINTS
#define MAX_PATH (2 * MC_DTW_MAX_WINDOW)
#define LOOKAHEAD_S 1.0
#define MEAN_SEGMENT_S 2.0

/* A rigid motion of the floor: rotation about z, then a translation. */
typedef struct {
	double c, s, tx, ty;
} place;

static mc_vec3 place_apply(place p, mc_vec3 v)
{
	return mc_v3(p.c * v.x - p.s * v.y + p.tx, p.s * v.x + p.c * v.y + p.ty, v.z);
}

static place place_compose(place a, place b) /* a after b */
{
	place r = {a.c * b.c - a.s * b.s, a.s * b.c + a.c * b.s, 0, 0};
	mc_vec3 t = place_apply(a, mc_v3(b.tx, b.ty, 0));
	r.tx = t.x;
	r.ty = t.y;
	return r;
}

static place place_inverse(place p)
{
	place r = {p.c, -p.s, 0, 0};
	r.tx = -(r.c * p.tx - r.s * p.ty);
	r.ty = -(r.s * p.tx + r.c * p.ty);
	return r;
}

/* The floor frame of a pose as the motion from its local frame to the world. */
static place place_of_floor(mc_floor_frame f)
{
	double a = f.heading - M_PI / 2;
	place p = {cos(a), sin(a), f.x, f.y};
	return p;
}

struct mc_walker {
	const mc_motion_graph *g;
	mc_graph_adj adj;
	mc_vec3 *features;
	mc_dtw_ws *ws;
	uint64_t rng;
	int node;
	place P;
	/* poses of the transition under way */
	mc_vec3 queue[MAX_PATH][J];
	int nqueue, iqueue;
	/* steering */
	mc_steer steer;
	int *plan; /* edges to follow, in order */
	int nplan, iplan;
	int since_transition; /* frames */
	long transitions;
	/* planning scratch */
	double *dist;
	int *pred;
	uint8_t *done;
};

static const mc_vec3 *frame(const mc_walker *w, int f) { return mc_motion_frame(&w->g->db, f); }

static int clip_end(const mc_walker *w, int f)
{
	const mc_motion_clip *c = &w->g->db.clips[w->g->db.clip_of[f]];
	return c->first + c->nframes - 1;
}

static bool in_class(const mc_walker *w, int f, const char *cls)
{
	return strcmp(w->g->db.clips[w->g->db.clip_of[f]].cls, cls) == 0;
}

mc_walker *mc_walker_new(const mc_motion_graph *g, int mask, uint64_t seed, mc_err *err)
{
	if (g->db.nframes < 2) {
		mc_err_set(err, "the graph has fewer than two frames");
		return NULL;
	}
	mc_walker *w = calloc(1, sizeof(*w));
	if (!w) {
		mc_err_set(err, "out of memory");
		return NULL;
	}
	int n = g->db.nframes;
	w->g = g;
	w->rng = seed;
	w->ws = mc_dtw_ws_new();
	w->plan = malloc(sizeof(int) * (size_t)n);
	w->dist = malloc(sizeof(double) * (size_t)n);
	w->pred = malloc(sizeof(int) * (size_t)n);
	w->done = malloc((size_t)n);
	if (!w->ws || !w->plan || !w->dist || !w->pred || !w->done) {
		mc_err_set(err, "out of memory");
		mc_walker_free(w);
		return NULL;
	}
	if (mc_graph_adj_build(g, mask, &w->adj, err) || mc_motion_features(&g->db, &w->features, err)) {
		mc_walker_free(w);
		return NULL;
	}
	/* the component holds at least one node; pick one at random */
	int nscc = 0;
	for (int f = 0; f < n; f++)
		nscc += w->adj.in_scc[f];
	int k = (int)(mc_rng_uniform(&w->rng) * nscc);
	for (int f = 0; f < n; f++)
		if (w->adj.in_scc[f] && k-- == 0)
			w->node = f;
	if (nscc < 2) {
		mc_err_set(err, "the graph has no cycle: its largest strongly connected component is one frame");
		mc_walker_free(w);
		return NULL;
	}
	/* start at the origin, facing +y */
	w->P = place_inverse(place_of_floor(mc_motion_floor_frame(frame(w, w->node))));
	w->steer.kind = MC_STEER_NONE;
	w->steer.speed = -1;
	w->nqueue = w->iqueue = 1; /* the start pose is emitted first */
	const mc_vec3 *x = frame(w, w->node);
	for (int j = 0; j < J; j++)
		w->queue[0][j] = place_apply(w->P, x[j]);
	w->iqueue = 0;
	return w;
}

void mc_walker_free(mc_walker *w)
{
	if (!w)
		return;
	mc_graph_adj_free(&w->adj);
	free(w->features);
	mc_dtw_ws_free(w->ws);
	free(w->plan);
	free(w->dist);
	free(w->pred);
	free(w->done);
	free(w);
}

int mc_walker_node(const mc_walker *w) { return w->node; }
long mc_walker_transitions(const mc_walker *w) { return w->transitions; }

/* ---- planning: shortest path (weights E) to a set of frames ---- */

static bool is_goal(const mc_walker *w, int f)
{
	if (w->steer.kind == MC_STEER_FRAME)
		return f == w->steer.frame;
	return w->steer.kind == MC_STEER_CLASS && in_class(w, f, w->steer.cls);
}

/* Dijkstra inside the component, O(n^2 + e): plans are rare. */
static int plan_path(mc_walker *w)
{
	const int n = w->g->db.nframes;
	for (int f = 0; f < n; f++) {
		w->dist[f] = INFINITY;
		w->pred[f] = -1;
		w->done[f] = 0;
	}
	w->dist[w->node] = 0;
	int goal = -1;
	for (;;) {
		int a = -1;
		for (int f = 0; f < n; f++)
			if (!w->done[f] && isfinite(w->dist[f]) && (a < 0 || w->dist[f] < w->dist[a]))
				a = f;
		if (a < 0)
			break;
		w->done[a] = 1;
		if (a != w->node && is_goal(w, a)) {
			goal = a;
			break;
		}
		for (int k = w->adj.start[a]; k < w->adj.start[a + 1]; k++) {
			const mc_edge *e = &w->g->edges[w->adj.edge[k]];
			if (!w->adj.in_scc[e->to] || w->done[e->to])
				continue;
			double d = w->dist[a] + e->E;
			if (d < w->dist[e->to]) {
				w->dist[e->to] = d;
				w->pred[e->to] = w->adj.edge[k];
			}
		}
	}
	w->nplan = w->iplan = 0;
	if (goal < 0)
		return -1;
	for (int f = goal; f != w->node; f = (int)w->g->edges[w->pred[f]].from)
		w->nplan++;
	int i = w->nplan;
	for (int f = goal; f != w->node; f = (int)w->g->edges[w->pred[f]].from)
		w->plan[--i] = w->pred[f];
	return 0;
}

int mc_walker_steer(mc_walker *w, const mc_steer *s, mc_err *err)
{
	const int n = w->g->db.nframes;
	if (s->kind == MC_STEER_FRAME && (s->frame < 0 || s->frame >= n || !w->adj.in_scc[s->frame]))
		return mc_err_set(err, "frame %d is not in the graph's strongly connected component", s->frame);
	if (s->kind == MC_STEER_CLASS) {
		bool any = false;
		for (int f = 0; f < n && !any; f++)
			any = w->adj.in_scc[f] && strcmp(w->g->db.clips[w->g->db.clip_of[f]].cls, s->cls) == 0;
		if (!any)
			return mc_err_set(err, "no clip of class '%s' in the graph's strongly connected component", s->cls);
	}
	w->steer = *s;
	w->nplan = w->iplan = 0;
	if ((s->kind == MC_STEER_FRAME || s->kind == MC_STEER_CLASS) && !is_goal(w, w->node))
		plan_path(w);
	return 0;
}

/* ---- emitting ---- */

static void emit_original(mc_walker *w, int v)
{
	const mc_vec3 *x = frame(w, v);
	for (int j = 0; j < J; j++)
		w->queue[0][j] = place_apply(w->P, x[j]);
	w->nqueue = 1;
	w->iqueue = 0;
	w->node = v;
	w->since_transition++;
}

/* The placement of the target after transition e from placement P. */
static place target_place(const mc_walker *w, const mc_edge *e)
{
	place fs = place_of_floor(mc_motion_floor_frame(frame(w, (int)e->from)));
	place ft = place_of_floor(mc_motion_floor_frame(frame(w, (int)e->to - e->lj + 1)));
	return place_compose(w->P, place_compose(fs, place_inverse(ft)));
}

/* Frame f + x (0 <= x < 1) of the database, x toward f + 1. */
static void frame_at(const mc_walker *w, int f, double x, place P, mc_vec3 *out)
{
	const mc_vec3 *a = frame(w, f), *b = x > 0 ? frame(w, f + 1) : a;
	for (int j = 0; j < J; j++)
		out[j] = place_apply(P, mc_v3_add(mc_v3_scale(a[j], 1 - x), mc_v3_scale(b[j], x)));
}

/* The warping path as smooth fractional times: a moving average of each
 * coordinate over 5 steps, the path continued diagonally past both ends
 * (the source played at its own pace before the transition, the target
 * plays at its own after), then a linear correction that puts the ends
 * back on (0, 0) and (li - 1, lj - 1).  A raw path stalls one window for a
 * frame at each horizontal or vertical step, a jump in velocity; averaged,
 * the stall spreads over five frames. */
static void smooth_path(const uint8_t (*path)[2], int L, int li, int lj, double (*out)[2])
{
	const int R = 2;
	double end[2] = {li - 1, lj - 1};
	for (int c = 0; c < 2; c++) {
		for (int k = 0; k < L; k++) {
			double sum = 0;
			for (int i = k - R; i <= k + R; i++)
				sum += i < 0 ? path[0][c] + i : (i >= L ? path[L - 1][c] + (i - L + 1) : path[i][c]);
			out[k][c] = sum / (2 * R + 1);
		}
		double e0 = -out[0][c], e1 = end[c] - out[L - 1][c];
		for (int k = 0; k < L; k++) {
			double x = L > 1 ? (double)k / (L - 1) : 1;
			out[k][c] = fmin(fmax(out[k][c] + (1 - x) * e0 + x * e1, 0), end[c]);
		}
	}
}

static void emit_transition(mc_walker *w, const mc_edge *e)
{
	int u = (int)e->from, v = (int)e->to, li = e->li, lj = e->lj, t0 = v - lj + 1;
	float tab[MC_DTW_MAX_WINDOW * MC_DTW_MAX_WINDOW];
	for (int s = 0; s < li; s++)
		for (int t = 0; t < lj; t++)
			tab[s * lj + t] = (float)mc_frame_distance(w->features + (size_t)(u + s) * 2 * J,
								    w->features + (size_t)(t0 + t) * 2 * J, w->g->tau);
	mc_dtw_fill(w->ws, tab, li, lj);
	uint8_t path[MAX_PATH][2];
	double times[MAX_PATH][2];
	int L = mc_dtw_path(w->ws, li, path);
	place Pt = target_place(w, e);
	w->nqueue = 0;
	if (L >= 2)
		smooth_path(path, L, li, lj, times);
	for (int k = 1; k < L; k++) {
		double x = (double)k / (L - 1), a = x * x * (3 - 2 * x);
		double fs = floor(times[k][0]), ft = floor(times[k][1]);
		mc_vec3 S[J], T[J];
		frame_at(w, u + (int)fs, times[k][0] - fs, w->P, S);
		frame_at(w, t0 + (int)ft, times[k][1] - ft, Pt, T);
		mc_vec3 *o = w->queue[w->nqueue++];
		for (int j = 0; j < J; j++)
			o[j] = mc_v3_add(mc_v3_scale(S[j], 1 - a), mc_v3_scale(T[j], a));
		mc_motion_fix_lengths(&w->g->db.skel, o);
		double zmin = 0;
		for (int j = 0; j < J; j++)
			zmin = fmin(zmin, o[j].z);
		for (int j = 0; j < J; j++)
			o[j].z -= zmin;
	}
	if (L < 2) { /* no path: land on the target directly */
		frame_at(w, v, 0, Pt, w->queue[0]);
		w->nqueue = 1;
	}
	w->iqueue = 0;
	w->P = Pt;
	w->node = v;
	w->since_transition = 0;
	w->transitions++;
}

/* ---- choosing the next edge ---- */

static double heading_at(const mc_walker *w, place P, int f)
{
	return mc_motion_floor_frame(frame(w, f)).heading + atan2(P.s, P.c);
}

static double speed_at(const mc_walker *w, int f)
{
	int a = f > w->g->db.clips[w->g->db.clip_of[f]].first ? f - 1 : f, b = f < clip_end(w, f) ? f + 1 : f;
	if (a == b)
		return 0;
	const mc_vec3 *x = frame(w, a), *y = frame(w, b);
	return hypot(y[0].x - x[0].x, y[0].y - x[0].y) * w->g->db.fps / (b - a);
}

/* How far the pose one second after landing on f under P is from the
 * target direction (radians) and speed (m/s). */
static double steer_score(const mc_walker *w, place P, int f)
{
	int ahead = f + (int)lround(LOOKAHEAD_S * w->g->db.fps);
	if (ahead > clip_end(w, f))
		ahead = clip_end(w, f);
	double score = 0;
	if (isfinite(w->steer.direction_deg))
		score = fabs(remainder(heading_at(w, P, ahead) - w->steer.direction_deg * M_PI / 180, 2 * M_PI));
	if (w->steer.speed >= 0)
		score += fabs(speed_at(w, ahead) - w->steer.speed);
	return score;
}

static bool original_next(const mc_walker *w)
{
	int u = w->node;
	return u < clip_end(w, u) && w->adj.in_scc[u + 1];
}

/* The transitions out of the node that stay in the component (and in
 * the class, when one is to be kept). */
static int transitions_out(const mc_walker *w, int *out, int cap)
{
	int n = 0;
	for (int k = w->adj.start[w->node]; k < w->adj.start[w->node + 1] && n < cap; k++) {
		const mc_edge *e = &w->g->edges[w->adj.edge[k]];
		if ((e->flags & MC_EDGE_ORIGINAL) || !w->adj.in_scc[e->to])
			continue;
		if (w->steer.kind == MC_STEER_CLASS && in_class(w, w->node, w->steer.cls) &&
		    !in_class(w, (int)e->to, w->steer.cls))
			continue;
		out[n++] = w->adj.edge[k];
	}
	return n;
}

static void step(mc_walker *w)
{
	/* a plan to a frame or a class comes first */
	if (w->iplan < w->nplan) {
		const mc_edge *e = &w->g->edges[w->plan[w->iplan++]];
		if (e->flags & MC_EDGE_ORIGINAL)
			emit_original(w, (int)e->to);
		else
			emit_transition(w, e);
		if (w->iplan == w->nplan && w->steer.kind == MC_STEER_FRAME)
			w->steer.kind = MC_STEER_NONE;
		return;
	}
	if (w->steer.kind == MC_STEER_CLASS && !in_class(w, w->node, w->steer.cls) && plan_path(w) == 0) {
		step(w);
		return;
	}
	int opts[256];
	int n = transitions_out(w, opts, 256);
	bool go_on = original_next(w);
	if (w->steer.kind == MC_STEER_DIRECTION && n > 0 && w->since_transition >= w->g->lmax) {
		double best = go_on ? steer_score(w, w->P, w->node + 1) - 0.2 : INFINITY;
		int pick = -1;
		for (int i = 0; i < n; i++) {
			const mc_edge *e = &w->g->edges[opts[i]];
			double s = steer_score(w, target_place(w, e), (int)e->to);
			if (s < best) {
				best = s;
				pick = opts[i];
			}
		}
		if (pick >= 0) {
			emit_transition(w, &w->g->edges[pick]);
			return;
		}
	}
	double p_jump = 1 - exp(-1 / (w->g->db.fps * MEAN_SEGMENT_S));
	bool jump = n > 0 && (!go_on || (w->steer.kind != MC_STEER_DIRECTION && mc_rng_uniform(&w->rng) < p_jump));
	if (jump) {
		emit_transition(w, &w->g->edges[opts[(int)(mc_rng_uniform(&w->rng) * n)]]);
		return;
	}
	if (go_on) {
		emit_original(w, w->node + 1);
		return;
	}
	/* kept out of the class by the filter: any transition in the component */
	w->steer.kind = w->steer.kind == MC_STEER_CLASS ? MC_STEER_NONE : w->steer.kind;
	n = transitions_out(w, opts, 256);
	emit_transition(w, &w->g->edges[opts[(int)(mc_rng_uniform(&w->rng) * n)]]);
}

int mc_walker_next(mc_walker *w, mc_vec3 *pose)
{
	int synthetic = 0;
	while (w->iqueue >= w->nqueue)
		step(w);
	synthetic = w->since_transition == 0 && w->transitions > 0;
	memcpy(pose, w->queue[w->iqueue++], sizeof(mc_vec3) * J);
	return synthetic;
}

/* ---- continuity ---- */

double mc_pose_vel_jump(const mc_vec3 *a, const mc_vec3 *b, const mc_vec3 *c, double fps)
{
	double m = 0;
	for (int j = 0; j < J; j++)
		m = fmax(m, mc_v3_norm(mc_v3_add(mc_v3_sub(c[j], mc_v3_scale(b[j], 2)), a[j])) * fps);
	return m;
}

double mc_pose_acc_jump(const mc_vec3 *a, const mc_vec3 *b, const mc_vec3 *c, const mc_vec3 *d, double fps)
{
	double m = 0;
	for (int j = 0; j < J; j++) {
		mc_vec3 x = mc_v3_sub(mc_v3_add(d[j], mc_v3_scale(b[j], 3)), mc_v3_add(mc_v3_scale(c[j], 3), a[j]));
		m = fmax(m, mc_v3_norm(x) * fps * fps);
	}
	return m;
}

void mc_motion_db_jumps(const mc_motion_db *db, double *vel, double *acc)
{
	*vel = *acc = 0;
	for (int c = 0; c < db->nclips; c++) {
		const mc_motion_clip *cl = &db->clips[c];
		for (int k = cl->first; k + 2 < cl->first + cl->nframes; k++) {
			const mc_vec3 *a = mc_motion_frame(db, k), *b = mc_motion_frame(db, k + 1),
				      *x = mc_motion_frame(db, k + 2);
			*vel = fmax(*vel, mc_pose_vel_jump(a, b, x, db->fps));
			if (k + 3 < cl->first + cl->nframes)
				*acc = fmax(*acc, mc_pose_acc_jump(a, b, x, mc_motion_frame(db, k + 3), db->fps));
		}
	}
}
