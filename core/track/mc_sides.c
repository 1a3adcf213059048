/* Which keypoint is the left limb and which the right (issue 35, "the
 * tracker decides the sides"; docs/TRACKER.md, "Sides").
 *
 * A detector that has not seen a face (the mannequins of our renders) or
 * sees a limb from behind mixes the sides up: MoveNet swaps 22 % of
 * left/right pairs on the outside-in renders, our own outside-in model put
 * both labels on one limb in 92 % of views.  The detector's labels are
 * therefore a hint, and three things decide:
 *   1. a pair collapsed onto one peak (both rays within COLLAPSE_RAD) is
 *      one limb: it pulls only the joint of the tracked pose nearer to it;
 *   2. with three cameras or more, the views must agree: each view's
 *      labels are kept or exchanged so that both joints triangulate best
 *      (the first such view fixed, the others enumerated), and the set as a
 *      whole then faces the way most views said; where the best labelling
 *      does not clearly beat the runner-up, step 3 decides view by view;
 *   3. the tracked pose (the last frame set's) exchanges the labels of a
 *      pair (in one view, or in every view at once after step 2) when the
 *      exchanged labels fit it clearly better: at most half the cost, and
 *      the kept labels at least SIDE_MIN_COST_M off per view.  The margin
 *      keeps a right detection from being overruled by a pose that has
 *      drifted; a pose that is far off is the re-fit's to mend. */
#include "track/mc_tracker_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define COLLAPSE_RAD 0.01
#define SIDE_MIN_COST_M 0.10
#define SIDE_MAX_VIEWS 8 /* views enumerated in step 2 (2^7 combinations) */
#define SIDE_DECISIVE 0.5  /* step 2's best must meet at most this share of the runner-up's spread */

static double ray_distance(mc_vec3 p, const mc_trk_keypoint_ray *r)
{
	return mc_v3_norm(mc_v3_reject(mc_v3_sub(p, r->origin), r->dir));
}

void mc_trk_find_other_sides(mc_tracker *t)
{
	for (int j = 0; j < MC_MAX_JOINTS; j++)
		t->other_side[j] = mc_model_other_side(&t->model, j);
}

int mc_trk_other_side(const mc_tracker *t, int joint)
{
	return joint >= 0 && joint < t->model.njoints ? t->other_side[joint] : -1;
}

static void exchange(mc_trk_keypoint_ray *a, mc_trk_keypoint_ray *b)
{
	int j = a->joint;
	a->joint = b->joint;
	b->joint = j;
}

/* Sum of squared distances of rays to their least-squares point. */
static double spread(const mc_trk_keypoint_ray *const *rays, int n)
{
	mc_vec3 o[MC_MAX_CAMERAS] = {{0, 0, 0}}, d[MC_MAX_CAMERAS] = {{0, 0, 0}}, x;
	if (n > MC_MAX_CAMERAS)
		n = MC_MAX_CAMERAS;
	for (int i = 0; i < n; i++) {
		o[i] = rays[i]->origin;
		d[i] = rays[i]->dir;
	}
	if (!mc_rays_nearest_point(o, d, NULL, n, &x))
		return INFINITY;
	double s = 0;
	for (int i = 0; i < n; i++) {
		double dist = ray_distance(x, rays[i]);
		s += dist * dist;
	}
	return s;
}

/* One pair's views: a[v], b[v] the rays labelled left and right in view v. */
typedef struct {
	mc_trk_keypoint_ray *a[MC_MAX_CAMERAS], *b[MC_MAX_CAMERAS];
	int n;
} pair_views;

/* Step 2: the exchanges (bit v: view v exchanged; view 0 never) under which
 * both joints' rays meet best, into *flips.  False when the views do not
 * settle it, the best spread being more than SIDE_DECISIVE of the
 * runner-up's (two cameras facing each other meet at ghost points between
 * the feet when one of them is exchanged): the tracked pose then decides
 * view by view. */
static bool consistent_flips(const pair_views *p, unsigned *flips_out)
{
	int n = p->n < SIDE_MAX_VIEWS ? p->n : SIDE_MAX_VIEWS;
	unsigned best = 0;
	double best_cost = INFINITY, runner_up = INFINITY;
	for (unsigned flips = 0; flips < (1u << (n - 1)); flips++) {
		const mc_trk_keypoint_ray *left[MC_MAX_CAMERAS], *right[MC_MAX_CAMERAS];
		for (int v = 0; v < n; v++) {
			bool x = v > 0 && (flips >> (v - 1)) & 1;
			left[v] = x ? p->b[v] : p->a[v];
			right[v] = x ? p->a[v] : p->b[v];
		}
		double cost = spread(left, n) + spread(right, n);
		if (cost < best_cost) {
			runner_up = best_cost;
			best_cost = cost;
			best = flips << 1;
		} else if (cost < runner_up) {
			runner_up = cost;
		}
	}
	/* Face the way most views said: exchange every view if most were. */
	int flipped = __builtin_popcount(best);
	if (2 * flipped > n)
		best = ~best & ((1u << n) - 1);
	*flips_out = best;
	return best_cost < SIDE_DECISIVE * runner_up;
}

/* Step 3 over the views of p (all of them as one, or each alone). */
static void follow_pose(const mc_fk *fk, pair_views *p, bool as_one)
{
	double kept_all = 0, swapped_all = 0;
	for (int v = 0; v < p->n; v++) {
		mc_vec3 pa = fk->rig_from_joint[p->a[v]->joint].t, pb = fk->rig_from_joint[p->b[v]->joint].t;
		double kept = ray_distance(pa, p->a[v]) + ray_distance(pb, p->b[v]);
		double swapped = ray_distance(pa, p->b[v]) + ray_distance(pb, p->a[v]);
		if (!as_one && swapped < 0.5 * kept && kept > SIDE_MIN_COST_M)
			exchange(p->a[v], p->b[v]);
		kept_all += kept;
		swapped_all += swapped;
	}
	if (as_one && swapped_all < 0.5 * kept_all && kept_all > SIDE_MIN_COST_M * p->n)
		for (int v = 0; v < p->n; v++)
			exchange(p->a[v], p->b[v]);
}

/* Step 1: a collapsed pair keeps only the ray of the joint nearer to it
 * (with no pose yet, the one with more confidence).  True if collapsed. */
static bool drop_collapsed(const mc_fk *fk, mc_trk_keypoint_ray *a, mc_trk_keypoint_ray *b)
{
	if (mc_v3_dot(a->dir, b->dir) <= cos(COLLAPSE_RAD))
		return false;
	bool keep_a = a->weight >= b->weight;
	if (fk) {
		mc_vec3 pa = fk->rig_from_joint[a->joint].t, pb = fk->rig_from_joint[b->joint].t;
		keep_a = ray_distance(pa, a) <= ray_distance(pb, a);
	}
	(keep_a ? b : a)->weight = 0;
	return true;
}

/* The views in which both joints of the pair (left, right) have a ray. */
static void collect(mc_trk_keypoint_ray *r, const int *cam, int n, int left, int right, const mc_fk *fk,
		    pair_views *p)
{
	p->n = 0;
	for (int i = 0; i < n; i++) {
		if (r[i].joint != left || !(r[i].weight > 0))
			continue;
		for (int k = 0; k < n; k++)
			if (r[k].joint == right && cam[k] == cam[i] && r[k].weight > 0) {
				if (!drop_collapsed(fk, &r[i], &r[k]) && p->n < MC_MAX_CAMERAS) {
					p->a[p->n] = &r[i];
					p->b[p->n++] = &r[k];
				}
				break;
			}
	}
}

void mc_trk_assign_sides(const mc_tracker *t, mc_trk_keypoint_ray *r, const int *cam, int n)
{
	if (!t->s.assign_sides)
		return;
	mc_fk fk;
	bool have_pose = !t->init.waiting;
	if (have_pose)
		mc_model_fk(&t->model, t->pose, &fk);
	for (int left = 0; left < t->model.njoints; left++) {
		int right = mc_trk_other_side(t, left);
		if (right < 0 || strncmp(t->model.joints[left].name, "left_", 5) != 0)
			continue;
		pair_views p;
		collect(r, cam, n, left, right, have_pose ? &fk : NULL, &p);
		bool views_agree = false;
		unsigned flips = 0;
		if (p.n >= 3)
			views_agree = consistent_flips(&p, &flips) || !have_pose;
		if (views_agree)
			for (int v = 0; v < p.n; v++)
				if ((flips >> v) & 1)
					exchange(p.a[v], p.b[v]);
		if (have_pose && p.n > 0)
			follow_pose(&fk, &p, views_agree);
	}
}
