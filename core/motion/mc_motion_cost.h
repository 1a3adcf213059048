/* mc_motion_cost: transition cost between frames of a motion database
 * (docs/MOTION_GRAPH.md, "Transition cost").
 *
 * Frame distance (the pose distance of Boukhayma & Boyer eq. 2, on joints
 * instead of mesh vertices, with the alignment of Kovar et al. 2002):
 *
 *   q_f,j = joint j of frame f in f's floor frame (mc_floor_frame: pelvis
 *           over the origin, facing +y: aligned about the vertical axis and
 *           on the floor);
 *   v_f,j = (x_f+1,j - x_f-1,j) * fps / 2 in f's floor frame (one-sided at
 *           a clip's ends): the joint velocity, root motion included;
 *   d(a, b) = sqrt( (1/J) sum_j ( |q_a,j - q_b,j|^2 + tau^2 |v_a,j - v_b,j|^2 ) )
 *
 * in metres (tau in seconds turns velocities into distances).
 *
 * Transition cost (Boukhayma & Boyer sec. 3.3, eq. 8): from frame i of one
 * clip to frame j of another (or the same) clip, a source window
 * S = [i, i + l_i - 1] and a target window T = [j - l_j + 1, j], both inside
 * their clips, are aligned by dynamic time warping with the cost d and a
 * slope constraint (at most MC_DTW_MAX_RUN horizontal or vertical steps in
 * a row, the paper's choice of 3); the path runs from (i, j - l_j + 1) to
 * (i + l_i - 1, j) and minimises the sum of d.  The lengths vary over
 * l_i, l_j in {lmin, lmin + lstep, ..., lmax} (the paper's 1/3 s to 2 s
 * bounds, shorter here for speed), and
 *
 *   D(i, j) = min over (l_i, l_j) of (1/|P|) sum_{(s,t) in P} d(s, t)
 *   L(i, j) = |P| for the minimising pair, in frames
 *
 * with P the warping path of that pair.  The mean, rather than the paper's
 * sum, keeps long and short windows comparable; the duration enters the
 * graph weights through L (mc_motion_graph.h). */
#ifndef MC_MOTION_COST_H
#define MC_MOTION_COST_H

#include "motion/mc_motion.h"

#include <stdint.h>

#define MC_DTW_MAX_RUN 3
#define MC_DTW_MAX_WINDOW 64

typedef struct {
	double tau;       /* velocity weight, seconds (default 0.1) */
	int lmin, lmax, lstep; /* window lengths, frames */
	int threads;      /* 0: every online CPU */
	/* Called from the threads as work gets done: the stage ("costs", then
	 * "shortest paths" in mc_graph_build), units done and in all (under a
	 * lock: keep it short). */
	void (*progress)(void *ctx, const char *stage, int done, int total);
	void *progress_ctx;
} mc_cost_params;

/* Defaults for a database at fps: tau 0.1 s, windows 1/3 s to 1 s in three
 * lengths. */
void mc_cost_params_default(mc_cost_params *p, double fps);

/* Threads to use: requested, or every online CPU when requested <= 0. */
int mc_motion_threads(int requested);

/* One transition's cost and its windows. */
typedef struct {
	float D;           /* metres; INFINITY when no window fits */
	uint8_t L, li, lj; /* path length and window lengths, frames */
	uint8_t pad;
} mc_transition;

typedef struct {
	int n;                 /* frames */
	float *d;              /* n * n frame distances d(a, b) */
	mc_transition *t;      /* n * n: t[i * n + j], from i to j */
} mc_cost_matrix;

/* The frame features (q, v) of every frame: n * 2 * MC_MOTION_JOINTS. */
int mc_motion_features(const mc_motion_db *db, mc_vec3 **features, mc_err *err);
/* d(a, b) of two feature rows. */
double mc_frame_distance(const mc_vec3 *fa, const mc_vec3 *fb, double tau);

/* Every frame distance and every transition cost, on p->threads threads. */
int mc_cost_matrix_build(const mc_motion_db *db, const mc_cost_params *p, mc_cost_matrix *m, mc_err *err);
void mc_cost_matrix_free(mc_cost_matrix *m);

/* Dynamic time warping over a local distance table w (ls rows for the
 * source window, lt columns for the target window, row-major) with the
 * slope constraint.  mc_dtw_fill fills the workspace; mc_dtw_end then gives
 * the path sum and length ending at (li - 1, lt - 1), li <= ls (-1 when the
 * constraint admits none), and mc_dtw_path the path itself: path[k] =
 * (s, t) from (0, 0) to (li - 1, lt - 1); it returns the length. */
typedef struct mc_dtw_ws mc_dtw_ws;
mc_dtw_ws *mc_dtw_ws_new(void);
void mc_dtw_ws_free(mc_dtw_ws *ws);
void mc_dtw_fill(mc_dtw_ws *ws, const float *w, int ls, int lt);
int mc_dtw_end(const mc_dtw_ws *ws, int li, double *sum);
int mc_dtw_path(const mc_dtw_ws *ws, int li, uint8_t (*path)[2]);

#endif
