/* libFuzzer target: the motion-graph file (core/motion/mc_motion_graph_io.c,
 * mc_graph_load), which mocapd's [source] graph and mocap-graph read
 * (issue 34).  A refused file gets a message naming it; an accepted one
 * holds only finite joint positions and bone offsets, finite costs that
 * are not negative, and an fps within 1..1000. */
#include "fuzz_util.h"

#include "motion/mc_motion_graph.h"

#include <math.h>

static bool finite3(mc_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

static void check_accepted(const mc_motion_graph *g)
{
	const mc_motion_db *db = &g->db;
	if (!(db->fps >= 1 && db->fps <= 1000))
		fuzz_fail("fuzz_graph", "accepted an fps outside 1..1000", NULL);
	for (int j = 0; j < MC_MOTION_JOINTS; j++)
		if (!finite3(db->skel.offset[j]))
			fuzz_fail("fuzz_graph", "accepted a non-finite bone offset", NULL);
	for (size_t i = 0; i < (size_t)db->nframes * MC_MOTION_JOINTS; i++)
		if (!finite3(db->pos[i]))
			fuzz_fail("fuzz_graph", "accepted a non-finite joint position", NULL);
	for (int i = 0; i < g->nedges; i++)
		if (!(g->edges[i].D >= 0 && g->edges[i].E >= 0 && isfinite(g->edges[i].D) && isfinite(g->edges[i].E)))
			fuzz_fail("fuzz_graph", "accepted a negative or non-finite edge cost", NULL);
	for (int k = 0; k < g->nparam_edges; k++)
		if (!(g->param_edges[k].E >= 0 && isfinite(g->param_edges[k].E)))
			fuzz_fail("fuzz_graph", "accepted a negative or non-finite parametric edge cost", NULL);
}

static int load(const char *path, void *ctx)
{
	(void)ctx;
	static mc_motion_graph g;
	mc_err err = {{0}};
	if (mc_graph_load(path, &g, &err) != 0) {
		fuzz_check_refusal("fuzz_graph", path, &err);
		return 0;
	}
	check_accepted(&g);
	mc_graph_free(&g);
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	fuzz_load_from_file(data, size, load, NULL);
	return 0;
}
