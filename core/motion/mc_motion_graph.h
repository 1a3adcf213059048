/* mc_motion_graph: the motion graph, the Essential graph and parametric
 * nodes over a motion database, and the graph file (docs/MOTION_GRAPH.md).
 *
 * Nodes are the database's frames.  Every edge u -> v has the weight
 * (Boukhayma & Boyer sec. 4.1.2, eq. 10)
 *
 *   E(u, v) = D(u, v) + alpha * L(u, v)
 *
 * with D and L of mc_motion_cost.h for a transition and D = 0, L = 1 for an
 * original edge u -> u + 1 inside a clip.  A transition must jump: one
 * inside a clip with |v - u| <= lmax is not one (it would replay the clip).
 *
 *   - motion graph (Kovar et al. 2002, as Boukhayma sec. 4.1.3 builds it):
 *     the original edges and, for every ordered pair of clips (a clip with
 *     itself included), the transitions at the local minima of the pair's
 *     cost matrix D (8-neighbourhood, no threshold, as in the paper's
 *     comparison);
 *   - Essential graph (Boukhayma sec. 4.1.1): the original edges and every
 *     transition on some shortest path of the complete digraph of all
 *     transitions.  With positive weights an edge u -> v lies on a shortest
 *     path exactly when E(u, v) equals the shortest distance from u to v, so
 *     one single-source search per node decides every edge out of it;
 *   - parametric nodes (Casas et al. 2013 sec. 4): the clips of one motion
 *     class, each with its parameters (mean speed, mean turn rate), which the
 *     synthesis blends to reach a requested speed or turn, and between two
 *     nodes the cheapest transition from a member of one to a member of the
 *     other. */
#ifndef MC_MOTION_GRAPH_H
#define MC_MOTION_GRAPH_H

#include "motion/mc_motion_cost.h"

#include <stdint.h>

enum {
	MC_EDGE_ORIGINAL = 1,  /* u -> u + 1 inside a clip */
	MC_EDGE_MOTION = 2,    /* a transition of the motion graph */
	MC_EDGE_ESSENTIAL = 4, /* a transition of the Essential graph */
};

typedef struct {
	uint32_t from, to;
	float D, E;
	uint8_t L, li, lj, flags;
} mc_edge;

#define MC_PARAM_MAX_MEMBERS 16

typedef struct {
	char cls[MC_MOTION_CLASS_MAX];
	int nmembers;
	int clip[MC_PARAM_MAX_MEMBERS];
	float speed[MC_PARAM_MAX_MEMBERS]; /* mean horizontal pelvis speed, m/s */
	float turn[MC_PARAM_MAX_MEMBERS];  /* mean heading rate, degrees/s, counter-clockwise */
} mc_param_node;

typedef struct {
	uint32_t from_node, to_node; /* parametric nodes */
	uint32_t from, to;           /* the frames of the cheapest transition */
	float E;
} mc_param_edge;

typedef struct {
	mc_motion_db db;
	double alpha;
	double tau;
	int lmin, lmax, lstep;
	int nedges;
	mc_edge *edges;   /* sorted by (from, to) */
	int nparams;
	mc_param_node *params;
	int nparam_edges;
	mc_param_edge *param_edges;
} mc_motion_graph;

typedef struct {
	double mean, var;   /* of the shortest-path cost over reachable ordered pairs */
	double unreachable; /* fraction of ordered pairs (u != v) with no path */
	double density;     /* edges / (n (n - 1)), original edges included */
	long edges;
} mc_graph_stats;

/* Builds both graphs over db's transitions m (db is moved into the graph
 * and left empty).  stats_ess gets the Essential graph's shortest paths
 * (those of the complete digraph), may be NULL. */
int mc_graph_build(mc_motion_db *db, const mc_cost_matrix *m, const mc_cost_params *p, double alpha,
		   mc_motion_graph *g, mc_graph_stats *stats_ess, mc_err *err);
void mc_graph_free(mc_motion_graph *g);

/* The edges of the complete digraph's shortest paths and their statistics
 * (the Essential graph alone, for comparisons over alpha): flags[u * n + v]
 * set when transition u -> v is kept.  threads as mc_cost_params. */
int mc_graph_essential(const mc_motion_db *db, const mc_cost_matrix *m, int lmax, double alpha, int threads,
		       uint8_t *keep, mc_graph_stats *st, mc_err *err);
/* Marks the motion graph's transitions in keep[u * n + v]. */
void mc_graph_motion(const mc_motion_db *db, const mc_cost_matrix *m, int lmax, uint8_t *keep);
/* Shortest-path statistics of the graph of the original edges plus the
 * transitions marked in keep, weights E = D + alpha L, on threads. */
int mc_graph_stats_of(const mc_motion_db *db, const mc_cost_matrix *m, double alpha, const uint8_t *keep, int threads,
		      mc_graph_stats *st, mc_err *err);

/* Parametric nodes from the clips' classes (a class with >= 2 clips). */
int mc_graph_param_nodes(mc_motion_graph *g, mc_err *err);
/* Mean pelvis speed (m/s) and heading rate (deg/s) of a clip. */
void mc_clip_params(const mc_motion_db *db, int clip, float *speed, float *turn);

/* ---- adjacency of one graph ---- */
typedef struct {
	int n;
	int *start;      /* n + 1 */
	int *edge;       /* indices into g->edges */
	uint8_t *in_scc; /* n: in the largest strongly connected component */
} mc_graph_adj;

/* The graph of edges with any flag in mask (MC_EDGE_ORIGINAL is always
 * included), and its largest strongly connected component. */
int mc_graph_adj_build(const mc_motion_graph *g, int mask, mc_graph_adj *a, mc_err *err);
void mc_graph_adj_free(mc_graph_adj *a);

/* ---- the graph file ---- */
#define MC_GRAPH_MAGIC "MCMGRAPH"
#define MC_GRAPH_VERSION 1

int mc_graph_save(const mc_motion_graph *g, const char *path, mc_err *err);
/* Errors name the file and the field: bad magic, version, sizes, a
 * truncated file, an index out of range, a checksum mismatch. */
int mc_graph_load(const char *path, mc_motion_graph *g, mc_err *err);

#endif
