/* check: `mocapd --check`, the parts of start-up that can be checked
 * without devices or OpenCL, each on its own, every error printed. */
#ifndef MCD_CHECK_H
#define MCD_CHECK_H

#include "config.h"

/* Checks a loaded config; prints "PATH: ok" or every error (log) and
 * their count.  Returns the exit status (0 or 1). */
int mcd_check(const mcd_config *cfg, const char *config_path);

#endif
