/* mc_motion_param: parametric blending of a node's members
 * (mc_motion_param.h has the method). */
#include "motion/mc_motion_param.h"

#include <stdlib.h>
#include <string.h>

#define J MC_MOTION_JOINTS
#define MAX_CLIP 4000 /* frames of a member: the DTW table is n_a x n_b */

int mc_param_find(const mc_motion_graph *g, const char *cls)
{
	for (int k = 0; k < g->nparams; k++)
		if (strcmp(g->params[k].cls, cls) == 0)
			return k;
	return -1;
}

/* Pose f of the database in its own floor frame. */
static void local_pose(const mc_motion_db *db, int f, mc_vec3 *q)
{
	const mc_vec3 *x = mc_motion_frame(db, f);
	mc_floor_frame ff = mc_motion_floor_frame(x);
	for (int j = 0; j < J; j++)
		q[j] = mc_floor_from_world(ff, x[j]);
}

static double pose_dist2(const mc_vec3 *a, const mc_vec3 *b)
{
	double s = 0;
	for (int j = 0; j < J; j++)
		s += mc_v3_norm2(mc_v3_sub(a[j], b[j]));
	return s;
}

/* The warping path of two clips (classic DTW, steps (1,0), (0,1), (1,1)),
 * as fractional frame pairs averaged over 5 steps; returns its length. */
static int align(const mc_motion_db *db, const mc_motion_clip *a, const mc_motion_clip *b, double (**path)[2])
{
	int na = a->nframes, nb = b->nframes;
	mc_vec3 *qa = malloc(sizeof(mc_vec3) * (size_t)na * J), *qb = malloc(sizeof(mc_vec3) * (size_t)nb * J);
	double *acc = malloc(sizeof(double) * (size_t)na * nb);
	int(*raw)[2] = malloc(sizeof(*raw) * (size_t)(na + nb));
	*path = malloc(sizeof(**path) * (size_t)(na + nb));
	int L = -1;
	if (!qa || !qb || !acc || !raw || !*path)
		goto out;
	for (int i = 0; i < na; i++)
		local_pose(db, a->first + i, qa + (size_t)i * J);
	for (int i = 0; i < nb; i++)
		local_pose(db, b->first + i, qb + (size_t)i * J);
	for (int i = 0; i < na; i++)
		for (int k = 0; k < nb; k++) {
			double d = pose_dist2(qa + (size_t)i * J, qb + (size_t)k * J), best = 0;
			if (i > 0 || k > 0) {
				best = INFINITY;
				if (i > 0)
					best = fmin(best, acc[(size_t)(i - 1) * nb + k]);
				if (k > 0)
					best = fmin(best, acc[(size_t)i * nb + k - 1]);
				if (i > 0 && k > 0)
					best = fmin(best, acc[(size_t)(i - 1) * nb + k - 1]);
			}
			acc[(size_t)i * nb + k] = d + best;
		}
	/* back from the end, then reversed */
	int n = 0, i = na - 1, k = nb - 1;
	for (;;) {
		raw[n][0] = i;
		raw[n][1] = k;
		n++;
		if (i == 0 && k == 0)
			break;
		double dg = i > 0 && k > 0 ? acc[(size_t)(i - 1) * nb + k - 1] : INFINITY;
		double up = i > 0 ? acc[(size_t)(i - 1) * nb + k] : INFINITY;
		double lf = k > 0 ? acc[(size_t)i * nb + k - 1] : INFINITY;
		if (dg <= up && dg <= lf) {
			i--;
			k--;
		} else if (up <= lf) {
			i--;
		} else {
			k--;
		}
	}
	for (int s = 0; s < n; s++) { /* reversed, averaged over 5 steps (ends kept) */
		int r = s < 2 ? s : (n - 1 - s < 2 ? n - 1 - s : 2);
		double x = 0, y = 0;
		for (int t = s - r; t <= s + r; t++) {
			x += raw[n - 1 - t][0];
			y += raw[n - 1 - t][1];
		}
		(*path)[s][0] = x / (2 * r + 1);
		(*path)[s][1] = y / (2 * r + 1);
	}
	L = n;
out:
	free(qa);
	free(qb);
	free(acc);
	free(raw);
	return L;
}

/* Frame `first + t` (fractional) of the database, world. */
static void frame_at(const mc_motion_db *db, const mc_motion_clip *c, double t, mc_vec3 *out)
{
	int f = (int)floor(t);
	if (f >= c->nframes - 1)
		f = c->nframes - 2;
	double x = t - f;
	const mc_vec3 *a = mc_motion_frame(db, c->first + f), *b = mc_motion_frame(db, c->first + f + 1);
	for (int j = 0; j < J; j++)
		out[j] = mc_v3_add(mc_v3_scale(a[j], 1 - x), mc_v3_scale(b[j], x));
}

/* The motion of the floor frame from b to e, in b's floor frame. */
static void floor_step(mc_floor_frame b, mc_floor_frame e, double *dx, double *dy, double *dh)
{
	mc_vec3 d = mc_floor_from_world(b, mc_v3(e.x, e.y, 0));
	*dx = d.x;
	*dy = d.y;
	*dh = remainder(e.heading - b.heading, 2 * M_PI);
}

/* The blend at weight w: poses (or only the speed when poses is NULL). */
static double blend(const mc_motion_db *db, const mc_motion_clip *ca, const mc_motion_clip *cb, const double (*path)[2],
		    int L, double w, int N, mc_vec3 *poses)
{
	mc_vec3 xa[J], xb[J], pa[J], pb[J];
	double x = 0, y = 0, h = M_PI / 2, dist = 0, ta0 = 0, tb0 = 0;
	for (int k = 0; k < N; k++) {
		double u = N > 1 ? (double)k / (N - 1) * (L - 1) : 0;
		int p = (int)floor(u);
		if (p >= L - 1)
			p = L > 1 ? L - 2 : 0;
		double fr = L > 1 ? u - p : 0;
		double ta = path[p][0] + fr * (path[L > 1 ? p + 1 : p][0] - path[p][0]);
		double tb = path[p][1] + fr * (path[L > 1 ? p + 1 : p][1] - path[p][1]);
		frame_at(db, ca, ta, xa);
		frame_at(db, cb, tb, xb);
		if (k > 0) { /* the root's step: the blend of the members' */
			frame_at(db, ca, ta0, pa);
			frame_at(db, cb, tb0, pb);
			double ax, ay, ah, bx, by, bh;
			floor_step(mc_motion_floor_frame(pa), mc_motion_floor_frame(xa), &ax, &ay, &ah);
			floor_step(mc_motion_floor_frame(pb), mc_motion_floor_frame(xb), &bx, &by, &bh);
			double sx = (1 - w) * ax + w * bx, sy = (1 - w) * ay + w * by;
			mc_floor_frame cur = {x, y, h};
			mc_vec3 d = mc_floor_to_world(cur, mc_v3(sx, sy, 0));
			dist += hypot(d.x - x, d.y - y);
			x = d.x;
			y = d.y;
			h += (1 - w) * ah + w * bh;
		}
		ta0 = ta;
		tb0 = tb;
		if (!poses)
			continue;
		mc_floor_frame fa = mc_motion_floor_frame(xa), fb = mc_motion_floor_frame(xb), cur = {x, y, h};
		mc_vec3 *o = poses + (size_t)k * J;
		for (int j = 0; j < J; j++) {
			mc_vec3 q = mc_v3_add(mc_v3_scale(mc_floor_from_world(fa, xa[j]), 1 - w),
					      mc_v3_scale(mc_floor_from_world(fb, xb[j]), w));
			o[j] = mc_floor_to_world(cur, q);
		}
		mc_motion_fix_lengths(&db->skel, o);
		double zmin = 0;
		for (int j = 0; j < J; j++)
			zmin = fmin(zmin, o[j].z);
		for (int j = 0; j < J; j++)
			o[j].z -= zmin;
	}
	return N > 1 ? dist / ((N - 1) / db->fps) : 0;
}

/* Samples of the blend at weight w: its duration in frames, plus one. */
static int frames_at(const mc_motion_clip *ca, const mc_motion_clip *cb, double w)
{
	return (int)lround((1 - w) * (ca->nframes - 1) + w * (cb->nframes - 1)) + 1;
}

int mc_param_blend(const mc_motion_graph *g, int node, double speed, mc_param_motion *out, mc_err *err)
{
	memset(out, 0, sizeof(*out));
	if (node < 0 || node >= g->nparams)
		return mc_err_set(err, "parametric node %d: the graph has %d", node, g->nparams);
	const mc_param_node *pn = &g->params[node];
	const mc_motion_db *db = &g->db;
	/* the bracketing members */
	int lo = -1, hi = -1;
	for (int i = 0; i < pn->nmembers; i++) {
		if (pn->speed[i] <= speed && (lo < 0 || pn->speed[i] > pn->speed[lo]))
			lo = i;
		if (pn->speed[i] >= speed && (hi < 0 || pn->speed[i] < pn->speed[hi]))
			hi = i;
	}
	if (lo < 0) /* below every member: the slowest alone */
		lo = hi;
	if (hi < 0)
		hi = lo;
	const mc_motion_clip *ca = &db->clips[pn->clip[lo]], *cb = &db->clips[pn->clip[hi]];
	if (ca->nframes > MAX_CLIP || cb->nframes > MAX_CLIP)
		return mc_err_set(err, "class '%s': a member longer than %d frames", pn->cls, MAX_CLIP);
	double(*path)[2] = NULL;
	int L = align(db, ca, cb, &path);
	if (L < 1) {
		free(path);
		return mc_err_set(err, "out of memory");
	}
	/* the weight that gives the speed: speed(w) grows with w */
	double w = 0;
	if (lo != hi) {
		double a = 0, b = 1;
		for (int it = 0; it < 30; it++) {
			double m = (a + b) / 2;
			if (blend(db, ca, cb, (const double(*)[2])path, L, m, frames_at(ca, cb, m), NULL) < speed)
				a = m;
			else
				b = m;
		}
		w = (a + b) / 2;
	}
	int N = frames_at(ca, cb, w);
	out->poses = malloc(sizeof(mc_vec3) * (size_t)N * J);
	if (!out->poses) {
		free(path);
		return mc_err_set(err, "out of memory");
	}
	out->clip_a = pn->clip[lo];
	out->clip_b = pn->clip[hi];
	out->w = w;
	out->nframes = N;
	out->speed = blend(db, ca, cb, (const double(*)[2])path, L, w, N, out->poses);
	free(path);
	return 0;
}
