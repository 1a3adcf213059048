/* `mocapctl actor save NAME`: the tracker's actor (its model, with the
 * actor's bone scales, head placement and colours) written as
 * [tracker] actor_dir/NAME.json, which `[tracker] actor` loads at the next
 * start (docs/CONFIG.md, docs/TRACKER.md). */
#ifndef MCD_ACTOR_H
#define MCD_ACTOR_H

#include "config.h"
#include "pipeline.h"

#include <stddef.h>

/* Saves; 0 with msg saying where, or -1 with msg saying why. */
int mcd_actor_save(mcd_pipeline *p, const mcd_config *cfg, const char *name, char *msg, size_t cap);

#endif
