/* latency: where a frame set's time goes between capture and publish.
 * The publishing thread adds every published set's stage times (the
 * stamps the grouper and the tracking thread put in mcd_output); the
 * status reads p50, p99 and max of each stage over the newest
 * MCD_LATENCY_WINDOW sets (srv_latency_status, `mocapctl status`). */
#ifndef MCD_LATENCY_H
#define MCD_LATENCY_H

#include "publish.h"
#include "server.h"

#include <stdint.h>

#define MCD_LATENCY_WINDOW 1024 /* frame sets: 34 s at 30 fps */

typedef struct {
	double ms[SRV_LAT_NSTAGES][MCD_LATENCY_WINDOW];
	int n, next;
} mcd_latency;

/* Adds the stage times of a set handed to the server at publish_ns. */
void mcd_latency_add(mcd_latency *l, const mcd_output *o, uint64_t publish_ns);
/* p50, p99 and max per stage, and the window's size; the skip counters
 * are not the window's and are left alone. */
void mcd_latency_summary(const mcd_latency *l, srv_latency_status *out);

#endif
