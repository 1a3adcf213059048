/* Graph files with a valid checksum and bad numbers (issue 34 item 8):
 * NaN and infinite joint positions and bone offsets, negative or NaN edge
 * costs, NaN parametric speeds, an fps of 1e-300 or 0.5, a NaN alpha.
 * Each once loaded (and mocapd published non-finite FRAMEs from it); each
 * is refused now with a message that names the file and the field. */
#include "motion/mc_motion_graph.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[] = "/tmp/test-graph-hostile-XXXXXX";

/* A graph of one clip of 3 frames at rest and its two original edges. */
static void tiny_graph(mc_motion_graph *g)
{
	memset(g, 0, sizeof(*g));
	mc_motion_skel s;
	mc_motion_skel_default(&s);
	mc_motion_db_init(&g->db, 30, &s);
	mc_motion_db *db = &g->db;
	db->nclips = 1;
	db->nframes = 3;
	db->clips = calloc(1, sizeof(*db->clips));
	db->pos = calloc(3 * MC_MOTION_JOINTS, sizeof(*db->pos));
	db->clip_of = calloc(3, sizeof(int));
	g->edges = calloc(2, sizeof(*g->edges));
	g->params = calloc(1, sizeof(*g->params));
	g->param_edges = calloc(1, sizeof(*g->param_edges));
	snprintf(db->clips[0].name, sizeof(db->clips[0].name), "rest");
	snprintf(db->clips[0].cls, sizeof(db->clips[0].cls), "stand");
	db->clips[0].nframes = 3;
	for (int f = 0; f < 3; f++)
		mc_motion_skel_rest(&s, db->pos + (size_t)f * MC_MOTION_JOINTS);
	g->alpha = 1e-4;
	g->tau = 0.5;
	g->lmin = 2;
	g->lmax = 4;
	g->lstep = 1;
	g->nedges = 2;
	for (int i = 0; i < 2; i++)
		g->edges[i] = (mc_edge){.from = (uint32_t)i, .to = (uint32_t)i + 1, .L = 1, .flags = MC_EDGE_ORIGINAL};
	g->nparams = 1;
	snprintf(g->params[0].cls, sizeof(g->params[0].cls), "stand");
	g->params[0].nmembers = 1;
}

typedef struct {
	const char *what, *want;
	void (*spoil)(mc_motion_graph *g);
} spoil_case;

static void nan_position(mc_motion_graph *g) { g->db.pos[MC_MOTION_JOINTS + 4].y = NAN; }
static void inf_position(mc_motion_graph *g) { g->db.pos[2 * MC_MOTION_JOINTS].z = INFINITY; }
static void huge_position(mc_motion_graph *g) { g->db.pos[7].x = 3e30; }
static void nan_offset(mc_motion_graph *g) { g->db.skel.offset[3].x = NAN; }
static void negative_cost(mc_motion_graph *g) { g->edges[1].D = -1; }
static void nan_cost(mc_motion_graph *g) { g->edges[0].E = NAN; }
static void nan_speed(mc_motion_graph *g) { g->params[0].speed[0] = NAN; }
static void tiny_fps(mc_motion_graph *g) { g->db.fps = 1e-300; }
static void half_fps(mc_motion_graph *g) { g->db.fps = 0.5; }
static void nan_alpha(mc_motion_graph *g) { g->alpha = NAN; }

static const spoil_case cases[] = {
	{"NaN position", "frames: frame 1, joint", nan_position},
	{"infinite position", "frames: frame 2, joint", inf_position},
	{"position 3e30 m", "is not finite, or beyond 10000 m", huge_position},
	{"NaN bone offset", "skeleton: joint 3", nan_offset},
	{"negative edge cost", "edges: edge 1: cost D -1", negative_cost},
	{"NaN edge cost", "edges: edge 0: cost D 0, E nan", nan_cost},
	{"NaN parametric speed", "params: node 0, member 0: speed nan", nan_speed},
	{"fps 1e-300", "fps: 1e-300: not a frame rate", tiny_fps},
	{"fps 0.5", "fps: 0.5: not a frame rate", half_fps},
	{"NaN alpha", "alpha, tau: nan", nan_alpha},
};

int main(void)
{
	if (!mkdtemp(dir))
		TEST_SKIP("cannot create a scratch directory");
	char path[128];
	mc_err err = {""};
	mc_motion_graph g, h;
	/* the unspoilt graph loads: the cases below fail for their number */
	tiny_graph(&g);
	snprintf(path, sizeof(path), "%s/good.mg", dir);
	CHECK_MSG(mc_graph_save(&g, path, &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_graph_load(path, &h, &err) == 0, "%s", err.msg);
	mc_graph_free(&h);
	mc_graph_free(&g);
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		tiny_graph(&g);
		cases[c].spoil(&g);
		snprintf(path, sizeof(path), "%s/bad%zu.mg", dir, c);
		CHECK_MSG(mc_graph_save(&g, path, &err) == 0, "%s", err.msg);
		mc_graph_free(&g);
		int rc = mc_graph_load(path, &h, &err);
		printf("%s: %s\n", cases[c].what, rc ? err.msg : "loaded");
		CHECK_MSG(rc == -1 && strstr(err.msg, path) == err.msg && strstr(err.msg, cases[c].want),
			  "%s: rc %d, '%s' (want '%s')", cases[c].what, rc, rc ? err.msg : "", cases[c].want);
		if (rc == 0)
			mc_graph_free(&h);
		unlink(path);
	}
	snprintf(path, sizeof(path), "%s/good.mg", dir);
	unlink(path);
	rmdir(dir);
	return mc_test_finish("test_graph_hostile");
}
