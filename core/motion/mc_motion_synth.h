/* mc_motion_synth: graph walks as a continuous skeleton stream
 * (docs/MOTION_GRAPH.md, "Synthesis"; Boukhayma & Boyer sec. 4.2).
 *
 * A walker stands on a node (frame) of the graph's largest strongly
 * connected component and emits one pose per database frame:
 *   - an original edge u -> u + 1 emits frame u + 1 as recorded;
 *   - a transition u -> v with windows l_i, l_j emits the frames of the
 *     warping path of its source window [u, u + l_i - 1] and target window
 *     [v - l_j + 1, v] (mc_dtw_path over the frame distances), each the
 *     blend (1 - w_k) S_k + w_k T_k of the placed source and target poses
 *     with w_k = 3 x^2 - 2 x^3, x = k / (|P| - 1); bone lengths are then
 *     re-imposed and the pose is kept above the floor.  The path's first
 *     pose is frame u itself, already emitted, so it is skipped.
 * Placement: every emitted pose is the database pose moved by a rotation
 * about z and a translation on the floor.  A transition's target is placed
 * so that the floor frame (mc_floor_frame) of its first window frame lands
 * on that of the source window's first frame; from the transition on, that
 * placement carries on, so the root trajectory is continuous.
 *
 * Steering: with no target the walk is random (seeded): at each node with
 * transitions it takes one with probability 1 - exp(-dt / 2 s).  A target
 * frame or motion class is reached along a shortest path (weights E); a
 * direction (degrees counter-clockwise from +x) and/or a speed (m/s) is
 * followed greedily: at each node the option (go on, or a transition) whose
 * pose one second later is nearest the target heading and speed is taken. */
#ifndef MC_MOTION_SYNTH_H
#define MC_MOTION_SYNTH_H

#include "motion/mc_motion_graph.h"

typedef enum {
	MC_STEER_NONE,
	MC_STEER_FRAME,     /* reach a frame */
	MC_STEER_CLASS,     /* reach and stay in a motion class */
	MC_STEER_DIRECTION, /* head towards a direction and/or move at a speed */
} mc_steer_kind;

typedef struct {
	mc_steer_kind kind;
	int frame;                     /* MC_STEER_FRAME */
	char cls[MC_MOTION_CLASS_MAX]; /* MC_STEER_CLASS */
	double direction_deg;          /* MC_STEER_DIRECTION; NAN: any direction */
	double speed;                  /* m/s, < 0: any */
} mc_steer;

typedef struct mc_walker mc_walker;

/* A walker over the graph's edges of kind mask (MC_EDGE_ESSENTIAL or
 * MC_EDGE_MOTION), started at a random node of the largest strongly
 * connected component.  g must outlive it. */
mc_walker *mc_walker_new(const mc_motion_graph *g, int mask, uint64_t seed, mc_err *err);
void mc_walker_free(mc_walker *w);
/* Sets the target; a frame or class that the component cannot reach is an
 * error (the walk goes on as before). */
int mc_walker_steer(mc_walker *w, const mc_steer *s, mc_err *err);
/* The next pose (MC_MOTION_JOINTS positions, metres, z up).  Returns 1 for
 * a pose of a transition, 0 for a recorded one. */
int mc_walker_next(mc_walker *w, mc_vec3 *pose);
/* The database frame the walker stands on, and transitions taken so far. */
int mc_walker_node(const mc_walker *w);
long mc_walker_transitions(const mc_walker *w);

/* ---- continuity ----
 * Over consecutive poses at fps: the velocity jump at pose b (its
 * velocity change, max over joints of |x_c - 2 x_b + x_a| * fps, m/s) and
 * the acceleration jump between poses b and c (max over joints of
 * |x_d - 3 x_c + 3 x_b - x_a| * fps^2, m/s^2). */
double mc_pose_vel_jump(const mc_vec3 *a, const mc_vec3 *b, const mc_vec3 *c, double fps);
double mc_pose_acc_jump(const mc_vec3 *a, const mc_vec3 *b, const mc_vec3 *c, const mc_vec3 *d, double fps);
/* The largest of each over the inside of every recorded clip. */
void mc_motion_db_jumps(const mc_motion_db *db, double *vel, double *acc);

#endif
