/* graph_source: mocapd's synthetic source (`[source] graph = FILE`,
 * docs/MOTION_GRAPH.md): instead of cameras and tracker, a thread walks a
 * mocap-graph file and publishes the walk as skeletons, through the same
 * socket and protocol, at [source] rate; clients steer it with the STEER
 * control request (`mocapctl steer class walk`). */
#ifndef MCD_GRAPH_SOURCE_H
#define MCD_GRAPH_SOURCE_H

#include "config.h"
#include "motion/mc_motion_synth.h"
#include "server.h"

#include <stddef.h>
#include <stdint.h>

typedef struct mcd_graph_source mcd_graph_source;

/* Loads the graph (errors name the file and the [source] key), gives srv
 * the skeleton definition (18 joints, world frame: z up, floor at 0) and
 * starts publishing.  srv may be NULL (no socket: the walk runs unseen). */
mcd_graph_source *mcd_graph_source_start(const mcd_config *cfg, srv_server *srv, mc_err *err);
void mcd_graph_source_stop(mcd_graph_source *gs);

/* Parses a STEER argument: "none", "class NAME", "frame N",
 * "direction DEG", "direction DEG speed M/S" or "speed M/S".  On error msg says why. */
int mcd_graph_steer_parse(const char *arg, mc_steer *s, char *msg, size_t cap);
/* Applies a STEER request; 0 and msg saying what the walk now does, or -1
 * and why not (a bad argument, a target the graph cannot reach). */
int mcd_graph_source_steer(mcd_graph_source *gs, const char *arg, char *msg, size_t cap);

/* Skeletons published so far (the watchdog's sign of progress). */
uint64_t mcd_graph_source_published(mcd_graph_source *gs);
/* The status snapshot for clients (STATUS). */
void mcd_graph_source_status(mcd_graph_source *gs, srv_status *st);

/* Checks that the file loads (mocapd --check). */
int mcd_graph_source_check(const mcd_config *cfg, mc_err *err);

#endif
